#!/usr/bin/env bash
# A private single-node Slurm on this machine, for testing `socketsmith sweep --slurm` (docs/sweep.md):
# munged, slurmctld and slurmd on 127.0.0.1, every file (configuration, munge key and socket,
# state, logs, pid files) under STATE_DIR, its own ports, so it touches no system Slurm or munge.
#
#   scripts/slurm_local.sh start STATE_DIR   # prints `export SLURM_CONF=STATE_DIR/slurm.conf`
#   scripts/slurm_local.sh stop STATE_DIR    # stops the daemons it started (by their pid files)
#
# Needs Debian's slurmctld, slurmd, slurm-client and munge (scripts/setup.sh --slurm) and root
# (slurmd runs jobs as their user). Ports: SOCKETSMITH_SLURM_PORT (slurmctld, default 16817) and
# the next one (slurmd).
set -euo pipefail

cmd=${1:-}
dir=${2:-}
if [ -z "$cmd" ] || [ -z "$dir" ]; then
  echo "usage: scripts/slurm_local.sh start|stop STATE_DIR" >&2
  exit 1
fi
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)

stop_pidfile() {  # the daemon of one pid file, if it is still running
  local f=$1
  if [ -f "$f" ]; then
    local pid
    pid=$(cat "$f")
    if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
      kill "$pid" 2>/dev/null || true
      for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
      kill -9 "$pid" 2>/dev/null || true
    fi
    rm -f "$f"
  fi
}

if [ "$cmd" = stop ]; then
  stop_pidfile "$dir/slurmd.pid"
  stop_pidfile "$dir/slurmctld.pid"
  stop_pidfile "$dir/munge/munged.pid"
  exit 0
fi
if [ "$cmd" != start ]; then
  echo "slurm_local: unknown command '$cmd' (start or stop)" >&2
  exit 1
fi

for p in munged mungekey slurmctld slurmd sbatch; do
  if ! command -v "$p" > /dev/null 2>&1 && [ ! -x "/usr/sbin/$p" ]; then
    echo "slurm_local: $p not found: install Slurm and munge with scripts/setup.sh --slurm" >&2
    exit 1
  fi
done
if [ "$(id -u)" -ne 0 ]; then
  echo "slurm_local: slurmd must run as root to start jobs: run as root (or under sudo)" >&2
  exit 1
fi
PATH=$PATH:/usr/sbin

port=${SOCKETSMITH_SLURM_PORT:-16817}
host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(awk '/MemTotal/ {print int($2 / 1024 / 2)}' /proc/meminfo)  # half the machine

mkdir -p "$dir/munge" "$dir/state" "$dir/spool"
chmod 700 "$dir/munge"
if [ ! -f "$dir/munge/munge.key" ]; then mungekey --create --keyfile="$dir/munge/munge.key"; fi
chmod 600 "$dir/munge/munge.key"
stop_pidfile "$dir/slurmd.pid"
stop_pidfile "$dir/slurmctld.pid"
stop_pidfile "$dir/munge/munged.pid"
# munged refuses root and loose permissions without --force; everything here is private to $dir.
munged --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.socket" \
  --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" --seed-file="$dir/munge/munged.seed"

cat > "$dir/slurm.conf" <<EOF
# Written by scripts/slurm_local.sh: a private single-node cluster for tests.
ClusterName=socketsmith-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$dir/slurm.conf
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
# Ready when the node is idle (or mixed/allocated by someone's job).
for _ in $(seq 100); do
  state=$(sinfo -h -N -o '%T' 2>/dev/null | head -1 || true)
  case "$state" in idle*|mixed*|allocated*) echo "export SLURM_CONF=$SLURM_CONF"; exit 0 ;; esac
  sleep 0.2
done
echo "slurm_local: the node did not come up (state '${state:-none}'): see $dir/slurmctld.log and $dir/slurmd.log" >&2
exit 1
