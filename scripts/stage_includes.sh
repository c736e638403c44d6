#!/usr/bin/env bash
# Prints which stage folders each stage folder includes (docs/ARCHITECTURE.md "Layout": an earlier
# stage never includes a later one) and fails (exit 1) on any include of a later stage.
# usage: scripts/stage_includes.sh   (run by ctest as Layout.StagesIncludeOnlyEarlierStages)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
stages=(core scene image importers clean atlas simplify stream multiplex exporters pipeline serve batch cli)
rank() { local i; for i in "${!stages[@]}"; do [ "${stages[$i]}" = "$1" ] && echo "$i" && return; done; echo -1; }
bad=0
printf '| folder | includes (stage folders) | later stages included |\n|---|---|---|\n'
for s in "${stages[@]}"; do
  r=$(rank "$s")
  used=$(cat "$here/$s"/*.h "$here/$s"/*.cpp 2>/dev/null |
    sed -n 's/^[[:space:]]*#[[:space:]]*include[[:space:]]*"\([a-z_]*\)\/.*/\1/p' | sort -u)
  list=() later=()
  for u in $used; do
    ur=$(rank "$u")
    [ "$ur" -lt 0 ] && continue
    [ "$u" = "$s" ] && continue
    list+=("$u")
    [ "$ur" -gt "$r" ] && later+=("$u")
  done
  printf '| %s | %s | %s |\n' "$s" "${list[*]:-—}" "${later[*]:-none}"
  if [ ${#later[@]} -gt 0 ]; then
    bad=1
    for u in "${later[@]}"; do
      grep -n "#include \"$u/" "$here/$s"/*.h "$here/$s"/*.cpp | sed "s|$here/||; s|^|  later stage: |" >&2
    done
  fi
done
[ $bad = 0 ] && echo "layout: every stage includes only earlier stages" || echo "layout: a stage includes a later one (see above)" >&2
exit $bad
