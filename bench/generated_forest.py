#!/usr/bin/env python3
"""Writes a generated instanced forest as a .glb: one tree mesh (a trunk cylinder and three
stacked cones of foliage, with normals and a uv set, about `--tree-triangles` triangles) placed by
`--side`² nodes on a grid with varied rotation, scale and jitter, and a ground grid with one node.
bench/speed.sh times the conversion on it ("a generated instanced forest"): the case instance-aware
simplification is for. Deterministic.

usage: bench/generated_forest.py OUT.glb [--side 30] [--tree-triangles 2000]
"""
import argparse
import json
import math
import random
import struct


def cone(pos, nrm, uv, idx, y0, y1, r0, r1, seg, rings):
    """A frustum from radius r0 at y0 to r1 at y1, `rings` rows of `seg` quads, open ends."""
    base = len(pos)
    slope = (r0 - r1) / max(1e-9, y1 - y0)
    for i in range(rings + 1):
        t = i / rings
        y, r = y0 + (y1 - y0) * t, r0 + (r1 - r0) * t
        for j in range(seg + 1):
            a = 2 * math.pi * j / seg
            x, z = math.cos(a), math.sin(a)
            pos.append((r * x, y, r * z))
            n = (x, slope, z)
            l = math.sqrt(sum(c * c for c in n))
            nrm.append(tuple(c / l for c in n))
            uv.append((j / seg, t))
    for i in range(rings):
        for j in range(seg):
            a, b = base + i * (seg + 1) + j, base + (i + 1) * (seg + 1) + j
            idx += (a, b, a + 1, a + 1, b, b + 1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--side", type=int, default=30)
    ap.add_argument("--tree-triangles", type=int, default=2000)
    a = ap.parse_args()
    rnd = random.Random(7)
    # The tree: 4 frusta of seg × rings quads; 2 triangles per quad.
    seg = max(6, int(math.sqrt(a.tree_triangles / 8)))
    rings = max(1, a.tree_triangles // (8 * seg))
    tp, tn, tt, ti = [], [], [], []
    cone(tp, tn, tt, ti, 0.0, 1.0, 0.12, 0.09, seg, rings)
    for k, (y0, y1, r0) in enumerate([(0.8, 2.0, 0.9), (1.5, 2.6, 0.7), (2.1, 3.2, 0.5)]):
        cone(tp, tn, tt, ti, y0, y1, r0, 0.02, seg, rings)
    # The ground: a grid.
    g = 20
    gp, gn, gt, gi = [], [], [], []
    size = a.side * 3.0
    for i in range(g + 1):
        for j in range(g + 1):
            gp.append((-size / 2 + size * j / g, 0.0, -size / 2 + size * i / g))
            gn.append((0.0, 1.0, 0.0))
            gt.append((j / g, i / g))
    for i in range(g):
        for j in range(g):
            p, q = i * (g + 1) + j, (i + 1) * (g + 1) + j
            gi += (p, q, p + 1, p + 1, q, q + 1)

    bin_ = bytearray()
    views, accessors = [], []

    def add(data, fmt, count, kind, target, minmax=None):
        while len(bin_) % 4:
            bin_.append(0)
        views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": len(data), "target": target})
        bin_.extend(data)
        acc = {"bufferView": len(views) - 1, "componentType": fmt, "count": count, "type": kind}
        if minmax:
            acc["min"], acc["max"] = minmax
        accessors.append(acc)
        return len(accessors) - 1

    def mesh(p, n, t, i, name):
        lo = [min(v[k] for v in p) for k in range(3)]
        hi = [max(v[k] for v in p) for k in range(3)]
        P = add(struct.pack(f"<{3 * len(p)}f", *[c for v in p for c in v]), 5126, len(p), "VEC3", 34962, (lo, hi))
        N = add(struct.pack(f"<{3 * len(n)}f", *[c for v in n for c in v]), 5126, len(n), "VEC3", 34962)
        T = add(struct.pack(f"<{2 * len(t)}f", *[c for v in t for c in v]), 5126, len(t), "VEC2", 34962)
        I = add(struct.pack(f"<{len(i)}I", *i), 5125, len(i), "SCALAR", 34963)
        return {"name": name, "primitives": [{"attributes": {"POSITION": P, "NORMAL": N, "TEXCOORD_0": T},
                                              "indices": I, "material": 0 if name == "tree" else 1}]}

    meshes = [mesh(tp, tn, tt, ti, "tree"), mesh(gp, gn, gt, gi, "ground")]
    nodes = [{"mesh": 1, "name": "ground"}]
    for i in range(a.side):
        for j in range(a.side):
            s = 0.7 + 0.6 * rnd.random()
            ang = 2 * math.pi * rnd.random()
            nodes.append({"mesh": 0, "name": f"tree {i} {j}",
                          "translation": [-a.side * 1.5 + 3 * j + rnd.uniform(-0.8, 0.8), 0.0,
                                          -a.side * 1.5 + 3 * i + rnd.uniform(-0.8, 0.8)],
                          "rotation": [0.0, math.sin(ang / 2), 0.0, math.cos(ang / 2)],
                          "scale": [s, s * (0.8 + 0.4 * rnd.random()), s]})
    doc = {
        "asset": {"version": "2.0", "generator": "meshmux bench/generated_forest.py"},
        "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes, "meshes": meshes,
        "materials": [{"name": "foliage", "pbrMetallicRoughness": {"baseColorFactor": [0.15, 0.45, 0.12, 1],
                                                                     "metallicFactor": 0, "roughnessFactor": 0.9}},
                      {"name": "ground", "pbrMetallicRoughness": {"baseColorFactor": [0.4, 0.3, 0.2, 1],
                                                                    "metallicFactor": 0, "roughnessFactor": 1}}],
        "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": len(bin_)}],
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    while len(bin_) % 4:
        bin_.append(0)
    with open(a.out, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(bin_)))
        f.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        f.write(struct.pack("<II", len(bin_), 0x004E4942) + bin_)
    tree = len(ti) // 3
    print(f"{a.out}: tree {tree} triangles × {a.side * a.side} nodes + ground {len(gi) // 3} = "
          f"{tree * a.side * a.side + len(gi) // 3} scene triangles")


if __name__ == "__main__":
    main()
