#!/usr/bin/env python3
"""A smoothed copy of an AAOP shape file: its radii filtered n times by [1 2 1] / 4 around each
slice (periodic) and along each spoke (the end slices kept), everything else copied as it is.

    python3 scripts/smooth_aaop.py IN.aop OUT.aop PASSES

Used to ask whether a limb's shape at the mesh's node scale is what two solvers part on
(docs/VALIDATION.md, "Where the two codes part on the AAOP example's open-loop socket").
OUT is written to a temporary file beside it, then renamed.
"""
import os
import sys

import numpy as np


def numbers_from(lines, i, count, what):
    """count numbers, the first token of each line from line i on."""
    try:
        return [float(lines[i + k].split()[0]) for k in range(count)], i + count
    except (IndexError, ValueError):
        sys.exit(f"smooth_aaop: line {i + 1}: expected {count} numbers ({what})")


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: smooth_aaop.py IN.aop OUT.aop PASSES")
    src, dst, passes = sys.argv[1], sys.argv[2], int(sys.argv[3])
    if passes < 0:
        sys.exit("smooth_aaop: PASSES must be >= 0")
    raw = open(src, newline="").read()
    eol = "\r\n" if "\r\n" in raw else ("\r" if "\r" in raw else "\n")
    lines = raw.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    while lines and not lines[-1].strip():
        lines.pop()
    try:
        i = next(k for k, l in enumerate(lines) if l.strip().upper() == "END COMMENTS") + 3  # type, side
    except StopIteration:
        sys.exit(f"smooth_aaop: '{src}' has no END COMMENTS line: not an AAOP shape file")
    (n_marks,), i = numbers_from(lines, i, 1, "landmark count")
    for _ in range(int(n_marks)):
        (n_points,), i = numbers_from(lines, i + 1, 1, "landmark points")  # after the name
        i += 3 * int(n_points)
    (n_spokes, spacing), i = numbers_from(lines, i, 2, "spoke count and spacing")
    if spacing == 0:
        i += int(n_spokes)
    (n_slices, spacing), i = numbers_from(lines, i, 2, "slice count and spacing")
    if spacing == 0:
        i += int(n_slices)
    n_spokes, n_slices = int(n_spokes), int(n_slices)
    radii, end = numbers_from(lines, i, n_spokes * n_slices, "radii")
    r = np.array(radii).reshape(n_slices, n_spokes)
    s = r.copy()
    for _ in range(passes):
        s = 0.25 * np.roll(s, 1, 1) + 0.5 * s + 0.25 * np.roll(s, -1, 1)
        t = s.copy()
        t[1:-1] = 0.25 * s[:-2] + 0.5 * s[1:-1] + 0.25 * s[2:]
        s = t
    out = lines[:i] + [f"{v:.3f}" for v in s.ravel()] + lines[end:]
    tmp = dst + ".tmp"
    with open(tmp, "w", newline="") as f:
        f.write(eol.join(out) + eol)
    os.replace(tmp, dst)
    d = np.abs(s - r)
    print(f"{n_spokes} spokes x {n_slices} slices, {passes} passes: radii changed by {d.mean():.2f} mm on average, "
          f"{d.max():.2f} mm at most")


if __name__ == "__main__":
    main()
