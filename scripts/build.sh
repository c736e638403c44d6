#!/usr/bin/env bash
# Configures and builds meshmux (and its tests) into build/ (or build-asan/ with
# MESHMUX_SANITIZE=1: AddressSanitizer + UBSan). -O2, ccache when installed, Ninja.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
dir="$here/build"
flags=()
if [ "${MESHMUX_SANITIZE:-0}" = 1 ]; then
  dir="$here/build-asan"
  flags+=(-DMESHMUX_SANITIZE=ON)
fi
# ccache keys paths relative to the checkout, and not the build folder's path (-g1 would put it
# in the key), so a clone elsewhere (CI's) reuses the cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$here}" CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-1}"
cmake -S "$here" -B "$dir" -G Ninja "${flags[@]}" >/dev/null
cmake --build "$dir" -j "$(nproc)"
echo "$dir"
