#!/usr/bin/env python3
"""Writes a generated test mesh as a .glb: a sphere displaced by a few octaves of smooth bumps,
with normals and a uv set, `--triangles` triangles (default 1,000,000), no texture.
bench/stream_bytes.sh and bench/speed.sh measure the stream and the conversion on it ("a generated
1M-triangle mesh").

usage: bench/generated_mesh.py OUT.glb [--triangles N]
"""
import argparse
import json
import math
import struct


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--triangles", type=int, default=1_000_000)
    a = ap.parse_args()
    # A uv sphere of r rings and s segments has 2·s·(r − 1) triangles; s = 2r.
    r = max(3, int(math.sqrt(a.triangles / 4)))
    s = 2 * r
    pos, nrm, uv = [], [], []

    def height(th, ph):
        return 1 + 0.04 * math.sin(7 * th) * math.cos(5 * ph) + 0.015 * math.sin(23 * th + 1) * math.sin(19 * ph)

    for i in range(r + 1):
        th = math.pi * i / r
        for j in range(s + 1):
            ph = 2 * math.pi * j / s
            h = height(th, ph)
            x, y, z = math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)
            pos.append((h * x, h * y, h * z))
            uv.append((j / s, i / r))
    # Normals from the displaced surface: cross product of the two parameter directions.
    for i in range(r + 1):
        for j in range(s + 1):
            a0 = pos[i * (s + 1) + j]
            an = pos[min(i + 1, r) * (s + 1) + j]
            ap_ = pos[max(i - 1, 0) * (s + 1) + j]
            bn = pos[i * (s + 1) + (j + 1) % (s + 1)]
            bp = pos[i * (s + 1) + (j - 1) % (s + 1)]
            du = [an[k] - ap_[k] for k in range(3)]
            dv = [bn[k] - bp[k] for k in range(3)]
            n = (du[1] * dv[2] - du[2] * dv[1], du[2] * dv[0] - du[0] * dv[2], du[0] * dv[1] - du[1] * dv[0])
            l = math.sqrt(sum(c * c for c in n))
            if l == 0:
                n, l = (a0[0], a0[1], a0[2]), math.sqrt(sum(c * c for c in a0))
            nrm.append(tuple(c / l for c in n))
    idx = []
    for i in range(r):
        for j in range(s):
            a0, b0 = i * (s + 1) + j, (i + 1) * (s + 1) + j
            if i != 0:
                idx += (a0, a0 + 1, b0)
            if i != r - 1:
                idx += (a0 + 1, b0 + 1, b0)
    n = len(pos)
    bin_ = bytearray()
    views = []

    def view(data, target):
        while len(bin_) % 4:
            bin_.append(0)
        views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": len(data), "target": target})
        bin_.extend(data)
        return len(views) - 1

    vp = view(struct.pack(f"<{3 * n}f", *[c for p in pos for c in p]), 34962)
    vn = view(struct.pack(f"<{3 * n}f", *[c for p in nrm for c in p]), 34962)
    vt = view(struct.pack(f"<{2 * n}f", *[c for p in uv for c in p]), 34962)
    vi = view(struct.pack(f"<{len(idx)}I", *idx), 34963)
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    doc = {
        "asset": {"version": "2.0", "generator": "meshmux bench/generated_mesh.py"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "bumpy sphere"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3}]}],
        "accessors": [
            {"bufferView": vp, "componentType": 5126, "count": n, "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": vn, "componentType": 5126, "count": n, "type": "VEC3"},
            {"bufferView": vt, "componentType": 5126, "count": n, "type": "VEC2"},
            {"bufferView": vi, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
        ],
        "bufferViews": views, "buffers": [{"byteLength": len(bin_)}],
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    while len(bin_) % 4:
        bin_.append(0)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    with open(a.out, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, total))
        f.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        f.write(struct.pack("<II", len(bin_), 0x004E4942) + bin_)
    print(f"{a.out}: {len(idx) // 3} triangles, {n} vertices")


if __name__ == "__main__":
    main()
