"""socketsmith.validate: the CalculiX check of `socketsmith validate design` from Python.

One tiny case (the demo at 600 nodes, the fe tissue model, design.follow_template false) checked in
load mode with a small-strain CalculiX step: the designed pressures as nodal loads, no socket. With
the fe model socketsmith solves CalculiX's own problem (same C3D8 element, same material, linear),
so the two displacement fields must agree to round-off (docs/validation_fe.md: R 1.0000 at 3k
nodes) and the bones must carry every designed load — an independent check, not a tautology.
The metrics come back as the CLI's summary.json and must be the statistics of the returned fields.
About 8 s with the real ccx (and as long again for the CLI's run of the same case).
"""
import json
import shutil

import numpy as np
import pytest

import socketsmith
from conftest import run_cli

CCX = shutil.which("ccx")
needs_ccx = pytest.mark.skipif(CCX is None, reason="CalculiX's ccx is not on the PATH (apt-get install calculix-ccx)")


def tiny_fe_case():
    case = socketsmith.demo_case(target_nodes=600)
    case["tissue"]["model"] = "fe"
    case.setdefault("design", {})["follow_template"] = False
    case["design"]["closed_loop"] = False  # the designed loads are what CalculiX gets in mode "load"
    return case


@pytest.fixture(scope="module")
def load_check(tmp_path_factory):
    out = tmp_path_factory.mktemp("validate") / "load"
    stages = []
    v = socketsmith.validate(tiny_fe_case(), str(out), mode="load", small_strain=True,
                             progress=lambda f, s: stages.append((f, s)))
    return v, out, stages


@needs_ccx
def test_the_fe_models_design_deforms_calculixs_stump_alike(load_check):
    v, out, _ = load_check
    assert v.converged, v.message
    assert v.mode == "load" and v.unit == "m"
    s = v.summary
    assert s["nlgeom"] is False and s["compared"] == "displacement [mm]"
    # Same element, same material, same linear problem: the fields agree to round-off.
    assert s["all"]["count"] > 100
    assert s["all"]["r"] > 0.999
    assert s["all"]["mae_mm"] < 0.01 * s["all"]["mean_b_mm"]
    # Every designed load reached CalculiX's stump and its bones carry it.
    assert s["fe_force_n"] == pytest.approx(s["designed_force_n"], rel=0.01)
    assert s["designed_force_n"] > 10
    for name in ("front", "back", "mid"):
        assert s["paths"][name]["count"] > 5 and s["paths"][name]["r"] > 0.99, name


@needs_ccx
def test_the_metrics_are_the_statistics_of_the_returned_fields(load_check):
    v, out, _ = load_check
    s = v.summary
    ours, fe, ring = v.socketsmith_values, v.calculix_values, v.rings_from_brim
    n = len(v.skin_nodes)
    assert ours.shape == fe.shape == ring.shape == (n,)
    assert v.calculix_displacement_m.shape == (len(v.design.stump.node_positions), 3)
    # 'all' is every socket node (ring >= 1), CalculiX as a, socketsmith as b, in mm.
    m = ring >= 1
    err = np.abs(fe[m] - ours[m]) * 1e3
    assert m.sum() == s["all"]["count"]
    assert err.mean() == pytest.approx(s["all"]["mae_mm"], rel=1e-9)
    assert fe[m].mean() * 1e3 == pytest.approx(s["all"]["mean_a_mm"], rel=1e-9)
    assert ours[m].mean() * 1e3 == pytest.approx(s["all"]["mean_b_mm"], rel=1e-9)
    assert np.corrcoef(fe[m], ours[m])[0, 1] == pytest.approx(s["all"]["r"], rel=1e-9)
    # p95 is the nearest-rank percentile of |a - b|.
    k = int(np.ceil(0.95 * m.sum())) - 1
    assert np.sort(err)[k] == pytest.approx(s["all"]["p95_mm"], rel=1e-9)
    # Socketsmith's side is the design's own displacement at the skin nodes.
    d = v.design
    u = np.linalg.norm(d.node_positions[v.skin_nodes] - d.stump.node_positions[v.skin_nodes], axis=1)
    assert np.allclose(ours, u, rtol=1e-9, atol=1e-12)
    # A path's statistics from its skin nodes.
    front = v.paths["front"]
    idx = np.asarray(front["skin_index"])
    assert len(front["s"]) == len(idx) == s["paths"]["front"]["count"]
    assert np.abs(fe[idx] - ours[idx]).mean() * 1e3 == pytest.approx(s["paths"]["front"]["mae_mm"], rel=1e-9)
    # Views, not copies: read-only, kept alive by the Validation.
    assert not fe.flags.writeable and not ours.flags.writeable
    # The files of the CLI's command, summary.json the dict returned.
    assert json.loads((out / "summary.json").read_text()) == s
    for f in ("comparison.csv", "design_fe.inp", "stump_fe.vtu", "case.json", "design/design.json"):
        assert (out / f).exists(), f


@needs_ccx
def test_progress_covers_the_design_and_calculix(load_check):
    _, _, stages = load_check
    fractions = [f for f, _ in stages]
    assert fractions == sorted(fractions) and 0 <= fractions[0] and fractions[-1] <= 1
    assert any(s.startswith("design") for _, s in stages)


@needs_ccx
def test_the_cli_runs_the_same_validation(exe, load_check, tmp_path):
    """`socketsmith validate design CASE --mode load --small-strain --json`: the same numbers."""
    v, _, _ = load_check
    (tmp_path / "case.json").write_text(json.dumps(tiny_fe_case()))
    rc, stdout, err = run_cli(exe, "validate", "design", tmp_path / "case.json", "--mode", "load", "--small-strain",
                              "--json", "--out", tmp_path / "out")
    assert rc == 0, err
    cli = json.loads(stdout)
    for region in ("all", "away_from_brim"):
        for key in ("count", "mae_mm", "r", "p95_mm", "p99_mm", "mean_a_mm", "mean_b_mm"):
            assert cli[region][key] == pytest.approx(v.summary[region][key], rel=1e-9), (region, key)
    assert cli["fe_force_n"] == pytest.approx(v.summary["fe_force_n"], rel=1e-9)


def test_a_missing_ccx_is_refused_before_the_design(tmp_path):
    with pytest.raises(socketsmith.InvalidInputError, match="is not found or not executable: install CalculiX") as e:
        socketsmith.validate(tiny_fe_case(), str(tmp_path / "out"), ccx="/nonexistent/ccx")
    assert e.value.exit_code == 1
    assert not (tmp_path / "out" / "design").exists()


def test_inconsistent_options_get_the_clis_line(tmp_path):
    with pytest.raises(socketsmith.InvalidInputError, match="against-donning needs --mode donning"):
        socketsmith.validate(tiny_fe_case(), str(tmp_path / "out"), against_donning=True)
