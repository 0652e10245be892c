#!/usr/bin/env bash
# Stop the cluster that tests/cluster/slurm_up.sh started: cancel its jobs, then stop
# slurmd, slurmctld and (if slurm_up.sh started it) munged, each by its pid file, and
# remove the /etc/slurm/slurm.conf it wrote.
set -uo pipefail

cluster_dir="${NNMSTOP_SLURM_DIR:-/tmp/nnmstop-slurm}"
conf=/etc/slurm/slurm.conf
marker="# Written by tests/cluster/slurm_up.sh"
ours=false
[[ -f "$conf" ]] && grep -qF "$marker" "$conf" && ours=true

if $ours && [[ -f "$cluster_dir/slurmctld.pid" ]]; then
    # The cluster is private to this machine's check: every job on it is the check's.
    scancel --user="$(id -un)" 2>/dev/null || true
fi

stop_by_pid_file() {
    local name="$1" pid_file="$2" pid
    [[ -f "$pid_file" ]] || return 0
    pid="$(cat "$pid_file")"
    if kill -0 "$pid" 2>/dev/null; then
        kill -TERM "$pid"
        for _ in $(seq 100); do
            kill -0 "$pid" 2>/dev/null || break
            sleep 0.1
        done
        if kill -0 "$pid" 2>/dev/null; then
            echo "slurm_down.sh: $name (pid $pid) ignored SIGTERM for 10 s; sending SIGKILL" >&2
            kill -KILL "$pid" 2>/dev/null || true
        fi
    fi
    rm -f "$pid_file"
    echo "slurm_down.sh: stopped $name"
}

stop_by_pid_file slurmd "$cluster_dir/slurmd.pid"
stop_by_pid_file slurmctld "$cluster_dir/slurmctld.pid"
stop_by_pid_file munged "$cluster_dir/munged.pid"
if $ours; then
    rm -f "$conf"
fi
