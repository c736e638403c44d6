#!/usr/bin/env bash
# Builds and runs the multiplexer benchmark on a generated ~112k-triangle textured scene and
# every textured shared model: the four areas under the rendered rate-distortion curves, the
# gain of the steepest descent over the best baseline, views, renders and seconds.
# usage: bench/multiplex.sh [BUILD_DIR]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="${1:-$here/build}"
[ -f "$build/build.ninja" ] || cmake -S "$here" -B "$build" -G Ninja >/dev/null
cmake --build "$build" --target meshmux_bench_multiplex -j 2 >/dev/null
models="$here/../shared/models"
args=()
for m in Duck-dae/duck.dae CesiumMilkTruck-dae/CesiumMilkTruck.dae DamagedHelmet-glb/DamagedHelmet.glb \
         Avocado-gltf/Avocado.gltf SheenChair-gltf/SheenChair.gltf Fox-glb/Fox.glb; do
  [ -f "$models/$m" ] && args+=("$models/$m")
done
"$build/meshmux_bench_multiplex" "${args[@]}"
