#!/usr/bin/env bash
# Converts every shared model (../shared/models) and, with --corpus, every corpus model (as an
# upload: its folder, --main its main file) with two meshmux binaries (say, a build of main
# before a change and one after) and prints, per model, whether model.glb, model.mmxp and
# base.glb are byte-identical, with their sizes. For a stream package that differs it also says
# whether the bytes after the JSON table (base .glb, base faces, chunks) are the same, i.e. only
# the table changed. From report.json it prints the stream order each binary chose (same or
# not), the area under its rate-distortion curve (old → new), the multiplexer's render seconds
# and the conversion's wall seconds. The last line counts the identical models.
#   --old-dir DIR  keep the old binary's outputs in DIR; a model already converted there is not
#                  converted again (a refactor's baseline made once, before the change);
#                  OLD_MESHMUX may then be "-" when DIR is complete.
#   --corpus       also every model of ../shared/corpus/models.tsv.
#   --only A,B     only these model folders.
# Other arguments go to the new binary's conversions only (e.g. --jpeg-quality 90, to take a
# deliberate default change out of the comparison). Run it alone: the seconds are this machine's.
# usage: bench/compare_outputs.sh OLD_MESHMUX NEW_MESHMUX [--old-dir DIR] [--corpus] [--only A,B] [convert options...]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
old=$1 new=$2
shift 2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
olddir="$work/old" corpus=0 only="" extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --old-dir) olddir=$2; shift 2 ;;
    --corpus) corpus=1; shift ;;
    --only) only=",$2,"; shift 2 ;;
    *) extra+=("$1"); shift ;;
  esac
done
mkdir -p "$olddir"
data_after_table() {  # bytes of a package after its 12-byte header and JSON table
  local j
  j=$(od -An -t u4 -j 8 -N 4 "$1" | tr -d ' ')
  tail -c +$((12 + j + 1)) "$1"
}
# One line per model: NAME<TAB>input arguments (separated by tabs).
models() {
  local dir file
  for dir in "$here"/../shared/models/*/; do
    file=$(ls "$dir" | grep -i -E '\.(glb|gltf|dae)$' | head -n 1 || true)
    [ -n "$file" ] && printf '%s\t%s\n' "$(basename "$dir")" "$dir$file"
  done
  if [ "$corpus" = 1 ]; then
    tail -n +2 "$here/../shared/corpus/models.tsv" | while IFS=$'\t' read -r folder main _; do
      printf 'corpus/%s\t%s\t--main\t%s\n' "$folder" "$here/../shared/corpus/$folder" "$main"
    done
  fi
}
same=0 total=0
printf '| model | model.glb | model.mmxp | base.glb (old → new bytes) | order | rd area old → new | render s old → new | convert s old → new |\n|---|---|---|---|---|---:|---:|---:|\n'
while IFS=$'\t' read -r -a row; do
  name=${row[0]} input=("${row[@]:1}")
  [ -z "$only" ] || [[ "$only" == *",${name#corpus/},"* ]] || continue
  t0=$(date +%s.%N)
  if [ ! -f "$olddir/$name/.done" ]; then
    rm -rf "${olddir:?}/$name"
    "$old" convert "${input[@]}" -o "$olddir/$name" -q 2>/dev/null </dev/null || true
    mkdir -p "$olddir/$name" && touch "$olddir/$name/.done"
  fi
  t1=$(date +%s.%N)
  "$new" convert "${input[@]}" -o "$work/new/$name" -q ${extra[@]+"${extra[@]}"} 2>/dev/null </dev/null || true
  t2=$(date +%s.%N)
  line="| $name" all=1
  for f in model.glb model.mmxp base.glb; do
    a="$olddir/$name/$f" b="$work/new/$name/$f"
    if [ ! -f "$a" ] && [ ! -f "$b" ]; then cell="—"
    elif [ ! -f "$a" ] || [ ! -f "$b" ]; then cell="only one side" all=0
    elif cmp -s "$a" "$b"; then cell="identical ($(stat -c %s "$a") B)"
    elif [ $f = model.mmxp ] && cmp -s <(data_after_table "$a") <(data_after_table "$b"); then
      cell="table only ($(stat -c %s "$a") → $(stat -c %s "$b") B)" all=0
    else cell="differs ($(stat -c %s "$a") → $(stat -c %s "$b") B)" all=0; fi
    line="$line | $cell"
  done
  total=$((total + 1)) same=$((same + all))
  line="$line | $(python3 - "$olddir/$name/report.json" "$work/new/$name/report.json" <<'PY'
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
  line="$line | $(python3 -c "import sys; a, b, c = map(float, sys.argv[1:]); print(f'{b - a:.2f} → {c - b:.2f}')" "$t0" "$t1" "$t2")"
  echo "$line |"
  rm -rf "${work:?}/new/$name"
done < <(models)
echo
echo "compare: $same of $total models byte-identical (model.glb, model.mmxp, base.glb)"
