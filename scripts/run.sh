#!/usr/bin/env bash
# The main job on the embedded default: set up, build, write the built-in sample scene and
# convert it. The result lands in out/sample/ (override with an argument).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
out="${1:-$here/out/sample}"
bash "$here/scripts/setup.sh"
dir=$(bash "$here/scripts/build.sh" | tail -n 1)
mkdir -p "$here/out"
"$dir/meshmux" sample -o "$here/out/sample.glb"
"$dir/meshmux" convert "$here/out/sample.glb" -o "$out"
"$dir/meshmux" info "$out/model.glb"
echo "meshmux: done. The converted sample is in $out: model.glb (full quality), base.glb (shown first), report.json and rd.svg (the rate-distortion order); the input was $here/out/sample.glb"
