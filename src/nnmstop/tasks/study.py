"""Tasks of ``workflow/rules/study.smk``: read the input datasets, run one study job, write its dataset.

The configuration becomes :class:`~nnmstop.settings.StudySettings` (:func:`nnmstop.settings.study_settings`);
the study's numerics (:mod:`nnmstop.study.error_runtime`, :mod:`nnmstop.study.stiff_cases`)
take those settings and datasets and return datasets; the file names of the jobs are the
rules' (``study.smk`` builds them from :func:`~nnmstop.study.error_runtime.sweep_cases` and
:func:`~nnmstop.study.stiff_cases.stiff_case_parameters`). The gathers receive the job files in
that order and hand their datasets on. The outputs are measurements (run times): exempt from
byte-identical reruns and never read by the paper's figures.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

from nnmstop.netcdf import read_dataset, write_dataset
from nnmstop.settings import exact_settings, model_parameters, study_settings
from nnmstop.study import error_runtime, stiff_cases
from nnmstop.tasks.manifest import dataset_manifest

__all__ = [
    "build_error_case",
    "build_reference",
    "build_exact_cost",
    "build_error_vs_runtime",
    "build_stiff_exact",
    "build_stiff_branch",
    "build_stiff_energy",
    "build_stiff_cases",
]

logger = logging.getLogger(__name__)


def _read_all(paths) -> list:
    return [read_dataset(p) for p in ([paths] if isinstance(paths, (str, Path)) else paths)]


# --------------------------------------------------------------------------- error against run time


def build_error_case(config: dict, inputs: dict, output_path, harmonics, eta, order=None, tolerance=None) -> Path:
    """One sweep setting (input ``exact``: the exact two-impact family), written to ``output_path``."""
    exact = read_dataset(inputs["exact"])
    order = None if order is None else int(order)
    tolerance = None if tolerance is None else float(tolerance)
    ds = error_runtime.error_case_dataset(study_settings(config), exact, int(harmonics), float(eta), order, tolerance)
    logger.info(
        "converged %s, compared %s, runtime %.3f s; %s",
        bool(ds["converged"]),
        bool(ds["compared"]),
        float(ds["runtime"]),
        str(ds["failure"].values) or "no failure",
    )
    return write_dataset(
        ds,
        output_path,
        kind="study_case",
        title="Study case: regularized NNM1 stage 1 against the exact orbits, timed",
        summary="One setting of the error-against-run-time study (measurement; not part of the paper's figures).",
        keywords="study, run time",
        metadata=config.get("metadata"),
    )


def build_reference(config: dict, inputs: dict, output_path, eta) -> Path:
    """The large-H reference orbits of one ``eta`` (input ``exact``)."""
    ds = error_runtime.reference_dataset(study_settings(config), read_dataset(inputs["exact"]), float(eta))
    return write_dataset(
        ds,
        output_path,
        kind="study_reference",
        title="Study reference: regularized NNM1 orbits with many harmonics at the study energies",
        summary="Large-H reference of the error-against-run-time study (measurement; not part of the paper's figures).",
        keywords="study, reference",
        metadata=config.get("metadata"),
    )


def build_exact_cost(config: dict, inputs: dict, output_path) -> Path:
    """The exact solver's cost per orbit (sections ``model``, ``exact``, ``study.phase_samples``)."""
    samples = int(config["study"]["phase_samples"])
    return write_dataset(
        error_runtime.exact_cost_dataset(model_parameters(config), exact_settings(config), samples),
        output_path,
        kind="exact_cost",
        title="Study: cost of the exact two-impact solver",
        summary="Run time per orbit of the closed-form exact solver (measurement).",
        keywords="study, run time",
        metadata=config.get("metadata"),
    )


def build_error_vs_runtime(config: dict, inputs: dict, output_path) -> Path:
    """Gather the sweep: inputs ``cases``, ``anm_cases``, ``references`` (in the order of
    :func:`~nnmstop.study.error_runtime.sweep_cases`) and ``exact_cost``."""
    ds = error_runtime.gather_error_vs_runtime(
        study_settings(config),
        _read_all(inputs["cases"]),
        _read_all(inputs["anm_cases"]),
        _read_all(inputs["references"]),
        read_dataset(inputs["exact_cost"]),
    )
    return write_dataset(
        ds,
        output_path,
        kind="error_vs_runtime",
        title="Error against run time of the regularized NNM1 (HBM + ANM) on its two-impact range",
        summary=(
            "Errors of the regularized NNM1 against the exact non-smooth orbits at matched energies, split into "
            "regularization and truncation parts, with measured run times and factorization counts, over the number "
            "of harmonics, the regularization parameter and the ANM order and tolerance. Measurements: exempt from "
            "byte-identical reruns; not used by the paper's figures."
        ),
        keywords="study, accuracy, run time, regularization, truncation",
        metadata=config.get("metadata"),
    )


# --------------------------------------------------------------------------- stiff cases


def build_stiff_exact(config: dict, inputs: dict, output_path, alpha, beta, delta) -> Path:
    """Exact family and checks of one ``(alpha, beta, delta)`` (sections ``model``, ``exact``)."""
    params = replace(model_parameters(config), alpha=float(alpha), beta=float(beta), delta=float(delta))
    ds = stiff_cases.stiff_exact_dataset(params, exact_settings(config))
    return write_dataset(
        ds,
        output_path,
        kind="stiff_exact",
        title="Study (stiff cases): exact two-impact NNM1 family with exactness checks",
        summary="Exact family, residuals, periodicity by event-located integration (measurement of the study).",
        keywords="study, stiff cases",
        metadata=config.get("metadata"),
    )


def build_stiff_branch(config: dict, inputs: dict, output_path, alpha, beta, delta, eta) -> Path:
    """Harmonics ladder of one stiff case against its exact family (input ``exact``)."""
    exact = read_dataset(inputs["exact"])
    settings = study_settings(config)
    out = stiff_cases.stiff_branch_dataset(settings, exact, float(alpha), float(beta), float(delta), float(eta))
    logger.info(
        "converged %s with H = %d; %s",
        bool(out["converged"]),
        int(out["harmonics"]),
        str(out["failure"].values) or "compared",
    )
    return write_dataset(
        out,
        output_path,
        kind="stiff_nnm1",
        title="Study (stiff cases): regularized NNM1 stage 1, harmonics needed and error",
        summary="Harmonics ladder of a guarded continuation against the exact family (measurement of the study).",
        keywords="study, stiff cases",
        metadata=config.get("metadata"),
    )


def build_stiff_energy(config: dict, inputs: dict, output_path, alpha) -> Path:
    """The energy sweep of one ``alpha``."""
    return write_dataset(
        stiff_cases.energy_sweep_dataset(study_settings(config), float(alpha)),
        output_path,
        kind="stiff_energy",
        title="Study (stiff cases): exact solver and HBM at energies from 1e-6 to 1e6",
        summary="Exact orbits and their periodicity by integration, and HBM orbits, at extreme energies (study).",
        keywords="study, stiff cases",
        metadata=config.get("metadata"),
    )


def build_stiff_cases(config: dict, inputs: dict, output_path) -> Path:
    """Gather the stiff cases: inputs ``exact``, ``branches``, ``energy`` (in the order of
    :func:`~nnmstop.study.stiff_cases.stiff_case_parameters`)."""
    ds = stiff_cases.gather_stiff_cases(
        study_settings(config), _read_all(inputs["exact"]), _read_all(inputs["branches"]), _read_all(inputs["energy"])
    )
    return write_dataset(
        ds,
        output_path,
        kind="stiff_cases",
        title="Stiff and extreme cases: exactness of the exact solver, convergence of the continuation, errors",
        summary=(
            "For stiff stops (alpha up to 1e4), sharp regularizations (eta down to 1e-3), extreme energies "
            "(1e-6 to 1e6) "
            "and stiffness and mass ratios from 0.01 to 100: residuals and periodicity of the exact orbits, the "
            "harmonics and steps the continuation needs (or why it cannot), and its distance to the exact orbits."
        ),
        keywords="study, stiff cases, robustness",
        metadata=config.get("metadata"),
    )


# --------------------------------------------------------------------------- the rules' tasks


def study_error_case(config, inputs, outputs, harmonics, eta):
    """One (H, eta) setting of the error-against-run-time study (input ``exact``)."""
    build_error_case(config, inputs, outputs["dataset"], harmonics, eta)


def study_anm_case(config, inputs, outputs, order, tolerance):
    """One ANM (order, tolerance) setting at ``study.error_runtime.anm_harmonics`` and ``model.eta``."""
    settings = study_settings(config)
    H, eta = settings.sweep().anm_harmonics, settings.run.params.eta
    build_error_case(config, inputs, outputs["dataset"], H, eta, order, tolerance)


def study_reference(config, inputs, outputs, eta):
    """Large-H reference orbits of one eta (truncation/regularization split)."""
    build_reference(config, inputs, outputs["dataset"], eta)


def study_exact_cost(config, inputs, outputs):
    """Cost per orbit of the exact solver."""
    build_exact_cost(config, inputs, outputs["dataset"])


def study_error_vs_runtime(config, inputs, outputs):
    """Gather the sweep into results/study/error_vs_runtime.nc."""
    build_error_vs_runtime(config, inputs, outputs["dataset"])


def study_error_vs_runtime_figure(config, inputs, outputs):
    """paper_figures/error_vs_runtime.pdf/.png (input ``dataset``)."""
    from nnmstop.tasks.figures import build_error_vs_runtime_figure

    build_error_vs_runtime_figure(config, inputs["dataset"], outputs["pdf"])


def study_stiff_exact(config, inputs, outputs, alpha, beta, delta):
    """Exact family and its exactness checks for one (alpha, beta, delta)."""
    build_stiff_exact(config, inputs, outputs["dataset"], alpha, beta, delta)


def study_stiff_branch(config, inputs, outputs, alpha, beta, delta, eta):
    """Harmonics ladder of NNM1 stage 1 for one stiff case (input ``exact``)."""
    build_stiff_branch(config, inputs, outputs["dataset"], alpha, beta, delta, eta)


def study_stiff_energy(config, inputs, outputs, alpha):
    """Exact solver and HBM at energies 1e-6..1e6 for one alpha."""
    build_stiff_energy(config, inputs, outputs["dataset"], alpha)


def study_stiff_cases(config, inputs, outputs):
    """Gather the stiff cases into results/study/stiff_cases.nc."""
    build_stiff_cases(config, inputs, outputs["dataset"])


def study_stiff_cases_figure(config, inputs, outputs):
    """paper_figures/stiff_cases.pdf/.png (input ``dataset``)."""
    from nnmstop.tasks.figures import build_stiff_cases_figure

    build_stiff_cases_figure(config, inputs["dataset"], outputs["pdf"])


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {
    f.__name__: f
    for f in (
        study_error_case,
        study_anm_case,
        study_reference,
        study_exact_cost,
        study_error_vs_runtime,
        study_error_vs_runtime_figure,
        study_stiff_exact,
        study_stiff_branch,
        study_stiff_energy,
        study_stiff_cases,
        study_stiff_cases_figure,
    )
}
TASKS["study_manifest"] = dataset_manifest  # SHA-256 manifest of the gathered study datasets, as the paper's
