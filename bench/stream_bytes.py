#!/usr/bin/env python3
"""Where the stream's bytes go, beside the plain download.

For each folder OUT written by `meshmux convert IN -o OUT` (model.glb + model.mmxp), prints:
package and model.glb bytes and their ratio; the mesh part of the stream (the base's geometry +
every mesh chunk) against Draco's geometry bytes for the same final mesh in model.glb, and its
bits per triangle; the texture part of the stream (the base's level 0 + every texture chunk)
against the top level alone (model.glb's image); the atlas's pixels against the source pixels
its materials reference (from OUT.convert.log, convert's progress). A second table says where the
refinements' bits go per vertex split, by field (report.json "mesh_stream_bits"), beside the whole
mesh stream's and Draco's bits per vertex.

usage: bench/stream_bytes.py OUT [OUT ...]      (bench/stream_bytes.sh converts the shared models)
"""
import json
import os
import re
import struct
import sys
import zlib


def glb_parts(data):
    """(json, image bytes, other bin bytes) of a GLB."""
    length = struct.unpack_from("<I", data, 8)[0]
    off, doc, bin_size = 12, None, 0
    while off + 8 <= length:
        size, kind = struct.unpack_from("<II", data, off)
        if kind == 0x4E4F534A:
            doc = json.loads(data[off + 8:off + 8 + size])
        elif kind == 0x004E4942:
            bin_size = size
        off += 8 + size
    image_views = {img["bufferView"] for img in doc.get("images", []) if "bufferView" in img}
    images = sum(doc["bufferViews"][v]["byteLength"] for v in image_views)
    # A view compressed with EXT_meshopt_compression costs its compressed bytes (its own
    # byteLength is the decoded size, in a data-less fallback buffer).
    def stored(v):
        ext = v.get("extensions", {}).get("EXT_meshopt_compression")
        return ext["byteLength"] if ext else v["byteLength"]
    other = sum(stored(v) for i, v in enumerate(doc.get("bufferViews", [])) if i not in image_views)
    return doc, images, other


def geometry_bytes(data):
    """The stored bytes of a GLB's non-image bufferViews (EXT_meshopt_compression: the
    compressed ones), concatenated."""
    length = struct.unpack_from("<I", data, 8)[0]
    off, doc, binary = 12, None, b""
    while off + 8 <= length:
        size, kind = struct.unpack_from("<II", data, off)
        if kind == 0x4E4F534A:
            doc = json.loads(data[off + 8:off + 8 + size])
        elif kind == 0x004E4942:
            binary = bytes(data[off + 8:off + 8 + size])
        off += 8 + size
    image_views = {img["bufferView"] for img in doc.get("images", []) if "bufferView" in img}
    out = b""
    for i, v in enumerate(doc.get("bufferViews", [])):
        if i in image_views:
            continue
        ext = v.get("extensions", {}).get("EXT_meshopt_compression")
        src = ext if ext else v
        if src.get("buffer", 0) == 0:
            start = src.get("byteOffset", 0)
            out += binary[start:start + src["byteLength"]]
    return out


# glTF material slots and the atlas channel each fills (docs/ARCHITECTURE.md "Atlas").
SLOT_CHANNELS = (("baseColorTexture", "base_color"), ("normalTexture", "normal"),
                 ("occlusionTexture", "occlusion_roughness_metallic"),
                 ("metallicRoughnessTexture", "occlusion_roughness_metallic"),
                 ("emissiveTexture", "emissive"), ("sheenColorTexture", "sheen_color"))


def image_bytes_by_channel(doc):
    """{channel: bytes} of a GLB's embedded images, each image counted once, under the first
    material slot that references it."""
    seen, out = set(), {}
    for mat in doc.get("materials", []):
        pbr = mat.get("pbrMetallicRoughness", {})
        for slot, channel in SLOT_CHANNELS:
            ref = pbr.get(slot) or mat.get(slot)
            if slot == "sheenColorTexture":
                ref = mat.get("extensions", {}).get("KHR_materials_sheen", {}).get(slot)
            if not ref:
                continue
            image = doc["textures"][ref["index"]].get("source")
            if image is None or image in seen or "bufferView" not in doc["images"][image]:
                continue
            seen.add(image)
            view = doc["bufferViews"][doc["images"][image]["bufferView"]]
            out[channel] = out.get(channel, 0) + view["byteLength"]
    return out


def package_table(data):
    """The JSON table (format 11 on: deflated) and the data start its offsets count from."""
    if data[:4] != b"MMXP":
        raise ValueError("not a meshmux package")
    json_size = struct.unpack_from("<I", data, 8)[0]
    return json.loads(zlib.decompress(data[12:12 + json_size])), 12 + json_size


def atlas_texels(out):
    """(atlas texels, referenced source texels) from convert's progress (OUT.convert.log)."""
    log = os.path.normpath(out) + ".convert.log"
    if not os.path.exists(log):
        return None, None
    text = open(log, encoding="utf-8").read()
    m = re.search(r"atlas: .*?, (\d+)x(\d+) \((\d+) texels of (\d+) referenced\)", text)
    if m:
        return int(m.group(1)) * int(m.group(2)), int(m.group(4))
    m = re.search(r"atlas: the source's one texture kept as it is, (\d+)x(\d+)", text)
    if m:
        return int(m.group(1)) * int(m.group(2)), int(m.group(1)) * int(m.group(2))
    return None, None


rows = []
for out in sys.argv[1:]:
    name = os.path.basename(os.path.normpath(out))
    glb_path, pkg_path = os.path.join(out, "model.glb"), os.path.join(out, "model.mmxp")
    if not os.path.exists(pkg_path):
        rows.append((name, None))
        continue
    glb = open(glb_path, "rb").read()
    pkg = open(pkg_path, "rb").read()
    doc, glb_images, glb_geometry = glb_parts(glb)
    table, header = package_table(pkg)
    base = table["base"]
    stored = pkg[header + base["offset"]:header + base["offset"] + base["size"]]
    base_glb = zlib.decompress(stored) if base.get("deflated") else stored
    base_doc, base_images, base_geometry = glb_parts(base_glb)
    # Texture bytes per channel: model.glb's images, and the stream's (the base's images and
    # every texture chunk's maps).
    glb_channels = image_bytes_by_channel(doc)
    stream_channels = image_bytes_by_channel(base_doc)
    for c in table["chunks"]:
        for m in c.get("maps", []) if c["kind"] == "texture" else []:
            stream_channels[m["channel"]] = stream_channels.get(m["channel"], 0) + m["size"]
    if base.get("deflated"):
        # Images (JPEG/PNG) do not deflate: the rest of the stored bytes is the mesh's (and the
        # glTF JSON's, deflated with it).
        base_geometry = len(stored) - base_images
    # The mesh alone, for the comparison with Draco below: the base's geometry buffers (meshopt's
    # or Draco's bytes; deflated on their own when the package deflates its base), no JSON.
    mesh_bytes = geometry_bytes(base_glb)
    base_mesh = len(zlib.compress(mesh_bytes, 9)) if base.get("deflated") else len(mesh_bytes)
    base_indices = sum(m.get("base_indices", {}).get("size", 0) for m in table["meshes"])
    # The same base mesh and quantization through Draco: base.glb's geometry buffers (the target:
    # the package's base mesh costs at most 1.2x that). JSON on neither side.
    base_draco = None
    if os.path.exists(os.path.join(out, "base.glb")):
        _, _, base_draco = glb_parts(open(os.path.join(out, "base.glb"), "rb").read())
    mesh_chunks = sum(c["size"] for c in table["chunks"] if c["kind"] == "mesh")
    tex_chunks = sum(c["size"] for c in table["chunks"] if c["kind"] == "texture")
    triangles = sum(m["faces"] for m in table["meshes"])
    mesh_total = base_geometry + base_indices + mesh_chunks
    tex_total = base_images + tex_chunks
    tex = table.get("texture") or {}
    atlas_px, referenced_px = atlas_texels(out)
    report = os.path.join(out, "report.json")
    report_doc = json.load(open(report)) if os.path.exists(report) else {}
    dl = report_doc.get("download", {})
    # model.glb's vertices (each mesh's primitives once): Draco's bits per vertex.
    glb_vertices = sum(doc["accessors"][p["attributes"]["POSITION"]]["count"]
                       for m in doc.get("meshes", []) for p in m["primitives"] if "POSITION" in p["attributes"])
    area = dl["package_area"] / dl["download_area"] if dl.get("download_area") else None
    rows.append((name, dict(
        package=len(pkg), glb=len(glb), header=header, triangles=triangles,
        mesh=mesh_total, draco=glb_geometry, bpt=8 * mesh_total / max(triangles, 1),
        tex=tex_total, top=glb_images, pixels=tex.get("width", 0) * tex.get("height", 0),
        referenced=referenced_px,
        levels=sum(1 for c in table["chunks"] if c["kind"] == "texture") + (1 if base_images else 0),
        area=area, base=base_mesh + base_indices, base_draco=base_draco,
        glb_channels=glb_channels, stream_channels=stream_channels,
        stream_bits=report_doc.get("mesh_stream_bits"), glb_vertices=glb_vertices,
        base_vertices=sum(m["base_vertices"] for m in table["meshes"]))))

print("| model | triangles | model.glb | package | package / glb (≤ 1.3) | mesh stream | Draco geometry | "
      "mesh / Draco (≤ 1.3) | bits / triangle | texture stream | top level | texture / top (≤ 1.15) | atlas px | "
      "referenced px | atlas / referenced (≤ 1) | area: stream / download (< 1) | base mesh | "
      "base.glb Draco | base / Draco (≤ 1.2) |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for name, r in rows:
    if r is None:
        print(f"| {name} | – | – | not streamed | | | | | | | | | | | | | | | |")
        continue
    ratio = lambda a, b: f"{a / b:.2f}" if b else "–"
    area_text = "–" if r["area"] is None else f"{r['area']:.2f}"
    print(f"| {name} | {r['triangles']} | {r['glb']} | {r['package']} | {ratio(r['package'], r['glb'])} | "
          f"{r['mesh']} | {r['draco']} | {ratio(r['mesh'], r['draco'])} | {r['bpt']:.1f} | {r['tex']} | "
          f"{r['top']} | {ratio(r['tex'], r['top'])} | {r['pixels']} | "
          f"{'–' if r['referenced'] is None else int(r['referenced'])} | "
          f"{'–' if not r['referenced'] else ratio(r['pixels'], r['referenced'])} | {area_text} | "
          f"{r['base']} | {r['base_draco'] if r['base_draco'] is not None else '–'} | "
          f"{ratio(r['base'], r['base_draco']) if r['base_draco'] else '–'} |")

# Where the refinements' bits go, per vertex split (report.json "mesh_stream_bits": the
# information each field's decisions carried), beside Draco's bits per vertex of model.glb (its
# geometry bytes over its vertices) and the whole mesh stream's (base included) per vertex.
fields = ["parent", "mode", "connectivity", "twin", "position", "normal", "uv", "other"]
split_rows = [(n, r) for n, r in rows if r and r["stream_bits"] and r["stream_bits"]["splits"]]
if split_rows:
    print()
    print("| model | splits | " + " | ".join(fields) + " | refinement bits / split | "
          "mesh stream bits / vertex | Draco bits / vertex | ratio |")
    print("|---|---:|" + "---:|" * (len(fields) + 4))
    for name, r in split_rows:
        b = r["stream_bits"]
        n = b["splits"]
        stream_bpv = 8 * r["mesh"] / max(1, r["base_vertices"] + n)
        draco_bpv = 8 * r["draco"] / max(1, r["glb_vertices"])
        print(f"| {name} | {n} | " + " | ".join(f"{b['fields'].get(f, 0) / n:.2f}" for f in fields) +
              f" | {b['bits'] / n:.2f} | {stream_bpv:.1f} | {draco_bpv:.1f} | {stream_bpv / draco_bpv:.2f} |")

# What the maps beyond base colour cost, in model.glb and in the stream.
channels = ["base_color", "normal", "occlusion_roughness_metallic", "emissive"]
textured = [(n, r) for n, r in rows if r and r["stream_channels"]]
if textured:
    print()
    print("| model | channel | model.glb bytes | stream bytes | share of package |")
    print("|---|---|---:|---:|---:|")
    for name, r in textured:
        for c in channels + sorted(set(r["stream_channels"]) - set(channels)):
            if c not in r["stream_channels"] and c not in r["glb_channels"]:
                continue
            sb = r["stream_channels"].get(c, 0)
            print(f"| {name} | {c} | {r['glb_channels'].get(c, 0)} | {sb} | "
                  f"{100 * sb / r['package']:.1f}% |")
