"""The workflow through a real SLURM scheduler gives the same bytes as a local build.

Runs the small configuration (tests/data/small_config.yaml: the default target and its small atlas) with
``--profile profiles/slurm`` on whatever cluster ``sinfo`` reaches, then locally, and compares every dataset
and figure byte for byte. The cluster check (tests/cluster/run_cluster_check.sh, see README) brings up
a single-node cluster without accounting on this machine and runs this test; elsewhere the
test is skipped when no SLURM cluster answers, unless NNMSTOP_REQUIRE_SLURM=1 (set by the
cluster check) turns that into a failure.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from snakemake_cli import snakemake_command as cli_command

REPO = Path(__file__).resolve().parents[1]
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"
PROFILE = REPO / "profiles" / "slurm"
# Hard limit on the SLURM run. The small configuration takes about a minute locally on
# 2 cores; through the scheduler each job adds submission, start-up and status polling.
SLURM_RUN_TIMEOUT_SECONDS = int(os.environ.get("NNMSTOP_SLURM_TIMEOUT", "1200"))


def no_cluster(reason: str):
    """Skip, or fail when the caller asked for a real cluster (NNMSTOP_REQUIRE_SLURM=1)."""
    if os.environ.get("NNMSTOP_REQUIRE_SLURM") == "1":
        pytest.fail(f"NNMSTOP_REQUIRE_SLURM=1 but {reason}")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def cluster_partition() -> str:
    """The default partition of the reachable SLURM cluster, with an idle or mixed node."""
    if shutil.which("sinfo") is None:
        no_cluster(
            "sinfo not found: no SLURM client here (run the cluster check: bash tests/cluster/run_cluster_check.sh)"
        )
    try:
        answer = subprocess.run(["sinfo", "--noheader", "--format=%P %T"], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        no_cluster("sinfo did not answer within 60 s")
    if answer.returncode != 0:
        last_line = (answer.stderr.strip().splitlines() or ["(no message)"])[-1]
        no_cluster(f"sinfo reaches no SLURM controller: {last_line}")
    usable = [
        line.split()[0]
        for line in answer.stdout.splitlines()
        if line.split()[0].endswith("*") and line.split()[1] in ("idle", "mixed")
    ]
    if not usable:
        no_cluster(f"no idle or mixed node in the default partition; sinfo says: {answer.stdout.strip()!r}")
    return usable[0].rstrip("*")


def snakemake_command(workdir: Path, *args: str) -> list[str]:
    return cli_command(workdir, SMALL_CONFIG, *args)


def run_under_timeout(cmd: list[str], timeout: float) -> subprocess.CompletedProcess:
    """Run ``cmd``; past ``timeout`` interrupt it (Snakemake then cancels its SLURM jobs) and fail."""
    process = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        output, _ = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        # SIGINT, as Ctrl-C: Snakemake's SLURM executor cancels the jobs it submitted.
        os.killpg(process.pid, signal.SIGINT)
        try:
            output, _ = process.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            output, _ = process.communicate()
        pytest.fail(f"{' '.join(cmd)} still running after {timeout:.0f} s; interrupted:\n{output[-4000:]}")
    return subprocess.CompletedProcess(cmd, process.returncode, output, "")


def outputs(workdir: Path) -> dict[str, bytes]:
    """Every file of results/ and paper_figures/, by path relative to the work directory."""
    return {
        str(p.relative_to(workdir)): p.read_bytes()
        for d in ("results", "paper_figures")
        for p in sorted((workdir / d).rglob("*"))
        if p.is_file()
    }


def test_slurm_build_is_byte_identical_to_local_build(cluster_partition, tmp_path):
    on_cluster = tmp_path / "slurm"
    start = time.monotonic()
    # the default target and the small atlas (one job per slice and per kind of curve, tests/data/small_config.yaml)
    run = run_under_timeout(
        snakemake_command(on_cluster, "--profile", str(PROFILE), "all", "atlas"), SLURM_RUN_TIMEOUT_SECONDS
    )
    slurm_seconds = time.monotonic() - start
    assert run.returncode == 0, f"SLURM run failed:\n{run.stdout[-6000:]}"
    # every job went through the scheduler (none ran as a local rule)
    assert "has been submitted with SLURM jobid" in run.stdout
    # only the targets' own rules (no output, nothing computed) run locally
    ran_locally = set(re.findall(r"localrule (\w+):", run.stdout))
    assert ran_locally <= {"all", "atlas"}, ran_locally

    local = tmp_path / "local"
    start = time.monotonic()
    build = subprocess.run(
        snakemake_command(local, "--cores", "2", "all", "atlas"), capture_output=True, text=True, timeout=900
    )
    local_seconds = time.monotonic() - start
    assert build.returncode == 0, f"local run failed:\n{build.stdout[-3000:]}\n{build.stderr[-3000:]}"

    expected, produced = outputs(local), outputs(on_cluster)
    assert len(expected) >= 30
    assert sorted(produced) == sorted(expected)
    differing = [path for path in expected if produced[path] != expected[path]]
    assert not differing, f"differ between the SLURM and the local build: {differing}"
    assert any(path.startswith("results/atlas/") for path in expected), "the small atlas was not built"
    print(
        f"\nSLURM run ({cluster_partition}): {slurm_seconds:.0f} s; local run (--cores 2): {local_seconds:.0f} s; "
        f"{len(expected)} files byte-identical"
    )
