#!/usr/bin/env python3
"""contact_csv_check.py OUT: checks `simulate donning`'s contact.csv against the friction law it
records: on every node in contact the wall's normal is a unit vector facing the skin (against the
skin's outward normal), the shear traction lies in the wall's tangent plane and is at most μ times
the pressure (5 % over allowed: the friction's limit uses the normal force of the previous pass),
and with a standing load most of the contact slides at μ p. μ comes from donning.json. Python's
standard library only.
"""
import csv
import json
import math
import pathlib
import sys


def main(argv):
    if len(argv) != 1:
        print(__doc__)
        return 2
    out = pathlib.Path(argv[0])
    mu = json.loads((out / "donning.json").read_text())["friction"]
    failed, touching, at_limit = 0, 0, 0
    worst_ratio, worst_tangent, worst_facing = 0.0, 0.0, -1.0
    with open(out / "contact.csv", newline="") as f:
        for k, row in enumerate(csv.DictReader(f)):
            p = float(row["pressure_pa"])
            wall = [float(row[c]) for c in ("wall_nx", "wall_ny", "wall_nz")]
            skin = [float(row[c]) for c in ("nx", "ny", "nz")]
            shear = [float(row[c]) for c in ("shear_x_pa", "shear_y_pa", "shear_z_pa")]
            s = math.sqrt(sum(v * v for v in shear))
            if p <= 0:
                if s > 0:
                    print(f"node {k}: shear {s:.1f} Pa without contact")
                    failed += 1
                continue
            touching += 1
            n = math.sqrt(sum(v * v for v in wall))
            facing = sum(a * b for a, b in zip(wall, skin))
            tangent = abs(sum(a * b for a, b in zip(wall, shear))) / max(s, 1e-12) if s > 0 else 0.0
            worst_ratio, worst_tangent, worst_facing = max(worst_ratio, s / p), max(worst_tangent, tangent), max(worst_facing, facing)
            at_limit += s >= 0.9 * mu * p
            if abs(n - 1) > 1e-6 or facing > 0 or tangent > 1e-2 or s > 1.05 * mu * p:
                print(f"node {k}: |wall n| {n:.6f}, wall n . skin n {facing:.3f}, shear off the tangent plane "
                      f"{tangent:.4f}, shear / pressure {s / p:.3f} (μ {mu})")
                failed += 1
    print(f"{touching} nodes in contact: shear / pressure at most {worst_ratio:.3f} (μ {mu}), {at_limit} at ≥ 0.9 μ; "
          f"shear off the wall's tangent plane at most {worst_tangent:.2e}; wall n . skin n at most {worst_facing:.3f}")
    if touching == 0:
        print("no node in contact")
        failed += 1
    elif mu > 0 and at_limit < touching // 2:
        print(f"only {at_limit} of {touching} nodes slide at μ p after standing")
        failed += 1
    print("contact.csv: " + ("ok" if failed == 0 else f"{failed} wrong"))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
