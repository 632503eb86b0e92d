#!/usr/bin/env python3
"""`socketsmith sweep --slurm` on a real Slurm (CTest cli.sweep_slurm, label slow): starts a
private single-node cluster with scripts/slurm_local.sh (munged, slurmctld, slurmd on 127.0.0.1),
submits a 5-case sweep (2 masses × 2 seeds and one broken case) as a job array through the CLI,
waits for the array to leave the queue, collects, and checks the table; a second --slurm has
nothing to submit. Skips (exit 77) without root or without Slurm.

Usage: sweep_slurm_test.py SOCKETSMITH_EXE SLURM_LOCAL_SH WORK_DIR   (standard library only)
"""
import csv
import json
import os
import pathlib
import shutil
import subprocess
import sys
import time

exe, slurm_local, work = sys.argv[1], sys.argv[2], pathlib.Path(sys.argv[3]).resolve()
if os.geteuid() != 0:
    print("skipped: slurmd must run as root to start jobs")
    sys.exit(77)
if not shutil.which("sbatch") or not (shutil.which("slurmd") or os.path.exists("/usr/sbin/slurmd")):
    print("skipped: Slurm is not installed (scripts/setup.sh --slurm)")
    sys.exit(77)

shutil.rmtree(work, ignore_errors=True)
work.mkdir(parents=True)
state = work / "slurm"
failures = []


def check(condition, what):
    if not condition:
        failures.append(what)
        print("FAILED:", what, file=sys.stderr)


start = subprocess.run([slurm_local, "start", state], capture_output=True, text=True)
if start.returncode != 0:
    print(start.stdout, start.stderr, file=sys.stderr)
    subprocess.run([slurm_local, "stop", state])
    sys.exit(1)
env = dict(os.environ, SLURM_CONF=str(state / "slurm.conf"))
try:
    sweep = {
        "name": "slurm test",
        "base_case": {"mesh": {"target_nodes": 1000}, "socket": {"subdivisions": 0}},
        "grid": {"body_mass_kg": [60, 75], "seeds": [1, 2]},
        "cases": [{"body_mass_kg": 500}],
        "slurm": {"time": "00:10:00", "cpus_per_task": 1, "mem_mb": 1000},
    }
    (work / "sweep.json").write_text(json.dumps(sweep))
    out = work / "out"
    p = subprocess.run([exe, "sweep", work / "sweep.json", "--out", out, "--slurm", "--json"], capture_output=True,
                       text=True, env=env)
    check(p.returncode == 0, f"--slurm submits (rc {p.returncode}: {p.stderr[-500:]})")
    job = json.loads(p.stdout)["job"] if p.returncode == 0 else ""
    check(job.isdigit() and json.loads(p.stdout)["tasks"] == 5, f"a job array of 5 tasks: {p.stdout}")
    # Wait for the array to leave the queue (CTest's timeout bounds the test).
    while job:
        q = subprocess.run(["squeue", "-h", "-j", job], capture_output=True, text=True, env=env)
        if q.returncode != 0 or not q.stdout.strip():
            break
        time.sleep(1)
    p = subprocess.run([exe, "sweep", "collect", out, "--json"], capture_output=True, text=True, env=env)
    check(p.returncode == 0, f"collect ({p.stderr[-500:]})")
    with open(out / "results.csv", newline="") as f:
        rows = {r["id"]: r for r in csv.DictReader(f)}
    check(len(rows) == 5, f"5 rows, not {len(rows)}")
    for i in ("c0000", "c0001", "c0002", "c0003"):
        r = rows.get(i, {})
        check(r.get("status") == "ok" and float(r.get("fz_n") or 0) > 0, f"{i} designed on the cluster: {r}")
    b = rows.get("c0004", {})
    check(b.get("status") == "failed" and "patient.body_mass_kg = 500 kg is outside" in b.get("message", ""),
          f"the broken case is a failed row with its message: {b}")
    logs = list((out / "slurm").glob(f"{job}_*.out"))
    check(len(logs) == 5, f"one Slurm log per task: {logs}")
    p = subprocess.run([exe, "sweep", work / "sweep.json", "--out", out, "--slurm"], capture_output=True, text=True,
                       env=env)
    check(p.returncode == 0 and "nothing to submit" in p.stderr, f"a finished sweep submits nothing: {p.stderr}")
finally:
    subprocess.run([slurm_local, "stop", state])

if failures:
    print(f"{len(failures)} check(s) failed", file=sys.stderr)
    sys.exit(1)
print("sweep on Slurm: all checks passed")
