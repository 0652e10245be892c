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
"""

from __future__ import annotations

import errno
import os
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["OutputWriteError", "atomic_output", "commit", "set_commit_guard", "temporary_name"]

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
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temporary_name(path)
    try:
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
