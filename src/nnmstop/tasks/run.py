"""The task dispatcher of the workflow: :func:`run_task` and the command line.

A rule of ``workflow/rules/<file>.smk`` runs the function of the rule's own name in the task
module of its rule file, :mod:`nnmstop.tasks.<file>` (:data:`TASK_MODULES`), through the one
script ``workflow/scripts/run_task.py``. A task takes ``(config, inputs, outputs, **wildcards)``:
the configuration sections its rule passes as ``params.config`` (a rule reruns when they
change), its named inputs and outputs (paths) and the rule's wildcards. A task module lists its
tasks in ``__all__``. The same task runs standalone for debugging, with the whole configuration::

    python -m nnmstop.tasks.run hbm_stage --branch nnm1 --stage 2 \\
        --input previous=results/hbm/stages/nnm1_stage1.nc \\
        --output dataset=/tmp/nnm1_stage2.nc

Other wildcards go through ``--wildcard KEY=VALUE`` (for example the study's
``--wildcard harmonics=100 --wildcard eta=0.1``). The log goes to the rule's ``log:`` file
(or stderr). The bodies of the exact, hbm, compare, figure and study tasks below are moving to
their task modules; a task module that defines a name takes precedence over them.
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

import xarray as xr

__all__ = ["TASK_MODULES", "find_task", "task_module", "task_table", "run_task", "main"]

logger = logging.getLogger("nnmstop.tasks.run")

#: Task modules, one per rule file: ``workflow/rules/<name>.smk`` -> ``nnmstop.tasks.<name>``.
TASK_MODULES = ("exact", "hbm", "compare", "figures", "study", "manifest", "bundle", "verify")


def exact_two_impacts(config, inputs, outputs):
    """Exact two-impact NNM1 family of the non-smooth system (Section 3.1)."""
    from nnmstop.exact.two_impact import build_two_impact_dataset

    build_two_impact_dataset(config, outputs["dataset"])


def exact_nnm1(config, inputs, outputs):
    """Exact NNM1 with any number of impacts per period, continued from the two-impact family."""
    from nnmstop.exact.multi_impact import build_multi_impact_dataset

    build_multi_impact_dataset(config, inputs["two_impacts"], outputs["dataset"])


def hbm_stage(config, inputs, outputs, branch: str, stage: str | int):
    """One stage of a regularized NNM branch (HBM + ANM)."""
    from nnmstop.hbm.branches import continue_stage
    from nnmstop.netcdf import write_dataset

    stage = int(stage)
    previous = None
    if stage > 1:
        with xr.open_dataset(inputs["previous"]) as prev:
            previous = prev.load()
    ds = continue_stage(config, branch, stage, previous)
    name = config["branches"][branch]["stages"][stage - 1]["name"]
    write_dataset(
        ds,
        outputs["dataset"],
        title=f"Regularized {branch.upper()}, stage {stage} ({name}): HBM-ANM continuation",
        summary=(
            f"Periodic orbits of the regularized 2-DOF oscillator with a bilateral elastic stop along "
            f"{branch.upper()}, stage {stage} ({name}), computed by harmonic balance with "
            f"{ds.attrs['harmonics']} harmonics and the asymptotic numerical method."
        ),
        metadata=config.get("metadata"),
    )


def hbm_bifurcated(config, inputs, outputs, bifurcation: str):
    """The branch switched at a branch point of a regularized branch (``bifurcations.<name>``)."""
    from nnmstop.hbm.branches import bifurcated_branch
    from nnmstop.netcdf import write_dataset

    with xr.open_dataset(inputs["parent"]) as parent:
        ds = bifurcated_branch(config, bifurcation, parent.load())
    n, parent_name = ds.attrs["resonance"], ds.attrs["parent_branch"].upper()
    write_dataset(
        ds,
        outputs["dataset"],
        title=f"Branch bifurcating from regularized {parent_name} at the {n}:1 internal resonance ({bifurcation})",
        summary=(
            f"Periodic orbits of the regularized 2-DOF oscillator with a bilateral elastic stop on the curve "
            f"that crosses {parent_name} at its {n}:1 branch point (orbits of period T/{n}), reached by branch "
            f"switching and continued both ways by harmonic balance with {ds.attrs['harmonics']} harmonics "
            f"and the asymptotic numerical method."
        ),
        metadata=config.get("metadata"),
    )


def hbm_branch(config, inputs, outputs, branch: str):
    """Concatenate the stages of a branch into one dataset."""
    from nnmstop.hbm.branches import combine_stages
    from nnmstop.netcdf import write_dataset

    stages = []
    for path in inputs["stages"]:
        with xr.open_dataset(path) as ds:
            stages.append(ds.load())
    combined = combine_stages(stages)
    write_dataset(
        combined,
        outputs["dataset"],
        title=f"Regularized {branch.upper()}: HBM-ANM continuation, whole branch",
        summary=(
            f"Periodic orbits of the regularized 2-DOF oscillator with a bilateral elastic stop along "
            f"{branch.upper()}, from its linear mode to the end of the last continuation stage."
        ),
        metadata=config.get("metadata"),
    )


def compare_nnm1(config, inputs, outputs):
    """Exact vs regularized NNM1 at matched energies (inputs ``exact``, ``nnm1`` = stage 1)."""
    from nnmstop.compare.matching import build_comparison_dataset

    build_comparison_dataset(config, inputs, outputs["dataset"])


def compare_regimes(config, inputs, outputs):
    """Frequency error of the regularized NNM1 per impact regime, whole branch (inputs ``exact``, ``nnm1``)."""
    from nnmstop.compare.regimes import build_regime_error_dataset

    build_regime_error_dataset(config, inputs, outputs)


def regime_error_figure(config, inputs, outputs):
    """paper_figures/extra_regime_error.pdf/.png from the regime error dataset (input ``dataset``)."""
    from nnmstop.figures.regime_errors import build_regime_error_figure

    build_regime_error_figure(config, inputs["dataset"], outputs["pdf"])


def compare_stability(config, inputs, outputs):
    """Exact vs regularized Floquet verdicts of NNM1 per impact regime (inputs ``exact``, ``nnm1``)."""
    from nnmstop.compare.stability import build_stability_comparison

    build_stability_comparison(config, inputs, outputs)


def stability_figure(config, inputs, outputs):
    """paper_figures/extra_stability.pdf/.png (inputs ``exact``, ``nnm1``, ``dataset``)."""
    from nnmstop.figures.stability import build_stability_figure

    build_stability_figure(config, inputs, outputs["pdf"])


def paper_figure(name: str, config, inputs, outputs):
    """Draw paper figure ``name`` (``fig02`` ... ``fig11``) from its rule's datasets.

    Figs 2-4 read the exact family, NNM1 stage 1 and the comparison
    (:mod:`nnmstop.figures.exact_vs_regularized`); Figs 5-11 read the branch datasets
    (:mod:`nnmstop.figures.frequency_energy`). Outputs ``pdf`` and ``png``.
    """
    if name in ("fig02", "fig03", "fig04"):
        from nnmstop.figures.exact_vs_regularized import build_figure
    else:
        from nnmstop.figures.frequency_energy import build_paper_figure as build_figure
    build_figure(name, config, inputs, outputs)


# one task per paper figure, named as the rules call them: paper_fig02 ... paper_fig11
PAPER_FIGURE_TASKS = {f"paper_fig{n:02d}": functools.partial(paper_figure, f"fig{n:02d}") for n in range(2, 12)}


# Study (issue 5): error against run time, stiff cases. Measurements, kept apart from Figs 2-11.


def study_error_case(config, inputs, outputs, harmonics, eta):
    """One (H, eta) setting of the error-against-run-time study (input ``exact``)."""
    from nnmstop.study.error_runtime import build_error_case

    build_error_case(config, inputs, outputs["dataset"], harmonics, eta)


def study_anm_case(config, inputs, outputs, order, tolerance):
    """One ANM (order, tolerance) setting at ``study.error_runtime.anm_harmonics`` and ``model.eta``."""
    from nnmstop.study.error_runtime import build_error_case

    H = config["study"]["error_runtime"]["anm_harmonics"]
    build_error_case(config, inputs, outputs["dataset"], H, config["model"]["eta"], order, tolerance)


def study_reference(config, inputs, outputs, eta):
    """Large-H reference orbits of one eta (truncation/regularization split)."""
    from nnmstop.study.error_runtime import build_reference

    build_reference(config, inputs, outputs["dataset"], eta)


def study_exact_cost(config, inputs, outputs):
    """Cost per orbit of the exact solver."""
    from nnmstop.study.error_runtime import build_exact_cost

    build_exact_cost(config, inputs, outputs["dataset"])


def study_error_vs_runtime(config, inputs, outputs):
    """Gather the sweep into results/study/error_vs_runtime.nc."""
    from nnmstop.study.error_runtime import build_error_vs_runtime

    build_error_vs_runtime(config, inputs, outputs["dataset"])


def study_error_vs_runtime_figure(config, inputs, outputs):
    """paper_figures/error_vs_runtime.pdf/.png (input ``dataset``)."""
    from nnmstop.figures.study import build_error_vs_runtime_figure

    build_error_vs_runtime_figure(config, inputs["dataset"], outputs["pdf"])


def study_stiff_exact(config, inputs, outputs, alpha, beta, delta):
    """Exact family and its exactness checks for one (alpha, beta, delta)."""
    from nnmstop.study.stiff_cases import build_stiff_exact

    build_stiff_exact(config, inputs, outputs["dataset"], alpha, beta, delta)


def study_stiff_branch(config, inputs, outputs, alpha, beta, delta, eta):
    """Harmonics ladder of NNM1 stage 1 for one stiff case (input ``exact``)."""
    from nnmstop.study.stiff_cases import build_stiff_branch

    build_stiff_branch(config, inputs, outputs["dataset"], alpha, beta, delta, eta)


def study_stiff_energy(config, inputs, outputs, alpha):
    """Exact solver and HBM at energies 1e-6..1e6 for one alpha."""
    from nnmstop.study.stiff_cases import build_stiff_energy

    build_stiff_energy(config, inputs, outputs["dataset"], alpha)


def study_stiff_cases(config, inputs, outputs):
    """Gather the stiff cases into results/study/stiff_cases.nc."""
    from nnmstop.study.stiff_cases import build_stiff_cases

    build_stiff_cases(config, inputs, outputs["dataset"])


def study_stiff_cases_figure(config, inputs, outputs):
    """paper_figures/stiff_cases.pdf/.png (input ``dataset``)."""
    from nnmstop.figures.study import build_stiff_cases_figure

    build_stiff_cases_figure(config, inputs["dataset"], outputs["pdf"])


STUDY_TASKS = (
    study_error_case, study_anm_case, study_reference, study_exact_cost, study_error_vs_runtime,
    study_error_vs_runtime_figure, study_stiff_exact, study_stiff_branch, study_stiff_energy, study_stiff_cases,
    study_stiff_cases_figure,
)


TASKS = {
    **{f.__name__: f for f in (exact_two_impacts, exact_nnm1, hbm_stage, hbm_bifurcated, hbm_branch, compare_nnm1,
                               compare_regimes, regime_error_figure, compare_stability, stability_figure,
                               *STUDY_TASKS)},
    **PAPER_FIGURE_TASKS,
}


def _module_tasks(module) -> dict[str, Callable]:
    names = getattr(module, "__all__", None)
    if names is None:  # a module without __all__: its public functions
        names = [n for n, f in vars(module).items() if callable(f) and not n.startswith("_")
                 and getattr(f, "__module__", None) == module.__name__]
    return {name: getattr(module, name) for name in names if callable(getattr(module, name))}


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
    """Name of the module that holds task ``name``.

    Raises
    ------
    ValueError
        If no task module defines ``name``, or two do.
    """
    holders = [module for module, tasks in _task_modules().items() if name in tasks]
    if len(holders) > 1:
        raise ValueError(f"task {name!r} is defined in several task modules: {holders}")
    if holders:
        return holders[0]
    if name in TASKS:  # not moved to its task module yet
        return __name__
    raise ValueError(f"unknown task {name!r}; tasks are {sorted(task_table())}")


def find_task(name: str) -> Callable:
    """The function of task ``name`` (see :func:`task_module`)."""
    module = task_module(name)
    return TASKS[name] if module == __name__ else _task_modules()[module][name]


def task_table() -> dict[str, Callable]:
    """Every task, by name."""
    table = {name: TASKS[name] for name in TASKS}
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


def _as_dict(named) -> dict:
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
        task(config, _as_dict(inputs), _as_dict(outputs), **wildcards)
    except Exception:
        logger.exception("task %s failed", name)
        raise


def _pairs(values):
    out = {}
    for item in values or []:
        key, sep, value = item.partition("=")
        if not sep:
            raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {item!r}")
        out.setdefault(key, []).append(value)
    return {k: v[0] if len(v) == 1 else v for k, v in out.items()}


def main(argv=None) -> None:
    """Command line: ``python -m nnmstop.tasks.run TASK [options]``."""
    from nnmstop.config import load_config

    parser = argparse.ArgumentParser(prog="python -m nnmstop.tasks.run", description=__doc__.splitlines()[0])
    parser.add_argument("task", choices=sorted(task_table()))
    parser.add_argument("--config", default="config/config.yaml")
    parser.add_argument("--input", action="append", metavar="KEY=PATH", help="named input (repeatable)")
    parser.add_argument("--output", action="append", metavar="KEY=PATH", help="named output (repeatable)")
    parser.add_argument("--log", default="-", help="log file, '-' for stderr")
    parser.add_argument("--branch")
    parser.add_argument("--stage")
    parser.add_argument("--bifurcation", help="name under bifurcations (task hbm_bifurcated)")
    parser.add_argument("--wildcard", action="append", metavar="KEY=VALUE",
                        help="any other wildcard of the task's rule, e.g. --wildcard harmonics=100 (repeatable)")
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
