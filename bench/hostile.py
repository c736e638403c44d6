#!/usr/bin/env python3
"""Hostile uploads against `meshmux convert`: generates each hostile case below in a
temporary folder, converts it with the default limits, and prints per case the exit code, the
peak RSS (GNU time) and the last line meshmux printed. The targets: every case exits with one
clear line (or converts, where the input is valid), with peak RSS <= 1 GB.

usage: bench/hostile.py [--meshmux build/meshmux]
"""
import argparse
import base64
import json
import os
import struct
import subprocess
import sys
import tempfile
import zlib

ap = argparse.ArgumentParser()
ap.add_argument("--meshmux", default=os.path.join(os.path.dirname(__file__), "..", "build", "meshmux"))
ap.add_argument("--cap-gb", type=float, default=0,
                help="run under prlimit --data=N GB (to try an older build safely)")
args = ap.parse_args()
meshmux = os.path.abspath(args.meshmux)


def triangle_bin():
    return struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<3H", 0, 1, 2) + b"\0\0"


def triangle_doc(uri):
    return {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": 44, "uri": uri}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }


def data_uri(b):
    return "data:application/octet-stream;base64," + base64.b64encode(b).decode()


def png(w, h):
    """An all-black RGB PNG, compressed row by row (a huge image in a small file)."""
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    z = zlib.compressobj(9)
    row = b"\0" * (1 + 3 * w)
    body = b"".join(z.compress(row) for _ in range(h)) + z.flush()
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", body) + chunk(b"IEND", b""))


def with_image(doc, image, used=True):
    doc["images"] = [image]
    doc["textures"] = [{"source": 0}]
    if used:
        doc["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
        doc["meshes"][0]["primitives"][0]["material"] = 0
    return doc


root = tempfile.mkdtemp(prefix="meshmux-hostile-")
cases = []


def case(name, files, main, extra=()):
    d = os.path.join(root, name)
    os.makedirs(os.path.join(d, "model"), exist_ok=True)
    for rel, content in files.items():
        p = os.path.join(d, rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open(p, "wb") as f:
            f.write(content if isinstance(content, bytes) else json.dumps(content).encode())
    cases.append((name, os.path.join(d, main), list(extra)))


tri = triangle_bin()
big_png = png(16384, 16384)  # 768 MiB decoded, ~1 MB encoded
# Memory safety
doc = triangle_doc("data.bin")
doc["bufferViews"].append({"buffer": 0, "byteOffset": 2**31 - 1, "byteLength": 64})
case("image-view-offset-2^31", {"model/data.bin": tri, "model/m.gltf": with_image(doc, {"bufferView": 2, "mimeType": "image/png"})}, "model/m.gltf")
doc = triangle_doc("data.bin")
doc["bufferViews"].append({"buffer": 0, "byteOffset": 0, "byteLength": 44 + 65536})
case("image-view-64KiB-too-long", {"model/data.bin": tri, "model/m.gltf": with_image(doc, {"bufferView": 2, "mimeType": "image/png"})}, "model/m.gltf")
deep = json.dumps(triangle_doc(data_uri(tri)))[:-1] + ',"extras":' + "[" * 15000 + "]" * 15000 + "}"
case("15000-nested-extras", {"model/m.gltf": deep.encode()}, "model/m.gltf")
# Reads outside the folder
case("buffer-../", {"secret.bin": tri, "model/m.gltf": triangle_doc("../secret.bin")}, "model/m.gltf")
case("buffer-..%2F", {"secret.bin": tri, "model/m.gltf": triangle_doc("..%2Fsecret.bin")}, "model/m.gltf")
case("image-../", {"secret.png": png(4, 4), "model/m.gltf": with_image(triangle_doc(data_uri(tri)), {"uri": "../secret.png"})}, "model/m.gltf")
# Hangs
fifo_dir = os.path.join(root, "buffer-fifo", "model")
os.makedirs(fifo_dir, exist_ok=True)
os.mkfifo(os.path.join(fifo_dir, "pipe.bin"))
with open(os.path.join(fifo_dir, "m.gltf"), "w") as f:
    json.dump(triangle_doc("pipe.bin"), f)
cases.append(("buffer-fifo", os.path.join(fifo_dir, "m.gltf"), []))
case("buffer-/dev/zero-allow-outside", {"model/m.gltf": triangle_doc("/dev/zero")}, "model/m.gltf", ["--allow-outside"])
# Tiny files, huge memory
doc = triangle_doc(data_uri(tri))
doc["images"] = [{"uri": "big.png"}] * 3
case("3-unused-images-of-a-huge-png", {"model/big.png": big_png, "model/m.gltf": doc}, "model/m.gltf")
case("used-huge-png", {"model/big.png": big_png, "model/m.gltf": with_image(triangle_doc(data_uri(tri)), {"uri": "big.png"})}, "model/m.gltf")
doc = triangle_doc(data_uri(tri))
doc["nodes"] = [{"children": [i + 1, i + 1]} for i in range(25)] + [{"mesh": 0}]
case("25-nodes-doubling", {"model/m.gltf": doc}, "model/m.gltf")
doc = triangle_doc(data_uri(tri))
del doc["accessors"][0]["bufferView"]
doc["accessors"][0]["count"] = 2**28
case("accessor-count-2^28-no-data", {"model/m.gltf": doc}, "model/m.gltf")
doc = triangle_doc(data_uri(tri))
doc["extensionsUsed"] = ["EXT_mesh_gpu_instancing"]
doc["accessors"].append({"componentType": 5126, "count": 5000000, "type": "VEC3"})
doc["nodes"][0]["extensions"] = {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 2}}}
case("gpu-instancing-5M-no-data", {"model/m.gltf": doc}, "model/m.gltf")
# A valid model that failed: 500 separate textured triangles
pos, uv, idx = [], [], []
for i in range(500):
    x, y = (i % 25) * 3.0, (i // 25) * 3.0
    pos += [x, y, 0, x + 1, y, 0, x, y + 1, 0]
    uv += [1.5 if i == 0 else 0.1, 0.1, 0.2, 0.1, 0.1, 0.2]
    idx += [3 * i, 3 * i + 1, 3 * i + 2]
b = struct.pack("<%df" % len(pos), *pos) + struct.pack("<%df" % len(uv), *uv) + struct.pack("<%dH" % len(idx), *idx)
doc = {
    "asset": {"version": "2.0"},
    "buffers": [{"byteLength": len(b), "uri": data_uri(b)}],
    "bufferViews": [{"buffer": 0, "byteLength": 4 * len(pos)}, {"buffer": 0, "byteOffset": 4 * len(pos), "byteLength": 4 * len(uv)},
                    {"buffer": 0, "byteOffset": 4 * (len(pos) + len(uv)), "byteLength": 2 * len(idx)}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 1500, "type": "VEC3", "min": [0, 0, 0], "max": [73, 58, 0]},
                  {"bufferView": 1, "componentType": 5126, "count": 1500, "type": "VEC2"},
                  {"bufferView": 2, "componentType": 5123, "count": 1500, "type": "SCALAR"}],
    "samplers": [{"wrapS": 33071, "wrapT": 33071}],
    "images": [{"uri": "t.png"}], "textures": [{"source": 0, "sampler": 0}],
    "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
    "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0,
}
case("500-separate-textured-triangles (valid)", {"model/t.png": png(8, 8), "model/m.gltf": doc}, "model/m.gltf")

print(f"| case | exit | peak RSS (MB) | last line |")
print(f"|---|---:|---:|---|")
worst = 0
for name, main, extra in cases:
    out = os.path.join(os.path.dirname(main), "..", "out")
    try:
        cap = ["prlimit", f"--data={int(args.cap_gb * 2**30)}"] if args.cap_gb else []
        r = subprocess.run(cap + ["/usr/bin/time", "-f", "RSS %M", meshmux, "convert", main, "-o", out, "-q", "--no-report"] + extra,
                           capture_output=True, text=True, timeout=120)
        lines = [l for l in r.stderr.splitlines() if l.strip()]
        rss = next((int(l.split()[1]) for l in lines if l.startswith("RSS ")), 0) / 1024
        msg = [l for l in lines if not l.startswith("RSS ") and not l.startswith("Command ")]
        code = r.returncode
        last = msg[-1] if msg else ("(converted)" if code == 0 else
                                    f"(no message; signal {code - 128})" if code > 128 else "(no message)")
    except subprocess.TimeoutExpired:
        rss, last, code = 0, "TIMEOUT (120 s)", -1
    worst = max(worst, rss)
    print(f"| {name} | {code} | {rss:.0f} | {last.replace(root, '…')[:150]} |")
print(f"\nworst peak RSS: {worst:.0f} MB (target ≤ 1024)")
