"""Timing and report helpers shared by the benchmark scripts (imported as ``timing`` from ``benchmarks/``).

Each script times its candidates side by side in one run, best of ``--repeat``, and prints a Markdown table
that ``--output`` also writes to a file; :func:`emit_report` puts :func:`run_header` (the command, the
commit, the machine and its load) on top, so that every report says what it measured and where.
"""

from __future__ import annotations

import os
import platform
import shlex
import subprocess
import sys
import time
from pathlib import Path

__all__ = ["timed", "best_time", "check_repeat", "emit_report", "run_header", "git_commit"]

REPO = Path(__file__).resolve().parents[1]
#: Load average (1 min) when the script started: a report shows it beside the load at its end.
LOAD_AT_START = os.getloadavg()[0]


def timed(function):
    """Result, CPU time (``time.process_time``, robust on a shared machine) and wall time of one call."""
    cpu, wall = time.process_time(), time.perf_counter()
    result = function()
    return result, time.process_time() - cpu, time.perf_counter() - wall


def best_time(function, repeat: int):
    """Result of the last call and smallest wall time of ``repeat`` calls."""
    check_repeat(repeat)
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return result, best


def check_repeat(repeat: int) -> int:
    """``--repeat`` as given, which must be >= 1 (ValueError otherwise)."""
    if repeat < 1:
        raise ValueError(f"--repeat must be >= 1, got {repeat}")
    return repeat


def git_commit(ref: str = "HEAD") -> str:
    """Short hash of ``ref`` in this repository, with ``+uncommitted`` when the working tree differs from it."""
    run = dict(cwd=REPO, capture_output=True, text=True)
    commit = subprocess.run(["git", "rev-parse", "--short", ref], **run).stdout.strip() or "unknown"
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], **run).stdout.strip()
    return commit + (" +uncommitted changes" if ref == "HEAD" and dirty else "")


#: Date and commit (:func:`git_commit`) when the script started.
STARTED = (time.strftime("%Y-%m-%dT%H:%M:%S"), git_commit())


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _memory_gib() -> str:
    try:
        total_kib = next(
            int(line.split()[1])
            for line in Path("/proc/meminfo").read_text().splitlines()
            if line.startswith("MemTotal")
        )
    except (OSError, StopIteration):
        return "unknown memory"
    return f"{total_kib / 2**20:.0f} GiB"


def run_header(argv=None) -> list[str]:
    """Lines that open a report: the command, date, commit, machine, Python and numerics, load averages.

    The date and commit are those of the script's start (:data:`STARTED`): a long run measures that tree.
    """
    argv = sys.argv if argv is None else argv
    command = "python " + shlex.join([os.path.relpath(argv[0], REPO) if argv and argv[0] else "?", *argv[1:]])
    import numpy
    import scipy

    return [
        f"Command: `{command}`",
        "",
        f"- date: {STARTED[0]}, commit {STARTED[1]}",
        f"- machine: {_cpu_model()}, {os.cpu_count()} logical CPUs, {_memory_gib()}, {platform.system()} "
        f"{platform.machine()}",
        f"- Python {platform.python_version()}, numpy {numpy.__version__}, scipy {scipy.__version__}",
        f"- load average (1 min) at the start and the end of the run: {LOAD_AT_START:.1f}, {os.getloadavg()[0]:.1f}",
        "",
    ]


def emit_report(report: str, output: Path | None) -> int:
    """Print the report under :func:`run_header` and, when ``output`` is given, also write it there.

    A report that starts with a Markdown title keeps it first. Returns the script's exit code (0).
    """
    lines = report.splitlines()
    title = lines[:2] if lines and lines[0].startswith("# ") else []
    text = "\n".join([*title, *run_header(), *lines[len(title) :]])
    print(text)
    if output:
        output.write_text(text + "\n")
    return 0
