"""Fixtures of the Python package's tests: the socketsmith program (for the CLI side of each
comparison) and a small demo design made once per session by each side.

Run from the build: `cd build && ctest -R python` (it sets PYTHONPATH and SOCKETSMITH_EXE), or
`PYTHONPATH=build/python SOCKETSMITH_EXE=build/socketsmith /usr/bin/python3 -m pytest tests/python`.
"""
import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]

# The smallest stump that keeps the demo's design meaningful and the tests quick.
TARGET_NODES = 1000


@pytest.fixture(scope="session")
def exe():
    path = pathlib.Path(os.environ.get("SOCKETSMITH_EXE", ROOT / "build" / "socketsmith"))
    if not path.exists():
        pytest.fail(f"the socketsmith program is not at {path}: build it, or set SOCKETSMITH_EXE")
    return str(path)


def run_cli(exe, *args):
    """Runs the socketsmith program; returns (exit code, stdout, stderr)."""
    p = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


@pytest.fixture(scope="session")
def demo_case():
    import socketsmith

    case = socketsmith.demo_case(target_nodes=TARGET_NODES)
    # The open-loop design: the CLI and Python sides compare the design itself (the closed loop,
    # on by default for a transtibial limb, is the C++ suite's: tests/pipeline/closed_loop_test.cpp).
    case["design"]["closed_loop"] = False
    return case


@pytest.fixture(scope="session")
def cli_design(exe, demo_case, tmp_path_factory):
    """`socketsmith design case.json --out DIR` on the demo case: (design.json, DIR)."""
    d = tmp_path_factory.mktemp("cli_design")
    (d / "case.json").write_text(json.dumps(demo_case))
    rc, _, err = run_cli(exe, "design", d / "case.json", "--out", d / "out")
    assert rc == 0, err
    return json.loads((d / "out" / "design.json").read_text()), d / "out"


@pytest.fixture(scope="session")
def py_design(demo_case, tmp_path_factory):
    """The same case designed from Python with out=DIR (the CLI's files too)."""
    import socketsmith

    out = tmp_path_factory.mktemp("py_design") / "out"
    return socketsmith.design(demo_case, out=str(out))
