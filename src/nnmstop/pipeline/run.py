"""The task dispatcher of the workflow: :func:`run_task` and the command line.

A rule of ``workflow/rules/<file>.smk`` runs the function of the rule's own name in the task
module of its rule file, :mod:`nnmstop.tasks.<file>` (:data:`TASK_MODULES`), through the one
script ``workflow/scripts/run_task.py``. A task takes ``(config, inputs, outputs, **wildcards)``:
the configuration sections its rule passes as ``params.config`` (a rule reruns when they
change), its named inputs and outputs (paths) and the rule's wildcards. A task module lists its
tasks in its ``TASKS`` table. The same task runs standalone for debugging, with the whole configuration::

    python -m nnmstop.pipeline.run hbm_stage --branch nnm1 --stage 2 \\
        --input previous=results/hbm/stages/nnm1_stage1.nc \\
        --output dataset=/tmp/nnm1_stage2.nc

Other wildcards go through ``--wildcard KEY=VALUE`` (for example the study's
``--wildcard harmonics=100 --wildcard eta=0.1``). The log goes to the rule's ``log:`` file
(or stderr).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import importlib.util
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

__all__ = [
    "TASK_MODULES",
    "Interrupted",
    "JobEnded",
    "find_task",
    "task_module",
    "task_table",
    "named_entries",
    "run_task",
    "run_request",
    "watch_parent",
    "main",
]

logger = logging.getLogger("nnmstop.pipeline.run")

#: The tasks of each task module, one module per rule file (``workflow/rules/<name>.smk`` ->
#: ``nnmstop.tasks.<name>``). A job imports only the module of its task (the figure modules pull in
#: matplotlib, the others need not); tests/pipeline/test_run.py checks this index against the modules'
#: ``TASKS`` tables and the rule files.
TASK_INDEX = {
    "exact": ("exact_two_impacts", "exact_nnm1"),
    "hbm": ("hbm_stage", "hbm_bifurcated", "hbm_branch"),
    "compare": ("compare_nnm1", "compare_regimes", "compare_stability"),
    "structure": ("structure_exact", "structure_compare", "structure_figure"),
    "figures": ("regime_error_figure", "stability_figure", *(f"paper_fig{n:02d}" for n in range(2, 12))),
    "study": (
        "study_error_case",
        "study_anm_case",
        "study_reference",
        "study_exact_cost",
        "study_error_vs_runtime",
        "study_error_vs_runtime_figure",
        "study_stiff_exact",
        "study_stiff_branch",
        "study_stiff_energy",
        "study_stiff_cases",
        "study_stiff_cases_figure",
        "study_manifest",
    ),
    "manifest": ("dataset_manifest",),
    "bundle": ("bundle",),
    "docs": ("docs",),
    "explorer": ("explorer",),
    "verify": ("verify", "update_reference"),
    "tube": (
        "tube_stage",
        "tube_exact",
        "tube_branch",
        "tube_compare",
        "tube_figure",
        "tube_study_case",
        "tube_study",
        "tube_manifest",
        "tube_circular_stage",
        "tube_circular_branch",
        "tube_circular_figure",
    ),
    "tube_plates": (
        "tube_plates_stage",
        "tube_plates_branch",
        "tube_plates_figure",
        "tube_plates_forced",
        "tube_plates_forced_figure",
        "tube_plates_circular_stage",
        "tube_plates_circular_branch",
        "tube_plates_circular_figure",
        "tube_plates_manifest",
    ),
    "forced": (
        "forced_exact",
        "forced_regularized",
        "forced_backbone",
        "forced_prediction",
        "forced_figure",
        "forced_manifest",
    ),
    "atlas": (
        "atlas_slice",
        "atlas_curves",
        "atlas_map",
        "atlas_backbone",
        "atlas_figure",
        "atlas_docs",
        "atlas_manifest",
    ),
}
TASK_MODULES = tuple(TASK_INDEX)


def _module_tasks(module) -> dict[str, Callable]:
    """The ``TASKS`` table of a task module (rule name -> function)."""
    tasks = getattr(module, "TASKS", None)
    if not isinstance(tasks, dict):
        raise TypeError(f"task module {module.__name__} has no TASKS table")
    return dict(tasks)


@functools.cache
def _task_modules() -> dict[str, dict[str, Callable]]:
    """Tasks of every task module that exists, by module name."""
    found = {}
    for name in TASK_MODULES:
        qualified = f"nnmstop.tasks.{name}"
        if importlib.util.find_spec(qualified) is not None:
            found[qualified] = _module_tasks(importlib.import_module(qualified))
    return found


def task_module(name: str) -> str:
    """Name of the module that holds task ``name`` (from :data:`TASK_INDEX`, without importing anything).

    Raises
    ------
    ValueError
        If no task module holds ``name``.
    """
    for module, names in TASK_INDEX.items():
        if name in names:
            return f"nnmstop.tasks.{module}"
    raise ValueError(f"unknown task {name!r}; tasks are {sorted(n for names in TASK_INDEX.values() for n in names)}")


def find_task(name: str) -> Callable:
    """The function of task ``name``: imports its task module only (see :func:`task_module`)."""
    return _module_tasks(importlib.import_module(task_module(name)))[name]


def task_table() -> dict[str, Callable]:
    """Every task, by name."""
    table = {}
    for tasks in _task_modules().values():
        table.update(tasks)
    return table


def configure_logging(log_path: str | None) -> None:
    """Send INFO messages to ``log_path`` (or stderr when None or '-')."""
    if log_path and log_path != "-":
        Path(log_path).parent.mkdir(parents=True, exist_ok=True)
        handler: logging.Handler = logging.FileHandler(log_path, mode="w")
    else:
        handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger()
    for old in list(root.handlers):
        root.removeHandler(old)
    root.addHandler(handler)
    root.setLevel(logging.INFO)
    # a numerical warning that escapes a task lands in its log, beside the step that raised it, not on the terminal
    logging.captureWarnings(True)


class Interrupted(BaseException):
    """The task's process received SIGTERM, SIGINT or SIGHUP (a ``BaseException``, like
    ``KeyboardInterrupt``: no ``except Exception`` of a task takes it for a failed computation)."""

    def __init__(self, signum: int):
        self.signum = int(signum)
        super().__init__(f"interrupted by {signal.Signals(self.signum).name}")


class JobEnded(RuntimeError):
    """The job that started the task has ended: the task must not put an output in place."""


#: Signals that interrupt a task: its log says so, and the job fails with 128 + the signal number.
INTERRUPTING_SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)


@contextmanager
def _interruptible():
    """Within the block, SIGTERM, SIGINT and SIGHUP raise :class:`Interrupted` (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise Interrupted(signum)

    previous = {signum: signal.signal(signum, interrupt) for signum in INTERRUPTING_SIGNALS}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _usage_line(name: str, where: str, wall: float, outcome: str) -> str:
    """The log line with the task's wall time, CPU time and peak memory (``python -m
    nnmstop.pipeline.usage`` sums these lines over a build's logs)."""
    try:
        import resource  # Unix only
    except ImportError:
        return f"task {name} ran {where}: {wall:.2f} s wall; {outcome}"
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    user, system = own.ru_utime + children.ru_utime, own.ru_stime + children.ru_stime
    return (
        f"task {name} ran {where}: {wall:.2f} s wall, {user + system:.2f} s CPU (user {user:.2f} s, "
        f"system {system:.2f} s), {max(own.ru_maxrss, children.ru_maxrss) / 1024:.0f} MB peak resident; {outcome}"
    )


def watch_parent() -> None:
    """For a task that runs in its job's own process (no warm worker): the task ends with the
    process that started it, and renames no output into place once that process has gone.

    On Linux the process asks for SIGTERM when its parent ends (``PR_SET_PDEATHSIG``), which
    interrupts the task; everywhere, the commit guard of :mod:`nnmstop.atomic` refuses a rename
    once the parent has changed (the process was handed over to another one).
    """
    from nnmstop import atomic

    parent = os.getppid()
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:  # the parent ended before the request took effect
        raise Interrupted(signal.SIGTERM)

    def guard(path: Path) -> None:
        if os.getppid() != parent:
            raise JobEnded(f"the process that started this task (pid {parent}) has ended: {path} is not written")

    atomic.set_commit_guard(guard)


def named_entries(named) -> dict:
    """A Snakemake ``Namedlist`` (or a dict, or None) as a plain dict of its named entries."""
    return dict(named.items()) if hasattr(named, "items") else dict(named or {})


def run_task(name: str, config: dict, inputs=None, outputs=None, log: str | None = None, **wildcards):
    """Run task ``name`` with named inputs/outputs (Snakemake ``Namedlist`` or dict).

    ``config`` holds the configuration sections the task reads; ``log`` is the path of the
    log file (None or '-' for stderr); ``wildcards`` are passed on as keywords.
    """
    _run_logged(name, config, inputs, outputs, log, "in its own process", wildcards)


def _run_logged(name: str, config: dict, inputs, outputs, log, where: str, wildcards: dict, note=None) -> None:
    """:func:`run_task`, saying ``where`` it ran in the log line of its cost."""
    task = find_task(name)
    configure_logging(log)
    if note:
        logger.warning(note)
    logger.info("task %s started %s (pid %d)", name, where, os.getpid())
    started, outcome = time.perf_counter(), "failed"
    try:
        with _interruptible():
            task(config, named_entries(inputs), named_entries(outputs), **wildcards)
        outcome = "finished"
    except Interrupted as interruption:
        outcome = f"interrupted by {signal.Signals(interruption.signum).name}"
        logger.error(
            "task %s was interrupted by %s before it finished; it puts no further output in place",
            name,
            signal.Signals(interruption.signum).name,
        )
        raise
    except JobEnded as ended:
        outcome = "its job has ended"
        logger.error("task %s stopped: %s", name, ended)
        raise
    except Exception:
        logger.exception("task %s failed", name)
        raise
    finally:
        logger.info(_usage_line(name, where, time.perf_counter() - started, outcome))


def run_request(request: dict, where: str = "in its own process", note: str | None = None) -> None:
    """:func:`run_task` from a request (``name``, ``config``, ``inputs``, ``outputs``, ``log``,
    ``wildcards``), as :func:`nnmstop.pipeline.worker.plain_request` makes it from a Snakemake job;
    ``where`` it runs is named in the log line of its cost; ``note``, if any, is logged first."""
    _run_logged(
        request["name"],
        request["config"],
        request["inputs"],
        request["outputs"],
        request["log"],
        where,
        request["wildcards"],
        note,
    )


def _pairs(values):
    out = {}
    for item in values or []:
        key, sep, value = item.partition("=")
        if not sep:
            raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {item!r}")
        out.setdefault(key, []).append(value)
    return {k: v[0] if len(v) == 1 else v for k, v in out.items()}


def main(argv=None) -> None:
    """Command line: ``python -m nnmstop.pipeline.run TASK [options]``."""
    from nnmstop.config import load_config

    parser = argparse.ArgumentParser(prog="python -m nnmstop.pipeline.run", description=__doc__.splitlines()[0])
    parser.add_argument("task", choices=sorted(task_table()))
    parser.add_argument("--config", default="config/config.yaml")
    parser.add_argument("--input", action="append", metavar="KEY=PATH", help="named input (repeatable)")
    parser.add_argument("--output", action="append", metavar="KEY=PATH", help="named output (repeatable)")
    parser.add_argument("--log", default="-", help="log file, '-' for stderr")
    parser.add_argument("--branch")
    parser.add_argument("--stage")
    parser.add_argument("--bifurcation", help="name under bifurcations (task hbm_bifurcated)")
    parser.add_argument(
        "--wildcard",
        action="append",
        metavar="KEY=VALUE",
        help="any other wildcard of the task's rule, e.g. --wildcard harmonics=100 (repeatable)",
    )
    args = parser.parse_args(argv)
    wildcards = {k: getattr(args, k) for k in ("branch", "stage", "bifurcation") if getattr(args, k) is not None}
    for key, value in _pairs(args.wildcard).items():
        if isinstance(value, list):
            parser.error(f"wildcard {key!r} given more than once")
        wildcards[key] = value
    inputs = _pairs(args.input)
    if "stages" in inputs and isinstance(inputs["stages"], str):
        inputs["stages"] = [inputs["stages"]]
    run_task(args.task, load_config(args.config), inputs, _pairs(args.output), args.log, **wildcards)


if __name__ == "__main__":
    main()
