#!/usr/bin/env bash
# The render plan on every shared model (bench/render_plan_bench.cpp): where the order is forced,
# the cheap measurement's cost and its curve against the full measurement's (within 2% of area).
# usage: bench/render_plan.sh [BUILD_DIR] [MODEL ...]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
if [ $# -gt 0 ] && [ -f "$1/build.ninja" ]; then build=$1; shift; fi
cmake --build "$build" --target meshmux_bench_render_plan -j 2 >/dev/null
models="$here/../shared/models"
[ -d "$models" ] || { echo "render_plan: $models absent" >&2; exit 77; }
args=("$@")
if [ ${#args[@]} -eq 0 ]; then
  for d in "$models"/*/; do
    f=$(ls "$d" | grep -iE '\.(glb|gltf|dae)$' | head -1)
    [ -n "$f" ] && args+=("$d$f")
  done
fi
"$build/meshmux_bench_render_plan" "${args[@]}"
