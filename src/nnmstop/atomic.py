"""Output files written whole or not at all: a temporary name, then a rename into place.

Every file the pipeline produces (datasets, tables, figures, manifests, the bundle) is written
through :func:`atomic_output`: the writer fills a temporary file next to the target, and only
a complete file is renamed to the target's name. A writer that fails (an exception, a full
disk, a permission refused, an interruption) leaves no file behind, neither the target nor
the temporary one, and a failure of the file system is reported with its reason and the path.

Before the rename, a *commit guard* may refuse it: the workflow's task runner
(:mod:`nnmstop.pipeline.run`) installs one that checks that the job which started the task is
still alive, so that a task whose job has ended (a killed build) never puts a file in place.
The numerical packages know nothing of jobs; they only write through this module.

A folder written as a whole (the verifier's reference) goes through :func:`atomic_folder`: filled
beside its target and put in its place when complete. A writer killed with SIGKILL runs no handler
and leaves its temporary behind; while it writes, it holds a lock on it (an open-file-description
lock, Linux), so that :func:`remove_stale_temporaries` (run when a build starts) removes the
temporaries no live writer holds and leaves those of a concurrent build alone.
"""

from __future__ import annotations

import errno
import os
import shutil
import struct
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = [
    "OutputWriteError",
    "atomic_output",
    "atomic_folder",
    "commit",
    "set_commit_guard",
    "temporary_name",
    "remove_stale_temporaries",
]

#: Errors of the file system that a writer cannot fix itself; reported with their reason.
_FILE_SYSTEM_ERRORS = (errno.ENOSPC, errno.EDQUOT, errno.EACCES, errno.EPERM, errno.EROFS, errno.EFBIG, errno.EIO)

_guard: Callable[[Path], None] | None = None


class OutputWriteError(OSError):
    """An output file could not be written; the message names the file and the reason."""


def set_commit_guard(guard: Callable[[Path], None] | None) -> Callable[[Path], None] | None:
    """Install ``guard(path)``, called before each rename into place (it raises to refuse it).

    Returns the guard it replaces (None: no guard).
    """
    global _guard
    previous, _guard = _guard, guard
    return previous


def temporary_name(path: str | Path) -> Path:
    """The temporary file of ``path``: same folder, ``.tmp`` before the suffix (writers such as
    matplotlib choose the format from the suffix)."""
    path = Path(path)
    return path.with_name(f"{path.stem}.tmp{path.suffix}")


def commit(tmp: str | Path, path: str | Path) -> Path:
    """Rename the complete file ``tmp`` to ``path``, if the commit guard allows it."""
    path = Path(path)
    if _guard is not None:
        _guard(path)
    os.replace(tmp, path)
    return path


#: The lock a writer holds on its temporary while it writes (whole file, write lock); None where the system
#: has no open-file-description locks (there no temporary is ever taken for stale).
try:
    import fcntl
except ImportError:  # not a Unix
    fcntl = None
_OFD_LOCK = getattr(fcntl, "F_OFD_SETLK", None)
_WHOLE_FILE = struct.pack("hhqqi", fcntl.F_WRLCK, os.SEEK_SET, 0, 0, 0) if _OFD_LOCK is not None else b""
#: Inside a folder being written by :func:`atomic_folder`: the file its writer holds locked.
_FOLDER_LOCK = ".writing"


def _hold(path: Path) -> int | None:
    """Create (or truncate) ``path`` and take the writer's lock on it; the descriptor that holds it.

    None where locks are not supported, or when another live writer holds ``path`` (then the caller
    writes anyway, as before: the rename decides; the other writer's file is never removed by a cleaner).
    """
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o644)
    if _OFD_LOCK is None:
        os.close(fd)
        return None
    try:
        fcntl.fcntl(fd, _OFD_LOCK, _WHOLE_FILE)
    except OSError:
        os.close(fd)
        return None
    return fd


def _release(fd: int | None) -> None:
    if fd is not None:
        os.close(fd)


def _unheld(path: Path) -> bool:
    """Whether no live writer holds ``path`` (it is a leftover of a killed writer)."""
    if _OFD_LOCK is None:
        return False
    try:
        fd = os.open(path, os.O_RDWR | os.O_CLOEXEC)
    except OSError:
        return False
    try:
        fcntl.fcntl(fd, _OFD_LOCK, _WHOLE_FILE)
    except OSError:
        return False
    finally:
        os.close(fd)
    return True


#: Folders of other tools (a documentation build, version control) never searched for temporaries.
_FOREIGN = frozenset({"_build", "jupyter_execute", ".git", ".snakemake", "__pycache__"})


def _temporaries(folder: Path):
    """Candidate temporaries under ``folder``: files named by :func:`temporary_name` and the folders of
    :func:`atomic_folder` (``.<name>.new``); the folders of other tools left out."""
    for path in folder.rglob("*"):
        if _FOREIGN & set(path.relative_to(folder).parts):
            continue
        if path.is_file() and not path.is_symlink() and (".tmp." in path.name or path.name.endswith(".tmp")):
            yield path, path
        elif path.is_dir() and path.name.startswith(".") and path.name.endswith(".new"):
            yield path, path / _FOLDER_LOCK


def remove_stale_temporaries(folders) -> list[Path]:
    """Remove the temporaries under ``folders`` that no live writer holds; the paths removed, sorted.

    A writer killed with SIGKILL (or the OOM killer, or a lost node) leaves its temporary file behind; a
    build calls this when it starts, so that no partial file lies beside the results. Temporaries of a
    writer that still runs (a concurrent build of other targets) are held locked and kept. Without
    open-file-description locks (not Linux) nothing is removed.
    """
    removed = []
    for folder in map(Path, folders):
        if not folder.is_dir():
            continue
        for path, lock in list(_temporaries(folder)):
            if path.is_dir() and not lock.exists():
                stale = True  # its writer had finished writing and died before the swap
            else:
                stale = _unheld(lock)
            if stale:
                shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)
                removed.append(path)
    return sorted(removed)


def _reason(error: BaseException, folder: Path) -> str | None:
    """Why writing into ``folder`` failed, when the file system is the cause (else None)."""
    if isinstance(error, OSError) and error.errno in _FILE_SYSTEM_ERRORS:
        return os.strerror(error.errno)
    try:  # libraries such as HDF5 report a full disk as their own error ("NetCDF: HDF error")
        free = shutil.disk_usage(folder).free
    except OSError:
        return None
    return f"{os.strerror(errno.ENOSPC)} ({free} bytes free)" if free < 64 * 1024 else None


@contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Context manager: yields the temporary file to write; on success renames it to ``path``.

    On any failure inside the block (including an interruption) the temporary file is removed
    and the error propagates; a failure of the file system (no space left, permission refused,
    read-only file system, ...) becomes an :class:`OutputWriteError` naming ``path`` and the
    reason.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> with atomic_output(folder / "table.csv") as tmp:
    ...     _ = tmp.write_text("a,b\\n1,2\\n")
    >>> sorted(p.name for p in folder.iterdir())
    ['table.csv']
    """
    path = Path(path)
    tmp = temporary_name(path)
    held = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        held = _hold(tmp)
        yield tmp
        commit(tmp, path)
    except BaseException as error:
        reason = _reason(error, path.parent) if isinstance(error, Exception) else None  # before the space is freed
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        if reason is None:
            raise
        raise OutputWriteError(
            getattr(error, "errno", None) or errno.EIO,
            f"cannot write {path}: {reason}; the partial file was removed ({type(error).__name__}: {error})",
        ) from error
    finally:
        _release(held)


def _swap(new: Path, path: Path) -> None:
    """Put the complete folder ``new`` in the place of ``path`` (which may exist), if the guard allows it.

    Two renames, ``path`` aside to ``.<name>.old`` then ``new`` to ``path``; the old one is removed last.
    At every moment one complete folder exists: at ``path``, or between the renames at ``.<name>.old``.
    """
    if _guard is not None:
        _guard(path)
    old = path.with_name(f".{path.name}.old")
    if old.exists():
        shutil.rmtree(old)
    if path.exists():
        os.replace(path, old)
    os.replace(new, path)
    shutil.rmtree(old, ignore_errors=True)


@contextmanager
def atomic_folder(path: str | Path) -> Iterator[Path]:
    """Context manager: yields an empty folder beside ``path`` to fill; on success it replaces ``path``.

    A failure inside the block (an exception, an interruption, a full disk) removes the new folder and
    leaves ``path`` as it was; a failure of the file system becomes an :class:`OutputWriteError` naming
    ``path`` and the reason. The commit guard (:func:`set_commit_guard`) may refuse the replacement.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp()) / "reference"
    >>> with atomic_folder(folder) as new:
    ...     _ = (new / "table.csv").write_text("a,b\\n")
    >>> sorted(p.name for p in folder.iterdir())
    ['table.csv']
    """
    path = Path(path)
    new = path.with_name(f".{path.name}.new")
    held = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if new.exists():
            shutil.rmtree(new)
        new.mkdir()
        held = _hold(new / _FOLDER_LOCK)
        yield new
        (new / _FOLDER_LOCK).unlink(missing_ok=True)
        _swap(new, path)
    except BaseException as error:
        reason = _reason(error, path.parent) if isinstance(error, Exception) else None
        shutil.rmtree(new, ignore_errors=True)
        if reason is None:
            raise
        raise OutputWriteError(
            getattr(error, "errno", None) or errno.EIO,
            f"cannot write {path}: {reason}; it is left as it was ({type(error).__name__}: {error})",
        ) from error
    finally:
        _release(held)
