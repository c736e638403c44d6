#!/usr/bin/env python3
"""Writes a generated test mesh as a .glb: a sphere displaced by a few octaves of smooth bumps,
with normals and a uv set, `--triangles` triangles (default 1,000,000), no texture.
bench/stream_bytes.sh and bench/speed.sh measure the stream and the conversion on it ("a generated
1M-triangle mesh").
`--scan` makes it scan-like, as a scanner's reconstruction comes: every vertex displaced along
its normal by seeded noise of about a third of an edge (the surface is rough at the sampling
scale, so nothing is flat and every collapse costs), no uv set, and the vertices and triangles in
a seeded random order (no grid order for caches to ride on). bench/speed.sh's "scan-like 4M
mesh" is `--triangles 4000000 --scan`.

usage: bench/generated_mesh.py OUT.glb [--triangles N] [--scan]
"""
import argparse
import json
import math
import random
import struct


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--scan", action="store_true", help="noisy surface, no uv, shuffled order")
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
    if a.scan:
        rng = random.Random(20261126)
        amp = 0.33 * math.pi / r  # about a third of an edge on the unit sphere
        pos = [tuple(p[k] + amp * (rng.random() - 0.5) * nrm[v][k] for k in range(3)) for v, p in enumerate(pos)]
    idx = []
    for i in range(r):
        for j in range(s):
            a0, b0 = i * (s + 1) + j, (i + 1) * (s + 1) + j
            if i != 0:
                idx += (a0, a0 + 1, b0)
            if i != r - 1:
                idx += (a0 + 1, b0 + 1, b0)
    n = len(pos)
    if a.scan:
        # Shuffled vertices (seam duplicates of the sphere's grid stay, welded by meshmux) and
        # shuffled triangles.
        perm = list(range(n))
        rng.shuffle(perm)
        inv = [0] * n
        for new, old in enumerate(perm):
            inv[old] = new
        pos, nrm = [pos[o] for o in perm], [nrm[o] for o in perm]
        tris = [(inv[idx[t]], inv[idx[t + 1]], inv[idx[t + 2]]) for t in range(0, len(idx), 3)]
        rng.shuffle(tris)
        idx = [c for t in tris for c in t]
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
    vt = None if a.scan else view(struct.pack(f"<{2 * n}f", *[c for p in uv for c in p]), 34962)
    vi = view(struct.pack(f"<{len(idx)}I", *idx), 34963)
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    accessors = [
        {"bufferView": vp, "componentType": 5126, "count": n, "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": vn, "componentType": 5126, "count": n, "type": "VEC3"},
    ]
    attributes = {"POSITION": 0, "NORMAL": 1}
    if vt is not None:
        attributes["TEXCOORD_0"] = len(accessors)
        accessors.append({"bufferView": vt, "componentType": 5126, "count": n, "type": "VEC2"})
    accessors.append({"bufferView": vi, "componentType": 5125, "count": len(idx), "type": "SCALAR"})
    doc = {
        "asset": {"version": "2.0", "generator": "meshmux bench/generated_mesh.py"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "bumpy sphere"}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": len(accessors) - 1}]}],
        "accessors": accessors,
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
