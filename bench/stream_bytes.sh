#!/usr/bin/env bash
# The stream-bytes table: converts every shared model (or the ones named; with none, also a
# generated 1M-triangle mesh) into build/stream_bytes/ and prints where the stream's bytes go
# beside model.glb (bench/stream_bytes.py), then the refinements' decoding rate in the web
# client's decoder (bench/decode_rate.mjs).
# usage: bench/stream_bytes.sh [BUILD_DIR] [MODEL ...]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build="$here/build"
if [ $# -gt 0 ] && [ -f "$1/build.ninja" ]; then build=$1; shift; fi
cmake --build "$build" --target meshmux -j 2 >/dev/null
models="$here/../shared/models"
[ -d "$models" ] || { echo "stream_bytes: $models absent" >&2; exit 77; }
work="$build/stream_bytes"
mkdir -p "$work"
names=("$@")
[ ${#names[@]} -gt 0 ] || mapfile -t names < <(ls "$models" | grep -v MANIFEST)
outs=()
for n in "${names[@]}"; do
  file=$(ls "$models/$n" | grep -iE '\.(glb|gltf|dae)$' | head -1)
  # Progress goes beside the folder (convert refuses folders holding files it did not write).
  "$build/meshmux" convert "$models/$n/$file" -o "$work/$n" 2> "$work/$n.convert.log" ||
    echo "stream_bytes: $n failed" >&2
  outs+=("$work/$n")
done
# With no model named, also the generated 1M-triangle mesh (bench/generated_mesh.py).
if [ $# -eq 0 ]; then
  gen="$work/generated-1M.glb"
  [ -f "$gen" ] || python3 "$here/bench/generated_mesh.py" "$gen" >/dev/null
  "$build/meshmux" convert "$gen" -o "$work/generated-1M" 2> "$work/generated-1M.convert.log" ||
    echo "stream_bytes: generated-1M failed" >&2
  outs+=("$work/generated-1M")
fi
python3 "$here/bench/stream_bytes.py" "${outs[@]}"
# The refinements' decoding rate, as the web client's worker decodes them (node runs the same
# module), with the decoded state checked against the encoder's digests.
echo
node "$here/bench/decode_rate.mjs" "${outs[@]}"
