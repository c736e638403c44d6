#!/usr/bin/env bash
# The conversion-speed table: meshmux against gltfpack (Debian's binary), back to back on the same
# inputs in one run, ratios printed. Inputs: every shared model over 50,000 scene triangles, the
# generated 1M-triangle mesh (bench/generated_mesh.py) and a generated instanced forest
# (bench/generated_forest.py), or the files named. Per input:
#   folder conversion (`convert IN -o DIR`: model.glb, base.glb, the stream) vs `gltfpack -cc`
#   single file (`convert IN -o X.glb`) vs `gltfpack -cc`
#   `simplify --ratio 0.2` vs `gltfpack -si 0.2`
#   the progressive record's rate (unique input triangles / the simplifier's time, from
#   convert's progress) and peak RSS (GNU time's maximum resident set size).
# Timings are wall seconds on this machine; run it alone.
# usage: bench/speed.sh [BUILD_DIR] [INPUT ...]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
if [ $# -gt 0 ] && [ -f "$1/build.ninja" ]; then build=$1; shift; fi
cmake --build "$build" --target meshmux -j 2 >/dev/null
mm="$build/meshmux"
command -v gltfpack >/dev/null || { echo "speed: gltfpack is not installed (apt install gltfpack)" >&2; exit 77; }
[ -x /usr/bin/time ] || { echo "speed: GNU time is not installed (apt install time)" >&2; exit 77; }
work="$build/speed"
mkdir -p "$work"
inputs=("$@")
if [ ${#inputs[@]} -eq 0 ]; then
  models="$here/../shared/models"
  if [ -d "$models" ]; then
    for d in "$models"/*/; do
      f=$(ls "$d" | grep -iE '\.(glb|gltf|dae)$' | head -1 || true)
      [ -n "$f" ] || continue
      tris=$("$mm" info "$d$f" --json 2>/dev/null | python3 -c 'import json,sys; print(json.load(sys.stdin).get("scene_triangles", 0))' || echo 0)
      [ "$tris" -gt 50000 ] && inputs+=("$d$f")
    done
  else
    echo "speed: $models absent; generated inputs only" >&2
  fi
  [ -f "$work/generated-1M.glb" ] || python3 "$here/bench/generated_mesh.py" "$work/generated-1M.glb" >/dev/null
  [ -f "$work/forest.glb" ] || python3 "$here/bench/generated_forest.py" "$work/forest.glb" >/dev/null
  inputs+=("$work/generated-1M.glb" "$work/forest.glb")
fi

# run NAME CMD...: runs CMD under GNU time; sets SEC and MB (peak RSS), keeps stderr in WORK/NAME.err.
run() {
  local name=$1; shift
  local t0 t1
  t0=$(date +%s.%N)
  if /usr/bin/time -f '%M' -o "$work/$name.time" "$@" >/dev/null 2>"$work/$name.err"; then
    t1=$(date +%s.%N)
    SEC=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.3f}')" "$t0" "$t1")
    MB=$(($(tail -1 "$work/$name.time") / 1024))
  else
    SEC=fail; MB=-
  fi
}
ratio() { python3 -c "import sys; a, b = sys.argv[1:]; print('–' if 'fail' in (a, b) or float(b) <= 0 else f'{float(a) / float(b):.1f}')" "$1" "$2"; }

printf '| input | scene triangles | convert -o DIR s | gltfpack -cc s | ratio (≤ 10) | convert -o X.glb s | ratio (≤ 3) | simplify 0.2 s | gltfpack -si 0.2 s | ratio (≤ 3) | record M tri/s (≥ 1) | peak RSS convert MB (≤ 1024) | gltfpack MB |\n'
printf '|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n'
for in in "${inputs[@]}"; do
  name=$(basename "$(dirname "$in")")
  case "$in" in "$work"/*) name=$(basename "$in" .glb) ;; esac
  tris=$("$mm" info "$in" --json 2>/dev/null | python3 -c 'import json,sys; print(json.load(sys.stdin).get("scene_triangles", 0))' || echo '?')
  rm -rf "$work/$name.dir" "$work/$name.mm.glb" "$work/$name.gp.glb" "$work/$name.si.glb" "$work/$name.gpsi.glb"
  run "$name.gp" gltfpack -cc -i "$in" -o "$work/$name.gp.glb"; gp=$SEC gp_mb=$MB
  run "$name.dir" "$mm" convert "$in" -o "$work/$name.dir"; dir=$SEC dir_mb=$MB
  record=$(python3 - "$work/$name.dir.err" <<'PY'
import re, sys
t = open(sys.argv[1], encoding="utf-8", errors="replace").read()
# The record is built on the unique (mesh) triangles; instances share theirs.
u = re.search(r"cleaned: (\d+) unique triangles", t)
m = re.search(r"collapses in (\d+) ms", t)
print(f"{int(u.group(1)) / max(1, int(m.group(1))) / 1000:.2f}" if u and m else "–")
PY
)
  run "$name.glb" "$mm" convert "$in" -o "$work/$name.mm.glb"; glb=$SEC
  run "$name.si" "$mm" simplify "$in" -o "$work/$name.si.glb" --ratio 0.2; si=$SEC
  run "$name.gpsi" gltfpack -si 0.2 -i "$in" -o "$work/$name.gpsi.glb"; gpsi=$SEC
  printf '| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$name" "$tris" \
    "$dir" "$gp" "$(ratio "$dir" "$gp")" "$glb" "$(ratio "$glb" "$gp")" "$si" "$gpsi" \
    "$(ratio "$si" "$gpsi")" "$record" "$dir_mb" "$gp_mb"
done
