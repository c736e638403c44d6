#!/usr/bin/env bash
# Issue 8/8's throughput figure: `meshmux batch` on the local pool against a sequential shell
# loop of `meshmux convert` over the same list, back to back in one run, ratio printed; a
# sequential `gltfpack -cc` loop over the list's .glb/.gltf inputs beside them for scale.
# The list: every shared model plus the 20 broken copies of tests/cli/batch_shared_test.mjs
# (or a list file given). Wall seconds on this machine; run it alone.
# usage: bench/batch.sh [BUILD_DIR] [LIST]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
if [ $# -gt 0 ] && [ -f "$1/build.ninja" ]; then build=$1; shift; fi
cmake --build "$build" --target meshmux -j 2 >/dev/null
mm="$build/meshmux"
work="$build/bench-batch"
rm -rf "$work"
mkdir -p "$work"
if [ $# -gt 0 ]; then
  list=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
else
  [ -d "$here/../shared/models" ] || { echo "batch: ../shared/models is absent" >&2; exit 77; }
  list=$(node "$here/tests/cli/batch_shared_test.mjs" --mode list --work "$work/inputs")
fi
mapfile -t inputs < <(grep -v '^#' "$list" | grep -v '^$')
cores=$(nproc)
echo "batch: ${#inputs[@]} inputs from $list, $cores cores"

now() { date +%s.%N; }
seconds() { awk -v a="$1" -v b="$2" 'BEGIN { print b - a }'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }'; }

# 1. The loop a user scripts today: one convert after the other.
t0=$(now)
i=0
for f in "${inputs[@]}"; do
  i=$((i + 1))
  "$mm" convert "$f" -o "$work/loop/$i" -q 2>/dev/null || true
done
t1=$(now)
loop=$(seconds "$t0" "$t1")

# 2. meshmux batch, one worker per core (the default), then one worker (the pool's own cost).
t0=$(now)
"$mm" batch "$list" -o "$work/pool" -q || true
t1=$(now)
pool=$(seconds "$t0" "$t1")
t0=$(now)
"$mm" batch "$list" -o "$work/pool1" --jobs 1 -q || true
t1=$(now)
pool1=$(seconds "$t0" "$t1")

# 3. For scale: gltfpack -cc, one after the other, on the inputs it reads (.glb, .gltf).
gp="-"
if command -v gltfpack >/dev/null; then
  t0=$(now)
  i=0
  for f in "${inputs[@]}"; do
    i=$((i + 1))
    case "${f,,}" in *.glb | *.gltf) gltfpack -cc -i "$f" -o "$work/gltfpack-$i.glb" >/dev/null 2>&1 || true ;; esac
  done
  t1=$(now)
  gp=$(seconds "$t0" "$t1")
fi

ok=$(node -e "const d=require('$work/pool/batch.json'); console.log(d.counts.ok + ' converted, ' + d.counts.failed + ' failed')")
printf '\n%-44s %9s %9s\n' "run (same ${#inputs[@]} inputs)" "wall s" "vs loop"
printf '%-44s %9.1f %9s\n' "sequential loop of meshmux convert" "$loop" "1.00"
printf '%-44s %9.1f %8sx\n' "meshmux batch (--jobs $cores, the default)" "$pool" "$(ratio "$loop" "$pool")"
printf '%-44s %9.1f %8sx\n' "meshmux batch --jobs 1" "$pool1" "$(ratio "$loop" "$pool1")"
[ "$gp" = "-" ] || printf '%-44s %9.1f\n' "sequential loop of gltfpack -cc (.glb/.gltf)" "$gp"
echo "batch: $ok (batch.json)"
