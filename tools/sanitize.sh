#!/usr/bin/env bash
# The whole test suite again under AddressSanitizer + UndefinedBehaviorSanitizer (CONESHADOW_SANITIZE):
# a separate build in build-asan/ (benchmarks off), then every test through ctest. Leak checking is off:
# the Vulkan loader and Mesa keep allocations until exit by design. Any sanitizer report fails the run.
# CI runs it after the README's test command (tools/test.sh), which has already installed the packages.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCONESHADOW_SANITIZE=ON -DCONESHADOW_BENCH=OFF \
  > build-asan.log 2>&1 || { cat build-asan.log >&2; echo "sanitize: configure failed" >&2; exit 1; }
cmake --build build-asan -j"$(nproc)" >> build-asan.log 2>&1 || {
  grep -E "error|Error" build-asan.log | head -40 >&2; echo "sanitize: build failed; log in build-asan.log" >&2; exit 1; }
export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir build-asan --output-on-failure -j"$(nproc)" --timeout 900 "$@"
