"""The warm worker: the workflow's jobs run in forks of one interpreter that has imported once.

Every job is a new Python process, and before its task starts it spends 1.3-2 s importing
numpy, scipy, xarray, netCDF4 and, for figures, matplotlib: as much as the task itself for
most jobs of the paper's build. The first job of a build starts a worker (:func:`serve`),
which imports the task modules once and listens on a Unix socket. Each job
(``workflow/scripts/run_task.py``, :func:`run_in_worker`) connects and hands over its
request (JSON), its standard streams, directory and environment; the worker forks a child, a
copy of the freshly imported interpreter in which no task has run, and the child runs the task
exactly as the job would have (:func:`nnmstop.pipeline.run.run_request`) and sends back its
exit status. The job waits for it and exits with it: Snakemake sees the same job.

The task lives only as long as its job: the child watches the job's end of the connection and
kills itself when the job has gone (a hang-up, SIGKILL, the OOM killer), and renames an output
into place only while the job is alive. The job passes on SIGTERM, SIGINT and SIGHUP, and fails
when the worker does not start its task within ``answer_timeout`` seconds. The worker's folder
and socket must belong to the user with no access for others, and both ends check that the
other runs as the same user.

A worker serves one interpreter, one package source (by content hash), one set of installed
distributions and one set of the environment variables read at import (:func:`worker_key`).
It exits after ``idle`` seconds without a running task. Method: docs/methods/warm_worker.md.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import importlib.util
import json
import math
import os
import select
import signal
import socket
import stat
import struct
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Mapping
from pathlib import Path

from nnmstop import atomic
from nnmstop.pipeline.run import Interrupted, JobEnded, named_entries

__all__ = [
    "WorkerUnavailable",
    "worker_key",
    "worker_directory",
    "socket_path",
    "plain_request",
    "run_in_worker",
    "serve",
    "worker_enabled",
    "MAX_IDLE_SECONDS",
]

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

#: Longest idle time of a worker (the schema's maximum of ``execution.worker_idle_seconds``).
MAX_IDLE_SECONDS = 3600.0

_HEADER = struct.Struct("!Q")  # length of the JSON request
_HELLO = struct.Struct("!q")  # the pid of the worker's child for a job, sent before it reads the request
_STATUS = struct.Struct("!i")  # the task's exit status, sent when it ends
_FORWARDED = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)  # passed on to the task, one byte each
_SOCKET_NAME_LIMIT = 107  # bytes of a Unix socket path (sun_path)


class WorkerUnavailable(RuntimeError):
    """No warm worker can run this job (the reason is the message); the job runs its task itself."""


def _source_digest(package: Path) -> str:
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*")):
        if path.suffix in (".py", ".yaml") and "__pycache__" not in path.parts:
            digest.update(str(path.relative_to(package)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def _installed_distributions() -> list[str]:
    """Names of the installed distributions with their versions (``numpy-2.4.6.dist-info``, ...)
    on ``sys.path``: a ``pip install`` that changes a package the worker imported changes them."""
    found = set()
    for entry in sys.path:
        try:
            names = os.listdir(entry or ".")
        except OSError:
            continue
        found.update(name for name in names if name.endswith((".dist-info", ".egg-info")))
    return sorted(found)


def _absolute_path_list(value: str) -> str:
    """A ``PYTHONPATH``-like list with every entry made absolute (the worker runs from another directory)."""
    return os.pathsep.join(str(Path(entry).resolve()) for entry in value.split(os.pathsep))


def worker_key(environ=None) -> str:
    """Identity of the worker that may run a job with environment ``environ`` (``os.environ`` by default).

    The interpreter, the installed ``nnmstop`` package (its path and the content of its
    sources), the installed distributions with their versions (:func:`_installed_distributions`)
    and the import-time environment variables (:data:`IMPORT_VARIABLES`, with ``PYTHONPATH``
    entries made absolute): a job only runs in a worker that imported the same code under the
    same settings.
    """
    environ = os.environ if environ is None else environ
    package = Path(importlib.util.find_spec("nnmstop").origin).parent
    variables = {k: v for k, v in environ.items() if k.startswith(IMPORT_VARIABLES)}
    if "PYTHONPATH" in variables:
        variables["PYTHONPATH"] = _absolute_path_list(variables["PYTHONPATH"])
    identity = [
        sys.executable,
        sys.version,
        str(package),
        _source_digest(package),
        _installed_distributions(),
        sorted(variables.items()),
    ]
    # the worker is started with that absolute PYTHONPATH (_start_worker), from another directory
    return hashlib.sha256(repr(identity).encode()).hexdigest()[:24]


def _check_private(path: Path, kind: str, is_kind) -> None:
    """Refuse ``path`` unless it is a ``kind`` (not a link) owned by this user with no access for others."""
    info = os.lstat(path)
    if not is_kind(info.st_mode):
        raise WorkerUnavailable(f"the worker {kind} {path} is not a {kind} (a symbolic link or another file?)")
    if info.st_uid != os.getuid():
        raise WorkerUnavailable(
            f"the worker {kind} {path} belongs to uid {info.st_uid}, not to you (uid {os.getuid()})"
        )
    if stat.S_IMODE(info.st_mode) & 0o077:
        wanted = "0700" if kind == "folder" else "0600"
        raise WorkerUnavailable(
            f"the worker {kind} {path} has mode {stat.S_IMODE(info.st_mode):04o}: others may use it (needs {wanted})"
        )


def worker_directory(environ=None) -> Path:
    """The folder of the workers' sockets: ``NNMSTOP_WORKER_DIR``, by default a folder of the
    user's own under the temporary directory. Created (mode 0700) if missing, but never its parent.

    Raises
    ------
    WorkerUnavailable
        If ``NNMSTOP_WORKER_DIR`` is relative, or the folder cannot be created, or is not a folder owned by
        this user with mode 0700 (another user could then read every job's environment and streams, or
        answer in the worker's place).
    """
    environ = os.environ if environ is None else environ
    configured = environ.get("NNMSTOP_WORKER_DIR")
    if configured and not Path(configured).is_absolute():
        raise WorkerUnavailable(
            f"NNMSTOP_WORKER_DIR={configured!r} is a relative path: the worker runs from '/', where it names another "
            "folder than the job's; give an absolute path"
        )
    directory = Path(configured) if configured else Path(tempfile.gettempdir()) / f"nnmstop-worker-{os.getuid()}"
    try:
        directory.mkdir(mode=0o700)
    except FileExistsError:
        pass
    except OSError as error:
        raise WorkerUnavailable(f"cannot create the worker folder {directory}: {error.strerror}") from None
    _check_private(directory, "folder", stat.S_ISDIR)
    return directory


def socket_path(key: str, environ=None) -> Path:
    """The socket of the worker with key ``key``, in :func:`worker_directory`."""
    path = worker_directory(environ) / f"{key}.sock"
    if len(os.fsencode(path)) > _SOCKET_NAME_LIMIT:
        raise WorkerUnavailable(f"the socket path {path} is longer than {_SOCKET_NAME_LIMIT} bytes")
    return path


def worker_enabled(config: dict | None, environ=None) -> bool:
    """Whether jobs use the warm worker: ``execution.warm_worker`` of the configuration (true by
    default), unless ``NNMSTOP_WARM_WORKER=0`` or the job runs under a cluster scheduler (a job
    there is alone on its node)."""
    environ = os.environ if environ is None else environ
    if environ.get("NNMSTOP_WARM_WORKER", "1") == "0" or "SLURM_JOB_ID" in environ:
        return False
    if not (hasattr(os, "fork") and hasattr(socket, "AF_UNIX") and hasattr(socket, "send_fds")):
        return False  # no fork or Unix sockets (Windows): jobs run in-process
    return bool(((config or {}).get("execution") or {}).get("warm_worker", True))


def _peer_uid(connection: socket.socket) -> tuple[int, int] | None:
    """(pid, uid) of the process at the other end of a Unix socket, where the system tells it."""
    if not hasattr(socket, "SO_PEERCRED"):
        return None
    pid, uid, _ = struct.unpack("3i", connection.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, 12))
    return pid, uid


def _receive_exactly(connection: socket.socket, size: int, buffer: bytearray | None = None) -> bytes:
    """``size`` bytes from ``connection``; ConnectionError if the other end closes before.

    With ``buffer``, bytes received before a timeout are kept there for the next call."""
    data = bytearray() if buffer is None else buffer
    while len(data) < size:
        chunk = connection.recv(size - len(data))
        if not chunk:
            raise ConnectionError(f"connection closed after {len(data)} of {size} bytes")
        data += chunk
    message = bytes(data[:size])
    del data[:size]
    return message


# --- the job's side -------------------------------------------------------------------------


def _plain(value):
    """``value`` with Snakemake's lists and path strings replaced by built-in JSON types (tuples
    become lists, in the job's own process as in the worker)."""
    if isinstance(value, str):
        return str(value)
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
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
    being started (``starting``) failed (a worker that lost the race to another exits with 0).

    Raises WorkerUnavailable if the socket, or the process behind it, is not this user's own."""
    deadline = time.monotonic() + wait
    while True:
        if os.path.lexists(path):
            _check_private(path, "socket", stat.S_ISSOCK)
            client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                client.connect(str(path))
            except OSError:
                client.close()
            else:
                peer = _peer_uid(client)
                if peer is not None and peer[1] != os.getuid():
                    client.close()
                    raise WorkerUnavailable(f"the worker at {path} runs as uid {peer[1]}, not as you")
                return client
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


class _Forwarder:
    """While the job waits: SIGTERM, SIGINT and SIGHUP end the job at once before its task has
    started, and are passed on to the task (one byte each on the connection) once it has."""

    def __init__(self, connection: socket.socket):
        self.connection = connection
        self.started = False
        self.received: int | None = None  # the first signal passed on
        self.when = 0.0

    def __call__(self, signum, frame):
        if not self.started:
            raise Interrupted(signum)
        if self.received is None:
            self.received, self.when = signum, time.monotonic()
        try:
            self.connection.send(bytes([signum]))
        except OSError:
            pass

    def __enter__(self):
        self.previous = {signum: signal.signal(signum, self) for signum in _FORWARDED}
        return self

    def __exit__(self, *exc):
        for signum, handler in self.previous.items():
            signal.signal(signum, handler)


def _exchange(connection: socket.socket, payload: bytes, path: Path, answer_timeout: float, grace: float) -> int:
    """Hand the request to the worker's child once it has answered; the task's exit status.

    The job's streams go to the child only after it has said hello (its pid), so a worker that
    does not answer never holds them."""
    peer = _peer_uid(connection)
    who = f"the warm worker (pid {peer[0]}, socket {path})" if peer else f"the warm worker at {path}"
    buffer = bytearray()
    with _Forwarder(connection) as forwarder:
        connection.settimeout(answer_timeout)
        try:
            pid = _HELLO.unpack(_receive_exactly(connection, _HELLO.size, buffer))[0]
        except TimeoutError:
            print(
                f"nnmstop: {who} did not start the task within {answer_timeout:g} s (stopped or hung?); the job "
                "fails. End that process, or run without the worker (NNMSTOP_WARM_WORKER=0).",
                file=sys.stderr,
            )
            return 1
        socket.send_fds(connection, [_HEADER.pack(len(payload))], [0, 1, 2])
        connection.sendall(payload)
        forwarder.started = True
        connection.settimeout(0.5)
        while True:
            try:
                return _STATUS.unpack(_receive_exactly(connection, _STATUS.size, buffer))[0]
            except TimeoutError:
                if forwarder.received is not None and time.monotonic() - forwarder.when > grace:
                    print(
                        f"nnmstop: the task's process {pid} did not end within {grace:g} s of "
                        f"{signal.Signals(forwarder.received).name}; the job ends, and the task with it.",
                        file=sys.stderr,
                    )
                    return 128 + forwarder.received
            except ConnectionError:
                print(f"nnmstop: the task's process {pid} ended without an exit status", file=sys.stderr)
                return 1


def run_in_worker(
    request: dict, idle: float = 20.0, start_timeout: float = 120.0, answer_timeout: float = 30.0, grace: float = 10.0
) -> int:
    """Run a task request in the warm worker; the task's exit status.

    ``request`` holds the arguments of :func:`nnmstop.pipeline.run.run_task` (``name``,
    ``config``, ``inputs``, ``outputs``, ``log``, ``wildcards``). A worker is started if none
    serves this job's :func:`worker_key`. The worker must start the task within
    ``answer_timeout`` seconds, or the job fails saying so. SIGTERM, SIGINT and SIGHUP
    received while the task runs are passed on to it; if it has not ended ``grace`` seconds
    later, the job ends (and the task, which watches its job, with it).

    Raises
    ------
    WorkerUnavailable
        When no worker can run the job (unusable socket folder, no worker started within
        ``start_timeout``, a request JSON cannot carry): the job then runs the task itself.
    Interrupted
        When the job receives one of those signals before its task has started.
    """
    path = socket_path(worker_key())
    try:
        payload = json.dumps({**request, "cwd": os.getcwd(), "environ": dict(os.environ)}).encode()
    except (TypeError, ValueError) as error:
        raise WorkerUnavailable(f"the request cannot be sent to a worker ({error})") from None
    for _attempt in range(2):  # a worker that closes before starting the task (it was exiting) is retried once
        client = _connect(path, 0.0)
        if client is None:
            client = _connect(path, start_timeout, starting=_start_worker(path, idle))
            if client is None:
                raise WorkerUnavailable(f"no warm worker answered at {path} within {start_timeout:g} s")
        with client:
            try:
                return _exchange(client, payload, path, answer_timeout, grace)
            except ConnectionError:  # closed before it said hello: no task runs for this job
                continue
    raise WorkerUnavailable(f"the warm worker at {path} closed the connection twice before starting the task")


# --- the worker's side ----------------------------------------------------------------------


def _job_gone(connection: socket.socket) -> bool:
    """Whether the job at the other end of ``connection`` has closed it (it has ended)."""
    events = select.POLLIN | select.POLLHUP | select.POLLERR | getattr(select, "POLLRDHUP", 0)
    poller = select.poll()
    poller.register(connection, events)
    for _, happened in poller.poll(0):
        if happened & (select.POLLHUP | select.POLLERR | getattr(select, "POLLRDHUP", 0)):
            return True
        if happened & select.POLLIN:
            try:
                return connection.recv(1, socket.MSG_PEEK | socket.MSG_DONTWAIT) == b""
            except BlockingIOError:
                return False
            except OSError:
                return True
    return False


class _JobWatch:
    """In the child: the task lives only as long as its job.

    A thread reads the connection: a byte is a signal the job passes on; the end of the
    connection means the job has ended, and the child's process group is killed at once. The
    commit guard (:func:`nnmstop.atomic.set_commit_guard`) refuses to rename an output into
    place once the job has gone, for the moments before the thread acts."""

    def __init__(self, connection: socket.socket, log: str | None):
        self.connection, self.log, self.finished = connection, log, False

    def guard(self, path: Path) -> None:
        if _job_gone(self.connection):
            raise JobEnded(f"the job of this task has ended: {path} is not written")

    def watch(self) -> None:
        while True:
            try:
                data = self.connection.recv(64)
            except OSError:
                data = b""
            if not data:
                break
            for signum in data:
                if signum in _FORWARDED:
                    os.kill(os.getpid(), signum)
        if self.finished:
            return
        if self.log:  # best effort, without the logging module's locks (the main thread may hold them)
            try:
                with open(self.log, "a") as handle:
                    handle.write("ERROR nnmstop.pipeline.worker: the job of this task has ended; task killed\n")
            except OSError:
                pass
        os.killpg(0, signal.SIGKILL)


def _run_request(connection: socket.socket) -> int:
    """In the forked child: take the job's streams, directory and environment; run its task."""
    from nnmstop.pipeline.run import run_request

    header, fds, _, _ = socket.recv_fds(connection, _HEADER.size, 3)
    request = json.loads(_receive_exactly(connection, _HEADER.unpack(header)[0]))
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
    watch = _JobWatch(connection, request.get("log"))
    if _job_gone(connection):  # the job ended while its request was on its way
        return 1
    threading.Thread(target=watch.watch, name="job watch", daemon=True).start()
    atomic.set_commit_guard(watch.guard)
    try:
        run_request(request, where="in the warm worker")
        status = 0
    except Interrupted as interruption:
        status = 128 + interruption.signum
    except Exception:  # run_task logged it
        status = 1
    watch.finished = True
    return status


def _reap(children: set) -> None:
    for pid in list(children):
        try:
            done, _ = os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            done = pid
        if done:
            children.discard(pid)


def _acquire_lock(path: Path):
    """The lock file of the worker at ``path``, locked; None if another worker holds it."""
    import fcntl  # Unix only, like the worker

    lock_path = Path(f"{path}.lock")
    while True:
        handle = open(lock_path, "a")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.close()
            return None
        try:  # the previous holder removes the file when it exits: a lock on a removed file locks nothing
            if os.fstat(handle.fileno()).st_ino == os.stat(lock_path).st_ino:
                return handle
        except FileNotFoundError:
            pass
        handle.close()


def _fork_child(connection: socket.socket, listener: socket.socket, lock) -> int:
    """Fork a child that runs the job of ``connection``; its pid (the child never returns)."""
    pid = os.fork()
    if pid:
        connection.close()
        return pid
    status = 1
    try:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)  # the worker's own handler (see serve) is not the task's
        os.setpgid(0, 0)  # its own group: the job's end kills the task and what it started, not the worker
        listener.close()
        lock.close()
        connection.settimeout(None)
        connection.sendall(_HELLO.pack(os.getpid()))
        status = _run_request(connection)
        connection.sendall(_STATUS.pack(status))
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(status)


def _accept(listener: socket.socket, children: set, lock) -> bool:
    """Accept one job and fork its child; False when no job came within the listener's timeout."""
    try:
        connection, _ = listener.accept()
    except (TimeoutError, BlockingIOError):
        return False
    peer = _peer_uid(connection)
    if peer is not None and peer[1] != os.getuid():
        connection.close()  # not this user's job
        return True
    children.add(_fork_child(connection, listener, lock))
    return True


def serve(path: Path, idle: float) -> None:
    """Import the task modules, then fork a child per job connecting to ``path``, until ``idle``
    seconds pass with no task running. One worker per socket: a second one exits at once. The
    socket and its lock file are removed when the worker exits."""
    if not (math.isfinite(idle) and 0 < idle <= MAX_IDLE_SECONDS):
        raise ValueError(f"idle must be a number of seconds in (0, {MAX_IDLE_SECONDS:g}], got {idle!r}")
    _check_private(path.parent, "folder", stat.S_ISDIR)
    lock = _acquire_lock(path)
    if lock is None:
        return  # another worker serves this socket
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(0))  # ended: remove the socket and lock first
    try:
        for name in WARM_MODULES:
            try:
                importlib.import_module(name)
            except ImportError:
                pass
        path.unlink(missing_ok=True)
        mask = os.umask(0o177)  # the socket is created with mode 0600
        try:
            listener.bind(str(path))
        finally:
            os.umask(mask)
        listener.listen(64)
        listener.settimeout(0.5)
        children: set[int] = set()
        last_busy = time.monotonic()
        while children or time.monotonic() - last_busy <= idle:
            if _accept(listener, children, lock) or children:
                last_busy = time.monotonic()
            _reap(children)
        path.unlink(missing_ok=True)  # no new job can connect; serve those already queued
        listener.setblocking(False)
        while _accept(listener, children, lock):
            pass
    finally:
        listener.close()
        path.unlink(missing_ok=True)
        Path(f"{path}.lock").unlink(missing_ok=True)
        lock.close()


def main(argv=None) -> None:
    """``python -m nnmstop.pipeline.worker --socket PATH --idle SECONDS``: run a worker (jobs start it)."""
    parser = argparse.ArgumentParser(prog="python -m nnmstop.pipeline.worker", description=main.__doc__)
    parser.add_argument("--socket", required=True, type=Path)
    parser.add_argument("--idle", type=float, default=20.0)
    args = parser.parse_args(argv)
    try:
        serve(args.socket, args.idle)
    except (ValueError, WorkerUnavailable) as error:
        parser.error(str(error))


if __name__ == "__main__":
    main()
