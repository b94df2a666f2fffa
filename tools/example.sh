#!/usr/bin/env bash
# The library as a renderer gets it: installs build/ into a fresh prefix, builds examples/two_lights
# against that prefix alone (find_package(coneshadow CONFIG REQUIRED)), runs it, and checks its two masks
# were written and agree with its own double-precision ray cast, then that they equal the CLI's answer for
# the same scene, samples and lights (coneshadow visibility). tools/test.sh runs it after the suite.
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
# The CLI on the same samples: where a sample faces a light, its visible_<l> must be the example's mask_<l>.
build/app/coneshadow visibility "$work/out/scene.obj" --samples "$work/out/samples.txt" --light 3,6,2 --light -4,5,-1.5 \
  --out "$work/out/cli.csv" 2> "$work/visibility.log" || { cat "$work/visibility.log" >&2; exit 1; }
tail -n +3 "$work/out/cli.csv" | paste -d, - <(tail -n +2 "$work/out/masks.csv") | awk -F, '
  NF != 6 { bad = "rows of different counts"; exit }
  { for (l = 0; l < 2; ++l) if ($(1 + l) == 1) { facing++; if ($(3 + l) != $(5 + l)) differ++ } }
  END {
    if (bad != "" || NR == 0) { print "example: the CLI and the example answer different samples (" bad ")" > "/dev/stderr"; exit 1 }
    printf "example: %d sample-light pairs facing the light, %d differ from coneshadow visibility\n", facing, differ
    exit (differ > 0 || facing == 0) }'
[[ $(wc -l < "$work/out/cli.csv") -eq $(($(wc -l < "$work/out/masks.csv") + 1)) ]] || {
  echo "example: the CLI answered $(($(wc -l < "$work/out/cli.csv") - 2)) samples, the example wrote $(($(wc -l < "$work/out/masks.csv") - 1))" >&2; exit 1; }
echo "example: built from the installed prefix, ran, masks written and equal to the CLI's"
