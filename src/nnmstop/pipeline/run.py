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
import sys
from collections.abc import Callable
from pathlib import Path

__all__ = ["TASK_MODULES", "find_task", "task_module", "task_table", "named_entries", "run_task", "run_request", "main"]

logger = logging.getLogger("nnmstop.pipeline.run")

#: The tasks of each task module, one module per rule file (``workflow/rules/<name>.smk`` ->
#: ``nnmstop.tasks.<name>``). A job imports only the module of its task (the figure modules pull in
#: matplotlib, the others need not); tests/pipeline/test_run.py checks this index against the modules'
#: ``TASKS`` tables and the rule files.
TASK_INDEX = {
    "exact": ("exact_two_impacts", "exact_nnm1"),
    "hbm": ("hbm_stage", "hbm_bifurcated", "hbm_branch"),
    "compare": ("compare_nnm1", "compare_regimes", "compare_stability"),
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
    ),
    "manifest": ("dataset_manifest",),
    "bundle": ("bundle",),
    "docs": ("docs",),
    "explorer": ("explorer",),
    "verify": ("verify", "update_reference"),
    "tube": ("tube_exact", "tube_branch", "tube_compare", "tube_figure", "tube_study_case", "tube_study"),
    "forced": ("forced_exact", "forced_regularized", "forced_backbone", "forced_prediction", "forced_figure"),
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


def named_entries(named) -> dict:
    """A Snakemake ``Namedlist`` (or a dict, or None) as a plain dict of its named entries."""
    return dict(named.items()) if hasattr(named, "items") else dict(named or {})


def run_task(name: str, config: dict, inputs=None, outputs=None, log: str | None = None, **wildcards):
    """Run task ``name`` with named inputs/outputs (Snakemake ``Namedlist`` or dict).

    ``config`` holds the configuration sections the task reads; ``log`` is the path of the
    log file (None or '-' for stderr); ``wildcards`` are passed on as keywords.
    """
    task = find_task(name)
    configure_logging(log)
    try:
        task(config, named_entries(inputs), named_entries(outputs), **wildcards)
    except Exception:
        logger.exception("task %s failed", name)
        raise


def run_request(request: dict) -> None:
    """:func:`run_task` from a request (``name``, ``config``, ``inputs``, ``outputs``, ``log``,
    ``wildcards``), as :func:`nnmstop.pipeline.worker.plain_request` makes it from a Snakemake job."""
    run_task(
        request["name"],
        request["config"],
        request["inputs"],
        request["outputs"],
        request["log"],
        **request["wildcards"],
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
