"""Faults injected into real builds: a build hung up or killed mid-job leaves no task behind and
rebuilds cleanly; a socket folder that is not the user's own, or cannot be made, is refused and the
job runs its task in its own process.

Each build makes one small dataset (the exact two-impact family of tests/data/small_config.yaml);
a smaller continuation step slows its task down to minutes, so that it is surely running when the
fault comes (it never runs to its end: the fault ends it).
"""

from __future__ import annotations

import os
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import pytest
import xarray as xr
import yaml

from snakemake_cli import run_snakemake, snakemake_command

REPO = Path(__file__).resolve().parents[2]
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"
TARGET = "results/exact/nnm1_two_impacts.nc"
LOG = "logs/exact_two_impacts.log"
FAST_STEP = yaml.safe_load(SMALL_CONFIG.read_text())["exact"]["step"]


@pytest.fixture
def worker_dir(monkeypatch):
    """A socket folder of the test's own, so that the builds start their own worker."""
    directory = Path(tempfile.mkdtemp(prefix="nnf"))
    monkeypatch.setenv("NNMSTOP_WORKER_DIR", str(directory))
    yield directory
    for path in directory.iterdir():
        path.unlink()
    directory.rmdir()


def slow_config(tmp_path: Path) -> Path:
    config = yaml.safe_load(SMALL_CONFIG.read_text())
    config["exact"] = {"step": 1e-4, "max_points": 1_000_000}  # minutes instead of a second
    path = tmp_path / "slow.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    return path


def alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(") ")[1][0] != "Z"
    except (FileNotFoundError, IndexError):
        return False


def wait_until(condition, timeout: float):
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value or time.monotonic() > deadline:
            return value
        time.sleep(0.2)


def task_pid(log: Path) -> int | None:
    """Pid of the task, from the line it logs when it starts."""
    if log.exists():
        for line in log.read_text().splitlines():
            if "task exact_two_impacts started" in line:
                return int(line.rsplit("(pid ", 1)[1].rstrip(")"))
    return None


def start_slow_build(workdir: Path, config: Path) -> tuple[subprocess.Popen, int]:
    """A build in a session of its own (as a terminal's), with its task running; its process and the task's pid."""
    build = subprocess.Popen(
        snakemake_command(workdir, config, "--cores", "1", TARGET),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    pid = wait_until(lambda: task_pid(workdir / LOG), timeout=180.0)
    assert pid, "the task never started"
    return build, pid


@pytest.mark.parametrize(
    "signum, warm_worker, logged",
    [
        # the hang-up reaches the job itself, or, when Snakemake dies first, the SIGTERM the job asked for
        (signal.SIGHUP, True, "task exact_two_impacts was interrupted by SIG"),
        (signal.SIGKILL, True, "the job of this task has ended; task killed"),
        (signal.SIGHUP, False, "task exact_two_impacts was interrupted by SIG"),
    ],
)
def test_a_build_ended_mid_job_leaves_no_task_behind_and_rebuilds_cleanly(
    tmp_path, worker_dir, monkeypatch, signum, warm_worker, logged
):
    """The issue's reproduction: a hang-up (a closed terminal) or SIGKILL of the build's process
    group (a CI cancel) while a slow task runs, then an unlock and a rebuild with another
    configuration. The killed build's task must be gone, so that it cannot replace the rebuild's
    output; the rebuild's output is that of its own configuration and is up to date. Without the
    warm worker the task runs in the job's process (SIGKILL of the group ends it with the job)."""
    if not warm_worker:
        monkeypatch.setenv("NNMSTOP_WARM_WORKER", "0")
    build, task = start_slow_build(tmp_path, slow_config(tmp_path))
    os.killpg(build.pid, signum)
    build.wait(timeout=120)
    assert wait_until(lambda: not alive(task), timeout=60.0), "the killed build's task still runs"
    assert logged in (tmp_path / LOG).read_text()
    assert not (tmp_path / TARGET).exists()
    assert not list((tmp_path / "results").rglob("*.tmp*"))
    run_snakemake(tmp_path, SMALL_CONFIG, "--unlock", "--cores", "1")
    # what a writer killed mid-write leaves (issue 33.7): its temporary, which the next build removes and names
    stale = tmp_path / "results" / "hbm" / "nnm1.tmp.nc"
    stale.parent.mkdir(parents=True, exist_ok=True)
    stale.write_bytes(b"partial netcdf")
    rebuild = run_snakemake(tmp_path, SMALL_CONFIG, "--cores", "1", "--rerun-incomplete", TARGET)
    assert "nnmstop: removed results/hbm/nnm1.tmp.nc, a partial file left by an interrupted job" in rebuild.stderr
    assert not stale.exists()
    with xr.open_dataset(tmp_path / TARGET) as ds:
        assert ds.attrs["continuation_step"] == FAST_STEP
    dry = run_snakemake(tmp_path, SMALL_CONFIG, "-n", "--cores", "1", TARGET)
    assert "Nothing to be done" in dry.stdout + dry.stderr


@pytest.mark.parametrize(
    "make_folder, reason",
    [
        (lambda root: (root / "shared").mkdir(mode=0o755) or (root / "shared").chmod(0o755) or root / "shared",
         "has mode 0755: others may use it"),
        (lambda root: root / "missing" / "parent" / "folder", "cannot create the worker folder"),
    ],
)  # fmt: skip
def test_an_unusable_worker_folder_is_refused_and_the_job_runs_in_its_own_process(
    tmp_path, monkeypatch, make_folder, reason
):
    folder = make_folder(tmp_path)
    monkeypatch.setenv("NNMSTOP_WORKER_DIR", str(folder))
    run_snakemake(tmp_path / "build", SMALL_CONFIG, "--cores", "1", TARGET)
    log = (tmp_path / "build" / LOG).read_text()
    assert "the task runs in the job's own process" in log and reason in log, log
    assert "task exact_two_impacts ran in its own process" in log
    assert not folder.exists() or not list(folder.iterdir())  # no socket, no request left there
    with xr.open_dataset(tmp_path / "build" / TARGET) as ds:
        assert ds.sizes["point"] > 10
