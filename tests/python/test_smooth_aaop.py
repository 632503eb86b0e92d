"""scripts/smooth_aaop.py: a smoothed copy of an AAOP shape (docs/VALIDATION.md uses it to ask
whether a limb's node-scale shape is what CalculiX and socketsmith part on). A synthetic shape
with listed spoke angles, a landmark and CR line ends: zero passes copy it, passes take the
ripple out of the radii and keep their level, and socketsmith reads the result."""
import pathlib
import subprocess
import sys

import numpy as np

from conftest import ROOT, run_cli

SCRIPT = ROOT / "scripts" / "smooth_aaop.py"
SPOKES, SLICES = 24, 30


def write_shape(path: pathlib.Path):
    """A tapered cylinder, 40-50 mm across, with a 1.5 mm ripple at every other spoke and slice."""
    angles = [-90 + 15 * j for j in range(SPOKES)]
    radii = np.array([[40 + 10 * i / SLICES + 1.5 * (-1) ** (i + j) for j in range(SPOKES)] for i in range(SLICES)])
    lines = ["AAOP1", "test shape", "END COMMENTS", "CYLINDRICAL", "RIGHT", "1", "TT", "1", "45.0", "0.0", "20.0",
             str(SPOKES), "0", *map(str, angles), str(SLICES), "5", *[f"{r:.3f}" for r in radii.ravel()]]
    path.write_bytes(("\r".join(lines) + "\r").encode())
    return radii


def smoothed(src, dst, passes):
    p = subprocess.run([sys.executable, str(SCRIPT), str(src), str(dst), str(passes)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    text = dst.read_bytes().decode()
    assert "\n" not in text, "the CR line ends are kept"
    return text.split("\r")[:-1]


def test_zero_passes_copy_the_file(tmp_path):
    write_shape(tmp_path / "a.aop")
    assert smoothed(tmp_path / "a.aop", tmp_path / "b.aop", 0) == (tmp_path / "a.aop").read_bytes().decode().split("\r")[:-1]


def test_passes_remove_the_ripple_and_keep_the_level(tmp_path, exe):
    radii = write_shape(tmp_path / "a.aop")
    lines = smoothed(tmp_path / "a.aop", tmp_path / "b.aop", 3)
    out = np.array([float(v) for v in lines[-SPOKES * SLICES:]]).reshape(SLICES, SPOKES)
    ripple = lambda r: np.abs(r - 0.5 * (np.roll(r, 1, 1) + np.roll(r, -1, 1))).mean()
    assert ripple(radii) > 1.4
    assert ripple(out) < 0.05
    assert abs(out[1:-1].mean() - radii[1:-1].mean()) < 0.05
    assert lines[:-SPOKES * SLICES] == (tmp_path / "a.aop").read_bytes().decode().split("\r")[: -1 - SPOKES * SLICES]
    code, _, err = run_cli(exe, "check", "mesh", tmp_path / "b.aop")
    assert code == 0, err
    assert f"{SPOKES} spokes" in err and "landmark TT" in err


def test_not_an_aaop_file_is_refused_and_nothing_written(tmp_path):
    (tmp_path / "a.aop").write_text("solid x\nendsolid x\n")
    p = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "a.aop"), str(tmp_path / "b.aop"), "1"],
                       capture_output=True, text=True)
    assert p.returncode != 0 and "not an AAOP shape file" in p.stderr
    assert not (tmp_path / "b.aop").exists()
