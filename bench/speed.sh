#!/usr/bin/env bash
# The conversion-speed table: meshmux against gltfpack (Debian's binary), back to back on the same
# inputs in one run, ratios printed against the targets (docs/ARCHITECTURE.md "Targets").
# Inputs: every shared model over 50,000 scene triangles, every ../shared/corpus model over
# 50,000 (converted as an upload: its folder, --main its main file; gltfpack reads the main
# file), the generated 1M-triangle mesh and the scan-like 4M one (bench/generated_mesh.py,
# --scan: noisy, no uv, shuffled order) and a generated instanced forest
# (bench/generated_forest.py); or the files named. Per input:
#   folder conversion (`convert IN -o DIR`: model.glb, base.glb, the stream) vs `gltfpack -cc`:
#     ≤ 15x on untextured inputs, ≤ 30x on textured ones
#   single file (`convert IN -o X.glb`) vs `gltfpack -cc`
#   `simplify --ratio 0.2` vs `gltfpack -si 0.2`: ≤ 3x
#   the progressive record's rate (unique input triangles / the simplifier's time, from
#     convert's progress): ≥ 1 M triangles/s
#   peak RSS of the folder conversion (GNU time's maximum resident set size): ≤ 1024 MB
#   base.glb / model.glb: ≤ 0.25 on inputs over 10,000 triangles
# and, for the 4M mesh, the folder conversion's seconds (≤ 15). Timings are wall seconds on
# this machine; run it alone. `--quick` leaves out the 4M mesh (its generation and conversion
# take minutes).
# usage: bench/speed.sh [BUILD_DIR] [--quick] [INPUT ...]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
if [ $# -gt 0 ] && [ -f "$1/build.ninja" ]; then build=$1; shift; fi
quick=0
if [ $# -gt 0 ] && [ "$1" = --quick ]; then quick=1; shift; fi
cmake --build "$build" --target meshmux -j 2 >/dev/null
mm="$build/meshmux"
command -v gltfpack >/dev/null || { echo "speed: gltfpack is not installed (apt install gltfpack)" >&2; exit 77; }
[ -x /usr/bin/time ] || { echo "speed: GNU time is not installed (apt install time)" >&2; exit 77; }
work="$build/speed"
mkdir -p "$work"
info() { "$mm" info "$1" --json 2>/dev/null | python3 -c "import json,sys; print(json.load(sys.stdin).get('$2', 0))" || echo 0; }

# Inputs as "NAME|FILE|UPLOAD_FOLDER" (the folder empty for a file converted as it is).
inputs=()
for f in "$@"; do inputs+=("$(basename "$f" | sed 's/\.[^.]*$//')|$f|"); done
if [ $# -eq 0 ]; then
  models="$here/../shared/models"
  if [ -d "$models" ]; then
    for d in "$models"/*/; do
      f=$(ls "$d" | grep -iE '\.(glb|gltf|dae)$' | head -1 || true)
      [ -n "$f" ] || continue
      [ "$(info "$d$f" scene_triangles)" -gt 50000 ] && inputs+=("$(basename "$d")|$d$f|")
    done
  else
    echo "speed: $models absent; generated inputs only" >&2
  fi
  corpus="$here/../shared/corpus"
  if [ -f "$corpus/models.tsv" ]; then
    while IFS=$'\t' read -r folder main _format tris _rest; do
      [ "$folder" = folder ] && continue
      [ "$tris" -gt 50000 ] 2>/dev/null && inputs+=("$folder|$corpus/$folder/$main|$corpus/$folder")
    done <"$corpus/models.tsv"
  else
    echo "speed: $corpus absent; no corpus inputs" >&2
  fi
  [ -f "$work/generated-1M.glb" ] || python3 "$here/bench/generated_mesh.py" "$work/generated-1M.glb" >/dev/null
  inputs+=("generated-1M|$work/generated-1M.glb|")
  if [ "$quick" = 0 ]; then
    [ -f "$work/scan-4M.glb" ] ||
      python3 "$here/bench/generated_mesh.py" "$work/scan-4M.glb" --triangles 4000000 --scan >/dev/null
    inputs+=("scan-4M|$work/scan-4M.glb|")
  fi
  [ -f "$work/forest.glb" ] || python3 "$here/bench/generated_forest.py" "$work/forest.glb" >/dev/null
  inputs+=("forest|$work/forest.glb|")
fi

# run NAME CMD...: runs CMD under GNU time; sets SEC and MB (peak RSS), keeps stderr in WORK/NAME.err.
run() {
  local name=$1; shift
  local t0 t1
  t0=$(date +%s.%N)
  if /usr/bin/time -f '%M' -o "$work/$name.time" "$@" >/dev/null 2>"$work/$name.err"; then
    t1=$(date +%s.%N)
    SEC=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.2f}')" "$t0" "$t1")
    MB=$(($(tail -1 "$work/$name.time") / 1024))
  else
    SEC=fail; MB=-
  fi
}
ratio() { python3 -c "import sys; a, b = sys.argv[1:]; print('–' if 'fail' in (a, b) or float(b) <= 0 else f'{float(a) / float(b):.1f}')" "$1" "$2"; }
# verdict VALUE OP LIMIT: "VALUE ✓" or "VALUE ✗" (– stays –).
verdict() { python3 -c "import sys; v, op, l = sys.argv[1:]; print(v if v in ('–', '-', 'fail') else f\"{v} {'✓' if (float(v) <= float(l) if op == 'le' else float(v) >= float(l)) else '✗'}\")" "$1" "$2" "$3"; }

printf '| input | scene triangles | textured | convert -o DIR s | gltfpack -cc s | ratio (≤ 15 / ≤ 30 textured) | convert -o X.glb s | simplify 0.2 s | gltfpack -si 0.2 s | ratio (≤ 3) | record M tri/s (≥ 1) | peak RSS MB (≤ 1024) | gltfpack MB | base.glb / model.glb (≤ 0.25 over 10k) |\n'
printf '|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n'
for entry in "${inputs[@]}"; do
  IFS='|' read -r name in upload <<<"$entry"
  tris=$(info "$in" scene_triangles)
  textures=$(info "$in" textures)
  rm -rf "$work/$name.dir" "$work/$name.mm.glb" "$work/$name.gp.glb" "$work/$name.si.glb" "$work/$name.gpsi.glb"
  src=("$in")
  [ -n "$upload" ] && src=("$upload" --main "${in#"$upload"/}")
  run "$name.gp" gltfpack -cc -i "$in" -o "$work/$name.gp.glb"; gp=$SEC gp_mb=$MB
  run "$name.dir" "$mm" convert "${src[@]}" -o "$work/$name.dir"; dir=$SEC dir_mb=$MB
  record=$(python3 - "$work/$name.dir.err" <<'PY'
import re, sys
t = open(sys.argv[1], encoding="utf-8", errors="replace").read()
# The record is built on the unique (mesh) triangles; instances share theirs.
u = re.search(r"cleaned: (\d+) unique triangles", t)
m = re.search(r"collapses in (\d+) ms", t)
print(f"{int(u.group(1)) / max(1, int(m.group(1))) / 1000:.2f}" if u and m else "–")
PY
)
  base_share=–
  if [ -f "$work/$name.dir/base.glb" ] && [ -f "$work/$name.dir/model.glb" ]; then
    base_share=$(python3 -c "import os,sys; print(f'{os.path.getsize(sys.argv[1]) / os.path.getsize(sys.argv[2]):.3f}')" "$work/$name.dir/base.glb" "$work/$name.dir/model.glb")
  fi
  run "$name.glb" "$mm" convert "${src[@]}" -o "$work/$name.mm.glb"; glb=$SEC
  run "$name.si" "$mm" simplify "$in" -o "$work/$name.si.glb" --ratio 0.2; si=$SEC
  run "$name.gpsi" gltfpack -si 0.2 -i "$in" -o "$work/$name.gpsi.glb"; gpsi=$SEC
  limit=15
  [ "$textures" -gt 0 ] && limit=30
  dir_cell=$dir
  [ "$name" = scan-4M ] && dir_cell=$(verdict "$dir" le 15)
  share_cell=$base_share
  [ "$tris" -gt 10000 ] && share_cell=$(verdict "$base_share" le 0.25)
  printf '| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$name" "$tris" \
    "$textures" "$dir_cell" "$gp" "$(verdict "$(ratio "$dir" "$gp")" le "$limit")" "$glb" "$si" "$gpsi" \
    "$(verdict "$(ratio "$si" "$gpsi")" le 3)" "$(verdict "$record" ge 1)" \
    "$(verdict "$dir_mb" le 1024)" "$gp_mb" "$share_cell"
done
