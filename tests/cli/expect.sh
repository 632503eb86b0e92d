#!/usr/bin/env bash
# expect.sh RC REGEX -- command...: passes when the command exits with RC and its combined
# output matches REGEX (grep -E) and, for RC != 0, the error is a single "error: " line.
set -u
rc_expected=$1; regex=$2; shift 3
out=$("$@" 2>&1); rc=$?
if [ "$rc" != "$rc_expected" ]; then echo "exit code $rc, expected $rc_expected"; echo "$out"; exit 1; fi
if ! grep -Eq "$regex" <<<"$out"; then echo "output does not match /$regex/:"; echo "$out"; exit 1; fi
if [ "$rc_expected" != 0 ] && [ "$(grep -c '^error: ' <<<"$out")" != 1 ]; then echo "expected one 'error:' line:"; echo "$out"; exit 1; fi
exit 0
