#!/usr/bin/env bash
# expect.sh RC REGEX [REGEX...] -- command...: passes when the command exits with RC and its
# combined output matches every REGEX (grep -E, each on some line) and, for RC != 0, the error is a
# single "error: " line.
set -u
rc_expected=$1; shift
regexes=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do regexes+=("$1"); shift; done
shift
out=$("$@" 2>&1); rc=$?
if [ "$rc" != "$rc_expected" ]; then echo "exit code $rc, expected $rc_expected"; echo "$out"; exit 1; fi
for regex in "${regexes[@]}"; do
  if ! grep -Eq "$regex" <<<"$out"; then echo "output does not match /$regex/:"; echo "$out"; exit 1; fi
done
if [ "$rc_expected" != 0 ] && [ "$(grep -c '^error: ' <<<"$out")" != 1 ]; then echo "expected one 'error:' line:"; echo "$out"; exit 1; fi
exit 0
