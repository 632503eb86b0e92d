#!/usr/bin/env bash
# cli_sweep.sh SOCKETSMITH DIR... : every file of the DIRs through the command line, each run under
# a 60 s timeout, and the counts of exit codes per command.
# - Meshes (.stl .obj .ply .aop, or any file under a folder named stl/obj/ply/aop): `check mesh`;
#   with SOCKETSMITH_SWEEP_MESH="check mesh design" also `mesh --limb FILE` (the stump at
#   $SOCKETSMITH_SWEEP_MAX_NODES, at least 200) and, when that meshed, `design` of a case file
#   whose limb is the file (same size, optimiser on, --time-limit 20).
# - Anything else as a case file with `design --time-limit 20` (the stump at most 1500 nodes, or
#   $SOCKETSMITH_SWEEP_MAX_NODES for cheaper runs).
# Passes when no run crashed (a signal, or an exit code >= 70 such as 70, internal error), hung
# (over 60 s), and every failing run's stderr, less its log lines ([info] ...) and progress lines
# ("  stage:  40%"), is one "error: " line with a documented exit code (1-4).
# Example, on the corpora scripts/fuzz.sh grew: tests/fuzz/cli_sweep.sh build/socketsmith build-fuzz/corpus/*
# on 1,000 case files mutated from its seeds (docs/fuzzing.md): tests/fuzz/mutate_cases.py DIR 1000
# on 1,000 mutated meshes: tests/fuzz/mutate_meshes.py DIR 1000 and SOCKETSMITH_SWEEP_MESH="check mesh design"
set -u
bin=$1; shift
max_nodes=${SOCKETSMITH_SWEEP_MAX_NODES:-1500}
mesh_runs=${SOCKETSMITH_SWEEP_MESH:-check}
mesh_nodes=$(( max_nodes < 200 ? 200 : max_nodes ))
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
declare -A count
bad=0; n=0; runs=0

# run NAME FILE CMD...: runs CMD, counts its exit code under NAME, reports a finding; sets rc.
run() {
  local name=$1 file=$2; shift 2
  timeout 60 "$@" > /dev/null 2> "$work/err"; rc=$?
  runs=$((runs + 1))
  count[$name $rc]=$(( ${count[$name $rc]:-0} + 1 ))
  case $rc in
    0) ;;
    1|2|3|4)
      local lines
      lines=$(tr '\r' '\n' < "$work/err" | grep -a -v -E '^\[(trace|debug|info|warning)\] |^  .*: +[0-9]+%$|^$')
      if [ "$(wc -l <<<"$lines")" != 1 ] || [ "${lines#error: }" = "$lines" ]; then
        bad=$((bad + 1)); echo "$name: not one error line ($rc): $file"; head -3 <<<"$lines"
      fi ;;
    124) bad=$((bad + 1)); echo "$name: hang over 60 s: $file" ;;
    *) bad=$((bad + 1)); echo "$name: exit $rc: $file"; grep -a -m 2 -E 'error|terminate|Sanitizer|Assert' "$work/err" ;;
  esac
}

for dir in "$@"; do
  kind=$(basename "$dir")
  for f in "$dir"/*; do
    [ -f "$f" ] || continue
    n=$((n + 1))
    ext=${f##*.}
    case "$kind" in stl|obj|ply|aop) ext=$kind ;; esac
    case "$ext" in
      stl|obj|ply|aop)
        limb="$work/in.$ext"; cp "$f" "$limb"
        [[ " $mesh_runs " == *" check "* ]] && run check "$f" "$bin" check mesh "$limb"
        if [[ " $mesh_runs " == *" mesh "* ]]; then
          rm -rf "$work/mesh"
          run mesh "$f" "$bin" mesh --limb "$limb" --target-nodes "$mesh_nodes" --out "$work/mesh"
          if [ "$rc" = 0 ] && [[ " $mesh_runs " == *" design "* ]]; then
            printf '{"limb": {"file": "%s"}, "mesh": {"target_nodes": %d}}\n' "$limb" "$mesh_nodes" > "$work/limb_case.json"
            rm -rf "$work/out"
            run design "$f" "$bin" design "$work/limb_case.json" --time-limit 20 --out "$work/out"
          fi
        fi ;;
      *)
        # The case as given, with the stump capped at max_nodes so a valid case designs in seconds.
        python3 - "$f" "$work/case.json" "$max_nodes" <<'PY' 2>/dev/null || cp "$f" "$work/case.json"
import json, sys
d = json.load(open(sys.argv[1]))
if isinstance(d, dict) and isinstance(d.get("mesh", {}), dict):
    m = d.setdefault("mesh", {})
    t = m.get("target_nodes", 8000)
    cap = int(sys.argv[3])
    if isinstance(t, (int, float)) and not isinstance(t, bool) and t > cap: m["target_nodes"] = cap
json.dump(d, open(sys.argv[2], "w"))
PY
        run design "$f" "$bin" design "$work/case.json" --time-limit 20 --out "$work/out" ;;
    esac
  done
done
for name in check mesh design; do
  line=""
  for key in $(printf '%s\n' "${!count[@]}" | grep "^$name " | sort -k2 -n | tr ' ' ':'); do
    rc=${key#*:}; line+=" exit $rc: ${count[$name $rc]};"
  done
  [ -n "$line" ] && echo "$name:$line"
done
echo "$n inputs, $runs runs; findings: $bad"
[ "$bad" = 0 ]
