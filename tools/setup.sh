#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages), configures and builds coneshadow into build/.
# Sourced by tools/run.sh and tools/test.sh; safe to run again (installs and rebuilds only what changed).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

PACKAGES=(
  build-essential cmake pkg-config
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers
  glslang-tools glslang-dev spirv-tools
  libembree-dev libtbb-dev libglm-dev libtinygltf-dev libstb-dev nlohmann-json3-dev
  libgtest-dev libcli11-dev libassimp-dev libtinyexr-dev
  assimp-testmodels
  librsvg2-dev chromium
  pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib
  libglfw3-dev libimgui-dev xvfb xauth
)

source tools/install_missing.sh
install_missing setup "${PACKAGES[@]}"

BUILD_TYPE=${CONESHADOW_BUILD_TYPE:-Release}
cmake -S . -B build -DCMAKE_BUILD_TYPE="$BUILD_TYPE" ${CONESHADOW_CMAKE_ARGS:-} > build.log 2>&1 || {
  cat build.log >&2; echo "setup: cmake configure failed (log above)" >&2; exit 1; }
cmake --build build -j"$(nproc)" >> build.log 2>&1 || {
  grep -E "error|Error|ERROR" build.log | head -40 >&2; echo "setup: build failed; full log in build.log" >&2; exit 1; }
echo "setup: built build/app/coneshadow"
