#!/usr/bin/env bash
# Bring up a single-node SLURM cluster on this machine, without accounting (as on many
# small clusters), for the cluster check (tests/cluster/run_cluster_check.sh).
#
# Needs root and Debian (apt-get). The configuration goes where every SLURM command
# looks for it, /etc/slurm/slurm.conf (SLURM_CONF would not do: the executor plugin
# removes SLURM_* variables before it calls srun inside a job); a slurm.conf this script
# did not write is never overwritten. State, spool, logs and pid files stay in
# $NNMSTOP_SLURM_DIR (default /tmp/nnmstop-slurm). Stop it with tests/cluster/slurm_down.sh.
set -euo pipefail

cluster_dir="${NNMSTOP_SLURM_DIR:-/tmp/nnmstop-slurm}"
conf=/etc/slurm/slurm.conf
marker="# Written by tests/cluster/slurm_up.sh"
wait_seconds="${NNMSTOP_SLURM_WAIT:-60}"

if [[ "$(id -u)" -ne 0 ]]; then
    echo "slurm_up.sh: must run as root (it installs packages and starts daemons)" >&2
    exit 1
fi

missing=()
for program in slurmctld slurmd sinfo munged; do
    command -v "$program" >/dev/null || missing+=("$program")
done
if ((${#missing[@]})); then
    echo "slurm_up.sh: installing SLURM and MUNGE (missing: ${missing[*]})"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q
    apt-get install -y -q slurmctld slurmd slurm-client munge
fi

if [[ -f "$cluster_dir/slurmctld.pid" ]] && kill -0 "$(cat "$cluster_dir/slurmctld.pid")" 2>/dev/null; then
    echo "slurm_up.sh: a cluster from $cluster_dir is already running; stop it first with slurm_down.sh" >&2
    exit 1
fi
if [[ -e "$conf" ]] && ! grep -qF "$marker" "$conf"; then
    echo "slurm_up.sh: $conf exists and was not written by this script; not overwriting it" >&2
    exit 1
fi
rm -rf "$cluster_dir"
mkdir -p "$cluster_dir/state" "$cluster_dir/spool"

# MUNGE authenticates every SLURM message. Reuse a running munged (for example the
# system service); otherwise start one whose pid file we own and slurm_down.sh stops.
if munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1; then
    echo "slurm_up.sh: using the munged already running"
else
    install -d -o munge -g munge -m 0755 /run/munge
    install -d -o munge -g munge -m 0700 /var/lib/munge /var/log/munge
    if [[ ! -s /etc/munge/munge.key ]]; then
        mungekey --create --keyfile=/etc/munge/munge.key
    fi
    chown munge:munge /etc/munge/munge.key
    chmod 0400 /etc/munge/munge.key
    runuser -u munge -- munged --pid-file=/run/munge/munged.pid
    for _ in $(seq 50); do
        munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1 && break
        sleep 0.1
    done
    cp /run/munge/munged.pid "$cluster_dir/munged.pid"
fi

# The node as slurmd sees it (CPUs, sockets, cores, threads, memory). If the CPUs we may
# use (nproc: affinity, cgroup) differ from the hardware's, give SLURM nproc CPUs.
host="$(hostname -s)"
cpus="$(env -u OMP_NUM_THREADS -u OMP_THREAD_LIMIT nproc)"  # nproc honours these; the check sets one
hardware="$(slurmd -C | head -n 1)"
memory="$(sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' <<<"$hardware")"
hardware_cpus="$(sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' <<<"$hardware")"
if [[ "$hardware_cpus" == "$cpus" ]]; then
    node_layout="$(sed -e 's/^NodeName=[^ ]* //' -e 's/ *UpTime=.*$//' <<<"$hardware")"
else
    node_layout="CPUs=$cpus RealMemory=$memory"
fi

mkdir -p "$(dirname "$conf")"
cat >"$conf" <<EOF
$marker: one node, no accounting database.
ClusterName=nnmstop
SlurmctldHost=$host(127.0.0.1)
AuthType=auth/munge
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$cluster_dir/state
SlurmdSpoolDir=$cluster_dir/spool
SlurmctldPidFile=$cluster_dir/slurmctld.pid
SlurmdPidFile=$cluster_dir/slurmd.pid
SlurmctldLogFile=$cluster_dir/slurmctld.log
SlurmdLogFile=$cluster_dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
ReturnToService=2
MinJobAge=300
NodeName=$host NodeAddr=127.0.0.1 $node_layout State=UNKNOWN
PartitionName=main Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF

slurmctld
slurmd

state=""
for _ in $(seq "$wait_seconds"); do
    state="$(sinfo --noheader --format=%T 2>/dev/null || true)"
    [[ "$state" == "idle" ]] && break
    sleep 1
done
if [[ "$state" != "idle" ]]; then
    echo "slurm_up.sh: node not idle after ${wait_seconds} s (sinfo: '${state}'); logs in $cluster_dir" >&2
    tail -n 20 "$cluster_dir/slurmctld.log" "$cluster_dir/slurmd.log" >&2 || true
    exit 1
fi
echo "slurm_up.sh: node $host idle ($node_layout), partition main"
