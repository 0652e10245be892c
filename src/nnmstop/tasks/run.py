"""Tasks of the Snakemake workflow, callable from rules and from the command line.

Every rule of ``workflow/rules/*.smk`` is a one-line call of :func:`run_task`; the
same task runs standalone for debugging::

    python -m nnmstop.tasks.run hbm_stage --branch nnm1 --stage 2 \\
        --input previous=results/hbm/stages/nnm1_stage1.nc \\
        --output dataset=/tmp/nnm1_stage2.nc

Wildcards of other rules go through ``--wildcard KEY=VALUE`` (for example the study's
``--wildcard harmonics=100 --wildcard eta=0.1``).

A task reads the validated configuration, its named inputs and writes its named
outputs; its log goes to the rule's ``log:`` file (or stderr).
"""

from __future__ import annotations

import argparse
import functools
import logging
import sys
from pathlib import Path

from nnmstop.tasks.hbm import hbm_bifurcated, hbm_branch, hbm_stage

__all__ = ["TASKS", "run_task", "main"]

logger = logging.getLogger("nnmstop.tasks.run")


def exact_two_impacts(config, inputs, outputs):
    """Exact two-impact NNM1 family of the non-smooth system (Section 3.1)."""
    from nnmstop.tasks.exact import build_two_impact_dataset

    build_two_impact_dataset(config, outputs["dataset"])


def exact_nnm1(config, inputs, outputs):
    """Exact NNM1 with any number of impacts per period, continued from the two-impact family."""
    from nnmstop.tasks.exact import build_multi_impact_dataset

    build_multi_impact_dataset(config, inputs["two_impacts"], outputs["dataset"])


def compare_nnm1(config, inputs, outputs):
    """Exact vs regularized NNM1 at matched energies (inputs ``exact``, ``nnm1`` = stage 1)."""
    from nnmstop.tasks.compare import build_comparison_dataset

    build_comparison_dataset(config, inputs, outputs["dataset"])


def compare_regimes(config, inputs, outputs):
    """Frequency error of the regularized NNM1 per impact regime, whole branch (inputs ``exact``, ``nnm1``)."""
    from nnmstop.tasks.compare import build_regime_error_dataset

    build_regime_error_dataset(config, inputs, outputs)


def regime_error_figure(config, inputs, outputs):
    """paper_figures/extra_regime_error.pdf/.png from the regime error dataset (input ``dataset``)."""
    from nnmstop.tasks.figures import build_regime_error_figure

    build_regime_error_figure(config, inputs["dataset"], outputs["pdf"])


def compare_stability(config, inputs, outputs):
    """Exact vs regularized Floquet verdicts of NNM1 per impact regime (inputs ``exact``, ``nnm1``)."""
    from nnmstop.tasks.compare import build_stability_comparison

    build_stability_comparison(config, inputs, outputs)


def stability_figure(config, inputs, outputs):
    """paper_figures/extra_stability.pdf/.png (inputs ``exact``, ``nnm1``, ``dataset``)."""
    from nnmstop.tasks.figures import build_stability_figure

    build_stability_figure(config, inputs, outputs["pdf"])


def paper_figure(name: str, config, inputs, outputs):
    """Draw paper figure ``name`` (``fig02`` ... ``fig11``) from its rule's datasets.

    Figs 2-4 read the exact family, NNM1 stage 1 and the comparison
    (:mod:`nnmstop.figures.exact_vs_regularized`); Figs 5-11 read the branch datasets
    (:mod:`nnmstop.figures.frequency_energy`). Outputs ``pdf`` and ``png``.
    """
    if name in ("fig02", "fig03", "fig04"):
        from nnmstop.tasks.figures import build_exact_vs_regularized_figure as build_figure
    else:
        from nnmstop.tasks.figures import build_paper_figure as build_figure
    build_figure(name, config, inputs, outputs)


def dataset_manifest(config, inputs, outputs):
    """SHA-256 manifest of the datasets (``sha256sum -c`` format, paths as given)."""
    import hashlib

    lines = []
    for path in sorted(inputs["datasets"] if not isinstance(inputs["datasets"], str) else [inputs["datasets"]]):
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        lines.append(f"{digest}  {path}\n")
    out = Path(outputs["manifest"])
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("".join(lines))


def bundle(config, inputs, outputs):
    """The result bundle (``nnmstop.bundle.build_bundle``): datasets, figures, manifest, lock, workflow."""
    from nnmstop.bundle import build_bundle

    def as_list(value):
        return [value] if isinstance(value, str) else list(value)

    build_bundle(
        config, datasets=as_list(inputs["datasets"]), figures=as_list(inputs["figures"]), manifest=inputs["manifest"],
        environment_lock=inputs["environment_lock"], workflow_files=as_list(inputs["workflow_files"]),
        output=outputs["bundle"],
    )


# one task per paper figure, named as the rules call them: paper_fig02 ... paper_fig11
PAPER_FIGURE_TASKS = {f"paper_fig{n:02d}": functools.partial(paper_figure, f"fig{n:02d}") for n in range(2, 12)}


# Study (issue 5): error against run time, stiff cases. Measurements, kept apart from Figs 2-11.


def study_error_case(config, inputs, outputs, harmonics, eta):
    """One (H, eta) setting of the error-against-run-time study (input ``exact``)."""
    from nnmstop.tasks.study import build_error_case

    build_error_case(config, inputs, outputs["dataset"], harmonics, eta)


def study_anm_case(config, inputs, outputs, order, tolerance):
    """One ANM (order, tolerance) setting at ``study.error_runtime.anm_harmonics`` and ``model.eta``."""
    from nnmstop.tasks.study import build_error_case

    H = config["study"]["error_runtime"]["anm_harmonics"]
    build_error_case(config, inputs, outputs["dataset"], H, config["model"]["eta"], order, tolerance)


def study_reference(config, inputs, outputs, eta):
    """Large-H reference orbits of one eta (truncation/regularization split)."""
    from nnmstop.tasks.study import build_reference

    build_reference(config, inputs, outputs["dataset"], eta)


def study_exact_cost(config, inputs, outputs):
    """Cost per orbit of the exact solver."""
    from nnmstop.tasks.study import build_exact_cost

    build_exact_cost(config, inputs, outputs["dataset"])


def study_error_vs_runtime(config, inputs, outputs):
    """Gather the sweep into results/study/error_vs_runtime.nc."""
    from nnmstop.tasks.study import build_error_vs_runtime

    build_error_vs_runtime(config, inputs, outputs["dataset"])


def study_error_vs_runtime_figure(config, inputs, outputs):
    """paper_figures/error_vs_runtime.pdf/.png (input ``dataset``)."""
    from nnmstop.tasks.figures import build_error_vs_runtime_figure

    build_error_vs_runtime_figure(config, inputs["dataset"], outputs["pdf"])


def study_stiff_exact(config, inputs, outputs, alpha, beta, delta):
    """Exact family and its exactness checks for one (alpha, beta, delta)."""
    from nnmstop.tasks.study import build_stiff_exact

    build_stiff_exact(config, inputs, outputs["dataset"], alpha, beta, delta)


def study_stiff_branch(config, inputs, outputs, alpha, beta, delta, eta):
    """Harmonics ladder of NNM1 stage 1 for one stiff case (input ``exact``)."""
    from nnmstop.tasks.study import build_stiff_branch

    build_stiff_branch(config, inputs, outputs["dataset"], alpha, beta, delta, eta)


def study_stiff_energy(config, inputs, outputs, alpha):
    """Exact solver and HBM at energies 1e-6..1e6 for one alpha."""
    from nnmstop.tasks.study import build_stiff_energy

    build_stiff_energy(config, inputs, outputs["dataset"], alpha)


def study_stiff_cases(config, inputs, outputs):
    """Gather the stiff cases into results/study/stiff_cases.nc."""
    from nnmstop.tasks.study import build_stiff_cases

    build_stiff_cases(config, inputs, outputs["dataset"])


def study_stiff_cases_figure(config, inputs, outputs):
    """paper_figures/stiff_cases.pdf/.png (input ``dataset``)."""
    from nnmstop.tasks.figures import build_stiff_cases_figure

    build_stiff_cases_figure(config, inputs["dataset"], outputs["pdf"])


STUDY_TASKS = (
    study_error_case, study_anm_case, study_reference, study_exact_cost, study_error_vs_runtime,
    study_error_vs_runtime_figure, study_stiff_exact, study_stiff_branch, study_stiff_energy, study_stiff_cases,
    study_stiff_cases_figure,
)


TASKS = {
    **{f.__name__: f for f in (exact_two_impacts, exact_nnm1, hbm_stage, hbm_bifurcated, hbm_branch, compare_nnm1,
                               compare_regimes, regime_error_figure, compare_stability, stability_figure,
                               dataset_manifest, bundle, *STUDY_TASKS)},
    **PAPER_FIGURE_TASKS,
}


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


def run_task(name: str, config: dict, inputs=None, outputs=None, log: str | None = None, **wildcards):
    """Run task ``name`` with named inputs/outputs (Snakemake ``Namedlist`` or dict).

    ``log`` is the path of the log file (None or '-' for stderr).
    """
    if name not in TASKS:
        raise ValueError(f"unknown task {name!r}; tasks are {sorted(TASKS)}")
    configure_logging(log)
    inputs = dict(inputs.items()) if hasattr(inputs, "items") else dict(inputs or {})
    outputs = dict(outputs.items()) if hasattr(outputs, "items") else dict(outputs or {})
    try:
        TASKS[name](config, inputs, outputs, **wildcards)
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
    parser.add_argument("task", choices=sorted(TASKS))
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
