"""The warm worker runs a task as the job's own process would, lives no longer than its job, and
refuses a socket folder or socket that is not the user's own."""

import json
import os
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import xarray as xr

from nnmstop import atomic
from nnmstop.config import load_config
from nnmstop.pipeline import worker
from nnmstop.pipeline.run import JobEnded, run_request
from nnmstop.pipeline.worker import (
    WorkerUnavailable,
    run_in_worker,
    socket_path,
    worker_directory,
    worker_enabled,
    worker_key,
)

REPO = Path(__file__).resolve().parents[2]
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"


def _own_worker_dir():
    """A socket directory of its own (short: a socket path has at most 107 characters), so that no
    worker of another build serves the test's jobs; workers still running at the end are ended."""
    directory = Path(tempfile.mkdtemp(prefix="nnw"))
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("NNMSTOP_WORKER_DIR", str(directory))
        yield directory
    ended = []
    for sock in directory.glob("*.sock"):
        pid = worker_pid(sock)
        if pid:
            os.kill(pid, signal.SIGCONT)
            os.kill(pid, signal.SIGTERM)
            ended.append(pid)
    wait_until(lambda: not any(alive(pid) for pid in ended), timeout=10.0)
    for leftover in directory.iterdir():
        leftover.unlink()
    directory.rmdir()


@pytest.fixture
def worker_dir():
    """A worker of the test's own (for tests that stop it, or wait for it to exit)."""
    yield from _own_worker_dir()


@pytest.fixture(scope="module")
def shared_worker_dir():
    """One worker for the tests that only send it jobs (each start imports numpy, scipy, ...)."""
    yield from _own_worker_dir()


def worker_pid(sock: Path) -> int | None:
    """Pid of the worker listening at ``sock`` (the system's record of the peer of a connection)."""
    client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        client.connect(str(sock))
        return worker._peer_uid(client)[0]
    except OSError:
        return None
    finally:
        client.close()


def two_impact_request(directory: Path, step: float | None = None) -> dict:
    """The request of rule exact_two_impacts on the small configuration; a smaller ``step`` slows it down."""
    config = load_config(SMALL_CONFIG)
    if step is not None:
        config["exact"] = {"step": step, "max_points": 1_000_000}
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


def alive(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie counts as ended)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(") ")[1][0] != "Z"
    except (FileNotFoundError, IndexError):
        return False


def started_pid(log: Path) -> int | None:
    """Pid of the task, from the line it logs when it starts."""
    if not log.exists():
        return None
    for line in log.read_text().splitlines():
        if " started " in line and "(pid " in line:
            return int(line.rsplit("(pid ", 1)[1].rstrip(")"))
    return None


def test_task_in_the_worker_writes_the_same_bytes_as_in_process(shared_worker_dir, tmp_path):
    in_process, in_worker = tmp_path / "process", tmp_path / "worker"
    in_process.mkdir(), in_worker.mkdir()
    run_request(two_impact_request(in_process))
    assert run_in_worker(two_impact_request(in_worker), idle=60.0) == 0
    assert (in_worker / "two_impacts.nc").read_bytes() == (in_process / "two_impacts.nc").read_bytes()
    xr.testing.assert_identical(
        xr.load_dataset(in_worker / "two_impacts.nc"), xr.load_dataset(in_process / "two_impacts.nc")
    )
    log = (in_worker / "two_impacts.log").read_text()
    assert "task exact_two_impacts ran in the warm worker" in log and "s CPU (user" in log


def test_a_failing_task_fails_the_job_and_leaves_no_output(shared_worker_dir, tmp_path):
    request = two_impact_request(tmp_path)
    request["config"]["model"] = {**request["config"]["model"], "eta": -1.0}
    assert run_in_worker(request, idle=60.0) == 1
    assert not (tmp_path / "two_impacts.nc").exists()
    assert "eta" in (tmp_path / "two_impacts.log").read_text()


def test_the_worker_exits_when_idle_and_removes_its_socket_and_lock(worker_dir, tmp_path):
    assert run_in_worker(two_impact_request(tmp_path), idle=0.5) == 0
    path = socket_path(worker_key())
    assert path.exists() and stat.S_IMODE(path.stat().st_mode) == 0o600
    assert wait_until(lambda: not path.exists(), timeout=30.0), "the idle worker did not exit"
    assert wait_until(lambda: not list(worker_dir.iterdir()), timeout=10.0), list(worker_dir.iterdir())


def test_the_worker_key_follows_the_import_time_environment_and_the_installed_packages(monkeypatch):
    environ = dict(os.environ, OPENBLAS_CORETYPE="Haswell")
    assert worker_key(environ) == worker_key(dict(environ, UNRELATED_VARIABLE="1"))
    assert worker_key(environ) != worker_key(dict(environ, OPENBLAS_CORETYPE="Prescott"))
    installed = worker._installed_distributions()
    assert any(name.startswith("numpy-") for name in installed), installed
    before = worker_key(environ)
    upgraded = [name.replace("numpy-", "numpy-99.") if name.startswith("numpy-") else name for name in installed]
    monkeypatch.setattr(worker, "_installed_distributions", lambda: upgraded)
    assert worker_key(environ) != before  # a pip install of a pre-imported package: another worker


def test_the_worker_is_off_under_slurm_or_when_configured_off():
    assert worker_enabled({}, {})
    assert not worker_enabled({}, {"SLURM_JOB_ID": "12"})
    assert not worker_enabled({}, {"NNMSTOP_WARM_WORKER": "0"})
    assert not worker_enabled({"execution": {"warm_worker": False}}, {})


def test_a_worker_that_cannot_start_hands_the_job_back_at_once(worker_dir, tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "executable", "/bin/false")  # the worker's interpreter exits with 1 at once
    started = time.monotonic()
    with pytest.raises(WorkerUnavailable, match="no warm worker answered"):
        run_in_worker(two_impact_request(tmp_path), idle=2.0, start_timeout=60.0)
    assert time.monotonic() - started < 30.0, "the job waited for a worker that had already failed"
    assert not (tmp_path / "two_impacts.nc").exists()


def test_a_worker_folder_under_a_missing_parent_is_unavailable_not_a_crash(tmp_path):
    missing = tmp_path / "no" / "such" / "folder"
    with pytest.raises(WorkerUnavailable, match=f"cannot create the worker folder {missing}"):
        worker_directory({"NNMSTOP_WORKER_DIR": str(missing)})
    assert not missing.parent.exists()


def test_a_relative_worker_folder_is_refused_naming_the_variable(tmp_path, monkeypatch):
    """Issue 33, reproduction 7: the worker runs from '/', where a relative path names another folder; the job
    fell back to its own process without saying why."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(WorkerUnavailable, match=r"NNMSTOP_WORKER_DIR='sockets' is a relative path"):
        worker_directory({"NNMSTOP_WORKER_DIR": "sockets"})
    assert not (tmp_path / "sockets").exists()


def test_a_foreign_socket_folder_is_refused(tmp_path):
    shared = tmp_path / "shared"
    shared.mkdir(mode=0o755)
    shared.chmod(0o755)  # others may enter it
    with pytest.raises(WorkerUnavailable, match=r"mode 0755: others may use it \(needs 0700\)"):
        worker_directory({"NNMSTOP_WORKER_DIR": str(shared)})
    link = tmp_path / "link"
    link.symlink_to(shared)
    with pytest.raises(WorkerUnavailable, match="is not a folder"):
        worker_directory({"NNMSTOP_WORKER_DIR": str(link)})
    if os.getuid() == 0:  # only root can give a folder to another user
        foreign = tmp_path / "foreign"
        foreign.mkdir(mode=0o700)
        os.chown(foreign, 65534, 65534)
        with pytest.raises(WorkerUnavailable, match="belongs to uid 65534, not to you"):
            worker_directory({"NNMSTOP_WORKER_DIR": str(foreign)})


def test_a_socket_others_may_use_is_refused_and_gets_no_request(worker_dir, tmp_path):
    """A socket planted with mode 0666: the job refuses it before sending anything."""
    path = socket_path(worker_key())
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(str(path))
    listener.listen(1)
    path.chmod(0o666)
    listener.settimeout(0.5)
    try:
        with pytest.raises(WorkerUnavailable, match="mode 0666"):
            run_in_worker(two_impact_request(tmp_path), idle=2.0)
        with pytest.raises(TimeoutError):
            listener.accept()  # nobody connected
    finally:
        listener.close()


def test_a_stopped_worker_fails_the_job_within_its_bound_and_never_runs_the_task(worker_dir, tmp_path):
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir(), second.mkdir()
    assert run_in_worker(two_impact_request(first), idle=60.0) == 0
    pid = worker_pid(socket_path(worker_key()))
    os.kill(pid, signal.SIGSTOP)
    job = subprocess.run(
        [sys.executable, "-c", JOB_SCRIPT, json.dumps(two_impact_request(second)), "2.0"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert job.returncode == 1, job.stderr
    assert f"the warm worker (pid {pid}" in job.stderr and "did not start the task within 2 s" in job.stderr
    os.kill(pid, signal.SIGCONT)  # the worker resumes with the dead job's request still queued
    assert run_in_worker(two_impact_request(first), idle=60.0) == 0  # served after the queued one
    assert not (second / "two_impacts.nc").exists() and not (second / "two_impacts.log").exists()


JOB_SCRIPT = """
import json, sys
from nnmstop.pipeline.run import Interrupted
from nnmstop.pipeline.worker import run_in_worker
try:
    sys.exit(run_in_worker(json.loads(sys.argv[1]), idle=60.0, answer_timeout=float(sys.argv[2])))
except Interrupted as interruption:
    sys.exit(128 + interruption.signum)
"""


def start_slow_job(directory: Path) -> tuple[subprocess.Popen, int]:
    """A job whose task runs for minutes in the worker; the job's process and the task's pid."""
    job = subprocess.Popen(
        [sys.executable, "-c", JOB_SCRIPT, json.dumps(two_impact_request(directory, step=1e-4)), "60"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert wait_until(lambda: started_pid(directory / "two_impacts.log"), timeout=120.0), "the task did not start"
    return job, started_pid(directory / "two_impacts.log")


def test_a_task_dies_with_its_killed_job_and_writes_nothing(shared_worker_dir, tmp_path):
    job, task = start_slow_job(tmp_path)
    assert alive(task) and task != job.pid
    job.kill()  # SIGKILL: the job cannot pass anything on
    job.wait(timeout=60)
    assert wait_until(lambda: not alive(task), timeout=30.0), "the task outlived its job"
    assert not (tmp_path / "two_impacts.nc").exists()
    assert not list(tmp_path.glob("*.tmp*"))
    assert "the job of this task has ended; task killed" in (tmp_path / "two_impacts.log").read_text()


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP])
def test_a_signalled_job_interrupts_its_task_which_logs_it(shared_worker_dir, tmp_path, signum):
    job, task = start_slow_job(tmp_path)
    job.send_signal(signum)
    _, stderr = job.communicate(timeout=60)
    assert job.returncode == 128 + signum, stderr
    assert wait_until(lambda: not alive(task), timeout=30.0)
    log = (tmp_path / "two_impacts.log").read_text()
    name = signal.Signals(signum).name
    assert f"task exact_two_impacts was interrupted by {name} before it finished" in log
    assert f"; interrupted by {name}" in log  # the cost line says how it ended
    assert not (tmp_path / "two_impacts.nc").exists()


def test_the_commit_guard_refuses_a_rename_once_the_job_has_gone(tmp_path):
    job_end, task_end = socket.socketpair()
    watch = worker._JobWatch(task_end, None)
    previous = atomic.set_commit_guard(watch.guard)
    try:
        with atomic.atomic_output(tmp_path / "alive.txt") as tmp:
            tmp.write_text("written while the job lives")
        job_end.send(bytes([0]))  # a byte that is not a signal: the job is still there
        with atomic.atomic_output(tmp_path / "alive2.txt") as tmp:
            tmp.write_text("still alive")
        job_end.close()
        with pytest.raises(JobEnded, match="the job of this task has ended"):
            with atomic.atomic_output(tmp_path / "orphan.txt") as tmp:
                tmp.write_text("written after the job ended")
    finally:
        atomic.set_commit_guard(previous)
        task_end.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["alive.txt", "alive2.txt"]
