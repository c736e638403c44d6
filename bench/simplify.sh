#!/usr/bin/env bash
# Builds meshmux_bench_simplify and runs it: every model in ../shared/models and a generated
# scene with one submesh instanced 400 times, simplified to 20% of the scene triangles by
# meshmux, gltfpack -si 0.2 (Debian's binary) and meshopt_simplify side by side. Prints
# markdown tables (time, triangles, .glb bytes, Hausdorff distance) and the targets of
# docs/ARCHITECTURE.md "Targets" as ratios. Progress goes to stderr.
# usage: bench/simplify.sh [BUILD_DIR] [-- BENCH_ARGS...]   e.g. bench/simplify.sh build -- --only Bunny
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
if [ $# -gt 0 ] && [ "$1" != "--" ]; then build="$1"; shift; fi
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
command -v gltfpack >/dev/null || echo "bench: gltfpack is not installed (apt install gltfpack); its rows will say so" >&2
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$here" -B "$build" -G Ninja >/dev/null
fi
cmake --build "$build" --target meshmux_bench_simplify -- -j2 >&2
exec "$build/meshmux_bench_simplify" "$here/../shared/models" "$@"
