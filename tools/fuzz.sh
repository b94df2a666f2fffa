#!/usr/bin/env bash
# The scene loaders under libFuzzer (fuzz/): one fuzzer per loader (glTF, GLB, BART .aff, and assimp's OBJ,
# PLY, STL, Collada and OFF) built with clang,
# AddressSanitizer and UndefinedBehaviorSanitizer into build-fuzz/, seeded from fuzz/seeds and assimp's glTF
# test models (broken ones included), each run for CONESHADOW_FUZZ_SECONDS (default 60). A crash, sanitizer
# report, exception other than cs::Error, hang (over 25 s on one input) or memory blow-up (over 2 GiB) fails
# the run and prints the input that reproduces it: `build-fuzz/<loader>_fuzzer FILE` runs it again.
# assimp parses in a reader process (core/child_process.h): what crashes it there is the loader's one-line
# error, not a finding, though libFuzzer in that process may still leave an oom- or crash- file in
# build-fuzz/findings; the run's verdict is its exit status.
# Installs what it needs that is missing (as tools/setup.sh does), so the test suite never needs clang.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

PACKAGES=(
  cmake clang-14 libclang-rt-14-dev
  libassimp-dev libglm-dev libtinygltf-dev libstb-dev nlohmann-json3-dev
  assimp-testmodels
)

source tools/install_missing.sh
install_missing fuzz "${PACKAGES[@]}"

SECONDS_EACH=${CONESHADOW_FUZZ_SECONDS:-60}
# A fixed seed by default, so a CI run explores what the last one did (set CONESHADOW_FUZZ_SEED=0 for a
# fresh random one each run).
FUZZ_SEED=${CONESHADOW_FUZZ_SEED:-1}
OUT=$PWD/build-fuzz
mkdir -p "$OUT"
cmake -S fuzz -B "$OUT" -DCMAKE_CXX_COMPILER=clang++-14 > "$OUT/build.log" 2>&1 || {
  cat "$OUT/build.log" >&2; echo "fuzz: configure failed" >&2; exit 1; }
cmake --build "$OUT" -j"${CONESHADOW_FUZZ_BUILD_JOBS:-$(nproc)}" >> "$OUT/build.log" 2>&1 || {
  grep -E "error|Error" "$OUT/build.log" | head -40 >&2; echo "fuzz: build failed; log in build-fuzz/build.log" >&2; exit 1; }

# Seeds: glTF files from the repository and assimp's test models, external buffers inlined, each in both
# containers; the BART and assimp seeds are fuzz/seeds/aff and fuzz/seeds/assimp as they are.
rm -rf "$OUT/seeds"
gltf_files=(fuzz/seeds/gltf/*.gltf)
while IFS= read -r -d '' f; do gltf_files+=("$f"); done < <(find /usr/share/assimp/models/glTF2 \( -name '*.gltf' -o -name '*.glb' \) -print0 | sort -z)
"$OUT/fuzz_seeds" "$OUT/seeds/gltf" "$OUT/seeds/glb" 65536 "${gltf_files[@]}"

export TMPDIR="$OUT/tmp"  # the fuzzers' input folders; one left by a crash stays in build-fuzz
mkdir -p "$TMPDIR"
export UBSAN_OPTIONS=print_stacktrace=1
failed=()
for loader in gltf glb aff assimp; do
  case $loader in
    aff) seeds=fuzz/seeds/aff dict=fuzz/aff.dict ;;
    assimp) seeds=fuzz/seeds/assimp dict=fuzz/assimp.dict ;;
    *) seeds=$OUT/seeds/$loader dict=fuzz/gltf.dict ;;
  esac
  findings=$OUT/findings/$loader
  rm -rf "$findings"
  mkdir -p "$findings" "$OUT/corpus/$loader"
  echo "fuzz: $loader for ${SECONDS_EACH} s"
  lsan=
  [ "$loader" = assimp ] && lsan=suppressions=$PWD/fuzz/assimp.lsan
  if LSAN_OPTIONS=$lsan "$OUT/${loader}_fuzzer" -max_total_time="$SECONDS_EACH" -timeout=25 -rss_limit_mb=2048 -max_len=65536 \
      -seed="$FUZZ_SEED" -dict="$dict" -artifact_prefix="$findings/" -print_final_stats=1 \
      "$OUT/corpus/$loader" "$seeds" > "$OUT/$loader.log" 2>&1; then
    echo "fuzz: $loader: $(grep -o 'stat::number_of_executed_units: *[0-9]*' "$OUT/$loader.log" | grep -o '[0-9]*$') inputs, no findings"
  else
    failed+=("$loader")
    grep -E "ERROR|SUMMARY|runtime error|uncaught|fuzz: |==[0-9]+==" "$OUT/$loader.log" | head -20 >&2 || true
    echo "fuzz: $loader FOUND A PROBLEM; log: build-fuzz/$loader.log" >&2
    for f in "$findings"/*; do
      [ -e "$f" ] && echo "fuzz: reproduce with: build-fuzz/${loader}_fuzzer ${f#"$PWD/"}" >&2
    done
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: findings in ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: no findings"
