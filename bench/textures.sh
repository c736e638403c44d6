#!/usr/bin/env bash
# GPU textures (issue "GPU textures: KTX2"): per textured model of ../shared/models, the default
# path (JPEG/PNG) against `--textures ktx2` (KTX2: ETC1S for colour, UASTC+zstd for normal and
# data maps), both converted as stream folders (`meshmux convert IN -o DIR`):
#   conversion seconds (wall, each alone) and the ratio ktx2 / default;
#   texture bytes on the wire: the package's texture levels (report.json texture_level_bytes: the
#     base's level and every texture chunk) and model.glb's images;
#   GPU bytes: what the three.js client holds for the finished stream's textures (stats.gpuBytes:
#     RGBA8 with mipmaps for JPEG/PNG, the block format KTX2Loader transcodes to on this chromium,
#     BC7) and the page's longest main-thread task of the library while the levels arrive, with a
#     renderer uploading them (bench/texture_tasks.mjs, the median of 3 plays);
#   appearance: the fidelity harness (bench/fidelity.mjs, three.js in chromium; its conversion is
#     a --no-report folder, with --convert-args "--textures ktx2" for the second) judged against the
#     original: unlit and lit PSNR of model.glb, met = unlit >= 30, lit >= 28.
# The corpus's appearance with KTX2: bench/sweep.sh --convert-args "--textures ktx2".
# Run it alone: the seconds and milliseconds are this machine's.
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
    rm -rf "${work:?}/$kind/$name"
    if "$meshmux" convert "$file" -o "$work/$kind/$name" -q "${args[@]}" 2>"$work/$kind/$name.err"; then
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
  dirs=$(awk -F'\t' -v k="$kind" -v w="$work" '$2 == k && $3 != "failed" {print w "/" k "/" $1}' "$manifest" | paste -sd, -)
  echo "textures: the client's GPU bytes and main thread, $kind" >&2
  [ -z "$dirs" ] || node "$here/bench/texture_tasks.mjs" --meshmux "$meshmux" --dirs "$dirs" \
    --json "$work/tasks-$kind.json" >"$work/tasks-$kind.log" 2>&1 ||
    echo "textures: texture_tasks ($kind) exited $? (see $work/tasks-$kind.log)" >&2
done
for kind in default ktx2; do
  args=()
  [ "$kind" = ktx2 ] && args=(--convert-args "--textures ktx2")
  echo "textures: fidelity, $kind" >&2
  node "$here/bench/fidelity.mjs" --meshmux "$meshmux" --models "$models" --only "$names" \
    --work "$work/fid-$kind" --json "$work/fid-$kind.json" "${args[@]}" >/dev/null 2>"$work/fid-$kind.err" ||
    echo "textures: fidelity ($kind) exited $? (see $work/fid-$kind.err)" >&2
done
python3 "$here/bench/textures_report.py" "$work"
