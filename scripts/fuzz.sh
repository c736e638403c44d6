#!/usr/bin/env bash
# Fuzzes every parser meshmux exposes to uploads (glTF, GLB, COLLADA, the stream package, and the
# web client's WebAssembly decoder API) with
# libFuzzer under AddressSanitizer + UBSan (clang; build-fuzz/). Seeds are generated here from
# the built-in sample and small inline documents. Any sanitizer report, crash, timeout (10 s)
# or RSS over 1 GB fails the run; the per-target executions are printed.
# usage: scripts/fuzz.sh [RUNS (default 100000)] [SECONDS per target (default 600)]
#        (FUZZ_TARGETS="collada package" runs only those)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
runs=${1:-100000}
seconds=${2:-600}
build="$here/build-fuzz"
command -v clang++ >/dev/null || { echo "fuzz: clang++ not installed (apt-get install clang)" >&2; exit 2; }
# ccache keys paths relative to the checkout, and not the build folder's path (-g1 would put it
# in the key), so a clone elsewhere (CI's) reuses the cache.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$here}" CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-1}"
cmake -S "$here" -B "$build" -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DMESHMUX_FUZZ=ON -DMESHMUX_TESTS=OFF >/dev/null
cmake --build "$build" -j "$(nproc)" --target fuzz_gltf fuzz_glb fuzz_collada fuzz_package \
  fuzz_decoder_api meshmux >/dev/null

seeds="$build/seeds"
rm -rf "$seeds" && mkdir -p "$seeds"/{gltf,glb,collada,package,decoder_api}
export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1
"$build/meshmux" sample -o "$seeds/glb/sample.glb" -q
"$build/meshmux" convert "$seeds/glb/sample.glb" -o "$seeds/out" -q
cp "$seeds/out/base.glb" "$seeds/glb/base.glb"
cp "$seeds/out/model.mmxp" "$seeds/package/sample.mmxp"
# A seed in the decoder API's input layout (tests/fuzz/fuzz_decoder_api.cpp): capacities 8 and 8,
# a base of three vertices and one face, then a short part to mutate.
printf '\x08\0\0\0\x08\0\0\0\x03\0\x03\0\0\0\0\0\0\0\x10\0\0\0\0\0\0\0\x10\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\x7f\0\0\x7f\0\0\x7f\0\0\0\0\x01\0\0\0\x02\0\0\0\x01\0\x02\0\x06\0\xc0\0\0\0\0\0' \
  >"$seeds/decoder_api/triangle.bin"
# The same base, a block table of one block (the whole grid, vertices 3 to 4, no dependency) and
# a part of that block to mutate.
printf '\x08\0\0\0\x08\0\0\0\x03\0\x03\0\0\0\0\0\0\0\x10\0\0\0\0\0\0\0\x10\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\x7f\0\0\x7f\0\0\x7f\0\0\0\0\x01\0\0\0\x02\0\0\0\xff\xff\x09\0\0\0\0\0\0\0\0\0\0\0\0\0\xff\xff\0\0\xff\xff\0\0\xff\xff\0\0\x03\0\0\0\x04\0\0\0\0\0\0\0\xfe\xff\0\0\x01\0\x02\0\x06\0\xe0\0\0\0\0\0' \
  >"$seeds/decoder_api/block.bin"
# One triangle with a data: buffer; the same with an instancing extension and a texture.
buf=$(printf '\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\x00\x00\x00\x01\x00\x02\x00\x00\x00' | base64 -w0)
cat > "$seeds/gltf/triangle.gltf" <<JSON
{"asset":{"version":"2.0"},"buffers":[{"byteLength":44,"uri":"data:application/octet-stream;base64,$buf"}],
"bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}],
"materials":[{"pbrMetallicRoughness":{"baseColorFactor":[1,0,0,1]},"extensions":{"KHR_materials_transmission":{"transmissionFactor":0.5}}}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"material":0}]}],
"nodes":[{"mesh":0,"children":[1]},{"mesh":0,"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"TRANSLATION":0}}}}],
"extensionsUsed":["EXT_mesh_gpu_instancing"],"scenes":[{"nodes":[0]}],"scene":0}
JSON
cat > "$seeds/collada/triangle.dae" <<'XML'
<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><up_axis>Y_UP</up_axis></asset>
<library_images><image id="img"><init_from>t.png</init_from></image></library_images>
<library_effects><effect id="fx"><profile_COMMON><technique sid="common"><phong>
<diffuse><color>0.5 0.2 0.1 1</color></diffuse><shininess><float>16</float></shininess>
</phong></technique></profile_COMMON></effect></library_effects>
<library_materials><material id="m"><instance_effect url="#fx"/></material></library_materials>
<library_geometries><geometry id="g"><mesh>
<source id="p"><float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array>
<technique_common><accessor source="#pa" count="3" stride="3"><param name="X" type="float"/>
<param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
<triangles material="mat" count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2</p></triangles>
</mesh></geometry></library_geometries>
<library_nodes><node id="lib"><instance_geometry url="#g"><bind_material><technique_common>
<instance_material symbol="mat" target="#m"/></technique_common></bind_material></instance_geometry></node></library_nodes>
<library_visual_scenes><visual_scene id="s"><node id="n"><matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</matrix>
<instance_node url="#lib"/></node><node id="n2"><instance_node url="#lib"/></node></visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
XML

status=0
for target in ${FUZZ_TARGETS:-gltf glb collada package decoder_api}; do
  corpus="$build/corpus/$target"
  mkdir -p "$corpus"
  log="$build/fuzz_$target.log"
  start=$(date +%s)
  if "$build/tests/fuzz/fuzz_$target" "$corpus" "$seeds/$target" -runs="$runs" -max_total_time="$seconds" \
       -timeout=10 -rss_limit_mb=1024 -max_len=65536 -print_final_stats=1 \
       -artifact_prefix="$build/crash-$target-" >"$log" 2>&1; then
    result=ok
  else
    result=FAILED
    status=1
  fi
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  echo "fuzz $target: $result, $execs executions in $(( $(date +%s) - start )) s (log: $log)"
  grep -E "ERROR: (AddressSanitizer|UndefinedBehaviorSanitizer|libFuzzer)|runtime error" "$log" | head -3 || true
done
exit $status
