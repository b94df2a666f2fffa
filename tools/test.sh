#!/usr/bin/env bash
# The whole test suite: set up (tools/setup.sh), then every test through ctest, on whatever Vulkan device
# the machine has (lavapipe without a GPU), with the validation layer on inside the tests; then the
# installed library's example (tools/example.sh).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash tools/setup.sh
ctest --test-dir build --output-on-failure -j"$(nproc)" --timeout 600 "$@"
# The library built from its installed prefix by a project of its own (examples/two_lights).
bash tools/example.sh
