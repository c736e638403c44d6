#!/usr/bin/env bash
# The batch throughput figure: `meshmux batch` on the local pool against a sequential shell
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

ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }'; }
# Runs a command under GNU time; sets wall and cpu (user + system seconds, children included).
timed() {
  /usr/bin/time -f "%e %U %S" -o "$work/time.txt" "$@" || true
  read -r wall user sys < <(tail -n 1 "$work/time.txt")
  cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { print u + s }')
}
[ -x /usr/bin/time ] || { echo "batch: GNU time is not installed (apt install time)" >&2; exit 77; }

# 1. The loop a user scripts today: one convert after the other, over the list's paths.
each_input='i=0; grep -v "^#" "$0" | grep -v "^$" | while IFS= read -r f; do i=$((i + 1)); '
timed bash -c "$each_input"'"$1" convert "$f" -o "$2/loop/$i" -q 2>/dev/null || true; done' \
  "$list" "$mm" "$work"
loop=$wall loop_cpu=$cpu

# 2. meshmux batch, one worker per core (the default), then one worker (the pool's own cost).
timed "$mm" batch "$list" -o "$work/pool" -q
pool=$wall pool_cpu=$cpu
timed "$mm" batch "$list" -o "$work/pool1" --jobs 1 -q
pool1=$wall pool1_cpu=$cpu

# 3. For scale: gltfpack -cc, one after the other, on the inputs it reads (.glb, .gltf).
gp="-"
if command -v gltfpack >/dev/null; then
  timed bash -c "$each_input"'case "${f,,}" in *.glb | *.gltf) gltfpack -cc -i "$f" -o "$1/gltfpack-$i.glb" >/dev/null 2>&1 || true ;; esac; done' \
    "$list" "$work"
  gp=$wall
fi

ok=$(node -e "const d=require('$work/pool/batch.json'); console.log(d.counts.ok + ' converted, ' + d.counts.failed + ' failed')")
busy() { awk -v c="$1" -v w="$2" 'BEGIN { printf "%.2f", c / w }'; }
printf '\n%-44s %8s %8s %8s %8s\n' "run (same ${#inputs[@]} inputs)" "wall s" "CPU s" "cores" "vs loop"
printf '%-44s %8.1f %8.1f %8s %8s\n' "sequential loop of meshmux convert" "$loop" "$loop_cpu" "$(busy "$loop_cpu" "$loop")" "1.00"
printf '%-44s %8.1f %8.1f %8s %7sx\n' "meshmux batch (--jobs $cores, the default)" "$pool" "$pool_cpu" "$(busy "$pool_cpu" "$pool")" "$(ratio "$loop" "$pool")"
printf '%-44s %8.1f %8.1f %8s %7sx\n' "meshmux batch --jobs 1" "$pool1" "$pool1_cpu" "$(busy "$pool1_cpu" "$pool1")" "$(ratio "$loop" "$pool1")"
[ "$gp" = "-" ] || printf '%-44s %8.1f\n' "sequential loop of gltfpack -cc (.glb/.gltf)" "$gp"
# The most a pool of $cores can gain over the loop: all cores busy, against the cores the loop
# keeps busy itself (convert's renders run on llvmpipe's rasterizer threads).
echo "batch: the loop keeps $(busy "$loop_cpu" "$loop") cores busy, so $cores cores allow at most $(awk -v n="$cores" -v c="$loop_cpu" -v w="$loop" 'BEGIN { printf "%.2f", n * w / c }')x; the pool reached $(ratio "$loop" "$pool")x"
echo "batch: $ok (batch.json)"
