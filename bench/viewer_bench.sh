#!/usr/bin/env bash
# The viewer's frame time against the cone path's own shadow time, built-in scene, its first view, under
# Xvfb. The viewer's: `coneshadow view --frames N --hide-ui --stats`, the median of its steady frames
# during which the Embree worker was idle (it shares the CPU on lavapipe; the wall clock of a whole frame:
# camera pass, the cone path through the public API, the composite, the present and the wait for it). The peer: `coneshadow render --methods cone` at the same size, the median
# of its timed frames (results.json total_ms: the shadow work alone). Rounds alternate the two; each
# figure is the median over the rounds. docs/ARCHITECTURE.md, "The viewer".
# Usage: bench/viewer_bench.sh [SIZES (512,1024)] [FRAMES (40)] [ROUNDS (3)]; BUILD (default build).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
SIZES=${1:-512,1024}
FRAMES=${2:-40}
ROUNDS=${3:-3}
CLI=${BUILD:-build}/app/coneshadow
[ -x "$CLI" ] || { echo "viewer_bench: $CLI is not built (run tools/setup.sh)" >&2; exit 1; }
command -v xvfb-run > /dev/null || { echo "viewer_bench: xvfb-run is not installed (tools/setup.sh)" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2) }'; }

echo "| size | view: frame, worker idle (ms) | render: cone shadow work (ms) | frame / shadow work |"
echo "| --- | --- | --- | --- |"
for size in ${SIZES//,/ }; do
  : > "$work/view" && : > "$work/render"
  for _ in $(seq "$ROUNDS"); do
    xvfb-run -a -s "-screen 0 $((size + 64))x$((size + 64))x24" "$CLI" view --width "$size" --height "$size" \
      --frames "$FRAMES" --hide-ui --stats | sed -n 's/.* ms, \([0-9.e+-]*\) ms over the [0-9]* with the reference worker idle.*/\1/p' >> "$work/view"
    "$CLI" render --methods cone --width "$size" --height "$size" --frames "$FRAMES" --quiet --out "$work/out" > /dev/null
    python3 -c "import json,sys; print([r for r in json.load(open(sys.argv[1])) if r['method'] == 'cone'][0]['total_ms'])" \
      "$work/out/results.json" >> "$work/render"
  done
  v=$(median < "$work/view")
  r=$(median < "$work/render")
  awk -v s="$size" -v v="$v" -v r="$r" 'BEGIN { printf "| %d² | %.1f | %.1f | %.2fx |\n", s, v, r, v / r }'
done
echo
echo "$ROUNDS rounds of $FRAMES frames each at each size; the medians of the rounds' medians; wall clock."
python3 -c "import json,sys; print('device:', [r for r in json.load(open(sys.argv[1])) if r['method'] == 'cone'][0]['device'])" \
  "$work/out/results.json"
