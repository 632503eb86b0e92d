#!/usr/bin/env bash
# cli_sweep.sh SOCKETSMITH DIR... : every file of the DIRs through the command line — meshes
# (.stl .obj .ply, or files under a folder named stl/obj/ply) with `check mesh`, anything else as a
# case file with `design --time-limit 20` (the stump at most 1500 nodes, or
# $SOCKETSMITH_SWEEP_MAX_NODES for cheaper runs) — each under a 60 s timeout. Passes when no run crashed, hung, or exited 70, and every failure is one "error:" line
# with a documented exit code (1-4). Prints the counts per exit code.
# Example, on the corpora scripts/fuzz.sh grew: tests/fuzz/cli_sweep.sh build/socketsmith build-fuzz/corpus/*
# or on 1,000 case files mutated from its seeds (docs/fuzzing.md): tests/fuzz/mutate_cases.py DIR 1000
set -u
bin=$1; shift
max_nodes=${SOCKETSMITH_SWEEP_MAX_NODES:-1500}
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
declare -A count
bad=0; n=0
for dir in "$@"; do
  kind=$(basename "$dir")
  for f in "$dir"/*; do
    [ -f "$f" ] || continue
    n=$((n + 1))
    case "$kind" in
      stl|obj|ply) cp "$f" "$work/in.$kind"; cmd=("$bin" check mesh "$work/in.$kind") ;;
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
        cmd=("$bin" design "$work/case.json" --time-limit 20 --out "$work/out") ;;
    esac
    out=$(timeout 60 "${cmd[@]}" 2>&1); rc=$?
    count[$rc]=$(( ${count[$rc]:-0} + 1 ))
    case $rc in
      0) ;;
      1|2|3|4)
        if [ "$(grep -c '^error: ' <<<"$out")" != 1 ]; then bad=$((bad + 1)); echo "not one error line ($rc): $f"; fi ;;
      124) bad=$((bad + 1)); echo "hang over 60 s: $f" ;;
      *) bad=$((bad + 1)); echo "exit $rc: $f"; grep -m 2 -E 'error|terminate|Sanitizer' <<<"$out" ;;
    esac
  done
done
summary="$n inputs:"
for rc in $(printf '%s\n' "${!count[@]}" | sort -n); do summary+=" exit $rc: ${count[$rc]};"; done
echo "$summary findings: $bad"
[ "$bad" = 0 ]
