#!/usr/bin/env bash
# Converts every shared model with two meshmux binaries (say, a build of main before a change
# and one after) and prints, per model, whether model.glb, model.mmxp and base.glb are
# byte-identical, with their sizes. For a stream package that differs it also says whether the
# bytes after the JSON table (base .glb, base faces, chunks) are the same, i.e. only the table
# changed. Extra arguments go to the new binary's conversions only (e.g. --jpeg-quality 90, to
# take a deliberate default change out of the comparison). From report.json it also prints
# the stream order each binary chose (same or not), the area under its rate-distortion curve
# (old → new, with the relative difference), the multiplexer's render seconds and the whole
# conversion's wall seconds (issue 6/8: "the order the multiplexer picks on each textured
# shared model, before and after"). Run it alone: the seconds are this machine's.
# usage: bench/compare_outputs.sh OLD_MESHMUX NEW_MESHMUX [convert options...]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
old=$1 new=$2
shift 2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
data_after_table() {  # bytes of a package after its 12-byte header and JSON table
  local j
  j=$(od -An -t u4 -j 8 -N 4 "$1" | tr -d ' ')
  tail -c +$((12 + j + 1)) "$1"
}
printf '| model | model.glb | model.mmxp | base.glb (old → new bytes) | order | rd area old → new | render s old → new | convert s old → new |\n|---|---|---|---|---|---:|---:|---:|\n'
for dir in "$here"/../shared/models/*/; do
  name=$(basename "$dir")
  file=$(ls "$dir" | grep -i -E '\.(glb|gltf|dae)$' | head -n 1 || true)
  [ -n "$file" ] || continue
  t0=$(date +%s.%N)
  "$old" convert "$dir$file" -o "$work/old/$name" -q 2>/dev/null || true
  t1=$(date +%s.%N)
  "$new" convert "$dir$file" -o "$work/new/$name" -q "$@" 2>/dev/null || true
  t2=$(date +%s.%N)
  row="| $name"
  for f in model.glb model.mmxp base.glb; do
    a="$work/old/$name/$f" b="$work/new/$name/$f"
    if [ ! -f "$a" ] && [ ! -f "$b" ]; then cell="—"
    elif [ ! -f "$a" ] || [ ! -f "$b" ]; then cell="only one side"
    elif cmp -s "$a" "$b"; then cell="identical ($(stat -c %s "$a") B)"
    elif [ $f = model.mmxp ] && cmp -s <(data_after_table "$a") <(data_after_table "$b"); then
      cell="table only ($(stat -c %s "$a") → $(stat -c %s "$b") B)"
    else cell="differs ($(stat -c %s "$a") → $(stat -c %s "$b") B)"; fi
    row="$row | $cell"
  done
  row="$row | $(python3 - "$work/old/$name/report.json" "$work/new/$name/report.json" <<'PY'
import json, sys
try:
    a, b = (json.load(open(f)) for f in sys.argv[1:3])
except (OSError, ValueError):
    print("— | — | —")
    sys.exit()
same = "same" if a["order"] == b["order"] else "differs: %s → %s" % (a["order"], b["order"])
x, y = a["areas"]["rd"], b["areas"]["rd"]
rel = (y - x) / x * 100 if x else 0.0
print("%s | %.6g → %.6g (%+.2f%%) | %.2f → %.2f" % (same, x, y, rel, a["seconds"]["render"], b["seconds"]["render"]))
PY
)"
  row="$row | $(python3 -c "import sys; a, b, c = map(float, sys.argv[1:]); print(f'{b - a:.2f} → {c - b:.2f}')" "$t0" "$t1" "$t2")"
  echo "$row |"
done
