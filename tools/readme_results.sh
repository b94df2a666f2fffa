#!/usr/bin/env bash
# Regenerates every measured figure of docs/RESULTS.md (the README's verdict reads them) from one run of
# the commands below, on one machine, and rewrites each section between its <!-- NAME:begin --> and
# <!-- NAME:end --> markers, every one
# stamped with this run's date and device. No figure is written twice: the frame bench's settings table
# holds the times, its host-cost table the ratios from those times, and the other benchmarks measure
# what that table does not (variants as ratios to the default, the sort primitives, dynamic scenes,
# scaling, large scenes, far lights).
#   results    every method setting per view at SIZE² (bench/frame_bench, i.e. `coneshadow compare`)
#   host-cost  the cone path's time against its peers and each method's host cost (same run, SMALL² and SIZE²)
#   variants   paper 002's variants (bench/variants_bench)
#   sort       GPU sort primitives against the CPU (bench/sort_bench)
#   access     what one memory access of each kind costs a kernel (bench/access_bench)
#   dynamic    moving scenes (`coneshadow compare --animate`)
#   scaling    resolution and triangle count (`coneshadow compare --scaling`)
#   scale      height fields to 10 M triangles (bench/scale_bench)
#   far        the light's distance (`coneshadow compare --light-distances`)
#   viewer     `coneshadow view`'s frame time against the cone path's shadow time (bench/viewer_bench.sh,
#              under Xvfb), and the README's screenshot of the window (docs/img/viewer.png, scripted)
# and copies the plots docs/RESULTS.md shows into docs/img/.
# Environment: SIZE (default 1024) and SMALL (512), the frame bench's sizes; FRAMES (default 3); OUT
# (default build/readme-results); RESULTS, the page written (default docs/RESULTS.md, with TAG=gpu
# docs/RESULTS_GPU.md), and IMG (default docs/img); SKIP_BUILD=1
# to use the current build/ as is; BUILD (default build) to run another build's binaries while this one
# changes; QUICK=1 (a check of the script: the scale bench on one small field); ONLY=far,sort (a comma
# list of run names: frames (the results and host-cost sections), variants, sort, access, dynamic,
# scaling, scale, far, viewer) reruns those alone and leaves the other sections as they are; TAG=gpu writes
# each section NAME into the NAME-gpu markers of docs/RESULTS_GPU.md instead (a GPU's figures on a page
# of their own beside lavapipe's: `TAG=gpu ONLY=frames,variants,sort,scale tools/readme_results.sh` on a
# machine whose Vulkan device is that GPU) and copies no plots. About 20 minutes on 2 CPU cores with lavapipe for
# everything; about 5 on a GPU with 16 cores.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

SIZE=${SIZE:-1024}
SMALL=${SMALL:-512}
FRAMES=${FRAMES:-3}
OUT=${OUT:-build/readme-results}
IMG=${IMG:-docs/img}
BUILD=${BUILD:-build}
CLI=$BUILD/app/coneshadow
ENGINE=/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb
MUSEUM=../shared/scenes/bart/museum/museum5.aff
[ -f shared/scenes/bart/museum/museum5.aff ] && MUSEUM=shared/scenes/bart/museum/museum5.aff

[ "${SKIP_BUILD:-0}" = 1 ] || ./tools/setup.sh
for b in "$CLI" "$BUILD"/bench/{frame_bench,variants_bench,sort_bench,access_bench,scale_bench}; do
  [ -x "$b" ] || { echo "readme_results: $b is not built (run tools/setup.sh)" >&2; exit 1; }
done
[ -f "$ENGINE" ] || { echo "readme_results: $ENGINE not found (Debian package assimp-testmodels)" >&2; exit 1; }
[ -f "$MUSEUM" ] || { echo "readme_results: $MUSEUM not found (the BART scenes, ../shared/scenes/bart)" >&2; exit 1; }
TAG=${TAG:-}
# The page the sections go into: docs/RESULTS.md, or docs/RESULTS_<TAG in capitals>.md for a tagged run.
if [ -n "$TAG" ]; then RESULTS=${RESULTS:-docs/RESULTS_$(echo "$TAG" | tr '[:lower:]' '[:upper:]').md}; fi
RESULTS=${RESULTS:-docs/RESULTS.md}
[ -f "$RESULTS" ] || { echo "readme_results: $RESULTS not found" >&2; exit 1; }
# marker NAME: the markers section NAME goes between in $RESULTS (NAME, or NAME-TAG).
marker() { echo "$1${TAG:+-$TAG}"; }
# want NAME: whether this run of the script reruns NAME (ONLY unset: every one).
want() { [ -z "${ONLY:-}" ] || [[ ",$ONLY," == *",$1,"* ]]; }
for name in results host-cost variants sort access dynamic scaling scale far viewer; do
  run_name=$name
  case $name in results | host-cost) run_name=frames ;; esac
  [ -z "$TAG" ] || want "$run_name" || continue  # a tagged run needs the markers of what it reruns only
  m=$(marker "$name")
  grep -q "^<!-- $m:begin -->\$" "$RESULTS" && grep -q "^<!-- $m:end -->\$" "$RESULTS" || {
    echo "readme_results: $RESULTS lacks the <!-- $m:begin --> / <!-- $m:end --> lines" >&2; exit 1; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$OUT"
date=$(date -u +%Y-%m-%d)
rev=$(git rev-parse --short HEAD 2>/dev/null || echo "no git revision")
device=unknown

# run NAME COMMAND...: runs it, keeps its output in $work/NAME.out and the command line in $work/NAME.cmd.
run() {
  local name=$1
  shift
  local shown="$*"
  shown=${shown//"$BUILD/"/build/}  # the page names the build a newcomer makes, whichever copy ran
  echo "readme_results: $*" >&2
  echo "$shown" >> "$work/$name.cmd"
  "$@" >> "$work/$name.out"
}
# plot FILE NAME: copies a plot docs/RESULTS.md shows into $IMG as NAME (not for a TAG run: the pages
# show lavapipe's).
plot() { [ -n "$TAG" ] || { mkdir -p "$IMG"; cp "$1" "$IMG/$2"; }; }
# tables FILE: the markdown tables of a report, its "## view" headings as bold lines.
tables() { awk '/^## / { sub(/^## /, ""); print ""; print "**" $0 "**"; print ""; next } /^\|/ { print }' "$1"; }
# section NAME: the header every section starts with (its date, device and commands), then stdin.
section() {
  local name=$1
  # A run without the frames (ONLY=...) names the device from the first bench output that prints it.
  [ "$device" != unknown ] || device=$(cat "$work"/*.out 2>/dev/null | sed -n 's/^device: //p' | head -1)
  [ -n "$device" ] || device=unknown
  local m
  m=$(marker "$name")
  {
    echo "<!-- $m:begin -->"
    echo "Run on $date at \`$rev\` by \`tools/readme_results.sh\` (SIZE=$SIZE SMALL=$SMALL FRAMES=$FRAMES${ONLY:+ ONLY=$ONLY}${TAG:+ TAG=$TAG}), device \`$device\`; command(s):"
    echo
    echo '```'
    cat "$work/$name.cmd"
    echo '```'
    echo
    cat
    echo "<!-- $m:end -->"
  } > "$work/$m.section"
}

# ---- the frames: every method and setting per view, at 512² and SIZE² ----------------------------
if want frames; then
run frames "$BUILD/bench/frame_bench" --sizes "$SMALL,$SIZE" --frames "$FRAMES" --scenes builtin,engine,museum \
  --out "$OUT/frames"
device=$(sed -n 's/^device: //p' "$work/frames.out" | head -1)
cp "$work/frames.cmd" "$work/results.cmd"
"$CLI" results-table "$OUT/frames/builtin_$SIZE" "$OUT/frames/engine_$SIZE" "$OUT/frames/museum_$SIZE" |
  section results
cp "$work/frames.cmd" "$work/host-cost.cmd"
"$CLI" results-table --host-cost "$OUT/frames/builtin_$SMALL" "$OUT/frames/builtin_$SIZE" "$OUT/frames/engine_$SMALL" \
  "$OUT/frames/engine_$SIZE" "$OUT/frames/museum_$SMALL" "$OUT/frames/museum_$SIZE" | section host-cost
plot "$OUT/frames/builtin_$SIZE/speed_vs_error.png" speed_vs_error_builtin.png
plot "$OUT/frames/museum_$SIZE/speed_vs_error.png" speed_vs_error_museum.png
plot "$OUT/frames/builtin_$SIZE/error_vs_bytes.png" error_vs_bytes_builtin.png
fi

# ---- the other benchmarks -------------------------------------------------------------------------
if want variants; then
  run variants "$BUILD/bench/variants_bench" --size "$SIZE" --frames "$FRAMES" --scenes builtin,engine,museum
  grep -v '^device:' "$work/variants.out" | section variants
fi

if want sort; then
  run sort "$BUILD/bench/sort_bench" --runs 9
  { echo '```'; grep -v '^device:' "$work/sort.out"; echo '```'; } | section sort
fi

if want access; then
  run access "$BUILD/bench/access_bench" --runs 7
  grep -v '^device:' "$work/access.out" | section access
fi

if want dynamic; then
run dynamic "$CLI" compare --animate 8 --width 256 --height 256 --methods embree,cone,rmsm --out "$OUT/dynamic-builtin" --quiet
run dynamic "$CLI" compare "$ENGINE" --animate 8 --moving-camera --width 256 --height 256 --methods embree,cone,rmsm \
  --out "$OUT/dynamic-engine" --quiet
run dynamic "$CLI" compare "$MUSEUM" --animate 8 --width 256 --height 256 --methods embree,cone,rmsm \
  --out "$OUT/dynamic-museum" --quiet
for d in builtin engine museum; do
  echo; echo "**$(head -1 "$OUT/dynamic-$d/dynamic.md" | sed 's/^# coneshadow compare --animate: //')**"
  tables "$OUT/dynamic-$d/dynamic.md" | sed 's/^\*\*\(.*\)\*\*$/*\1*/'
done | section dynamic
fi

if want scaling; then
  run scaling "$CLI" compare --scaling --views wall --frames "$FRAMES" --out "$OUT/scaling" --quiet
  tables "$OUT/scaling/scaling.md" | section scaling
  plot "$OUT/scaling/scaling_triangles.png" scaling_triangles.png
  plot "$OUT/scaling/scaling_resolution.png" scaling_resolution.png
fi

if ! want scale; then
  :
elif [ "${QUICK:-0}" = 1 ]; then  # a check of this script, not a result: one small field
  run scale "$BUILD/bench/scale_bench" --sizes "$SMALL,$SIZE" --frames 1 --memory-budget 1G --scenes heightfield:100k
else
  run scale "$BUILD/bench/scale_bench" --sizes "$SMALL,$SIZE" --frames "$FRAMES" --memory-budget 1G
fi
if want scale; then
  { echo '```'; grep -v '^device:' "$work/scale.out"; echo '```'; } | section scale
fi

if want far; then
  run far "$CLI" compare "$ENGINE" --light-distances 1,10,100,1000,10000,100000 --width 256 --height 256 \
    --frames "$FRAMES" --out "$OUT/far" --quiet
  [ "$device" != unknown ] || device=$(sed -n 's/^device: //p' "$OUT/far/light_distances.md" | head -1)
  tables "$OUT/far/light_distances.md" | section far
  plot "$OUT/far/light_distances.png" light_distances_engine.png
fi

if want viewer; then
  run viewer env BUILD="$BUILD" bench/viewer_bench.sh "$SMALL,$SIZE" 40 3
  grep -v '^device:' "$work/viewer.out" | section viewer
  # The README's picture of the window: cubesm's diff against Embree on the room view, the panels shown.
  if [ -z "$TAG" ]; then
    mkdir -p "$IMG" "$OUT/viewer"
    printf 'method cubesm\ndisplay diff\nwait-reference\nwait 2\nscreenshot %s\nquit\n' "$OUT/viewer/viewer.png" > "$OUT/viewer/script.txt"
    xvfb-run -a -s '-screen 0 1024x768x24' "$CLI" view --view room --width 960 --height 540 --methods cone,cubesm \
      --script "$OUT/viewer/script.txt" > /dev/null
    cp "$OUT/viewer/viewer.png" "$IMG/viewer.png"
  fi
fi

# ---- every section into the results page at once ------------------------------------------------
awk -v dir="$work" '
  /^<!-- [a-z-]+:begin -->$/ { name = $2; sub(/:begin$/, "", name); file = dir "/" name ".section"
                               if ((getline line < file) <= 0) { print; next }  # not rerun (ONLY): kept
                               print line; while ((getline line < file) > 0) print line; skip = 1; next }
  /^<!-- [a-z-]+:end -->$/ { if (!skip) print; skip = 0; next }  # a kept section keeps its end line
  !skip { print }
' "$RESULTS" > "$work/results"
mv "$work/results" "$RESULTS"
echo "readme_results: ${ONLY:-every} results section(s) of $RESULTS rewritten ($date, $device)"
