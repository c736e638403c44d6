#!/usr/bin/env bash
# The fidelity table (docs/ARCHITECTURE.md "Fidelity"): builds meshmux, then judges model.glb
# and base.glb of every shared model against the original input, rendered by three.js in
# Debian's headless chromium (bench/fidelity.mjs). Prints the table; --dump also writes the
# views (build/fidelity/MODEL/views-*.png). Extra arguments go to bench/fidelity.mjs
# (e.g. --only Duck-dae,Fox-glb).
# usage: bench/fidelity.sh [BUILD_DIR] [options]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then build=$1; shift; fi
[ -f "$build/build.ninja" ] || cmake -S "$here" -B "$build" -G Ninja >/dev/null
cmake --build "$build" --target meshmux -j 2 >/dev/null
exec node "$here/bench/fidelity.mjs" --meshmux "$build/meshmux" --work "$build/fidelity" "$@"
