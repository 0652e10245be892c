"""Timing and report helpers shared by the benchmark scripts (imported as ``timing`` from ``benchmarks/``).

Each script times its candidates side by side in one run, best of ``--repeat``, and prints a Markdown table
that ``--output`` also writes to a file.
"""

from __future__ import annotations

import time
from pathlib import Path

__all__ = ["timed", "best_time", "check_repeat", "emit_report"]


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


def emit_report(report: str, output: Path | None) -> int:
    """Print the report and, when ``output`` is given, also write it there; the script's exit code (0)."""
    print(report)
    if output:
        output.write_text(report + "\n")
    return 0
