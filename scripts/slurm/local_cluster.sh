#!/usr/bin/env bash
# A one-node Slurm cluster on this machine (Debian's slurm-wlm and munge, installed by
# scripts/setup.sh), for trying scripts/slurm/ and for the tests. No systemd: munged, slurmctld
# and slurmd are started directly, as root, with a generated slurm.conf, munge key, state,
# spool, logs and pid files all in DIR; node "localhost" with 2 CPUs, partition "debug".
#
#   scripts/slurm/local_cluster.sh start DIR   # then: export SLURM_CONF=DIR/slurm.conf
#   scripts/slurm/local_cluster.sh stop DIR    # stops exactly the daemons started in DIR
#
# Needs root (slurmd launches jobs as their users); as another user it re-runs itself with sudo.
set -euo pipefail

cmd="${1:-}" dir="${2:-}"
if [[ "$cmd" != start && "$cmd" != stop ]] || [ -z "$dir" ]; then
  echo "usage: $0 start|stop DIR" >&2
  exit 2
fi
if [ "$(id -u)" -ne 0 ]; then exec sudo -n "$0" "$@"; fi
mkdir -p "$dir"
dir="$(cd "$dir" && pwd)"

stop_pidfile() {  # the daemon whose pid is in $1, if it is still running: TERM, then KILL
  local f="$1" pid
  [ -f "$f" ] || return 0
  pid="$(cat "$f")"
  if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
    kill "$pid" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
  fi
  rm -f "$f"
}

if [ "$cmd" = stop ]; then
  stop_pidfile "$dir/slurmd.pid"
  stop_pidfile "$dir/slurmctld.pid"
  stop_pidfile "$dir/munged.pid"
  echo "local slurm cluster in $dir stopped"
  exit 0
fi

for tool in munged mungekey slurmctld slurmd sinfo; do
  command -v "$tool" >/dev/null || { echo "local_cluster: '$tool' not found: run scripts/setup.sh (slurm-wlm, munge)" >&2; exit 1; }
done
chmod 755 "$dir"  # jobs of other users reach the munge socket in it
mkdir -p "$dir/state" "$dir/spool"

# munge: a fresh key, its own socket (the system's munged, if any, is left alone).
[ -f "$dir/munge.key" ] || mungekey --create --keyfile="$dir/munge.key"
chmod 600 "$dir/munge.key"
munged --socket="$dir/munge.socket" --key-file="$dir/munge.key" --pid-file="$dir/munged.pid" \
  --log-file="$dir/munged.log" --seed-file="$dir/munged.seed" --force

# Ports from the directory name, so two clusters on one machine do not collide.
port=$((20000 + $(printf '%s' "$dir" | cksum | cut -d' ' -f1) % 20000))
cat > "$dir/slurm.conf" <<CONF
ClusterName=gradphoton-local
SlurmctldHost=localhost
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge.socket
CredType=cred/munge
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
MpiDefault=none
ReturnToService=2
MinJobAge=600
NodeName=localhost NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$dir/slurm.conf"
slurmctld -c -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF" -N localhost
for _ in $(seq 150); do  # up to 30 s for the node to register idle
  if sinfo -h -n localhost -o '%t' 2>/dev/null | grep -q '^idle'; then
    echo "local slurm cluster up in $dir"
    echo "export SLURM_CONF=$SLURM_CONF"
    exit 0
  fi
  sleep 0.2
done
echo "local_cluster: the node did not come up; logs in $dir:" >&2
tail -n 20 "$dir/slurmctld.log" "$dir/slurmd.log" "$dir/munged.log" >&2 || true
exit 1
