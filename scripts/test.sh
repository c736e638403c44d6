#!/usr/bin/env bash
# Sets up, builds and runs every test (GoogleTest units, end-to-end conversions of
# ../shared/models checked with Khronos' gltf-validator). Ends with ctest's summary line.
# MESHMUX_SANITIZE=1 runs the same suite under AddressSanitizer + UBSan (build-asan/). Before
# the suite, scripts/fuzz.sh fuzzes the four parsers for a bounded time (build-fuzz/).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
bash "$here/scripts/setup.sh"
dir=$(bash "$here/scripts/build.sh" | tail -n 1)
if [ ! -d "$here/../shared/models" ]; then
  echo "test: ../shared/models is absent: tests that need the shared models will be skipped" >&2
fi
# The parsers under libFuzzer + ASan + UBSan, bounded (scripts/fuzz.sh RUNS SECONDS per
# target; MESHMUX_FUZZ_RUNS=0 skips it): any sanitizer report fails the run.
fuzz_runs=${MESHMUX_FUZZ_RUNS:-20000}
if [ "$fuzz_runs" != 0 ]; then
  bash "$here/scripts/fuzz.sh" "$fuzz_runs" "${MESHMUX_FUZZ_SECONDS:-60}"
fi
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
cd "$dir" && ctest --output-on-failure -j "$(nproc)" --timeout 900
