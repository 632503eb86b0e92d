#!/usr/bin/env python3
"""ring_means_check.py OUT: checks `validate design --stand`'s ring-by-ring table (summary.json
`rings_below_brim`) against its own per-node file (comparison.csv): every ring's node count and its
area-weighted designed, CalculiX and socketsmith (donned and stood) means recomputed from the CSV's
`area_m2`, `rings_from_brim`, `designed_kPa`, `calculix_kPa` and `socketsmith_stood_kPa` (the
deeper rings pooled in the last listed one), each ring's mean between its nodes' smallest and
largest value, and rings.svg / rings.png written. Python's standard library only.
"""
import csv
import json
import pathlib
import sys


def main(argv):
    if len(argv) != 1:
        print(__doc__)
        return 2
    out = pathlib.Path(argv[0])
    summary = json.loads((out / "summary.json").read_text())
    listed = summary.get("rings_below_brim")
    if not listed:
        print("summary.json has no rings_below_brim")
        return 1
    deepest = max(int(k) for k in listed)
    sums = {}
    with open(out / "comparison.csv", newline="") as f:
        for row in csv.DictReader(f):
            ring = int(row["rings_from_brim"])
            if ring < 1:
                continue
            ring = min(ring, deepest)
            a = float(row["area_m2"])
            values = [float(row["designed_kPa"]), float(row["calculix_kPa"]), float(row["socketsmith_stood_kPa"])]
            s = sums.setdefault(ring, {"nodes": 0, "area": 0.0, "sum": [0.0] * 3, "lo": [1e300] * 3, "hi": [-1e300] * 3})
            s["nodes"] += 1
            s["area"] += a
            for k, v in enumerate(values):
                s["sum"][k] += a * v
                s["lo"][k] = min(s["lo"][k], v)
                s["hi"][k] = max(s["hi"][k], v)
    failed = 0
    if sorted(sums) != sorted(int(k) for k in listed):
        print(f"rings in the CSV {sorted(sums)} but in summary.json {sorted(int(k) for k in listed)}")
        return 1
    names = ("designed_kpa", "calculix_kpa", "socketsmith_kpa")
    for ring, s in sorted(sums.items()):
        got = listed[str(ring)]
        line = f"ring {ring:2d}: {s['nodes']:4d} nodes"
        if got["nodes"] != s["nodes"]:
            line += f"  nodes {got['nodes']} in summary.json"
            failed += 1
        for k, name in enumerate(names):
            mean = s["sum"][k] / s["area"]
            ok = abs(got[name] - mean) <= 1e-6 * max(1.0, abs(mean)) and s["lo"][k] - 1e-9 <= got[name] <= s["hi"][k] + 1e-9
            failed += not ok
            line += f"  {name} {got[name]:.3f} (csv {mean:.3f}){'' if ok else ' WRONG'}"
        for name, a, b in (("calculix_minus_design_kpa", "calculix_kpa", "designed_kpa"),
                           ("socketsmith_minus_design_kpa", "socketsmith_kpa", "designed_kpa")):
            if abs(got[name] - (got[a] - got[b])) > 1e-9:
                line += f"  {name} WRONG"
                failed += 1
        print(line)
    for f in ("rings.svg", "rings.png"):
        if not (out / f).is_file() or (out / f).stat().st_size == 0:
            print(f"{f} missing")
            failed += 1
    print("ring means: " + ("ok" if failed == 0 else f"{failed} wrong"))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
