"""The warm worker runs a task as the job's own process would, and goes away when idle."""

import os
import sys
import tempfile
import time
from pathlib import Path

import pytest
import xarray as xr

from nnmstop.config import load_config
from nnmstop.pipeline.run import run_request
from nnmstop.pipeline.worker import run_in_worker, socket_path, worker_enabled, worker_key

SMALL_CONFIG = Path(__file__).resolve().parents[2] / "tests" / "data" / "small_config.yaml"


@pytest.fixture
def worker_dir(monkeypatch):
    """A socket directory of the test's own (short: a socket path has at most 107 characters),
    so that no worker of another build serves the test's jobs."""
    directory = Path(tempfile.mkdtemp(prefix="nnw"))
    monkeypatch.setenv("NNMSTOP_WORKER_DIR", str(directory))
    yield directory
    for leftover in directory.iterdir():
        leftover.unlink()
    directory.rmdir()


def two_impact_request(directory: Path) -> dict:
    config = load_config(SMALL_CONFIG)
    return {
        "name": "exact_two_impacts",
        "config": {key: config[key] for key in ("model", "exact", "metadata")},
        "inputs": {},
        "outputs": {"dataset": str(directory / "two_impacts.nc")},
        "log": str(directory / "two_impacts.log"),
        "wildcards": {},
    }


def wait_until(condition, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)
    return True


def test_task_in_the_worker_writes_the_same_bytes_as_in_process(worker_dir, tmp_path):
    in_process, in_worker = tmp_path / "process", tmp_path / "worker"
    in_process.mkdir(), in_worker.mkdir()
    run_request(two_impact_request(in_process))
    assert run_in_worker(two_impact_request(in_worker), idle=2.0) == 0
    assert (in_worker / "two_impacts.nc").read_bytes() == (in_process / "two_impacts.nc").read_bytes()
    xr.testing.assert_identical(
        xr.load_dataset(in_worker / "two_impacts.nc"), xr.load_dataset(in_process / "two_impacts.nc")
    )
    assert "ran in the warm worker" in (in_worker / "two_impacts.log").read_text()


def test_a_failing_task_fails_the_job_and_leaves_no_output(worker_dir, tmp_path):
    request = two_impact_request(tmp_path)
    request["config"]["model"] = {**request["config"]["model"], "eta": -1.0}
    assert run_in_worker(request, idle=2.0) == 1
    assert not (tmp_path / "two_impacts.nc").exists()
    assert "eta" in (tmp_path / "two_impacts.log").read_text()


def test_the_worker_exits_when_idle(worker_dir, tmp_path):
    assert run_in_worker(two_impact_request(tmp_path), idle=0.5) == 0
    path = socket_path(worker_key())
    assert path.exists()
    assert wait_until(lambda: not path.exists(), timeout=30.0), "the idle worker did not exit"


def test_the_worker_key_follows_the_import_time_environment():
    environ = dict(os.environ, OPENBLAS_CORETYPE="Haswell")
    assert worker_key(environ) == worker_key(dict(environ, UNRELATED_VARIABLE="1"))
    assert worker_key(environ) != worker_key(dict(environ, OPENBLAS_CORETYPE="Prescott"))


def test_the_worker_is_off_under_slurm_or_when_configured_off():
    assert worker_enabled({}, {})
    assert not worker_enabled({}, {"SLURM_JOB_ID": "12"})
    assert not worker_enabled({}, {"NNMSTOP_WARM_WORKER": "0"})
    assert not worker_enabled({"execution": {"warm_worker": False}}, {})


def test_a_worker_that_cannot_start_hands_the_job_back_at_once(worker_dir, tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "executable", "/bin/false")  # the worker's interpreter exits with 1 at once
    started = time.monotonic()
    assert run_in_worker(two_impact_request(tmp_path), idle=2.0, start_timeout=60.0) is None
    assert time.monotonic() - started < 30.0, "the job waited for a worker that had already failed"
    assert not (tmp_path / "two_impacts.nc").exists()
