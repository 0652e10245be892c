"""Tasks of the figure rules: read the datasets named by a rule, take the figure's settings, draw.

The drawing functions (:mod:`nnmstop.figures`) take datasets and settings and never read
files or the configuration; the functions here are the only ones of the figures that do:
they pick the ``figures.<name>`` (or ``compare``, ``study``) settings of the validated
configuration, check the rule's named inputs and outputs, load the datasets and save the
PDF and its PNG side by side. Paths come from the rules (``workflow/rules/*.smk``).
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop.figures import exact_vs_regularized as comparison_figures
from nnmstop.figures import frequency_energy as fep
from nnmstop.figures import regime_errors as regime_error_drawing
from nnmstop.figures import stability as stability_drawing
from nnmstop.figures.common import save_figure
from nnmstop.figures.labels import place_labels
from nnmstop.figures.study import error_vs_runtime_figure, stiff_cases_figure
from nnmstop.hbm.dataset import is_skipped
from nnmstop.hbm.stages import combine_stages
from nnmstop.netcdf import read_dataset

__all__ = [
    "figure_config",
    "figure_nnm1_stages",
    "combine_nnm1_stages",
    "build_exact_vs_regularized_figure",
    "build_paper_figure",
    "build_regime_error_figure",
    "build_stability_figure",
    "build_error_vs_runtime_figure",
    "build_stiff_cases_figure",
]


def _as_list(value) -> list:
    if value is None:
        return []
    if isinstance(value, (str, Path)):
        return [value]
    return list(value)


def _pdf_and_png(name: str, outputs: dict) -> Path:
    """The PDF output, checked to have its PNG beside it (``save_figure`` writes both)."""
    pdf, png = Path(outputs["pdf"]), Path(outputs["png"])
    if pdf.suffix != ".pdf" or png != pdf.with_suffix(".png"):
        raise ValueError(f"{name}: outputs must be NAME.pdf and NAME.png side by side, got {pdf} and {png}")
    return pdf


def _need(name: str, inputs: dict, key: str):
    if key not in inputs or not inputs[key]:
        raise ValueError(f"{name}: missing input {key!r}, got {sorted(inputs)}")
    return inputs[key]


def figure_config(config: dict, name: str) -> dict:
    """The ``figures.<name>`` section of a validated configuration.

    Raises
    ------
    ValueError
        If the configuration has no ``figures`` section or no entry ``name``.
    """
    figures = config.get("figures")
    if not isinstance(figures, dict):
        raise ValueError("the configuration has no 'figures' section (config/config.yaml, key 'figures')")
    if name not in figures:
        raise ValueError(f"the configuration has no entry 'figures.{name}'")
    return figures[name]


def figure_nnm1_stages(config: dict, figure: str) -> list[int]:
    """Numbers of the NNM1 stages paper figure ``figure`` reads (``figures.<figure>.nnm1_stages``).

    Raises
    ------
    ValueError
        If the figure is not configured or names a stage that ``branches.nnm1`` lacks.
    """
    stages = figure_config(config, figure).get("nnm1_stages")
    if not stages:
        raise ValueError(f"the configuration has no 'figures.{figure}.nnm1_stages'")
    available = len(config["branches"]["nnm1"]["stages"])
    unknown = [k for k in stages if not 1 <= k <= available]
    if unknown:
        raise ValueError(
            f"figures.{figure}.nnm1_stages: stage(s) {unknown} do not exist (branches.nnm1 has {available} stages)"
        )
    return [int(k) for k in stages]


def combine_nnm1_stages(stages: list[xr.Dataset], where: str, expected: list[int] | None = None) -> xr.Dataset:
    """Check and concatenate consecutive stage datasets of NNM1 (skipped stages left out).

    Parameters
    ----------
    stages : list of xarray.Dataset
        Stage datasets in order (each holds a single ``stage`` value, or none when skipped).
    where : str
        Figure name, for messages.
    expected : list of int, optional
        Stage numbers the datasets must hold, in order (from the configuration).

    Returns
    -------
    xarray.Dataset
        The joined stages; when every one was skipped, the first of them (no point; the figure says why).

    Raises
    ------
    ValueError
        On NaN, a dataset of another branch, non-consecutive stages or stages other than ``expected``.
    """
    if not stages:
        raise ValueError(f"{where}: no NNM1 stage dataset given")
    numbers = []
    for ds in stages:
        fep.check_finite(ds, where)
        if ds.attrs.get("branch") != "nnm1":
            found = ds.attrs.get("branch")
            raise ValueError(
                f"{where}: expected a dataset of branch 'nnm1', got branch {found!r} ({fep.dataset_name(ds)})"
            )
        held = np.unique(ds["stage"].values) if not is_skipped(ds) else [ds.attrs.get("skipped_stage", 0)]
        if len(held) != 1:
            raise ValueError(f"{where}: {fep.dataset_name(ds)} is not a single-stage dataset")
        numbers.append(int(held[0]))
    if expected is not None and numbers != list(expected):
        raise ValueError(
            f"{where}: the NNM1 datasets hold stages {numbers}, the configuration asks for {list(expected)}"
        )
    if numbers != list(range(numbers[0], numbers[0] + len(numbers))):
        raise ValueError(f"{where}: NNM1 stages must be consecutive to be joined, got {numbers}")
    if all(is_skipped(ds) for ds in stages):
        return stages[0]
    if len(stages) == 1:
        return stages[0]
    combined = combine_stages(stages)
    combined.encoding = {}  # the first stage's file name would misname the combined branch
    return combined


def build_exact_vs_regularized_figure(name: str, config: dict, inputs: dict, outputs: dict) -> tuple[Path, Path]:
    """Paper figure ``name`` (``fig02``, ``fig03`` or ``fig04``) from its rule's inputs.

    Inputs: ``comparison`` (all three), plus ``exact`` and ``nnm1`` (stage 1) for
    ``fig02``. Outputs: ``pdf`` and ``png`` side by side. The PNG resolution is
    ``compare.png_dpi`` of the configuration.

    Raises
    ------
    ValueError
        On an unknown figure, a missing input, or outputs that are not NAME.pdf/NAME.png.
    """
    if name not in comparison_figures.FIGURES:
        raise ValueError(f"unknown figure {name!r}; this task draws {comparison_figures.FIGURES}")
    if "compare" not in config:
        raise ValueError("config lacks the section 'compare'")
    png_dpi = int(config["compare"]["png_dpi"])
    pdf = _pdf_and_png(name, outputs)
    needed = ("exact", "nnm1", "comparison") if name == "fig02" else ("comparison",)
    data = {key: read_dataset(_need(name, inputs, key)) for key in needed}
    if name == "fig02":
        return comparison_figures.figure_02(data["exact"], data["nnm1"], data["comparison"], pdf, png_dpi)
    builder = comparison_figures.figure_03 if name == "fig03" else comparison_figures.figure_04
    return builder(data["comparison"], pdf, png_dpi)


def build_paper_figure(name: str, config: dict, inputs: dict, outputs: dict) -> tuple[Path, Path]:
    """Paper figure ``name`` (``fig05`` ... ``fig11``) from the named inputs of its rule.

    Inputs: ``nnm1`` and ``nnm2`` (whole branches) for ``fig05``; ``nnm2`` for
    ``fig06``; ``nnm1_stages`` (list of stage files), optionally ``exact`` (the exact
    multi-impact NNM1 overlay) and, for Figs 8-10, ``nnm2`` and ``bifurcated`` (the files
    of ``figures.<name>.bifurcated``, possibly none). Outputs: ``pdf`` and ``png``.

    Raises
    ------
    ValueError
        If the outputs do not share a stem, an input is missing, or the figure
        cannot honour its configuration.
    """
    if name not in fep.PAPER_FIGURES:
        raise ValueError(f"unknown paper figure {name!r}; figures are {sorted(fep.PAPER_FIGURES)}")
    spec = figure_config(config, name)
    png_dpi = int(config["figures"].get("png_dpi", 150))
    pdf = _pdf_and_png(name, outputs)
    if name == "fig05":
        return fep.figure_05(
            read_dataset(_need(name, inputs, "nnm1")), read_dataset(_need(name, inputs, "nnm2")), spec, pdf, png_dpi
        )
    if name == "fig06":
        return fep.figure_06(read_dataset(_need(name, inputs, "nnm2")), spec, pdf, png_dpi)
    # the rule reads stages 1 .. the figure's last (each stage starts from the one before, so nothing more is
    # built); the figure draws its own stages, or its scene by physics where they hold no orbit
    read = [read_dataset(p) for p in _as_list(_need(name, inputs, "nnm1_stages"))]
    wanted = [int(k) for k in spec.get("nnm1_stages") or []]
    numbers = list(range(1, len(read) + 1))
    if wanted and numbers[-1] != max(wanted):
        raise ValueError(f"{name}: expected NNM1 stages 1-{max(wanted)} as inputs, got {len(read)} dataset(s)")
    whole = combine_nnm1_stages(read, name, numbers)
    stages = [ds for k, ds in zip(numbers, read) if k in wanted] if wanted else read
    nnm1 = combine_nnm1_stages(stages, name, wanted or None)
    # optional overlay of the exact multi-impact NNM1 (figures.overlay_exact)
    exact = read_dataset(inputs["exact"]) if inputs.get("exact") else None
    if name in ("fig07", "fig11"):
        builder = fep.figure_07 if name == "fig07" else fep.figure_11
        return builder(nnm1, spec, pdf, png_dpi, exact=exact, stages=stages, whole=whole)
    builder = {"fig08": fep.figure_08, "fig09": fep.figure_09, "fig10": fep.figure_10}[name]
    # branches switched at branch points (figures.<name>.bifurcated), one input file each
    wanted = spec.get("bifurcated", [])
    bifurcated = [read_dataset(p) for p in _as_list(_need(name, inputs, "bifurcated"))] if wanted else []
    if len(bifurcated) != len(wanted):
        raise ValueError(
            f"{name}: figures.{name}.bifurcated lists {wanted}, the inputs hold {len(bifurcated)} datasets"
        )
    nnm2 = read_dataset(_need(name, inputs, "nnm2"))
    return builder(nnm1, nnm2, spec, pdf, png_dpi, exact=exact, bifurcated=bifurcated, stages=stages, whole=whole)


def build_regime_error_figure(config: dict, dataset_path, pdf_path) -> tuple[Path, Path]:
    """Extra figure of the regime errors: ``pdf_path`` and its PNG (resolution ``figures.png_dpi``)."""
    dpi = int(config.get("figures", {}).get("png_dpi", 150))
    return save_figure(regime_error_drawing.regime_error_figure(read_dataset(dataset_path)), pdf_path, png_dpi=dpi)


def build_stability_figure(config: dict, inputs: dict, pdf_path) -> tuple[Path, Path]:
    """Extra stability figure and its PNG (task of rule ``stability_figure``).

    ``inputs``: ``exact`` and ``nnm1`` (branch datasets), ``dataset`` (the stability comparison).
    """
    for key in ("exact", "nnm1", "dataset"):
        if key not in inputs:
            raise ValueError(f"missing input {key!r}; inputs are {sorted(inputs)}")
    figures = config.get("figures", {})
    dpi = int(figures.get("png_dpi", 150))
    zoom = figures.get("extra_stability", {}).get("zoom_energy")  # None: where the changes crowd
    fig = stability_drawing.stability_figure(
        read_dataset(inputs["exact"]), read_dataset(inputs["nnm1"]), read_dataset(inputs["dataset"]), zoom_energy=zoom
    )
    return save_figure(fig, pdf_path, png_dpi=dpi)


def build_error_vs_runtime_figure(config: dict, dataset_path, pdf_path) -> tuple[Path, Path]:
    """The study's error-against-run-time figure and its PNG (resolution ``study.png_dpi``)."""
    fig = error_vs_runtime_figure(read_dataset(dataset_path))
    return save_figure(fig, pdf_path, png_dpi=int(config["study"]["png_dpi"]), after_layout=place_labels)


def build_stiff_cases_figure(config: dict, dataset_path, pdf_path) -> tuple[Path, Path]:
    """The study's stiff-cases figure and its PNG (resolution ``study.png_dpi``)."""
    fig = stiff_cases_figure(read_dataset(dataset_path))
    return save_figure(fig, pdf_path, png_dpi=int(config["study"]["png_dpi"]))


# --------------------------------------------------------------------------- the rules' tasks


def regime_error_figure(config, inputs, outputs):
    """paper_figures/extra_regime_error.pdf/.png from the regime error dataset (input ``dataset``)."""
    build_regime_error_figure(config, inputs["dataset"], outputs["pdf"])


def stability_figure(config, inputs, outputs):
    """paper_figures/extra_stability.pdf/.png (inputs ``exact``, ``nnm1``, ``dataset``)."""
    build_stability_figure(config, inputs, outputs["pdf"])


def paper_figure(name: str, config, inputs, outputs):
    """Draw paper figure ``name`` (``fig02`` ... ``fig11``) from its rule's datasets.

    Figs 2-4 read the exact family, NNM1 stage 1 and the comparison
    (:mod:`nnmstop.figures.exact_vs_regularized`); Figs 5-11 read the branch datasets
    (:mod:`nnmstop.figures.frequency_energy`). Outputs ``pdf`` and ``png``.
    """
    build_figure = build_exact_vs_regularized_figure if name in ("fig02", "fig03", "fig04") else build_paper_figure
    build_figure(name, config, inputs, outputs)


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {
    **{f.__name__: f for f in (regime_error_figure, stability_figure)},
    # one task per paper figure, named as the rules call them: paper_fig02 ... paper_fig11
    **{f"paper_fig{n:02d}": functools.partial(paper_figure, f"fig{n:02d}") for n in range(2, 12)},
}
