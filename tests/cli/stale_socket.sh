#!/usr/bin/env bash
# stale_socket.sh SOCKETSMITH GOOD_CASE FAILING_CASE DIR: a design that meets its constraints
# writes DIR/socket.stl; a failing design into the same DIR must remove it (exit 1, one line
# that says so), so no socket sits beside a report that does not describe it.
set -u
bin=$1; good=$2; failing=$3; dir=$4
rm -rf "$dir"
out=$("$bin" design "$good" --out "$dir" 2>&1) || { echo "the good case failed:"; echo "$out"; exit 1; }
[ -s "$dir/socket.stl" ] || { echo "no socket.stl after the good case"; exit 1; }
out=$("$bin" design "$failing" --out "$dir" 2>&1); rc=$?
[ "$rc" = 1 ] || { echo "exit code $rc, expected 1"; echo "$out"; exit 1; }
grep -q "the earlier socket.stl there was removed" <<<"$out" || { echo "the removal is not said:"; echo "$out"; exit 1; }
[ "$(grep -c '^error: ' <<<"$out")" = 1 ] || { echo "expected one 'error:' line:"; echo "$out"; exit 1; }
[ ! -e "$dir/socket.stl" ] || { echo "the earlier socket.stl is still in $dir"; exit 1; }
grep -q '"constraints_met": false' "$dir/design.json" || { echo "design.json is not the failing run's"; exit 1; }
exit 0
