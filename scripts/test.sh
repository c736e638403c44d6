#!/usr/bin/env bash
# Sets up, builds and runs every test (GoogleTest units, end-to-end conversions of
# ../shared/models checked with Khronos' gltf-validator). Ends with ctest's summary line.
# MESHMUX_SANITIZE=1 runs the same suite under AddressSanitizer + UBSan (build-asan/).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
bash "$here/scripts/setup.sh"
dir=$(bash "$here/scripts/build.sh" | tail -n 1)
if [ ! -d "$here/../shared/models" ]; then
  echo "test: ../shared/models is absent: tests that need the shared models will be skipped" >&2
fi
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
cd "$dir" && ctest --output-on-failure -j "$(nproc)" --timeout 900
