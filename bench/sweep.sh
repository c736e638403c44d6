#!/usr/bin/env bash
# The corpus sweep (docs/ARCHITECTURE.md "Targets": appearance and uploads on ../shared/corpus):
# builds meshmux, then converts every corpus model as an upload (its folder, --main its main
# file) and judges model.glb against the original with three.js (bench/fidelity.mjs --corpus):
# unlit ≥ 30 dB, lit ≥ 28 dB, coverage IoU ≥ 0.99, normals against winding ≤ the input's + 0.1%.
# Writes BUILD/sweep/sweep.md (summary line, table, misses by cause), sweep.tsv and sweep.json,
# prints the markdown and the total time. Two conversions (one thread each) run ahead of the judge:
# about 106 models in well under an hour on 2 cores. Extra arguments go to bench/fidelity.mjs
# (e.g. --only Duck-glb,gazebo-bowl-dae, --require ..., --jobs 0, --legacy-input, --dump);
# --no-build uses BUILD_DIR/meshmux as it is. Exit 77 when ../shared/corpus is absent.
# usage: bench/sweep.sh [BUILD_DIR] [--no-build] [options]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
corpus="$here/../shared/corpus"
build="$here/build"
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then build=$1; shift; fi
if [ ! -f "$corpus/models.tsv" ]; then
  echo "SKIPPED: $corpus/models.tsv not found (../shared/corpus absent)" >&2
  exit 77
fi
args=()
build_it=1
for a in "$@"; do
  if [ "$a" = --no-build ]; then build_it=0; else args+=("$a"); fi
done
if [ "$build_it" = 1 ]; then
  [ -f "$build/build.ninja" ] || cmake -S "$here" -B "$build" -G Ninja >/dev/null
  cmake --build "$build" --target meshmux -j 2 >/dev/null
fi
start=$(date +%s)
rc=0
node "$here/bench/fidelity.mjs" --meshmux "$build/meshmux" --corpus "$corpus" --work "$build/sweep" \
  ${args[@]+"${args[@]}"} || rc=$?
elapsed=$(( $(date +%s) - start ))
printf '\nsweep: %d min %02d s in all\n' $((elapsed / 60)) $((elapsed % 60))
exit "$rc"
