#!/usr/bin/env bash
# The test suite again under AddressSanitizer + UndefinedBehaviorSanitizer (CONESHADOW_SANITIZE): a separate
# build in build-asan/ (benchmarks off), then the tests through ctest. Leak checking is off: the Vulkan
# loader and Mesa keep allocations until exit by design. Any sanitizer report fails the run.
# CI runs it after the README's test command (tools/test.sh), which has already installed the packages and
# run every test, slow ones included, without sanitizers.
#
# What runs here, to keep CI (tools/test.sh, this, tools/fuzz.sh) within its hour on 2 cores:
# - Every test except those labelled `slow` (tests/labels.cmake), plus the slow ones in KEEP. The
#   sanitizers instrument our host C++ only, not lavapipe's kernels, Embree or the validation layer, so a
#   test is worth its ~3x cost here for the host code it reaches. The slow tests mostly run host paths the
#   quick ones already run, on more scenes, views, lights and variants: the cone exactness and hard-case
#   sweeps (the same harness as the quick hard cases: every variant, both leaf tests, near and far
#   frames), the variant, leaf-ray, budget and arena sweeps (each variant, the chunked path, its overflow
#   and two-pass at the least arena are in quick tests), the look-back sort's spin count (a shader
#   constant), the method contract, the default compare report and its screenshot (the report is written
#   by quick compare runs too), the engine's eight lights on the museum (KEEP has them on the built-in
#   scene), the one-submission frames of every variant and the brute-force masks of the larger frames (a
#   quick test each runs their host paths: --profile-stages, a frame with no lit sample, frames of 1x1,
#   2x2 and 3x5 samples). KEEP holds the slow tests that reach host code no quick test does.
#   Cli.EveryMemoryLimit... skips itself under ASan in any case. Left out: ~770 of the suite's ~1320
#   test-seconds in Release (~2300 s under the sanitizers, ~19 min of CI on 2 cores).
# - RelWithDebInfo at -O1 (the level AddressSanitizer's authors advise) with -g1: a clean build 644 s on 2
#   cores against 1,035 at -O2 (the code's compiler time halved), the quick tests 740 s against 697.
#   -g1: line tables only. The reports' stacks keep every function and file:line,
#   inlined frames included (only a debugger's local variables go), and the sanitized files compile
#   25-45 % faster than with -g (measured on cone_method.cpp, cli.cpp, metrics.cpp, traversal_test.cpp).
# - The test files compile at -O0 (tests/CMakeLists.txt: 370 s of compiler time, about three times that
#   at -O2, the same test times) and the executables link at a fixed address (CMakeLists.txt: a process
#   starts in 0.35 s, not 0.9): the quick tests here 919 -> 697 s on 2 cores at -O2.
# - The Release run's test costs (build/Testing) seed build-asan's, so ctest starts the longest first.
# CONESHADOW_SANITIZE_ALL=1 runs every test, slow ones included; arguments (e.g. -R Cli) pick the tests
# of one ctest run instead of the selection above.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

# The slow tests that run here all the same, each for what only it reaches.
KEEP=(
  ConeMethod.SpheresWrittenOnSeveralThreadsKeepTheMask        # cluster spheres written on several threads
  ConeHardCases.NonFiniteTrianglesAreDroppedAsEmbreeDropsThem # the cone method dropping non-finite triangles
  Compare.SkipsWhatTheDeviceCannotRunAndSaysWhy               # CONESHADOW_HIDE_FEATURES; skipped sweep points
  TinyGltf.CameraNamesNeverBecomePathsOutsideTheOutputFolder  # camera names made file names
  Api.EightLightsInOneFrameEqualOneLightFramesOnTheBuiltinScene # the engine's frames of 2..8 lights
  ConeMethod.ALightThatOverflowsAFrameOfSeveralIsRunAgainAloneWithItsOneLightMask # a light run again alone
)

cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
  -DCONESHADOW_SANITIZE=ON -DCONESHADOW_BENCH=OFF \
  > build-asan.log 2>&1 || { cat build-asan.log >&2; echo "sanitize: configure failed" >&2; exit 1; }
cmake --build build-asan -j"$(nproc)" >> build-asan.log 2>&1 || {
  grep -E "error|Error" build-asan.log | head -40 >&2; echo "sanitize: build failed; log in build-asan.log" >&2; exit 1; }
export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1

costs=build-asan/Testing/Temporary/CTestCostData.txt
if [ ! -f "$costs" ] && [ -f build/Testing/Temporary/CTestCostData.txt ]; then
  mkdir -p "$(dirname "$costs")"
  cp build/Testing/Temporary/CTestCostData.txt "$costs"
fi

run() { ctest --test-dir build-asan --output-on-failure -j"$(nproc)" --timeout 900 "$@"; }
if [ $# -gt 0 ]; then
  run "$@"
elif [ "${CONESHADOW_SANITIZE_ALL:-0}" = 1 ]; then
  run
else
  keep=$(printf '%s|' "${KEEP[@]}")
  keep="^(${keep%|})\$"
  keep=${keep//./\\.}
  found=$(ctest --test-dir build-asan -N -R "$keep" | sed -n 's/^Total Tests: //p')
  if [ "$found" != "${#KEEP[@]}" ]; then
    echo "sanitize: KEEP names ${#KEEP[@]} tests, ctest knows $found of them (renamed?)" >&2
    exit 1
  fi
  status=0
  run -LE slow || status=$?
  run -L slow -R "$keep" || status=$?
  exit $status
fi
