#!/usr/bin/env bash
# GPU textures (issue "GPU textures: KTX2"): per textured model of ../shared/models, the default
# path (JPEG/PNG as the sources have them) against `--textures ktx2` (KTX2: ETC1S for colour,
# UASTC for normal and data maps), both as `meshmux convert IN -o X.glb`:
#   conversion seconds (wall, each alone) and the ratio ktx2 / default;
#   texture bytes on the wire (the glb's images, by format) and the whole glb;
#   GPU bytes: every image with a full mip chain (×4/3), RGBA8 (4 B/px) for JPEG/PNG as three.js
#     uploads them, 1 B/px for KTX2 (what three's KTX2Loader transcodes to on a desktop GPU with
#     BPTC: BC7; ETC1S to BC1 where BC7 is missing would be 0.5 B/px for opaque maps);
#   appearance: the fidelity harness (bench/fidelity.mjs, three.js in chromium; its conversion is
#     a --no-report folder, with --convert-args "--textures ktx2" for the second) judged against the
#     original: unlit and lit PSNR of model.glb, met = unlit ≥ 30, lit ≥ 28.
# Not measured here: the main thread's longest task while maps arrive (the client does not read
# KTX2 streams yet). Run it alone: the seconds are this machine's.
# usage: bench/textures.sh [BUILD_DIR] [--only A,B] [--work DIR]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
if [ $# -gt 0 ] && [ "${1#--}" = "$1" ]; then build=$(cd "$1" && pwd); shift; fi
only="" work="$build/textures"
while [ $# -gt 0 ]; do
  case "$1" in
    --only) only="$2"; shift 2 ;;
    --work) work="$2"; shift 2 ;;
    *) echo "textures: unknown option $1" >&2; exit 1 ;;
  esac
done
meshmux="$build/meshmux"
models="$here/../shared/models"
[ -d "$models" ] || { echo "textures: $models is absent" >&2; exit 77; }
mkdir -p "$work/default" "$work/ktx2"
manifest="$work/models.tsv"
: >"$manifest"
for dir in "$models"/*/; do
  name=$(basename "$dir")
  if [ -n "$only" ] && [[ ",$only," != *",$name,"* ]]; then continue; fi
  file=$(find "$dir" -maxdepth 1 -type f \( -name '*.glb' -o -name '*.gltf' -o -name '*.dae' \) | sort | head -1)
  [ -n "$file" ] || continue
  textures=$("$meshmux" info "$file" --json 2>/dev/null | python3 -c 'import json,sys; print(json.load(sys.stdin).get("textures", 0))' || echo 0)
  [ "$textures" -gt 0 ] || continue
  for kind in default ktx2; do
    args=()
    [ "$kind" = ktx2 ] && args=(--textures ktx2)
    echo "textures: $name: $kind" >&2
    start=$(date +%s.%N)
    if "$meshmux" convert "$file" -o "$work/$kind/$name.glb" -q "${args[@]}" 2>"$work/$kind/$name.err"; then
      seconds=$(echo "$(date +%s.%N) - $start" | bc)
    else
      seconds=failed
    fi
    printf '%s\t%s\t%s\n' "$name" "$kind" "$seconds" >>"$manifest"
  done
done
names=$(cut -f1 "$manifest" | sort -u | paste -sd, -)
[ -n "$names" ] || { echo "textures: no textured model" >&2; exit 1; }
for kind in default ktx2; do
  args=()
  [ "$kind" = ktx2 ] && args=(--convert-args "--textures ktx2")
  echo "textures: fidelity, $kind" >&2
  node "$here/bench/fidelity.mjs" --meshmux "$meshmux" --models "$models" --only "$names" \
    --work "$work/fid-$kind" --json "$work/fid-$kind.json" "${args[@]}" >/dev/null 2>"$work/fid-$kind.err" ||
    echo "textures: fidelity ($kind) exited $? (see $work/fid-$kind.err)" >&2
done
python3 "$here/bench/textures_report.py" "$work"
