"""Figs 5-11 of the paper: frequency-energy plots of the regularized NNMs with modal lines.

Every figure is drawn from branch datasets (layout of :mod:`nnmstop.hbm.dataset`) and its
``figures.<name>`` settings: energies, frequencies and impact counts of the points, and the
modal lines of the labelled points from their Fourier coefficients; nothing is solved. NNM1 is
blue, NNM2 green, the NNM2 curve divided by 5 red (as in the paper); frequencies in Hz of the
nondimensional time, energies on a logarithmic axis.

* Fig 5: NNM1 and NNM2 over the whole energy range; Fig 6: NNM2 with modal lines a)-f).
* Fig 7: NNM1 at low energy, a)-c); Fig 11: NNM1 at high energy, tending to the gap-0 mode.
* Figs 8-10: NNM1 with the NNM2 curve at ``f2/3`` (``f2/5``), the 3:1 (5:1) internal resonance
  and the branch switched there (an NNM2 orbit read over ``3T`` (``5T``) has the fundamental
  frequency ``f2/3`` (``f2/5``) at the same energy, see the project NOTES).

The dashed lines are the linear modes of the gap-0 system, from the model parameters stored in
the datasets. Anything a figure cannot honour (a NaN, a label energy outside the data or the
plotted window) raises a :class:`ValueError` naming it. Reading the files, joining the NNM1
stages and the settings: :mod:`nnmstop.tasks.figures`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.ticker import LogFormatterSciNotation

from nnmstop.figures.common import (
    EXACT_OVERLAY_COLOR,
    NNM2_COLOR,
    REGULARIZED_COLOR,
    RESONANCE_COLOR,
    frequency_energy_axes,
    plot_branch,
    save_figure,
    stability_legend_handles,
)
from nnmstop.figures.modal_lines import LabelSpec, draw_modal_line, label_specs, mark_point, select_point
from nnmstop.models.two_dof import ModelParameters, linear_modes

__all__ = [
    "PAPER_FIGURES",
    "dataset_name",
    "check_finite",
    "model_parameters",
    "gap_zero_frequencies",
    "figure_05",
    "figure_06",
    "figure_07",
    "figure_08",
    "figure_09",
    "figure_10",
    "figure_11",
]

logger = logging.getLogger("nnmstop.figures")

NNM1_COLOR = REGULARIZED_COLOR
GAP_ZERO_STYLE = {"color": "0.25", "ls": (0, (5, 3)), "lw": 0.9}
BIFURCATED_COLOR = "black"
BRANCH_POINT_STYLES = {
    "resonance": {"marker": "x", "ms": 5, "mew": 1.1, "color": "black", "ls": "none", "zorder": 5},
    "branch point": {"marker": "x", "ms": 5, "mew": 1.1, "color": "black", "ls": "none", "zorder": 5},
    "breaking": {"marker": "+", "ms": 7, "mew": 1.1, "color": "black", "ls": "none", "zorder": 5},
    "fold": {"marker": "D", "ms": 3, "mew": 0.8, "mfc": "none", "color": "0.35", "ls": "none", "zorder": 4.5},
}
PARAMETER_KEYS = ("alpha", "beta", "delta", "eta")


@dataclass(frozen=True)
class _FigureKind:
    """What a paper figure shows: the branch with the modal lines and its companions."""

    branch: str  # "nnm1" or "nnm2": the branch whose points are labelled
    title: str
    resonance: int | None = None  # n: the NNM2 curve at f2/n is drawn
    resonance_color: str = NNM2_COLOR
    gap_zero_modes: tuple[int, ...] = (1,)
    inset_gap_zero_mode: int | None = None  # draw this gap-0 modal line (dashed) in the insets


PAPER_FIGURES = {
    "fig05": _FigureKind(
        "nnm1", "Fig. 5: first (NNM1) and second (NNM2) nonlinear normal modes", gap_zero_modes=(1, 2)
    ),
    "fig06": _FigureKind("nnm2", "Fig. 6: second NNM and its modal lines", gap_zero_modes=(2,), inset_gap_zero_mode=2),
    "fig07": _FigureKind("nnm1", "Fig. 7: first NNM at low energy"),
    "fig08": _FigureKind(
        "nnm1", "Fig. 8: first NNM, three then two impacts per stop, 3:1 internal resonance", 3, NNM2_COLOR
    ),
    "fig09": _FigureKind(
        "nnm1", "Fig. 9: first NNM, four then five impacts per stop, 5:1 internal resonance", 5, RESONANCE_COLOR
    ),
    "fig10": _FigureKind(
        "nnm1", "Fig. 10: first NNM after the 5:1 internal resonance, back to one impact per stop", 5, RESONANCE_COLOR
    ),
    "fig11": _FigureKind(
        "nnm1", "Fig. 11: first NNM at high energy, tending to the gap-0 first linear mode", inset_gap_zero_mode=1
    ),
}


# --------------------------------------------------------------------------- configuration, checks


def dataset_name(ds: xr.Dataset) -> str:
    """How messages name a branch dataset: branch, stage(s) and file when known."""
    branch = str(ds.attrs.get("branch", "dataset")).upper()
    if "stage" in ds:
        stages = np.unique(ds["stage"].values)
        text = f"{branch} stage{'s' if stages.size > 1 else ''} {', '.join(str(int(s)) for s in stages)}"
    else:
        text = branch
    source = ds.encoding.get("source")
    return f"{text} ({source})" if source else text


def check_finite(ds: xr.Dataset, where: str) -> None:
    """Raise ``ValueError`` if a numeric variable of ``ds`` holds NaN or infinite values.

    The message names ``where`` (the figure), the dataset, the variable and the
    first offending point.
    """
    for name, var in {**ds.coords, **ds.data_vars}.items():
        if not np.issubdtype(var.dtype, np.number):
            continue
        bad = ~np.isfinite(var.values)
        if bad.any():
            first = ""
            if "point" in var.dims:
                axis = var.dims.index("point")
                rows = np.flatnonzero(bad.any(axis=tuple(a for a in range(bad.ndim) if a != axis)))
                first = f" (first at point {int(rows[0])})"
            raise ValueError(
                f"{where}: dataset {dataset_name(ds)}: variable {name!r} holds {int(bad.sum())} NaN or "
                f"infinite value(s){first}; refusing to draw it"
            )


def _check_branch(ds: xr.Dataset, branch: str, where: str) -> None:
    found = ds.attrs.get("branch")
    if found != branch:
        raise ValueError(f"{where}: expected a dataset of branch {branch!r}, got branch {found!r} ({dataset_name(ds)})")


def model_parameters(*datasets: xr.Dataset, where: str = "figure") -> ModelParameters:
    """Model parameters stored in the datasets' attributes, checked to agree.

    Raises
    ------
    ValueError
        If a dataset lacks a parameter or two datasets disagree.
    """
    values = None
    for ds in datasets:
        missing = [k for k in PARAMETER_KEYS if k not in ds.attrs]
        if missing:
            raise ValueError(f"{where}: dataset {dataset_name(ds)} lacks the model attribute(s) {missing}")
        these = {k: float(ds.attrs[k]) for k in PARAMETER_KEYS}
        if values is None:
            values = these
        elif these != values:
            raise ValueError(f"{where}: datasets of different models: {values} and {these} ({dataset_name(ds)})")
    return ModelParameters(**values)


def gap_zero_frequencies(params: ModelParameters) -> np.ndarray:
    """Frequencies (Hz) of the two linear modes of the gap-0 system (stop always engaged)."""
    return linear_modes(params, "gap_zero")[0] / (2 * np.pi)


def _parameter_line(params: ModelParameters, ds: xr.Dataset) -> str:
    text = f"α = {params.alpha:g}, β = {params.beta:g}, δ = {params.delta:g}, η = {params.eta:g}"
    if "harmonics" in ds.attrs:
        text += f", H = {int(ds.attrs['harmonics'])}"
    return text


# --------------------------------------------------------------------------- drawing


def _range(spec: dict, key: str, where: str):
    value = spec.get(key)
    if value is None:
        return None
    lo, hi = (float(v) for v in value)
    if not lo < hi:
        raise ValueError(f"{where}: {key} must be increasing, got {value!r}")
    return lo, hi


def _bifurcation_markers(ax, ds: xr.Dataset) -> set:
    """Mark the branch points and energy folds of ``ds``; return the kinds drawn.

    Located values (``branch_point_*``, ``fold_*``) are used when the dataset has them,
    the flagged points otherwise. Kinds: ``"resonance"`` (the orbit has period T/n),
    ``"breaking"`` (symmetry-breaking crossing), ``"branch point"`` (flag only), ``"fold"``.
    """
    drawn = set()
    if "branch_point_energy" in ds:
        e, f = ds["branch_point_energy"].values, ds["branch_point_frequency"].values
        resonance = ds["branch_point_resonance"].values > 0
        for kind, mask in (("resonance", resonance), ("breaking", ~resonance)):
            if mask.any():
                ax.plot(e[mask], f[mask], **BRANCH_POINT_STYLES[kind])
                drawn.add(kind)
    elif "branch_point" in ds and ds["branch_point"].values.any():
        idx = np.flatnonzero(ds["branch_point"].values)
        ax.plot(ds["energy"].values[idx], ds["frequency"].values[idx], **BRANCH_POINT_STYLES["branch point"])
        drawn.add("branch point")
    if "fold_energy" in ds and ds.sizes.get("located_fold", 0):
        ax.plot(ds["fold_energy"].values, ds["fold_frequency"].values, **BRANCH_POINT_STYLES["fold"])
        drawn.add("fold")
    return drawn


def _bifurcation_legend(drawn: set) -> list:
    text = {
        "resonance": "branch point, n:1 resonance (orbit of period T/n)",
        "breaking": "branch point, symmetry breaking",
        "branch point": "branch point",
        "fold": "energy fold",
    }
    return [
        Line2D([], [], label=text[k], **{a: v for a, v in BRANCH_POINT_STYLES[k].items() if a != "zorder"})
        for k in ("resonance", "breaking", "branch point", "fold")
        if k in drawn
    ]


def _auto_limits(ds_list, energy_range, levels=()):
    """Frequency limits covering the branches within the energy window and the
    horizontal ``levels`` (the gap-0 asymptotes), with room for the letters above."""
    freqs = [np.asarray(levels, dtype=float)]
    for ds in ds_list:
        e, f = ds["energy"].values, ds["frequency"].values
        inside = (
            np.ones(e.shape, dtype=bool) if energy_range is None else (e >= energy_range[0]) & (e <= energy_range[1])
        )
        freqs.append(f[inside])
    f = np.concatenate(freqs)
    if f.size == 0:
        return None
    span = max(float(f.max() - f.min()), 1e-3 * float(f.max()))
    return float(f.min()) - 0.05 * span, float(f.max()) + 0.1 * span


def _check_in_window(ds, point, spec: LabelSpec, energy_range, frequency_range, where):
    e = float(ds["energy"].values[point])
    f = float(ds["frequency"].values[point])
    for value, window, what in ((e, energy_range, "energy"), (f, frequency_range, "frequency")):
        if window is not None and not window[0] <= value <= window[1]:
            raise ValueError(
                f"{where}: label {spec.label}) lies at {what} {value:.6g}, outside the plotted "
                f"{what}_range [{window[0]:g}, {window[1]:g}]"
            )


def _draw_fep(
    ax,
    kind: _FigureKind,
    branch: xr.Dataset,
    nnm2: xr.Dataset | None,
    params,
    spec,
    where,
    branch_label,
    exact: xr.Dataset | None = None,
    bifurcated: list | None = None,
):
    """Frequency-energy plot of ``branch`` with its companions; returns the legend handles.

    ``exact``: optional exact NNM1 of the non-smooth system (results/exact/nnm1.nc),
    drawn dotted in black (red is taken by the f2/5 curve) under the regularized branch.
    ``bifurcated``: branches switched at branch points of ``branch``
    (results/hbm/bifurcated/*.nc), drawn thin in black over the curve they should
    follow (for the n:1 resonances, the NNM2 curve at f2/n), with their branch point.
    """
    color = NNM1_COLOR if kind.branch == "nnm1" else NNM2_COLOR
    energy_range = _range(spec, "energy_range", where)
    frequency_range = _range(spec, "frequency_range", where)
    handles = []
    drawn = plot_branch(ax, branch, color, lw=1.2, zorder=3)
    handles.append(Line2D([], [], color=color, lw=1.2, label=branch_label))
    handles.extend(stability_legend_handles(drawn, color=color))
    if exact is not None:
        ax.plot(
            exact["energy"].values, exact["frequency"].values, color=EXACT_OVERLAY_COLOR, lw=1.4, ls=":", zorder=2.5
        )
        handles.append(
            Line2D([], [], color=EXACT_OVERLAY_COLOR, lw=1.4, ls=":", label="non-smooth model, exact orbits")
        )
    if kind.resonance is not None:
        n = kind.resonance
        ax.plot(nnm2["energy"].values, nnm2["frequency"].values / n, color=kind.resonance_color, lw=1.2, zorder=2)
        handles.append(Line2D([], [], color=kind.resonance_color, lw=1.2, label=f"NNM2 frequency / {n} (same energy)"))
    for ds in bifurcated or []:
        drawn_b = plot_branch(ax, ds, BIFURCATED_COLOR, lw=0.7, zorder=2.6)
        handles.append(
            Line2D(
                [],
                [],
                color=BIFURCATED_COLOR,
                lw=0.7,
                label=f"branch switched at the {ds.attrs['resonance']}:1 branch point (HBM-ANM)",
            )
        )
        shown = {h.get_label() for h in handles}
        handles.extend(
            h for h in stability_legend_handles(drawn_b, color=BIFURCATED_COLOR, lw=0.7) if h.get_label() not in shown
        )
    gap_zero = gap_zero_frequencies(params)
    levels = [float(gap_zero[mode - 1]) for mode in kind.gap_zero_modes]
    if frequency_range is None:
        frequency_range = _auto_limits([branch], energy_range, levels)
    for mode, value in zip(kind.gap_zero_modes, levels):
        if frequency_range is None or frequency_range[0] <= value <= frequency_range[1]:
            ax.axhline(value, zorder=1, **GAP_ZERO_STYLE)
            text = f"gap-0 linear mode {mode} ({value:.4f} Hz)"
            if kind.inset_gap_zero_mode == mode:
                text += ";\nits modal line dashed in the insets"
            handles.append(Line2D([], [], label=text, **GAP_ZERO_STYLE))
    handles.extend(_bifurcation_legend(_bifurcation_markers(ax, branch)))
    frequency_energy_axes(ax)
    _label_minor_decades(ax)
    if energy_range is not None:
        ax.set_xlim(*energy_range)
    if frequency_range is not None:
        ax.set_ylim(*frequency_range)
    return handles, energy_range, frequency_range


def _label_minor_decades(ax) -> None:
    """Label some minor ticks of the energy axis when it spans fewer than two decades."""
    ax.xaxis.set_minor_formatter(LogFormatterSciNotation(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
    ax.tick_params(axis="x", which="minor", labelsize=7)


def _inset_grid(n: int) -> tuple[int, int]:
    """(rows, columns) of the modal-line panels: one row up to 4, else rows of 3."""
    if n <= 4:
        return 1, max(n, 1)
    cols = 3 if n <= 6 else 4
    return int(np.ceil(n / cols)), cols


def _figure_with_modal_lines(
    name: str,
    branch: xr.Dataset,
    spec: dict,
    pdf_path,
    nnm2=None,
    png_dpi: int = 150,
    branch_label=None,
    exact=None,
    bifurcated=None,
):
    """Frequency-energy plot of ``branch`` on top, the modal lines of its labels below."""
    kind = PAPER_FIGURES[name]
    where = name
    bifurcated = list(bifurcated or [])
    datasets = [branch] + [ds for ds in (nnm2, exact) if ds is not None] + bifurcated
    for ds in datasets:
        check_finite(ds, where)
    _check_branch(branch, kind.branch, where)
    if kind.resonance is not None:
        if nnm2 is None:
            raise ValueError(f"{where}: the NNM2 dataset is needed for the f2/{kind.resonance} curve")
        _check_branch(nnm2, "nnm2", where)
    params = model_parameters(*[ds for ds in datasets if ds is not exact], where=where)
    for ds in bifurcated:
        if ds.attrs.get("parent_branch") != kind.branch or "resonance" not in ds.attrs:
            raise ValueError(f"{where}: {dataset_name(ds)} is not a branch bifurcated from {kind.branch.upper()}")
    labels = label_specs(spec.get("labels"))
    if not labels:
        raise ValueError(f"{where}: no labelled points configured (figures.{name}.labels)")
    points = [select_point(branch, s, f"{where}, {dataset_name(branch)}") for s in labels]

    slope = None
    if kind.inset_gap_zero_mode is not None:
        slope = float(linear_modes(params, "gap_zero")[1][1, kind.inset_gap_zero_mode - 1])
    if branch_label is None:
        branch_label = kind.branch.upper()
    color = NNM1_COLOR if kind.branch == "nnm1" else NNM2_COLOR

    rows, cols = _inset_grid(len(labels))
    fig = plt.figure(figsize=(7.5, 4.0 + 2.3 * rows), layout="constrained")
    try:
        fig.get_layout_engine().set(h_pad=0.06, w_pad=0.06, hspace=0.04, wspace=0.06)
        grid = fig.add_gridspec(1 + rows, cols, height_ratios=[4.0] + [2.3] * rows)
        ax = fig.add_subplot(grid[0, :])
        handles, energy_range, frequency_range = _draw_fep(
            ax, kind, branch, nnm2, params, spec, where, branch_label, exact, bifurcated
        )
        for i, (s, p) in enumerate(zip(labels, points)):
            _check_in_window(branch, p, s, energy_range, frequency_range, where)
            mark_point(ax, branch, p, s)
            draw_modal_line(fig.add_subplot(grid[1 + i // cols, i % cols]), branch, p, s, color, reference_slope=slope)
        ax.legend(handles=handles, loc=spec.get("legend", "best"), fontsize=7.5, framealpha=0.9)
        fig.suptitle(f"{kind.title}\n{_parameter_line(params, branch)}", fontsize=9.5, linespacing=1.4)
    except Exception:
        plt.close(fig)
        raise
    return save_figure(fig, pdf_path, png_dpi=png_dpi)


# --------------------------------------------------------------------------- the figures


def figure_05(nnm1: xr.Dataset, nnm2: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150):
    """Fig 5: FEP of NNM1 (blue) and NNM2 (green) over the whole energy range.

    Parameters
    ----------
    nnm1, nnm2 : xarray.Dataset
        Whole-branch datasets.
    spec : dict
        ``figures.fig05`` of the configuration (optional ``energy_range``,
        ``frequency_range``, ``legend``).
    pdf_path : path-like
        The PDF to write; the PNG goes beside it.

    Returns
    -------
    tuple of pathlib.Path
        The PDF and PNG written.
    """
    where = "fig05"
    kind = PAPER_FIGURES[where]
    for ds, branch in ((nnm1, "nnm1"), (nnm2, "nnm2")):
        check_finite(ds, where)
        _check_branch(ds, branch, where)
    params = model_parameters(nnm1, nnm2, where=where)
    energy_range = _range(spec, "energy_range", where)
    frequency_range = _range(spec, "frequency_range", where)
    fig, ax = plt.subplots(figsize=(7.5, 4.8), layout="constrained")
    handles = []
    drawn = set()
    for ds, color, label in ((nnm1, NNM1_COLOR, "NNM1"), (nnm2, NNM2_COLOR, "NNM2")):
        drawn |= plot_branch(ax, ds, color, lw=1.3, zorder=3)
        handles.append(Line2D([], [], color=color, lw=1.3, label=label))
    handles.extend(stability_legend_handles(drawn, lw=1.3))
    gap_zero = gap_zero_frequencies(params)
    for mode in kind.gap_zero_modes:
        value = float(gap_zero[mode - 1])
        ax.axhline(value, zorder=1, **GAP_ZERO_STYLE)
    handles.append(Line2D([], [], label="gap-0 linear modes", **GAP_ZERO_STYLE))
    handles.extend(_bifurcation_legend(_bifurcation_markers(ax, nnm1) | _bifurcation_markers(ax, nnm2)))
    frequency_energy_axes(ax)
    if energy_range is not None:
        ax.set_xlim(*energy_range)
    if frequency_range is None:
        frequency_range = _auto_limits([nnm1, nnm2], energy_range, gap_zero)
    ax.set_ylim(*frequency_range)
    # label the dashed lines at the right edge, just above them (the branches reach them from below)
    right = ax.get_xlim()[1]
    for mode in kind.gap_zero_modes:
        value = float(gap_zero[mode - 1])
        ax.annotate(
            f"gap-0 linear mode {mode}: {value:.4f} Hz",
            xy=(right, value),
            xytext=(-4, 3),
            textcoords="offset points",
            fontsize=7.5,
            color="0.2",
            va="bottom",
            ha="right",
        )
    ax.legend(handles=handles, loc=spec.get("legend", "best"), fontsize=8, framealpha=0.9)
    fig.suptitle(f"{kind.title}\n{_parameter_line(params, nnm1)}", fontsize=9.5, linespacing=1.4)
    return save_figure(fig, pdf_path, png_dpi=png_dpi)


def figure_06(nnm2: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150):
    """Fig 6: FEP of NNM2 with the modal lines a)-f) of ``spec['labels']``.

    Needs only the NNM2 dataset. Returns the PDF and PNG paths.
    """
    return _figure_with_modal_lines("fig06", nnm2, spec, pdf_path, png_dpi=png_dpi)


def _nnm1_figure(name, branch, spec, pdf_path, nnm2=None, png_dpi=150, exact=None, bifurcated=None):
    stages = np.unique(branch["stage"].values)
    text = f"stage {stages[0]}" if stages.size == 1 else f"stages {stages[0]}-{stages[-1]}"
    return _figure_with_modal_lines(
        name,
        branch,
        spec,
        pdf_path,
        nnm2=nnm2,
        png_dpi=png_dpi,
        branch_label=f"NNM1 ({text} of the continuation)",
        exact=exact,
        bifurcated=bifurcated,
    )


def figure_07(nnm1: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150, exact=None):
    """Fig 7: NNM1 at low energy, modal lines a)-c) (no impact, one impact per stop,
    secondary oscillation between impacts). ``nnm1``: the NNM1 stages read, joined
    (``nnmstop.tasks.figures.combine_nnm1_stages``)."""
    return _nnm1_figure("fig07", nnm1, spec, pdf_path, png_dpi=png_dpi, exact=exact)


def figure_08(
    nnm1: xr.Dataset, nnm2: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150, exact=None, bifurcated=None
):
    """Fig 8: NNM1 with the NNM2 curve at ``f2/3``; three then two impacts per stop and
    the 3:1 internal resonance, modal lines d)-i)."""
    return _nnm1_figure("fig08", nnm1, spec, pdf_path, nnm2=nnm2, png_dpi=png_dpi, exact=exact, bifurcated=bifurcated)


def figure_09(
    nnm1: xr.Dataset, nnm2: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150, exact=None, bifurcated=None
):
    """Fig 9: NNM1 with the NNM2 curve at ``f2/5``; four then five impacts per stop and
    the 5:1 internal resonance, modal lines j)-m)."""
    return _nnm1_figure("fig09", nnm1, spec, pdf_path, nnm2=nnm2, png_dpi=png_dpi, exact=exact, bifurcated=bifurcated)


def figure_10(
    nnm1: xr.Dataset, nnm2: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150, exact=None, bifurcated=None
):
    """Fig 10: NNM1 with the NNM2 curve at ``f2/5`` after the 5:1 resonance: impacts
    without oscillation between the stops, back to one impact per stop, o)-q)."""
    return _nnm1_figure("fig10", nnm1, spec, pdf_path, nnm2=nnm2, png_dpi=png_dpi, exact=exact, bifurcated=bifurcated)


def figure_11(nnm1: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150, exact=None):
    """Fig 11: NNM1 at high energy, tending to the gap-0 first linear mode (dashed)."""
    return _nnm1_figure("fig11", nnm1, spec, pdf_path, png_dpi=png_dpi, exact=exact)
