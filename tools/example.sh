#!/usr/bin/env bash
# The library as a renderer gets it: installs build/ into a fresh prefix, builds examples/two_lights
# against that prefix alone (find_package(coneshadow CONFIG REQUIRED)), runs it, and checks its two masks
# were written and agree with its own double-precision ray cast. tools/test.sh runs it after the suite.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install build --prefix "$work/prefix" > "$work/install.log" 2>&1 || { cat "$work/install.log" >&2; exit 1; }
cmake -S examples/two_lights -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" > "$work/configure.log" 2>&1 || {
  cat "$work/configure.log" >&2; echo "example: configure against the installed prefix failed" >&2; exit 1; }
cmake --build "$work/build" > "$work/build.log" 2>&1 || {
  cat "$work/build.log" >&2; echo "example: build against the installed prefix failed" >&2; exit 1; }
mkdir -p "$work/out"
"$work/build/two_lights" "$work/out"
for f in light0.png light1.png; do
  [[ -s "$work/out/$f" ]] || { echo "example: $f was not written" >&2; exit 1; }
done
echo "example: built from the installed prefix, ran, masks written"
