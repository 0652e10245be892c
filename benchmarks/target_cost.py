"""The cost of each target of the workflow, wall and CPU time, one after the other in one fresh tree.

Extracts the committed tree (HEAD by default, as :mod:`cold_build` does) into a temporary directory and runs
``snakemake --cores N <target>`` for each target in turn (default: the default target, then explorer, forced,
tube, study, verify, docs, bundle, and ``--report`` of every figure built), each one building what it needs
that the targets before it have not built. Measured per target: the wall time, and the CPU time of its jobs
(Snakemake's own process tree, from ``resource.getrusage(RUSAGE_CHILDREN)``, plus the jobs run in the warm
worker, whose forks are outside that tree: their CPU time is in their logs,
``nnmstop.pipeline.worker``). Prints a Markdown table; ``--output`` also writes it (with the command, commit,
machine and load on top) and ``--docs`` writes it into ``docs/pipeline.md`` (section "Cost") between its
``target-cost`` markers. ``--slow-tests`` also times ``python -m pytest -m slow`` in the tree.

Usage::

    python benchmarks/target_cost.py [--cores 2] [--targets all forced ...] [--slow-tests]
                                     [--output benchmarks/target_cost.md] [--docs]

Run it on an otherwise idle machine: it measures wall time.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cold_build import tracked_copy
from timing import REPO, emit_report

#: The targets in the order they are built, and what each makes (README, "Main targets").
TARGETS = {
    "all": "every figure of the paper and the datasets behind them (the default target)",
    "explorer": "dist/explorer.html",
    "forced": "forced responses, exact and regularized, and their figures",
    "tube": "the finite-element tube's NNMs and study",
    "study": "accuracy against run time, stiff cases",
    "verify": "the build (its forced responses included) against the committed reference",
    "docs": "docs/results.md and docs/paper_vs_build.md",
    "bundle": "dist/nnmstop-results.zip",
    "report": "snakemake --report report.html report_figures (every figure built)",
}
WORKER_CPU = re.compile(r"task \w+ ran in the warm worker: [0-9.]+ s wall, ([0-9.]+) s CPU")
MARKERS = (
    "<!-- target-cost: written by `python benchmarks/target_cost.py --slow-tests --docs` -->",
    "<!-- target-cost end -->",
)
PAGE = REPO / "docs" / "pipeline.md"


def worker_cpu(workdir: Path) -> float:
    """CPU time of every job the warm worker has run in ``workdir`` so far (from the jobs' logs)."""
    return sum(float(cpu) for log in (workdir / "logs").rglob("*.log") for cpu in WORKER_CPU.findall(log.read_text()))


def build(workdir: Path, target: str, cores: int, env: dict, config: list) -> tuple[float, float]:
    """Wall and CPU time (seconds) of ``snakemake <target>`` in ``workdir`` (``config``: a --configfile option)."""
    if target == "report":
        command = [sys.executable, "-m", "snakemake", "--report", "report.html", "report_figures", *config]
    else:
        command = [sys.executable, "-m", "snakemake", target, "--cores", str(cores), "--quiet", "all", *config]
    before_children = resource.getrusage(resource.RUSAGE_CHILDREN)
    before_worker = worker_cpu(workdir)
    started = time.perf_counter()
    run = subprocess.run(command, cwd=workdir, env=env)
    wall = time.perf_counter() - started
    if run.returncode != 0:
        raise RuntimeError(f"snakemake {target} failed (exit {run.returncode}) in {workdir}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    children = (after.ru_utime - before_children.ru_utime) + (after.ru_stime - before_children.ru_stime)
    return wall, children + worker_cpu(workdir) - before_worker


def table(rows: list, cores: int) -> list[str]:
    lines = [
        f"| target (`snakemake --cores {cores} ...`) | what | wall | CPU |",
        "|---|---|---:|---:|",
    ]
    for target, wall, cpu in rows:
        lines.append(f"| `{target}` | {TARGETS.get(target, '')} | {_duration(wall)} | {_duration(cpu)} |")
    return lines


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


SLOW_LINE = "The slow tests (`python -m pytest -m slow`):"


def write_page(table_lines: list[str], slow_line: str, cores: int) -> None:
    """The table and the slow tests' line into docs/pipeline.md between :data:`MARKERS`, with how they were
    measured; either kept from the page where this run did not measure it."""
    text = PAGE.read_text()
    start, end = (text.index(marker) for marker in MARKERS)
    old = text[start:end].splitlines()[1:]
    if not table_lines:
        table_lines = [line for line in old if line.startswith("|")]
    if not slow_line:
        slow_line = next((line for line in old if line.startswith(SLOW_LINE)), "")
    note = (
        f"Measured on {cores} shared cores (`benchmarks/target_cost.md`): each target builds what the targets above "
        "it have not; CPU is the jobs' (the warm worker's included)."
    )
    block = [MARKERS[0], note, "", *table_lines] + (["", slow_line] if slow_line else []) + [""]
    PAGE.write_text(text[:start] + "\n".join(block) + text[end:])


def slow_tests(workdir: Path, env: dict) -> tuple[float, float]:
    """Wall and CPU time of ``python -m pytest -m slow`` in the tree (the tests at the configured numerics); their
    builds' temporary folders under the tree (``--basetemp``), where the warm worker's CPU time is read."""
    basetemp = workdir / ".slow-tests"
    before_children = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    command = [sys.executable, "-m", "pytest", "-m", "slow", "-q", "-p", "no:cacheprovider", f"--basetemp={basetemp}"]
    run = subprocess.run(command, cwd=workdir, env=env)
    wall = time.perf_counter() - started
    if run.returncode != 0:
        raise RuntimeError(f"the slow tests failed (exit {run.returncode}) in {workdir}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before_children.ru_utime) + (after.ru_stime - before_children.ru_stime)
    worker = sum(
        float(value)
        for log in basetemp.rglob("logs/**/*.log")
        for value in WORKER_CPU.findall(log.read_text(errors="replace"))
    )
    return wall, cpu + worker


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--targets", nargs="*", default=list(TARGETS), help=f"in order (default: {list(TARGETS)})")
    parser.add_argument("--configfile", type=Path, help="a configuration to build with instead of the tree's own")
    parser.add_argument("--ref", default="HEAD", help="the commit whose tree is built")
    parser.add_argument("--output", type=Path, help="also write the Markdown table here")
    parser.add_argument("--docs", action="store_true", help="write the table into docs/pipeline.md")
    parser.add_argument("--slow-tests", action="store_true", help="also time `python -m pytest -m slow` in the tree")
    parser.add_argument("--keep", action="store_true", help="keep the temporary tree")
    args = parser.parse_args(argv)
    workdir = Path(tempfile.mkdtemp(prefix="nnmstop-targets-"))
    rows = []
    try:
        tracked_copy(workdir, args.ref)
        env = {**os.environ, "PYTHONPATH": str(workdir / "src")}
        config = ["--configfile", str(args.configfile.resolve())] if args.configfile else []
        for target in args.targets:
            wall, cpu = build(workdir, target, args.cores, env, config)
            print(f"{target}: {wall:.1f} s wall, {cpu:.1f} s CPU", file=sys.stderr)
            rows.append((target, wall, cpu))
        slow = slow_tests(workdir, env) if args.slow_tests else None
    except RuntimeError as error:
        print(error, file=sys.stderr)
        return 1
    finally:
        if args.keep:
            print(f"tree kept in {workdir}", file=sys.stderr)
        else:
            shutil.rmtree(workdir, ignore_errors=True)
    table_lines = table(rows, args.cores) if rows else []
    slow_line = ""
    if slow is not None:
        wall, cpu = (_duration(value) for value in slow)
        slow_line = f"{SLOW_LINE} {wall} wall, {cpu} CPU."
    if args.docs:
        write_page(table_lines, slow_line, args.cores)
    return emit_report("\n".join(table_lines + ([""] if table_lines and slow_line else []) + [slow_line]), args.output)


if __name__ == "__main__":
    sys.exit(main())
