#!/usr/bin/env bash
# Converts every model in ../shared/models with `meshmux convert` and prints, per model:
# input bytes (the main file plus the buffers and images beside it), output bytes, scene and
# unique triangles of the output, wall time; and, for glTF inputs, gltfpack -c (Debian's
# gltfpack, a peer that also compresses) on the same file for comparison.
# usage: bench/convert_models.sh [BUILD_DIR]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="${1:-$here/build}"
models="$here/../shared/models"
[ -d "$models" ] || { echo "bench: $models is absent" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '| model | input bytes | meshmux bytes | scene tris | unique tris | meshmux s | gltfpack -c bytes | gltfpack s |\n'
printf '|---|---:|---:|---:|---:|---:|---:|---:|\n'
for dir in "$models"/*/; do
  name=$(basename "$dir")
  main=$(find "$dir" -maxdepth 1 -type f \( -iname '*.dae' -o -iname '*.gltf' -o -iname '*.glb' \) | head -n 1)
  [ -n "$main" ] || continue
  inbytes=$(find "$dir" -maxdepth 1 -type f ! -iname '*.md' ! -iname '*.txt' -printf '%s\n' | awk '{s+=$1} END {print s}')
  start=$(date +%s%N)
  "$build/meshmux" convert "$main" -o "$tmp/$name.glb" --quiet
  end=$(date +%s%N)
  secs=$(awk -v a="$start" -v b="$end" 'BEGIN {print (b - a) / 1e9}')
  info=$("$build/meshmux" info "$tmp/$name.glb" --json)
  scene=$(echo "$info" | sed -n 's/.*"scene_triangles": \([0-9]*\).*/\1/p')
  unique=$(echo "$info" | sed -n 's/.*"unique_triangles": \([0-9]*\).*/\1/p')
  outbytes=$(stat -c %s "$tmp/$name.glb")
  gp_bytes="n/a (no .dae input)"
  gp_secs="-"
  case "$main" in
    *.gltf|*.glb)
      if command -v gltfpack >/dev/null; then
        s2=$(date +%s%N)
        if gltfpack -c -i "$main" -o "$tmp/$name.gp.glb" >/dev/null 2>&1; then
          e2=$(date +%s%N)
          gp_bytes=$(stat -c %s "$tmp/$name.gp.glb")
          gp_secs=$(awk -v a="$s2" -v b="$e2" 'BEGIN {printf "%.2f", (b - a) / 1e9}')
        else
          gp_bytes="failed"
        fi
      fi
      ;;
  esac
  printf '| %s | %s | %s | %s | %s | %.2f | %s | %s |\n' "$name" "$inbytes" "$outbytes" "$scene" "$unique" "$secs" "$gp_bytes" "$gp_secs"
done
