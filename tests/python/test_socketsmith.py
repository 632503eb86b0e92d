"""The Python package against the command line: the same design, the same errors, and the data
as NumPy views. Each comparison runs the real `socketsmith` program (conftest.exe)."""
import json

import numpy as np
import pytest

import socketsmith
from conftest import TARGET_NODES, run_cli


def radar_of(summary):
    return np.array([summary["radar"][k] for k in socketsmith.RADAR_AXES])


def test_design_radar_equals_the_cli_within_1e_9(cli_design, py_design):
    cli_summary, _ = cli_design
    cli = radar_of(cli_summary)
    py = py_design.radar
    assert py.shape == (7,)
    scale = np.maximum(np.abs(cli), 1e-12)
    assert np.all(np.abs(py - cli) / scale <= 1e-9), (py, cli)
    # The summary written from Python is the CLI's design.json, number for number.
    assert radar_of(py_design.summary) == pytest.approx(cli, rel=1e-9, abs=0)
    assert py_design.summary["nodes"] == cli_summary["nodes"]
    assert py_design.constraints_met == cli_summary["constraints_met"]
    assert py_design.max_pressure_ratio == pytest.approx(cli_summary["max_pressure_ratio"], rel=1e-9)


def test_design_without_out_writes_nothing_and_gives_the_same_radar(demo_case, cli_design, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    d = socketsmith.design(demo_case)
    assert d.summary is None
    assert list(tmp_path.iterdir()) == []
    assert d.radar == pytest.approx(radar_of(cli_design[0]), rel=1e-9, abs=0)


def test_pressures_equal_the_cli_surface_nodes_csv(cli_design, py_design):
    _, out = cli_design
    lines = (out / "surface_nodes.csv").read_text().splitlines()
    header = lines[0].split(",")
    rows = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    assert rows.shape[0] == py_design.pressure_pa.shape[0]
    # 12 significant digits in the file.
    np.testing.assert_allclose(py_design.pressure_pa, rows[:, header.index("pressure_pa")], rtol=1e-10, atol=1e-6)
    np.testing.assert_allclose(py_design.skin_positions, rows[:, 0:3], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(py_design.stump.thresholds_pa, rows[:, header.index("threshold_pa")], rtol=1e-10)


def test_fields_are_read_only_views_with_consistent_shapes(py_design):
    d = py_design
    s = d.stump
    n = s.node_positions.shape[0]
    skin = s.skin_nodes.shape[0]
    assert n >= 0.5 * TARGET_NODES
    assert d.node_positions.shape == (n, 3)
    assert s.hexahedra.shape[1] == 8 and s.hexahedra.max() < n
    assert d.pressure_pa.shape == (skin,)
    assert d.skin_positions.shape == (skin, 3)
    assert d.skin_triangles.shape[1] == 3 and d.skin_triangles.max() < skin
    assert d.socket_vertices.shape[1] == 3 and d.socket_triangles.max() < d.socket_vertices.shape[0]
    for a in (d.pressure_pa, d.skin_positions, d.node_positions, s.node_positions, s.hexahedra):
        assert not a.flags.owndata, "a view of the C++ data, not a copy"
        assert not a.flags.writeable
        with pytest.raises(ValueError):
            a[0] = 0
    # A view keeps its owner alive: the data survives the Design object going away.
    p = d.pressure_pa
    assert p.base is not None
    # The deformed skin is the deformed stump at the skin nodes.
    np.testing.assert_array_equal(d.node_positions[s.skin_nodes], d.skin_positions)
    # Pressure is what the design applies: never above the pain threshold.
    assert np.all(d.pressure_pa <= s.thresholds_pa * (1 + 1e-12))
    assert d.pressure_pa.max() > 0


def test_bad_case_raises_the_cli_error_with_its_message(exe, demo_case, tmp_path):
    case = json.loads(json.dumps(demo_case))
    case["patient"]["friction"] = 3
    (tmp_path / "case.json").write_text(json.dumps(case))
    rc, _, err = run_cli(exe, "design", tmp_path / "case.json", "--out", tmp_path / "out")
    with pytest.raises(socketsmith.InvalidInputError) as e:
        socketsmith.design(case)
    assert rc == 1 == e.value.exit_code
    assert "patient.friction = 3 is outside [0, 2]" in str(e.value)
    assert err.strip().splitlines()[-1] == "error: " + str(e.value)
    assert isinstance(e.value, socketsmith.Error) and isinstance(e.value, ValueError)


def test_missing_limb_file_raises_io_error_with_the_cli_message(exe, tmp_path):
    case = {"limb": {"file": str(tmp_path / "no_such_limb.stl"), "units": "mm"}, "mesh": {"target_nodes": 500}}
    (tmp_path / "case.json").write_text(json.dumps(case))
    rc, _, err = run_cli(exe, "design", tmp_path / "case.json", "--out", tmp_path / "out")
    with pytest.raises(socketsmith.IoError) as e:
        socketsmith.design(case)
    assert rc == 2 == e.value.exit_code
    assert err.strip().splitlines()[-1] == "error: " + str(e.value)


def test_unknown_key_names_the_key(demo_case):
    case = json.loads(json.dumps(demo_case))
    case["patient"]["body_mas_kg"] = 70
    with pytest.raises(socketsmith.InvalidInputError, match="unknown key 'body_mas_kg'"):
        socketsmith.normalise_case(case)
    with pytest.raises(socketsmith.InvalidInputError, match="expected a dict"):
        socketsmith.design(42)


def test_progress_callback_is_called_with_fractions_and_stages(demo_case):
    calls = []

    def progress(fraction, stage):
        calls.append((fraction, stage))

    stump = socketsmith.prepare(demo_case, progress=progress)
    n_prepare = len(calls)
    assert n_prepare >= 2
    socketsmith.solve(stump, optimise=False, progress=progress)
    assert len(calls) > n_prepare
    assert all(0.0 <= f <= 1.0 for f, _ in calls)
    assert all(isinstance(s, str) and s for _, s in calls)
    assert any("meshing" in s for _, s in calls)
    assert calls[n_prepare - 1][0] == 1.0 and calls[-1][0] == 1.0


def test_an_exception_in_the_callback_stops_the_work_and_is_raised():
    class Stop(Exception):
        pass

    def progress(fraction, stage):
        if fraction > 0:
            raise Stop(stage)

    with pytest.raises(Stop):
        socketsmith.prepare(socketsmith.demo_case(target_nodes=TARGET_NODES), progress=progress)


def test_read_and_check_a_mesh_as_the_cli_does(exe, tmp_path):
    stl = tmp_path / "limb.stl"
    rc, _, err = run_cli(exe, "limb", "generate", "--type", "transtibial", "--seed", "2", "--out", stl)
    assert rc == 0, err
    rc, out, err = run_cli(exe, "check", "mesh", stl, "--json")
    assert rc == 0, err
    cli = json.loads(out)
    py = socketsmith.check_mesh(str(stl))
    for key in ("vertices", "triangles", "closed", "components", "boundary_loops", "unit", "format"):
        assert py[key] == cli[key], key
    m = socketsmith.read_mesh(str(stl))
    assert m.vertices.shape == (cli["vertices"], 3)
    assert m.triangles.shape == (cli["triangles"], 3)
    np.testing.assert_allclose(np.ptp(m.vertices, axis=0), cli["bounding_box_m"], rtol=1e-12)
    with pytest.raises(socketsmith.IoError, match="cannot open"):
        socketsmith.read_mesh(str(tmp_path / "missing.stl"))


def test_donning_the_designed_socket(py_design):
    don = py_design.don(steps=4, stand=False)
    assert don.nodes.shape == py_design.stump.skin_nodes.shape
    assert don.pressure_pa.shape == don.nodes.shape
    assert don.node_positions.shape == py_design.node_positions.shape
    assert len(don.series) >= 1
    if don.completed:
        assert don.pressure_pa.max() > 0
    else:
        assert don.message


def test_aaop_shape_file_with_its_landmarks_as_the_cli_reads_it(exe):
    import os
    import pathlib

    aop = pathlib.Path(os.environ.get("SOCKETSMITH_SHARED_DATA_DIR", "/nonexistent")) / "aaop" / "example_transtibial.aop"
    if not aop.exists():
        pytest.skip(f"{aop} is not here (../shared/data)")
    rc, out, err = run_cli(exe, "check", "mesh", aop, "--json")
    assert rc == 0, err
    cli = json.loads(out)
    assert socketsmith.check_mesh(str(aop)) == cli
    m = socketsmith.read_mesh(str(aop))
    assert m.format == "aaop" and m.unit == cli["unit"]
    assert "TIB" in m.landmarks
    first_mm = next(lm for lm in cli["landmarks"] if lm["name"] == "TIB")["points_mm"][0]
    np.testing.assert_allclose(m.landmarks["TIB"][0] * 1e3, first_mm, rtol=1e-12)


def test_the_gil_is_released_while_the_cpp_works(demo_case):
    # With a huge switch interval the interpreter never takes the GIL from a thread running Python:
    # the main thread, woken by the first progress call, can only run while the worker is inside
    # C++ with the GIL released. A later progress call then sees it has run. No timing involved.
    import sys
    import threading

    woken = threading.Event()
    main_ran = threading.Event()
    seen_by_worker = []

    def progress(fraction, stage):
        woken.set()
        seen_by_worker.append(main_ran.is_set())

    old = sys.getswitchinterval()
    sys.setswitchinterval(1000.0)
    try:
        worker = threading.Thread(target=lambda: socketsmith.prepare(demo_case, progress=progress))
        worker.start()
        woken.wait()
        main_ran.set()
        worker.join()
    finally:
        sys.setswitchinterval(old)
    assert len(seen_by_worker) >= 2
    assert any(seen_by_worker), "the main thread never ran while prepare() was working"
