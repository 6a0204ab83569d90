#!/usr/bin/env bash
# A single-node Slurm cluster on this machine, for trying scripts/slurm/sweep.sbatch
# without a real cluster (and for scripts/slurm/prove.sh, which uses it).
#
#   scripts/slurm/local-cluster.sh start DIR   installs slurm-wlm and munge if missing (apt,
#                                              as root), writes DIR/slurm.conf for this host
#                                              (every core one CPU of partition "local"),
#                                              starts munged, slurmctld and slurmd, and waits
#                                              until the node is idle
#   scripts/slurm/local-cluster.sh stop DIR    stops the daemons started from DIR
#
# After `start`, point the clients at the configuration: export SLURM_CONF=DIR/slurm.conf.
# Everything the daemons write (state, spool, logs, pid files) stays under DIR. The daemons
# run as root with no cgroups (proctrack/linuxproc, task/none), which suits a container or
# a workstation; a real cluster has its own configuration and needs none of this.
set -euo pipefail

usage() { echo "usage: $0 start|stop DIR" >&2; exit 2; }
[[ $# -eq 2 ]] || usage
action=$1
mkdir -p "$2"
dir=$(cd "$2" && pwd)

stop() {
    for pidfile in "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munged.pid"; do
        if [[ -f "$pidfile" ]]; then
            pid=$(cat "$pidfile")
            kill "$pid" 2>/dev/null || true
            for _ in $(seq 1 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
            rm -f "$pidfile"
        fi
    done
}

case "$action" in
stop) stop; exit 0 ;;
start) ;;
*) usage ;;
esac

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    [[ $(id -u) -eq 0 ]] || { echo "local-cluster: slurm-wlm and munge are missing; run as root to install them" >&2; exit 2; }
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
fi
[[ $(id -u) -eq 0 ]] || { echo "local-cluster: start the daemons as root" >&2; exit 2; }

host=$(hostname -s)
cpus=$(nproc)
memory_mb=$(awk '/MemTotal/ { print int($2 / 1024 * 0.9) }' /proc/meminfo)
mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
cat > "$dir/slurm.conf" <<CONF
ClusterName=tessref-local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
SlurmctldPort=16817
SlurmdPort=16818
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
NodeName=$host CPUs=$cpus RealMemory=$memory_mb State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF

# munge: a key of this cluster's own, the daemon's socket and pid under DIR.
if [[ ! -f "$dir/munge/munge.key" ]]; then
    dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
    chmod 400 "$dir/munge/munge.key"
fi
stop
# Slurm's munge plugin talks to the default socket, so munged serves it there.
mkdir -p /run/munge
munged --key-file="$dir/munge/munge.key" --pid-file="$dir/munged.pid" --log-file="$dir/munged.log" \
       --seed-file="$dir/munge/munge.seed" --force
export SLURM_CONF="$dir/slurm.conf"
slurmctld -f "$dir/slurm.conf"
slurmd -f "$dir/slurm.conf"
for _ in $(seq 1 60); do
    if sinfo -h -o '%t' 2>/dev/null | grep -q '^idle'; then
        echo "local-cluster: node $host idle ($cpus CPUs); export SLURM_CONF=$dir/slurm.conf"
        exit 0
    fi
    sleep 1
done
echo "local-cluster: the node did not become idle within 60 s; see $dir/slurmctld.log and $dir/slurmd.log" >&2
exit 1
