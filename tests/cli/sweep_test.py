#!/usr/bin/env python3
"""`socketsmith sweep` end to end (CTest cli.sweep): a 5-case sweep — a 2 × 2 grid of body masses
and generated limbs plus one deliberately broken case — runs with 2 workers, collects into one CSV
with a row per case, the broken case a failed row with its message; a rerun does no work; --slurm
writes a job array of the unfinished cases and says in one line that sbatch is missing.

Usage: sweep_test.py SOCKETSMITH_EXE WORK_DIR   (standard library only)
"""
import csv
import json
import os
import pathlib
import shutil
import subprocess
import sys

exe = sys.argv[1]
work = pathlib.Path(sys.argv[2]).resolve()
shutil.rmtree(work, ignore_errors=True)
work.mkdir(parents=True)
failures = []


def check(condition, what):
    if not condition:
        failures.append(what)
        print("FAILED:", what, file=sys.stderr)


def run(*args, env=None):
    p = subprocess.run([exe, *map(str, args)], capture_output=True, text=True, env=env)
    return p.returncode, p.stdout, p.stderr


sweep = {
    "socketsmith_sweep": 1,
    "name": "cli test",
    # The open-loop design: the sweep's mechanics are tested here, not the closed loop.
    "base_case": {"mesh": {"target_nodes": 1000}, "socket": {"subdivisions": 0}, "design": {"closed_loop": False}},
    "grid": {"body_mass_kg": [60, 75], "seeds": [1, 2]},
    # Broken on purpose: out of the body mass range; it must become a failed row, not a failed sweep.
    "cases": [{"body_mass_kg": 500}],
    "slurm": {"time": "00:15:00", "cpus_per_task": 2, "mem_mb": 1500},
}
(work / "sweep.json").write_text(json.dumps(sweep))
out = work / "out"

# 1. Run with 2 workers.
rc, stdout, err = run("sweep", work / "sweep.json", "--out", out, "--workers", 2, "--json")
check(rc == 0, f"the sweep exits 0 even with a broken case (rc {rc}: {err[-400:]})")
counts = json.loads(stdout) if rc == 0 else {}
check(counts.get("cases") == 5 and counts.get("ran") == 5 and counts.get("skipped") == 0, f"5 cases run: {counts}")
check(counts.get("failed", 0) >= 1, f"the broken case counted as failed: {counts}")
manifest = json.loads((out / "manifest.json").read_text())
ids = [c["id"] for c in manifest["cases"]]
check(ids == ["c0000", "c0001", "c0002", "c0003", "c0004"], f"case ids {ids}")
for i in ids:
    check((out / "cases" / i / "done.json").exists(), f"{i} has its done marker")
broken = json.loads((out / "cases" / "c0004" / "done.json").read_text())
check(broken["status"] == "failed" and broken["exit_code"] == 1, f"c0004 failed with exit code 1: {broken}")
check("patient.body_mass_kg = 500 kg is outside" in broken["message"], f"c0004's message names the key: {broken}")

# 2. Collect.
rc, stdout, err = run("sweep", "collect", out, "--json")
check(rc == 0, f"collect exits 0 ({err[-400:]})")
with open(out / "results.csv", newline="") as f:
    rows = list(csv.DictReader(f))
check(len(rows) == 5, f"results.csv has 5 rows, not {len(rows)}")
by_id = {r["id"]: r for r in rows}
b = by_id.get("c0004", {})
check(b.get("status") == "failed" and "patient.body_mass_kg = 500 kg is outside" in b.get("message", ""),
      f"the broken case is a failed row with its message: {b}")
for i in ids[:4]:
    r = by_id.get(i, {})
    check(r.get("status") in ("ok", "unmet"), f"{i} ran to a design: {r.get('status')} {r.get('message')}")
    design = json.loads((out / "cases" / i / "out" / "design.json").read_text())
    check(float(r["fz_n"]) == float(f"{design['radar']['fz_n']:.10g}"), f"{i}: fz_n is design.json's")
    check(float(r["target_fz_n"]) > 0 and r["design_seconds"] != "", f"{i}: target and timing present")
    check(r["body_mass_kg"] in ("60", "75") and r["seed"] in ("1", "2"), f"{i}: its parameters {r}")
    check("delivery_bar_met" in r and r["closed_loop_mae_kpa"] == "" and r["closed_loop_converged"] == ""
          and r["closed_loop_retried_donnings"] == "" and r["closed_loop_drag_band_kept"] == "",
          f"{i}: closed-loop columns, empty without a loop")
    if r.get("status") == "ok":
        check(float(r["cavity_volume_cm3"]) > 0, f"{i}: a socket cavity volume")
# Heavier patients need more axial force: the design's Fz target is M g / 2.
check(abs(float(by_id["c0000"]["target_fz_n"]) - 60 * 9.80665 / 2) < 1e-6, "c0000's Fz target is 60 kg g / 2")
png = (out / "summary.png").read_bytes()
check(png[:8] == b"\x89PNG\r\n\x1a\n", "summary.png is a PNG")
check("<svg" in (out / "summary.svg").read_text(), "summary.svg is an SVG")


# 3. A rerun does no work: nothing runs, no marker, log or the manifest is rewritten.
def stamps_of_the_sweep():
    return {p: p.stat().st_mtime_ns for p in [out / "manifest.json", *out.glob("cases/*/*")] if p.is_file()}


stamps = stamps_of_the_sweep()
rc, stdout, err = run("sweep", work / "sweep.json", "--out", out, "--workers", 2, "--json")
again = json.loads(stdout) if rc == 0 else {}
check(rc == 0 and again.get("ran") == 0 and again.get("skipped") == 5, f"a rerun skips every case: {again}")
check(stamps == stamps_of_the_sweep(), "a rerun leaves the manifest and every case file untouched")

# 4. --slurm without sbatch on the PATH: the array script of the unfinished cases, one line said.
empty_path = work / "empty_path"
empty_path.mkdir()
env = dict(os.environ, PATH=str(empty_path))
rc, stdout, err = run("sweep", work / "sweep.json", "--out", work / "slurm_out", "--slurm", env=env)
check(rc == 0, f"--slurm without sbatch exits 0 ({err[-400:]})")
check(sum("sbatch not found" in line for line in err.splitlines()) == 1, f"one line says sbatch is missing: {err}")
script = (work / "slurm_out" / "slurm" / "sweep.sbatch").read_text()
for line in ("#SBATCH --array=0-4", "#SBATCH --cpus-per-task=2", "#SBATCH --mem=1500M", "#SBATCH --time=00:15:00",
             "sweep case"):
    check(line in script, f"the job script has '{line}'")
rc, stdout, err = run("sweep", work / "sweep.json", "--out", out, "--slurm", env=env)
check(rc == 0 and "nothing to submit" in err, f"a finished sweep has nothing to submit: {err}")

# 5. Bad input: one line naming the problem and the fix.
(work / "bad.json").write_text(json.dumps({"grid": {"mass": [70]}}))
rc, stdout, err = run("sweep", work / "bad.json", "--out", work / "bad_out")
check(rc == 1 and err.strip().splitlines()[-1].startswith("error: sweep file: unknown axis 'mass'"),
      f"an unknown axis: exit 1 and one line ({rc}: {err})")
rc, stdout, err = run("sweep", "collect", work / "no_such_sweep")
check(rc == 1 and "holds no sweep" in err, f"collect of a folder without a sweep ({rc}: {err})")
other = dict(sweep, grid={"body_mass_kg": [61]})
(work / "other.json").write_text(json.dumps(other))
rc, stdout, err = run("sweep", work / "other.json", "--out", out)
check(rc == 1 and "holds another sweep" in err, f"another sweep into the same folder is refused ({rc}: {err})")

if failures:
    print(f"{len(failures)} check(s) failed", file=sys.stderr)
    sys.exit(1)
print("sweep: all checks passed")
