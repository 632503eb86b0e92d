#!/usr/bin/env python3
"""json_bars.py JSON BAR... -- COMMAND...: runs COMMAND (it must exit 0), then checks numeric bars on
the JSON file it wrote (removed before the run, so an earlier run's file cannot pass). A BAR is `PATH>=NUMBER`, `PATH<=NUMBER` or `PATH==VALUE` (true, false or a
number); PATH names a field with dots (`all.r`), and `A/B` compares the ratio of two fields
(`fe_force_n/stand_force_n>=0.98`). Every measured value is printed beside its bar, so a run's log
says how far from each bar it was. Python's standard library only.
"""
import json
import operator
import pathlib
import re
import subprocess
import sys

OPS = {">=": operator.ge, "<=": operator.le, "==": operator.eq}


def field(doc, path):
    value = doc
    for key in path.split("."):
        if not isinstance(value, dict) or key not in value:
            raise KeyError(f"{path}: no field '{key}'")
        value = value[key]
    return value


def measure(doc, expr):
    parts = expr.split("/")
    value = field(doc, parts[0])
    if len(parts) == 2:
        value = value / field(doc, parts[1])
    elif len(parts) != 1:
        raise ValueError(f"{expr}: at most one '/'")
    return value


def main(argv):
    if "--" not in argv or argv.index("--") < 2:
        print(__doc__)
        return 2
    split = argv.index("--")
    path, bars, command = argv[0], argv[1:split], argv[split + 1:]
    pathlib.Path(path).unlink(missing_ok=True)
    run = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    print(run.stdout, end="")
    if run.returncode != 0:
        print(f"exit code {run.returncode}, expected 0")
        return 1
    with open(path) as f:
        doc = json.load(f)
    failed = 0
    for bar in bars:
        m = re.fullmatch(r"([\w./]+)(>=|<=|==)(.+)", bar)
        if not m:
            print(f"bad bar '{bar}' (expected PATH>=N, PATH<=N or PATH==VALUE)")
            return 2
        expr, op, want = m.groups()
        want = {"true": True, "false": False}.get(want, None) if want in ("true", "false") else float(want)
        try:
            got = measure(doc, expr)
        except (KeyError, ValueError, TypeError, ZeroDivisionError) as e:
            print(f"FAIL {bar}: {e}")
            failed += 1
            continue
        ok = OPS[op](got, want) if isinstance(want, bool) else (
            isinstance(got, (int, float)) and not isinstance(got, bool) and OPS[op](got, want))
        print(f"{'ok  ' if ok else 'FAIL'} {expr} = {got!r} (bar {op} {want!r})")
        failed += not ok
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
