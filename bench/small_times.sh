#!/usr/bin/env bash
# The conversion-time target for ordinary models (DESIGN.md "Targets": every corpus model under
# 100k triangles converts in ≤ 3 s on 2 cores), measured as a user converting one model sees it:
# each model of ../shared/corpus/models.tsv under the triangle limit converted alone (the whole
# pipeline into a folder: model.glb, base.glb, model.mmxp, report, viewer), one after the other,
# with every core; wall time per model. The corpus sweep (bench/sweep.sh) times the same
# conversions two at a time beside the fidelity judge, which is what a batch on a busy machine
# sees; run this one on a quiet machine.
# usage: bench/small_times.sh [BUILD_DIR] [--limit SECONDS] [--max-triangles N] [--only A,B]
# Prints a table (model, triangles, seconds) sorted slowest first, then the count over the limit.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
limit=3
max_tris=100000
only=""
while [ $# -gt 0 ]; do
  case "$1" in
    --limit) limit="$2"; shift 2 ;;
    --max-triangles) max_tris="$2"; shift 2 ;;
    --only) only=",$2,"; shift 2 ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) build="$1"; shift ;;
  esac
done
corpus="$here/../shared/corpus"
[ -f "$corpus/models.tsv" ] || { echo "small_times: $corpus/models.tsv is absent" >&2; exit 1; }
[ -x "$build/meshmux" ] || { echo "small_times: $build/meshmux is not built" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rows="$tmp/rows"
: > "$rows"
# models.tsv: folder, main file, format, triangles, textures, bytes, features.
while IFS=$'\t' read -r folder main _format tris _rest; do
  [ "$folder" = folder ] && continue
  [[ "$tris" =~ ^[0-9]+$ ]] || continue
  [ "$tris" -lt "$max_tris" ] || continue
  [ -z "$only" ] || [[ "$only" == *",$folder,"* ]] || continue
  start=$(date +%s%N)
  if "$build/meshmux" convert "$corpus/$folder" --main "$main" -o "$tmp/out" --quiet \
      > /dev/null 2>&1; then
    status=converted
  else
    status="exit $?"
  fi
  end=$(date +%s%N)
  rm -rf "$tmp/out"
  secs=$(awk -v a="$start" -v b="$end" 'BEGIN {printf "%.2f", (b - a) / 1e9}')
  printf '%s\t%s\t%s\t%s\n' "$folder" "$tris" "$secs" "$status" >> "$rows"
  echo "small_times: $folder $secs s ($status)" >&2
done < "$corpus/models.tsv"
printf '| model | triangles | seconds | result |\n|---|---:|---:|---|\n'
sort -t$'\t' -k3,3 -g -r "$rows" | awk -F'\t' '{printf "| %s | %s | %s | %s |\n", $1, $2, $3, $4}'
awk -F'\t' -v l="$limit" '$4 == "converted" {n++; if ($3 > l) over++}
  END {printf "\n%d converted models under the triangle limit, %d over %s s\n", n, over + 0, l}' "$rows"
