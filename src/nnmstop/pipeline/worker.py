"""The warm worker: the workflow's jobs run in forks of one interpreter that has imported once.

Every job is a new Python process, and before its task starts it spends 1.3-2 s importing
numpy, scipy, xarray, netCDF4 and, for figures, matplotlib: as much as the task itself for
most jobs of the paper's build. The first job of a build starts a worker (:func:`serve`),
which imports the task modules once and listens on a Unix socket. Each job
(``workflow/scripts/run_task.py``, :func:`run_in_worker`) connects and hands over its
request, its working directory, environment and standard streams; the worker forks a
child, a copy of the freshly imported interpreter in which no task has run, and the child
runs the task exactly as the job would have (:func:`nnmstop.pipeline.run.run_task`) and sends
back its exit status. The job waits for it and exits with it: Snakemake sees the same job.

A worker serves one interpreter, one package source (by content hash) and one set of the
environment variables read at import (:func:`worker_key`): change any of them and the next
job starts a new worker. A worker exits after ``idle`` seconds without a running task.
Method and measurements: docs/methods/warm_worker.md.
"""

from __future__ import annotations

import argparse
import errno
import hashlib
import importlib
import importlib.util
import logging
import os
import pickle
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path

from nnmstop.pipeline.run import named_entries

__all__ = ["worker_key", "socket_path", "plain_request", "run_in_worker", "serve", "worker_enabled"]

#: Environment variables that take effect when modules are imported: a worker serves jobs
#: whose values of these equal its own (the pinned numerics set the first four families).
IMPORT_VARIABLES = ("OPENBLAS_", "OMP_", "MKL_", "NPY_", "PYTHON", "MPL")

#: Modules the worker imports before its first fork (those missing are imported by the task).
WARM_MODULES = (
    "numpy",
    "scipy.linalg",
    "scipy.integrate",
    "scipy.sparse.linalg",
    "xarray",
    "netCDF4",
    "matplotlib.pyplot",
    "matplotlib.backends.backend_pdf",
    "nnmstop.tasks.exact",
    "nnmstop.tasks.hbm",
    "nnmstop.tasks.compare",
    "nnmstop.tasks.figures",
    "nnmstop.tasks.tube",
)

_HEADER = struct.Struct("!Q")  # length of the pickled request
_STATUS = struct.Struct("!qi")  # child pid, then exit status (-1 before it is known)


def _source_digest(package: Path) -> str:
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*")):
        if path.suffix in (".py", ".yaml") and "__pycache__" not in path.parts:
            digest.update(str(path.relative_to(package)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def _absolute_path_list(value: str) -> str:
    """A ``PYTHONPATH``-like list with every entry made absolute (the worker runs from another directory)."""
    return os.pathsep.join(str(Path(entry).resolve()) for entry in value.split(os.pathsep))


def worker_key(environ=None) -> str:
    """Identity of the worker that may run a job with environment ``environ`` (``os.environ`` by default).

    The interpreter, the installed ``nnmstop`` package (its path and the content of its
    sources) and the import-time environment variables (:data:`IMPORT_VARIABLES`, with
    ``PYTHONPATH`` entries made absolute): a job only runs in a worker that imported the
    same code under the same settings.
    """
    environ = os.environ if environ is None else environ
    package = Path(importlib.util.find_spec("nnmstop").origin).parent
    variables = {k: v for k, v in environ.items() if k.startswith(IMPORT_VARIABLES)}
    if "PYTHONPATH" in variables:
        variables["PYTHONPATH"] = _absolute_path_list(variables["PYTHONPATH"])
    identity = [sys.executable, sys.version, str(package), _source_digest(package), sorted(variables.items())]
    # the worker is started with that absolute PYTHONPATH (_start_worker), from another directory
    return hashlib.sha256(repr(identity).encode()).hexdigest()[:24]


def socket_path(key: str) -> Path:
    """The worker's socket: in ``NNMSTOP_WORKER_DIR``, by default a directory of the user's own under
    the temporary directory (a Unix socket's path has at most 107 characters)."""
    default = Path(tempfile.gettempdir()) / f"nnmstop-worker-{os.getuid()}"
    directory = Path(os.environ.get("NNMSTOP_WORKER_DIR", default))
    directory.mkdir(mode=0o700, exist_ok=True)
    return directory / f"{key}.sock"


def worker_enabled(config: dict | None, environ=None) -> bool:
    """Whether jobs use the warm worker: ``execution.warm_worker`` of the configuration (true by
    default), unless ``NNMSTOP_WARM_WORKER=0`` or the job runs under a cluster scheduler (a job
    there is alone on its node)."""
    environ = os.environ if environ is None else environ
    if environ.get("NNMSTOP_WARM_WORKER", "1") == "0" or "SLURM_JOB_ID" in environ:
        return False
    if not (hasattr(os, "fork") and hasattr(socket, "AF_UNIX")):
        return False  # no fork or Unix sockets (Windows): jobs run in-process
    return bool(((config or {}).get("execution") or {}).get("warm_worker", True))


# --- the job's side -------------------------------------------------------------------------


def _plain(value):
    """``value`` with Snakemake's lists and path strings replaced by built-in types."""
    if isinstance(value, str):
        return str(value)
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return tuple(_plain(v) for v in value)
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


def plain_request(rule: str, config, inputs, outputs, log, wildcards) -> dict:
    """The arguments of :func:`nnmstop.pipeline.run.run_task` for a Snakemake job, in built-in types
    (so that the worker needs no Snakemake class to read them): named inputs and outputs, the first
    log file or None, the wildcards."""
    return {
        "name": str(rule),
        "config": _plain(config),
        "inputs": _plain(named_entries(inputs)),
        "outputs": _plain(named_entries(outputs)),
        "log": str(log[0]) if log else None,
        "wildcards": _plain(named_entries(wildcards)),
    }


def _connect(path: Path, wait: float, starting=None) -> socket.socket | None:
    """Connect to the worker at ``path`` within ``wait`` seconds; None if none answers or if the worker
    being started (``starting``) failed (a worker that lost the race to another exits with 0)."""
    deadline = time.monotonic() + wait
    while True:
        client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            client.connect(str(path))
            return client
        except OSError:
            client.close()
            failed = starting is not None and starting.poll() not in (None, 0)
            if failed or time.monotonic() >= deadline:
                return None
            time.sleep(0.05)


def _start_worker(path: Path, idle: float) -> subprocess.Popen:
    """Start a worker for ``path`` in its own session, detached from the job's streams."""
    environ = dict(os.environ)
    if "PYTHONPATH" in environ:
        environ["PYTHONPATH"] = _absolute_path_list(environ["PYTHONPATH"])
    return subprocess.Popen(
        [sys.executable, "-P", "-m", "nnmstop.pipeline.worker", "--socket", str(path), "--idle", str(idle)],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
        cwd="/",
        env=environ,
    )


def _receive_exactly(connection: socket.socket, size: int) -> bytes:
    """``size`` bytes from ``connection``; ConnectionError if the other end closes before."""
    data = bytearray()
    while len(data) < size:
        chunk = connection.recv(size - len(data))
        if not chunk:
            raise ConnectionError(f"connection closed after {len(data)} of {size} bytes")
        data += chunk
    return bytes(data)


def run_in_worker(request: dict, idle: float = 20.0, start_timeout: float = 120.0) -> int | None:
    """Run a task request in the warm worker; its exit status, or None if no worker could be reached.

    ``request`` holds the arguments of :func:`nnmstop.pipeline.run.run_task` (``name``,
    ``config``, ``inputs``, ``outputs``, ``log``, ``wildcards``). A worker is started if none
    serves this job's :func:`worker_key`. SIGTERM and SIGINT received while waiting are passed
    on to the task's process.
    """
    path = socket_path(worker_key())
    client = _connect(path, 0.0)
    if client is None:
        client = _connect(path, start_timeout, starting=_start_worker(path, idle))
        if client is None:
            return None
    payload = pickle.dumps({**request, "cwd": os.getcwd(), "environ": dict(os.environ)})
    with client:
        socket.send_fds(client, [_HEADER.pack(len(payload))], [0, 1, 2])
        client.sendall(payload)
        child = None
        previous = {}

        def forward(signum, frame):
            if child:
                os.kill(child, signum)

        for signum in (signal.SIGTERM, signal.SIGINT):
            previous[signum] = signal.signal(signum, forward)
        try:
            child, _ = _STATUS.unpack(_receive_exactly(client, _STATUS.size))  # the task's pid, at its start
            return _STATUS.unpack(_receive_exactly(client, _STATUS.size))[1]  # its exit status, at its end
        except ConnectionError:
            print(f"nnmstop warm worker: the task's process {child} ended without an exit status", file=sys.stderr)
            return 1
        finally:
            for signum, handler in previous.items():
                signal.signal(signum, handler)


# --- the worker's side ----------------------------------------------------------------------


def _run_request(connection: socket.socket) -> int:
    """In the forked child: take the job's streams, directory and environment; run its task."""
    header, fds, _, _ = socket.recv_fds(connection, _HEADER.size, 3)
    request = pickle.loads(_receive_exactly(connection, _HEADER.unpack(header)[0]))
    for target, fd in enumerate(fds):
        os.dup2(fd, target)
        os.close(fd)
    sys.stdin, sys.stdout, sys.stderr = (
        open(0, closefd=False),
        open(1, "w", closefd=False, buffering=1),
        open(2, "w", closefd=False, buffering=1),
    )
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["environ"])
    connection.sendall(_STATUS.pack(os.getpid(), -1))

    from nnmstop.pipeline.run import run_request

    started = time.perf_counter()
    try:
        run_request(request)
        status = 0
    except Exception:  # run_task logged it
        status = 1
    import resource  # Unix only, like the worker

    usage = resource.getrusage(resource.RUSAGE_SELF)
    logging.getLogger("nnmstop.pipeline.worker").info(
        "task %s ran in the warm worker: %.2f s wall, %.2f s CPU, %.0f MB peak resident",
        request["name"],
        time.perf_counter() - started,
        usage.ru_utime + usage.ru_stime,
        usage.ru_maxrss / 1024,
    )
    return status


def _reap(children: set) -> None:
    for pid in list(children):
        try:
            done, _ = os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            done = pid
        if done:
            children.discard(pid)


def serve(path: Path, idle: float) -> None:
    """Import the task modules, then fork a child per job connecting to ``path``, until ``idle``
    seconds pass with no task running. One worker per socket: a second one exits at once."""
    import fcntl  # Unix only, like the worker

    lock = open(f"{path}.lock", "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as err:
        if err.errno in (errno.EAGAIN, errno.EACCES):
            return  # another worker serves this socket
        raise
    for name in WARM_MODULES:
        try:
            importlib.import_module(name)
        except ImportError:
            pass
    path.unlink(missing_ok=True)
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(str(path))
    listener.listen(64)
    listener.settimeout(0.5)
    children: set[int] = set()
    last_busy = time.monotonic()
    try:
        while True:
            try:
                connection, _ = listener.accept()
            except TimeoutError:
                _reap(children)
                if children:
                    last_busy = time.monotonic()
                elif time.monotonic() - last_busy > idle:
                    return
                continue
            pid = os.fork()
            if pid == 0:
                status = 1
                try:
                    listener.close()
                    connection.settimeout(None)
                    lock.close()
                    status = _run_request(connection)
                    connection.sendall(_STATUS.pack(os.getpid(), status))
                finally:
                    for stream in (sys.stdout, sys.stderr):
                        stream.flush()
                    os._exit(status)
            connection.close()
            children.add(pid)
            _reap(children)
            last_busy = time.monotonic()
    finally:
        listener.close()
        path.unlink(missing_ok=True)


def main(argv=None) -> None:
    """``python -m nnmstop.pipeline.worker --socket PATH --idle SECONDS``: run a worker (jobs start it)."""
    parser = argparse.ArgumentParser(prog="python -m nnmstop.pipeline.worker", description=main.__doc__)
    parser.add_argument("--socket", required=True, type=Path)
    parser.add_argument("--idle", type=float, default=20.0)
    args = parser.parse_args(argv)
    serve(args.socket, args.idle)


if __name__ == "__main__":
    main()
