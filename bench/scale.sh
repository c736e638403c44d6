#!/usr/bin/env bash
# How meshmux scales with big scan-like meshes (issue "Big content"). Inputs: generated scan-like
# meshes (bench/generated_mesh.py --scan: a bumpy sphere with noise of a third of an edge along
# the normals, no uv, vertices and triangles in a seeded random order) of 4M and 20M triangles,
# generated once into the work folder and reused, and a real scan: the Stanford bunny
# (../shared/models/StanfordBunny-glb, 69k triangles; the Stanford dragon the issue names is not
# available offline, so the bunny stands in for it). Per input:
#   `meshmux convert IN -o DIR` under GNU time: wall seconds, peak RSS (MB = MiB), bytes per
#     input triangle (peak RSS / the input's scene triangles, `meshmux info`);
#   package / model.glb (model.mmxp bytes / model.glb bytes), base.glb bytes;
#   stage times: the progressive record ("base level: ... collapses in N ms" in the progress
#     log), the multiplexer ("multiplexed: ... N s") and report.json "seconds" (layers, render,
#     total); report.json "render_cut" (error, triangles drawn);
#   meshmux_bench_scale (bench/scale_bench.cpp): the symmetric Hausdorff distance, relative to
#     the bounding-box diagonal, of meshmux's progressive record at 25%, 6% and 1.5% of the
#     triangles against the input, beside meshopt_simplify (a global simplifier we did not write)
#     at the same triangle counts, and (inputs up to 4M; the bunny forced into blocks) beside
#     the record built without block levels (the whole-unit loop: "block-built levels ≤ 1.1×
#     today's global simplifier"; the bunny, under the size threshold, in a second run forced
#     into blocks: NAME.blocks.scale.json); --no-hausdorff leaves it out.
# Targets (issue "Big content"), met / NOT met printed where they apply:
#   generated 20M: converts in ≤ 90 s, peak RSS ≤ 2 GB (2048 MiB), ≤ 100 bytes per input triangle
#   generated 4M: ≤ 20 s, peak RSS ≤ 600 MB, base.glb ≤ 256 KiB, package ≤ 1.3× model.glb
#   every input: meshmux's Hausdorff ≤ 1.1× meshopt_simplify's at 25%, 6% and 1.5%
# Prints one markdown table (a row per input) and the targets; writes WORK/scale.json. Each
# run's progress log is kept in WORK (NAME.log, NAME.scale.err). Timings are wall seconds on this
# machine: run it alone. --quick: generated sizes 200000,400000 only (no target of size applies).
# usage: bench/scale.sh [BUILD_DIR] [--sizes 4000000,20000000] [--work DIR] [--quick]
#                       [--no-hausdorff] [--samples N]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
if [ $# -gt 0 ] && [ "${1#--}" = "$1" ]; then build=$(cd "$1" && pwd); shift; fi
sizes=4000000,20000000 work="" hausdorff=1 samples=""
usage() { sed -n '/^# usage:/,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//' >&2; exit 2; }
while [ $# -gt 0 ]; do
  case $1 in
    --sizes) [ $# -ge 2 ] || usage; sizes=$2; shift 2 ;;
    --work) [ $# -ge 2 ] || usage; work=$2; shift 2 ;;
    --quick) sizes=200000,400000; shift ;;
    --no-hausdorff) hausdorff=0; shift ;;
    --samples) [ $# -ge 2 ] || usage; samples=$2; shift 2 ;;
    -h | --help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "scale: unknown argument '$1'" >&2; usage ;;
  esac
done
[[ $sizes =~ ^[1-9][0-9]*(,[1-9][0-9]*)*$ ]] ||
  { echo "scale: --sizes wants N,N,... (got '$sizes')" >&2; exit 2; }
[ -z "$samples" ] || [[ $samples =~ ^[1-9][0-9]*$ ]] ||
  { echo "scale: --samples wants a positive integer (got '$samples')" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "scale: GNU time is not installed (apt install time)" >&2; exit 77; }
[ -f "$build/build.ninja" ] || cmake -S "$here" -B "$build" -G Ninja >/dev/null
cmake --build "$build" --target meshmux meshmux_bench_scale -j 2 >/dev/null
mm="$build/meshmux"
work=${work:-$build/scale}
mkdir -p "$work"
work=$(cd "$work" && pwd)

# 4000000 → 4M, 200000 → 200k.
label() {
  if [ $(($1 % 1000000)) = 0 ]; then echo "$(($1 / 1000000))M"
  elif [ $(($1 % 1000)) = 0 ]; then echo "$(($1 / 1000))k"
  else echo "$1"; fi
}

# The inputs as NAME<TAB>FILE<TAB>KIND<TAB>SIZE (SIZE: the size asked of the generator, or 0).
manifest="$work/inputs.tsv"
: >"$manifest"
IFS=, read -r -a size_list <<<"$sizes"
for n in "${size_list[@]}"; do
  name="scan-$(label "$n")"
  file="$work/$name.glb"
  if [ ! -f "$file" ]; then
    echo "scale: generating $file ($n triangles, --scan)" >&2
    python3 "$here/bench/generated_mesh.py" "$file.part" --triangles "$n" --scan >/dev/null
    mv "$file.part" "$file"
  fi
  printf '%s\t%s\tgenerated\t%s\n' "$name" "$file" "$n" >>"$manifest"
done
bunny="$here/../shared/models/StanfordBunny-glb/bunny.glb"
if [ -f "$bunny" ]; then
  printf '%s\t%s\treal scan\t0\n' bunny "$(cd "$(dirname "$bunny")" && pwd)/bunny.glb" >>"$manifest"
else
  echo "scale: $bunny absent; no real scan" >&2
fi

# The manifest is read on fd 3: nothing run in the loop can take its lines from stdin.
while IFS=$'\t' read -r -u 3 name file _kind _size; do
  echo "scale: $name: converting" >&2
  "$mm" info "$file" --json >"$work/$name.info.json" 2>/dev/null ||
    echo '{}' >"$work/$name.info.json"
  rm -rf "$work/$name.out" "$work/$name.time"
  if ! /usr/bin/time -f '%e %M' -o "$work/$name.time" "$mm" convert "$file" -o "$work/$name.out" \
    >/dev/null 2>"$work/$name.log"; then
    echo "scale: $name: convert failed: $(grep -v '^meshmux: \[' "$work/$name.log" | tail -1)" >&2
  fi
  rm -f "$work/$name.scale.json"
  if [ "$hausdorff" = 1 ]; then
    echo "scale: $name: meshmux_bench_scale" >&2
    # Inputs up to 4M also against the record without block levels (today's global simplifier,
    # the whole-unit loop: the issue's ≤ 1.1× target); the bunny under the size threshold is
    # forced into blocks for it. 20M: without (the whole-unit record alone would not fit).
    global=()
    if [ "$_kind" = generated ] && [ "$_size" -le 4000000 ]; then global=(--global); fi
    "$build/meshmux_bench_scale" "$file" --fractions 0.25,0.06,0.015 "${global[@]}" \
      ${samples:+--samples "$samples"} --json "$work/$name.scale.json" \
      >"$work/$name.scale.md" 2>"$work/$name.scale.err" ||
      echo "scale: $name: meshmux_bench_scale failed: $(tail -1 "$work/$name.scale.err")" >&2
    rm -f "$work/$name.blocks.scale.json"
    if [ "$_kind" = "real scan" ]; then  # under the threshold: forced into blocks for the comparison
      "$build/meshmux_bench_scale" "$file" --fractions 0.25,0.06,0.015 --global \
        --block-above 20000 --block-positions 2048 ${samples:+--samples "$samples"} \
        --json "$work/$name.blocks.scale.json" >/dev/null 2>>"$work/$name.scale.err" ||
        echo "scale: $name: meshmux_bench_scale (blocks) failed" >&2
    fi
  fi
done 3<"$manifest"

commit=$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)
exec python3 "$here/bench/scale_report.py" "$work" "$commit"
