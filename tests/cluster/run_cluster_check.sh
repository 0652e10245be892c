#!/usr/bin/env bash
# The cluster check: bring up a single-node SLURM cluster without accounting on this
# machine (root, Debian), run the small configuration through `--profile profiles/slurm`
# and compare every output byte for byte with a local build
# (tests/test_slurm_cluster.py), then stop the cluster, whatever the outcome.
#   bash tests/cluster/run_cluster_check.sh
set -euo pipefail
cd "$(dirname "$0")/../.."

export NNMSTOP_SLURM_DIR="${NNMSTOP_SLURM_DIR:-/tmp/nnmstop-slurm}"
# No skipping here: without a reachable cluster the test fails.
export NNMSTOP_REQUIRE_SLURM=1
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1

trap 'bash tests/cluster/slurm_down.sh' EXIT
SECONDS=0
bash tests/cluster/slurm_up.sh
echo "run_cluster_check.sh: cluster up after ${SECONDS} s"

status=0
# Outer limit in case the test's own timeout (NNMSTOP_SLURM_TIMEOUT, 1200 s) fails to act.
timeout --kill-after=60 2400 python -m pytest -p no:cacheprovider -rA tests/test_slurm_cluster.py || status=$?
if [[ $status -eq 5 ]]; then
    echo "run_cluster_check.sh: pytest collected no test (exit 5): the cluster check did not run" >&2
fi
echo "run_cluster_check.sh: finished after ${SECONDS} s (pytest exit ${status})"
exit $((status == 0 ? 0 : 1))
