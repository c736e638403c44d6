#!/usr/bin/env python3
"""bench/scale.sh's table: reads what it left in WORK and prints one markdown table (a row per
input) and the issue's targets with met / NOT met, and writes WORK/scale.json.

WORK holds inputs.tsv (NAME, FILE, KIND, SIZE asked of the generator or 0) and per NAME:
NAME.time (GNU time '%e %M' of the conversion), NAME.log (its progress), NAME.out/ (its outputs),
NAME.info.json (`meshmux info --json` of the input) and NAME.scale.json (meshmux_bench_scale).
Every figure printed is read from those files.

usage: bench/scale_report.py WORK [COMMIT]
"""
import json
import os
import re
import sys

FRACTIONS = (0.25, 0.06, 0.015)
HAUSDORFF_LIMIT = 1.1
# Targets of size (issue "Big content"), keyed by the generator's size: (key, label, limit, as
# the limit is printed, how the measure is printed), met when measured ≤ limit.
SIZE_TARGETS = {
    20_000_000: [
        ("convert_s", "conversion wall time", 90, "≤ 90 s", "{:.2f} s"),
        ("peak_rss_mib", "peak RSS", 2048, "≤ 2 GiB", "{:.0f} MiB"),
        ("bytes_per_triangle", "peak RSS per input triangle", 100, "≤ 100 B", "{:.1f} B"),
    ],
    4_000_000: [
        ("convert_s", "conversion wall time", 20, "≤ 20 s", "{:.2f} s"),
        ("peak_rss_mib", "peak RSS", 600, "≤ 600 MiB", "{:.0f} MiB"),
        ("base_glb", "base.glb", 256 * 1024, "≤ 256 KiB", "{:,} B"),
        ("package_over_model", "package / model.glb", 1.3, "≤ 1.3×", "{:.3f}×"),
    ],
}


def read_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def size_of(path):
    return os.path.getsize(path) if os.path.isfile(path) else None


def conversion(work, name):
    """Wall seconds, peak RSS and the stage figures of one conversion (None where absent)."""
    c = {"ok": False}
    try:
        with open(os.path.join(work, name + ".time"), encoding="utf-8") as f:
            last = f.read().strip().splitlines()[-1].split()
        c["convert_s"], c["peak_rss_kb"] = float(last[0]), int(last[1])
    except (OSError, IndexError, ValueError):
        return c
    out = os.path.join(work, name + ".out")
    c["model_glb"] = size_of(os.path.join(out, "model.glb"))
    c["base_glb"] = size_of(os.path.join(out, "base.glb"))
    c["package"] = size_of(os.path.join(out, "model.mmxp"))
    c["ok"] = c["model_glb"] is not None
    try:
        with open(os.path.join(work, name + ".log"), encoding="utf-8", errors="replace") as f:
            log = f.read()
    except OSError:
        log = ""
    m = re.search(r"base level: .*collapses in (\d+) ms", log)
    c["record_ms"] = int(m.group(1)) if m else None
    m = re.search(r"multiplexed: .*, ([0-9.]+) s", log)
    c["multiplexed_s"] = float(m.group(1)) if m else None
    if not c["ok"]:
        errors = [l for l in log.splitlines() if l and not l.startswith("meshmux: [")]
        c["error"] = errors[-1] if errors else "no model.glb written"
    report = read_json(os.path.join(out, "report.json")) or {}
    c["report_seconds"] = report.get("seconds")
    c["render_cut"] = report.get("render_cut")
    return c


def collect(work, name, path, kind, size):
    info = read_json(os.path.join(work, name + ".info.json")) or {}
    row = {"name": name, "file": path, "kind": kind, "size": size,
           "triangles": info.get("scene_triangles")}
    row["convert"] = c = conversion(work, name)
    if c.get("peak_rss_kb") is not None:
        c["peak_rss_mib"] = c["peak_rss_kb"] / 1024
        if row["triangles"]:
            c["bytes_per_triangle"] = c["peak_rss_kb"] * 1024 / row["triangles"]
    if c.get("package") and c.get("model_glb"):
        c["package_over_model"] = c["package"] / c["model_glb"]
    row["hausdorff"] = read_json(os.path.join(work, name + ".scale.json"))
    # A real scan under the size threshold: its block-built comparison from a run forced into
    # blocks (scale.sh), its meshopt comparison from the default record above.
    forced = read_json(os.path.join(work, name + ".blocks.scale.json"))
    if forced and row["hausdorff"]:
        for e in row["hausdorff"].get("fractions", []):
            for x in forced.get("fractions", []):
                if abs(x["fraction"] - e["fraction"]) < 1e-9 and x.get("whole_unit"):
                    e["whole_unit"] = dict(x["whole_unit"], block_built=x["meshmux"])
    return row


def fraction_entry(row, f):
    h = row["hausdorff"]
    for e in (h or {}).get("fractions", []):
        if abs(e["fraction"] - f) < 1e-9:
            return e
    return None


def hausdorff_met(e):
    """(met, measured text) of one fraction's comparison; met None when it cannot be judged."""
    mm, mo = e["meshmux"]["h"], e["meshopt"]["h"]
    if mm is None or mo is None:
        return None, "n/a (a surface without area)"
    text = f'{mm["hausdorff"]:.5f} / {mo["hausdorff"]:.5f}'
    if e["ratio"] is not None:
        return e["ratio"] <= HAUSDORFF_LIMIT, f'{text} = {e["ratio"]:.2f}'
    exact = mm["hausdorff"] <= 1e-6
    return exact, text + (" (both exact)" if exact else " (meshopt exact)")


def targets(rows):
    out = []
    for r in rows:
        c = r["convert"]
        sized = SIZE_TARGETS.get(r["size"], []) if r["kind"] == "generated" else []
        for key, label, limit, limit_text, shown in sized:
            v = c.get(key) if c["ok"] else None
            out.append({"input": r["name"], "target": label, "measured": v,
                        "shown": "conversion failed" if v is None else shown.format(v),
                        "limit": limit_text, "met": v is not None and v <= limit})
        for f in FRACTIONS:
            e = fraction_entry(r, f)
            if e is None:
                continue
            met, shown = hausdorff_met(e)
            out.append({"input": r["name"], "target": f"Hausdorff at {f:g} vs meshopt_simplify "
                        f'({e["meshmux"]["triangles"]:,} / {e["meshopt"]["triangles"]:,} tris)',
                        "measured": e["ratio"], "shown": shown,
                        "limit": f"≤ {HAUSDORFF_LIMIT}× meshopt's", "met": met})
            w = e.get("whole_unit")
            b = (w or {}).get("block_built", e["meshmux"])
            if w and w.get("h") and b["h"]:
                q = w.get("ratio")
                out.append({"input": r["name"], "target": f"Hausdorff at {f:g}, block-built vs "
                            f'whole-unit record ({b["triangles"]:,} / {w["triangles"]:,} tris)',
                            "measured": q,
                            "shown": f'{b["h"]["hausdorff"]:.5f} / {w["h"]["hausdorff"]:.5f}'
                            + (f" = {q:.2f}" if q is not None else " (exact)"),
                            "limit": f"≤ {HAUSDORFF_LIMIT}× the whole-unit record's",
                            "met": q is None or q <= HAUSDORFF_LIMIT})
    return out


def num(v, spec, none="–"):
    return none if v is None else format(v, spec)


def stages_cell(c):
    parts = []
    if c.get("record_ms") is not None:
        parts.append(f'record {c["record_ms"] / 1000:.2f} s')
    if c.get("multiplexed_s") is not None:
        parts.append(f'multiplexed {c["multiplexed_s"]:.1f} s')
    s = c.get("report_seconds")
    if s:
        parts.append("report layers {layers:.2f} / render {render:.2f} / total {total:.2f} s"
                     .format(**s))
    return "; ".join(parts) or "–"


def hausdorff_cell(r, f):
    e = fraction_entry(r, f)
    if e is None:
        return "–"
    mm, mo = e["meshmux"]["h"], e["meshopt"]["h"]
    if mm is None or mo is None:
        return "n/a"
    ratio = f'{e["ratio"]:.2f}' if e["ratio"] is not None else "–"
    return f'{mm["hausdorff"]:.5f} / {mo["hausdorff"]:.5f} ({ratio})'


def print_table(rows):
    print("| input | triangles | convert s | peak RSS MiB | bytes / input tri | package / model.glb "
          "| base.glb bytes | stages | render_cut error / tris | "
          + " | ".join(f"Hausdorff {f * 100:g}% meshmux / meshopt (ratio)" for f in FRACTIONS)
          + " |")
    print("|---|---:|---:|---:|---:|---:|---:|---|---:|" + "---:|" * len(FRACTIONS))
    for r in rows:
        c = r["convert"]
        cut = c.get("render_cut")
        cut_cell = f'{cut["error"]:.4g} / {cut["triangles"]:,}' if cut else "–"
        convert = num(c.get("convert_s"), ".2f") if c["ok"] else f'failed: {c.get("error", "?")}'
        cells = [f'{r["name"]} ({r["kind"]})', num(r["triangles"], ","), convert,
                 num(c.get("peak_rss_mib"), ".0f"), num(c.get("bytes_per_triangle"), ".1f"),
                 num(c.get("package_over_model"), ".3f"), num(c.get("base_glb"), ","),
                 stages_cell(c), cut_cell] + [hausdorff_cell(r, f) for f in FRACTIONS]
        print("| " + " | ".join(cells) + " |")


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: bench/scale_report.py WORK [COMMIT]")
    work = sys.argv[1]
    rows = []
    with open(os.path.join(work, "inputs.tsv"), encoding="utf-8") as f:
        for line in f:
            name, path, kind, size = line.rstrip("\n").split("\t")
            rows.append(collect(work, name, path, kind, int(size)))
    samples = next((r["hausdorff"]["samples"] for r in rows if r["hausdorff"]), None)
    print("## meshmux on big scan-like meshes\n")
    if samples:
        print("Hausdorff: symmetric, relative to the bounding-box diagonal, against the cleaned "
              f"input, {samples:,} samples per surface; meshopt_simplify at meshmux's triangle "
              "count (meshmux_bench_scale). ", end="")
    else:
        print("Hausdorff: not measured. ", end="")
    print("Stages: the progressive record and the multiplexer from the progress log, the "
          "multiplexer's layers / render / total from report.json.\n")
    print_table(rows)
    t = targets(rows)
    print("\n## Targets (issue \"Big content\")\n")
    if not t:
        print("No target applies to these inputs.")
    else:
        print("| input | target | measured | target | verdict |\n|---|---|---:|---|---|")
        for x in t:
            verdict = "n/a" if x["met"] is None else ("met" if x["met"] else "NOT met")
            print(f'| {x["input"]} | {x["target"]} | {x["shown"]} | {x["limit"]} | {verdict} |')
    doc = {"commit": sys.argv[2] if len(sys.argv) > 2 else None, "inputs": rows,
           "targets": [{k: v for k, v in x.items() if k != "shown"} for x in t]}
    with open(os.path.join(work, "scale.json"), "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=2)
        f.write("\n")
    print(f"\nwrote {os.path.join(work, 'scale.json')}")


if __name__ == "__main__":
    main()
