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
`--level` makes a faceted game level instead (as low-poly game scenes come): flat-shaded (every
triangle its own three vertices and face normal), one material, no uv set; three storeys of
faceted terrain (seeded random heights) over the same ground, each with walls and scattered
rocks (randomly turned boxes), so views from outside look through layers of geometry. About
`--triangles` triangles (default for it 58,000).

usage: bench/generated_mesh.py OUT.glb [--triangles N] [--scan | --level]
"""
import argparse
import json
import math
import random
import struct


def write_glb(out, pos, nrm, uv, idx, name):
    """One mesh of positions, normals, an optional uv set and 32-bit indices as a .glb."""
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
    vt = None if uv is None else view(struct.pack(f"<{2 * n}f", *[c for p in uv for c in p]), 34962)
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
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": name}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": len(accessors) - 1}]}],
        "accessors": accessors,
        "bufferViews": views, "buffers": [{"byteLength": len(bin_)}],
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    while len(bin_) % 4:
        bin_.append(0)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    with open(out, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, total))
        f.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        f.write(struct.pack("<II", len(bin_), 0x004E4942) + bin_)
    print(f"{out}: {len(idx) // 3} triangles, {n} vertices")


def faceted_level(triangles):
    """Flat-shaded triangles of a three-storey level: terrain, walls, rocks (see the usage)."""
    rng = random.Random(20261127)
    pos, nrm, idx = [], [], []

    def tri(a, b, c):
        u = [b[k] - a[k] for k in range(3)]
        v = [c[k] - a[k] for k in range(3)]
        n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        l = math.sqrt(sum(x * x for x in n))
        if l == 0:
            return
        for p in (a, b, c):
            idx.append(len(pos))
            pos.append(p)
            nrm.append(tuple(x / l for x in n))

    def box(cx, cy, cz, sx, sy, sz, turn):
        c, s_ = math.cos(turn), math.sin(turn)
        corner = [(cx + c * x * sx - s_ * z * sz, cy + y * sy, cz + s_ * x * sx + c * z * sz)
                  for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
        for a0, b0, c0, d0 in ((0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)):
            tri(corner[a0], corner[b0], corner[c0])
            tri(corner[a0], corner[c0], corner[d0])

    storeys = 3
    per = triangles / storeys
    g = max(4, int(math.sqrt(per * 0.6 / 2)))  # terrain: 60% of each storey's triangles
    rocks = max(1, int(per * 0.3 / 12))
    for st in range(storeys):
        y0 = st * 4.0
        h = [[y0 + 0.8 * rng.random() for _ in range(g + 1)] for _ in range(g + 1)]
        cell = 40.0 / g
        for i in range(g):
            for j in range(g):
                p = [(-20 + (i + di) * cell, h[i + di][j + dj], -20 + (j + dj) * cell) for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1))]
                tri(p[0], p[2], p[1])
                tri(p[0], p[3], p[2])
        for k in range(rocks):
            box(rng.uniform(-19, 19), y0 + 1, rng.uniform(-19, 19), rng.uniform(0.2, 0.8), rng.uniform(0.3, 1.2), rng.uniform(0.2, 0.8), rng.uniform(0, math.pi))
        walls = max(4, int(per * 0.1 / 12))
        for k in range(walls):
            along = k % 2 == 0
            box(rng.uniform(-18, 18), y0 + 1.5, rng.uniform(-18, 18), 3 if along else 0.15, 1.5, 0.15 if along else 3, 0)
    return pos, nrm, idx


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--scan", action="store_true", help="noisy surface, no uv, shuffled order")
    ap.add_argument("--level", action="store_true", help="a faceted game level (flat-shaded)")
    a = ap.parse_args()
    if a.level:
        pos, nrm, idx = faceted_level(a.triangles if a.triangles != 1_000_000 else 58_000)
        write_glb(a.out, pos, nrm, None, idx, "faceted level")
        return
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
    write_glb(a.out, pos, nrm, None if a.scan else uv, idx, "bumpy sphere")


if __name__ == "__main__":
    main()
