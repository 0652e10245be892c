"""Figs 5-11 of the paper: frequency-energy plots of the regularized NNMs with modal lines, scenes from the data.

Every figure is drawn from branch datasets (the schema of :mod:`nnmstop.hbm.dataset`, any structure) and
its ``figures.<name>`` settings, and nothing is solved. Its labelled points are placed by what the
data hold (:mod:`nnmstop.figures.modal_lines`: branch points by resonance ``n``, changes of impact
regime, energy minima, fractions of an energy range, or explicit energies), and its energy window by its
focus stages and labels (:func:`energy_window`), so that the paper's scene at its parameters is an
analogous scene at others. What does not exist for the parameters at hand (a label's feature, a stage
that was not continued, a branch point to switch at) is said in the title and the figure is drawn
anyway. NNM1 is blue, NNM2 green, the NNM2 curve divided by 5 red (as in the paper); frequencies in Hz
of the nondimensional time, energies on a logarithmic axis; the dash-dotted lines are the gap-0 linear modes
(every stop engaged) stored in the datasets.

* Fig 5: NNM1 and NNM2 over the whole energy range; Fig 6: NNM2 with modal lines a)-f).
* Fig 7: NNM1 at low energy, a)-c); Fig 11: NNM1 at high energy, tending to the gap-0 mode.
* Figs 8-10: NNM1 with the NNM2 curve at ``f2/3`` (``f2/5``), the 3:1 (5:1) internal resonance
  and the branch switched there (an NNM2 orbit read over ``3T`` (``5T``) has the fundamental
  frequency ``f2/3`` (``f2/5``) at the same energy, see the project NOTES).

Reading the files, joining the NNM1 stages and the settings: :mod:`nnmstop.tasks.figures`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle

from nnmstop.figures.common import (
    EXACT_OVERLAY_COLOR,
    GAP_ZERO_STYLE,
    NNM2_COLOR,
    REGULARIZED_COLOR,
    RESONANCE_COLOR,
    branch_identity_name,
    frequency_energy_axes,
    identity_legend_handles,
    label_minor_decades,
    plot_branch,
    plot_identities,
    save_figure,
    stability_legend_handles,
)
from nnmstop.figures.labels import mark_obstacle, place_labels
from nnmstop.figures.modal_lines import draw_modal_line, label_specs, locate_label, mark_point, modal_line_dofs
from nnmstop.hbm.identity import identity_runs

__all__ = [
    "PAPER_FIGURES",
    "dataset_name",
    "check_finite",
    "check_same_structure",
    "gap_zero_frequencies",
    "structure_line",
    "energy_window",
    "scene_part",
    "wrapped_title",
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
BIFURCATED_COLOR = "black"
BRANCH_POINT_STYLES = {
    "resonance": {"marker": "x", "ms": 5, "mew": 1.1, "color": "black", "ls": "none", "zorder": 5},
    "branch point": {"marker": "x", "ms": 5, "mew": 1.1, "color": "black", "ls": "none", "zorder": 5},
    "breaking": {"marker": "+", "ms": 7, "mew": 1.1, "color": "black", "ls": "none", "zorder": 5},
    "fold": {"marker": "D", "ms": 3, "mew": 0.8, "mfc": "none", "color": "0.35", "ls": "none", "zorder": 4.5},
}
#: The NNM2 curve at f2/n of Figs 8-10: a band this wide (points) and pale, drawn under the branches.
RESONANCE_BAND_WIDTH = 7.0
RESONANCE_BAND_ALPHA = 0.3
#: Global attributes (and stop variables) that must agree between the datasets of one figure.
STRUCTURE_KEYS = ("structure", "alpha", "beta", "delta", "eta", "dofs", "stops")
#: Relative widening of an automatic energy window on each side, in log energy.
WINDOW_MARGIN = 0.1
#: Width (inches) of Figs 5-11 and the size (points) of their titles.
FIGURE_WIDTH = 7.5
TITLE_FONTSIZE = 8.5
#: The NNM1 figures whose scene can be found by physics where their configured stages hold no orbit.
SCENES = ("fig07", "fig08", "fig09", "fig10", "fig11")


@dataclass(frozen=True)
class _FigureKind:
    """What a paper figure shows: the branch with the modal lines and its companions."""

    branch: str  # "nnm1" or "nnm2": the branch whose points are labelled
    title: str
    resonance: int | None = None  # n: the NNM2 curve at f2/n is drawn
    resonance_color: str = NNM2_COLOR
    gap_zero_modes: tuple[int, ...] = (1,)
    inset_gap_zero_mode: int | None = None  # draw this gap-0 modal line (dash-dotted) in the insets


PAPER_FIGURES = {
    "fig05": _FigureKind(
        "nnm1", "Fig. 5: first (NNM1) and second (NNM2) nonlinear normal modes", gap_zero_modes=(1, 2)
    ),
    "fig06": _FigureKind("nnm2", "Fig. 6: second NNM and its modal lines", gap_zero_modes=(2,), inset_gap_zero_mode=2),
    "fig07": _FigureKind("nnm1", "Fig. 7: first NNM at low energy"),
    "fig08": _FigureKind("nnm1", "Fig. 8: first NNM and the NNM2 curve at f2/3 (3:1 internal resonance)", 3),
    "fig09": _FigureKind(
        "nnm1", "Fig. 9: first NNM and the NNM2 curve at f2/5 (5:1 internal resonance)", 5, RESONANCE_COLOR
    ),
    "fig10": _FigureKind("nnm1", "Fig. 10: first NNM after the 5:1 internal resonance", 5, RESONANCE_COLOR),
    "fig11": _FigureKind(
        "nnm1", "Fig. 11: first NNM at high energy, towards the gap-0 first linear mode", inset_gap_zero_mode=1
    ),
}


# --------------------------------------------------------------------------- checks, structure


def dataset_name(ds: xr.Dataset) -> str:
    """How messages name a branch dataset: branch, stage(s) and file when known."""
    branch = str(ds.attrs.get("branch", "dataset")).upper()
    if "stage" in ds and ds["stage"].size:
        stages = np.unique(ds["stage"].values)
        text = f"{branch} stage{'s' if stages.size > 1 else ''} {', '.join(str(int(s)) for s in stages)}"
    else:
        text = branch
    source = ds.encoding.get("source")
    return f"{text} ({source})" if source else text


def check_finite(ds: xr.Dataset, where: str) -> None:
    """Raise ``ValueError`` if a numeric variable of ``ds`` holds NaN or infinite values.

    The message names ``where`` (the figure), the dataset, the variable and the first offending point.
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


def check_same_structure(*datasets: xr.Dataset, where: str = "figure") -> None:
    """Refuse datasets of different structures (attributes :data:`STRUCTURE_KEYS` and the stops).

    Raises
    ------
    ValueError
        Naming the dataset and what differs.
    """
    first = datasets[0]
    for ds in datasets[1:]:
        for key in STRUCTURE_KEYS:
            a, b = first.attrs.get(key), ds.attrs.get(key)
            if str(a) != str(b):
                raise ValueError(
                    f"{where}: datasets of different structures: {key} = {a!r} in {dataset_name(first)}, {b!r} in "
                    f"{dataset_name(ds)}"
                )
        for name in ("stop_dof", "stop_gap", "stop_stiffness", "stop_eta"):
            if name in first and name in ds and not np.array_equal(first[name].values, ds[name].values):
                raise ValueError(f"{where}: datasets of different structures: {name} differs in {dataset_name(ds)}")


def gap_zero_frequencies(ds: xr.Dataset) -> np.ndarray:
    """Frequencies (Hz) of the linear modes with every stop always engaged, as stored in a branch dataset."""
    return np.asarray(ds["gap_zero_frequency"].values, dtype=float)


_KIND_WORDS = {"beam": "finite-element beam", "matrices": "structure from matrices"}


def structure_line(ds: xr.Dataset) -> str:
    """The structure and ``H`` in a line: the paper's parameters, else the degrees of freedom and stops."""
    a = ds.attrs
    if a.get("structure") == "two_dof":
        text = f"α = {a['alpha']:g}, β = {a['beta']:g}, δ = {a['delta']:g}, η = {a['eta']:g}"
    else:
        stops = "; ".join(
            f"stop on {ds['dof_label'].values[d]}: gap {g:g}, α = {k:g}, η = {e:g}"
            for d, g, k, e in zip(
                ds["stop_dof"].values, ds["stop_gap"].values, ds["stop_stiffness"].values, ds["stop_eta"].values
            )
        )
        kind = _KIND_WORDS.get(a.get("structure"), "structure")
        text = f"{int(a.get('dofs', ds.sizes.get('dof', 0)))}-DOF {kind}; {stops}"
    if "harmonics" in a:
        text += f", H = {int(a['harmonics'])}"
    return text


# --------------------------------------------------------------------------- windows and markers


def _range(spec: dict, key: str, where: str):
    value = spec.get(key)
    if value is None:
        return None
    lo, hi = (float(v) for v in value)
    if not lo < hi:
        raise ValueError(f"{where}: {key} must be increasing, got {value!r}")
    return lo, hi


def energy_window(branch: xr.Dataset, spec: dict, points: list[int], where: str, focus=None):
    """The plotted energy range: ``energy_range`` if configured, else from the data.

    The points of the ``focus_stages`` (all points without them; ``focus``, a mask of the points, when
    given instead: the scene by physics where those stages hold no orbit, :func:`scene_part`), their
    log-energy span widened by :data:`WINDOW_MARGIN` on each side, and widened further to hold every
    labelled point. None when the branch holds no point.
    """
    explicit = _range(spec, "energy_range", where)
    energy = branch["energy"].values
    if explicit is not None or energy.size == 0:
        return explicit
    if focus is None:
        stages = spec.get("focus_stages")
        focus = np.isin(branch["stage"].values, stages) if stages else np.ones(energy.size, dtype=bool)
    inside = np.asarray(focus, dtype=bool)
    chosen = np.concatenate([energy[inside] if inside.any() else energy, energy[list(points)]])
    lo, hi = np.log(chosen.min()), np.log(chosen.max())
    pad = WINDOW_MARGIN * max(hi - lo, np.log(2.0))
    return float(np.exp(lo - pad)), float(np.exp(hi + pad))


def _involves(run, n: int) -> bool:
    """Whether an identity run is in the ``n:1`` tongue or on an NNM seen at 1/n of its frequency."""
    return (run.kind == 1 and run.tongue == n) or (run.kind == 2 and run.harmonic == n)


def scene_part(branch: xr.Dataset, name: str) -> tuple[np.ndarray | None, str]:
    """The points of ``branch`` that NNM1 figure ``name`` is about by physics, and that part in words.

    Where a figure's configured stages hold no orbit (the paper's continuation stages end elsewhere at other
    parameters), its scene is found from what the orbits are (:mod:`nnmstop.hbm.identity`) and their impacts:

    * ``fig07``: NNM1 up to its first orbit with more than one impact per stop side;
    * ``fig08``, ``fig09``: the orbits in the 3:1 (5:1) tongue or on an NNM seen at 1/3 (1/5) of its frequency;
    * ``fig10``: the orbits after the last of those of the 5:1 resonance;
    * ``fig11``: the high-energy end of the continuation: its last run of one identity, from the last change of
      the impacts per period in it.

    Returns ``(None, why)`` when the branch has no such part (no 5:1 resonance, say).
    """
    n_points = branch.sizes["point"]
    mask = np.zeros(n_points, dtype=bool)
    if n_points == 0:
        return None, "no orbit"
    energy, impacts = branch["energy"].values, branch["impacts_per_period"].values
    runs = identity_runs(branch)
    stops = int(branch.sizes.get("stop", 1))
    if name == "fig07":
        above = np.flatnonzero(impacts > 2 * stops)
        mask[: above[0] if above.size else n_points] = True
        return mask, "NNM1 up to its first orbit with more than one impact per stop side"
    if name in ("fig08", "fig09", "fig10"):
        n = PAPER_FIGURES[name].resonance
        hits = [run for run in runs if _involves(run, n)]
        if not hits:
            return None, f"no {n}:1 internal resonance on this branch (no orbit in a {n}:1 tongue or seen at 1/{n})"
        if name == "fig10":
            mask[hits[-1].stop :] = True
            if not mask.any():
                return None, f"no orbit after the {n}:1 internal resonance (the branch ends in it)"
            return mask, f"the branch after its {n}:1 internal resonance (E > {energy[hits[-1].stop - 1]:.4g})"
        mask[hits[0].start : hits[-1].stop] = True
        lo, hi = energy[mask].min(), energy[mask].max()
        return mask, f"the branch in its {n}:1 internal resonance (E {lo:.4g} - {hi:.4g})"
    if name == "fig11":
        last = runs[-1] if runs else None
        start = last.start if last else 0
        changes = np.flatnonzero(impacts[start + 1 :] != impacts[start:-1]) + start + 1
        start = int(changes[-1]) if changes.size else start
        mask[start:] = True
        what = last.label if last else "the branch"
        return (
            mask,
            f"the high-energy end of the continuation: {what}, {int(impacts[-1])} impacts per period "
            f"(E {energy[start]:.4g} - {energy[-1]:.4g})",
        )
    return np.ones(n_points, dtype=bool), "the whole branch"


def _bifurcation_markers(ax, ds: xr.Dataset) -> set:
    """Mark the branch points and energy folds of ``ds``; return the kinds drawn."""
    drawn = set()
    if ds.sizes.get("located_branch_point", 0):
        e, f = ds["branch_point_energy"].values, ds["branch_point_frequency"].values
        resonance = ds["branch_point_resonance"].values > 0
        for kind, mask in (("resonance", resonance), ("breaking", ~resonance)):
            if mask.any():
                mark_obstacle(ax.plot(e[mask], f[mask], **BRANCH_POINT_STYLES[kind])[0])
                drawn.add(kind)
    if ds.sizes.get("located_fold", 0):
        mark_obstacle(ax.plot(ds["fold_energy"].values, ds["fold_frequency"].values, **BRANCH_POINT_STYLES["fold"])[0])
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
    """Frequency limits covering the branches within the energy window and the horizontal ``levels`` (the
    gap-0 asymptotes) near them (within half the branches' frequency span), with room for the letters above.

    A level far from the branches (the gap-0 mode of another scene) would squash them into a line."""
    freqs = []
    for ds in ds_list:
        e, f = ds["energy"].values, ds["frequency"].values
        inside = (
            np.ones(e.shape, dtype=bool) if energy_range is None else (e >= energy_range[0]) & (e <= energy_range[1])
        )
        freqs.append(f[inside])
    data = np.concatenate(freqs) if freqs else np.zeros(0)
    levels = np.asarray(levels, dtype=float)
    if data.size:
        reach = 0.5 * max(float(np.ptp(data)), 1e-3 * float(np.abs(data).max()))
        levels = levels[(levels >= data.min() - reach) & (levels <= data.max() + reach)]
    f = np.concatenate([levels, data])
    if f.size == 0:
        return None
    span = max(float(f.max() - f.min()), 1e-3 * float(f.max()))
    return float(f.min()) - 0.05 * span, float(f.max()) + 0.1 * span


# --------------------------------------------------------------------------- what the data say


def regime_sequence(ds: xr.Dataset, window=None) -> str:
    """The impact regimes along the branch within the energy window, in order (``"0 → 2 → 6"``)."""
    energy, impacts = ds["energy"].values, ds["impacts_per_period"].values
    inside = np.ones(energy.size, dtype=bool) if window is None else (energy >= window[0]) & (energy <= window[1])
    runs = [int(n) for i, n in enumerate(impacts) if inside[i] and (i == 0 or impacts[i - 1] != n or not inside[i - 1])]
    collapsed = [n for i, n in enumerate(runs) if i == 0 or runs[i - 1] != n]
    return " → ".join(map(str, collapsed))


def _scene_line(branch: xr.Dataset, window, resonance: int | None) -> str:
    """What the drawn part of the branch holds: its impact regimes and the located resonance."""
    if branch.sizes["point"] == 0:
        return ""
    text = f"impacts per period along the drawn part: {regime_sequence(branch, window)}"
    if resonance is not None:
        match = np.flatnonzero(branch["branch_point_resonance"].values == resonance)
        found = f"at E = {float(branch['branch_point_energy'].values[match[0]]):.4g}" if match.size else "none"
        text += f"; {resonance}:1 branch point: {found}"
    return text


def _missing_notes(branch: xr.Dataset, stages: list[xr.Dataset], bifurcated: list, missing: list) -> list[str]:
    """Lines saying what the figure could not show: stages not continued, branches not switched, labels."""
    notes = []
    for ds in stages:
        name = f"stage {int(ds.attrs.get('skipped_stage', 0)) or _stage_number(ds)} ({ds.attrs.get('stage_name', '')})"
        if int(ds.attrs.get("skipped", 0)):
            notes.append(f"{name} not continued")
        elif not int(ds.attrs.get("stage_condition_met", 1)):
            why = _END_WORDS.get(ds.attrs.get("stage_end"), ds.attrs["end_reason"])
            end = float(ds["energy"].values[-1])
            notes.append(f"{name} ended at E = {end:.4g} before {ds.attrs['stage_condition']}: {why}")
    for ds in bifurcated:
        if int(ds.attrs.get("skipped", 0)):
            notes.append(f"no branch switched at a {int(ds.attrs['resonance'])}:1 branch point (none located)")
    if missing:
        notes.append("not on this branch: " + "; ".join(_grouped(missing)))
    return notes


def _grouped(missing: list) -> list[str]:
    """``(label, why)`` pairs as text, the labels that miss for one reason together."""
    reasons: dict[str, list] = {}
    for label, why in missing:
        reasons.setdefault(why, []).append(label)
    return [
        f"{labels[0].describe()} ({why})" if len(labels) == 1 else f"{', '.join(s.label + ')' for s in labels)} ({why})"
        for why, labels in reasons.items()
    ]


#: How the notes say why a stage ended before its condition (``stage_end`` of its dataset).
_END_WORDS = {
    "bound": "its energy bound was reached",
    "truncation": "the harmonics no longer resolve the stop beyond it",
}


def _stage_number(ds: xr.Dataset) -> int:
    return int(ds["stage"].values[0]) if ds["stage"].size else 0


def _title(kind: _FigureKind, branch: xr.Dataset, scene: str, notes: list[str]) -> str:
    lines = [kind.title, structure_line(branch)] + ([scene] if scene else []) + notes
    return "\n".join(lines)


# --------------------------------------------------------------------------- drawing


def _companions(ax, kind: _FigureKind, nnm2, exact, bifurcated) -> list:
    """The exact NNM1, the NNM2 curve at f2/n and the switched branches; their legend handles."""
    handles = []
    if exact is not None:
        ax.plot(
            exact["energy"].values, exact["frequency"].values, color=EXACT_OVERLAY_COLOR, lw=1.4, ls=":", zorder=2.5
        )
        handles.append(
            Line2D([], [], color=EXACT_OVERLAY_COLOR, lw=1.4, ls=":", label="non-smooth model, exact orbits")
        )
    if kind.resonance is not None:
        n = kind.resonance
        band = {"color": kind.resonance_color, "alpha": RESONANCE_BAND_ALPHA, "lw": RESONANCE_BAND_WIDTH}
        # wide and pale under everything: where the switched branch runs on it, both stay visible
        ax.plot(nnm2["energy"].values, nnm2["frequency"].values / n, zorder=1.5, solid_capstyle="butt", **band)
        switched = any(ds.sizes["point"] for ds in bifurcated)
        text = f"NNM2 frequency / {n} at the same energy (pale band"
        text += ";\nthe switched branch runs on it where they coincide)" if switched else ")"
        handles.append(Line2D([], [], label=text, **band))
    for ds in bifurcated:
        if ds.sizes["point"] == 0:
            continue
        drawn = plot_branch(ax, ds, BIFURCATED_COLOR, lw=0.7, zorder=2.6)
        label = f"{branch_identity_name(ds)}: switched at the {ds.attrs['resonance']}:1 branch point (HBM-ANM)"
        handles.append(Line2D([], [], color=BIFURCATED_COLOR, lw=0.7, label=label))
        shown = {h.get_label() for h in handles}
        handles.extend(
            h for h in stability_legend_handles(drawn, color=BIFURCATED_COLOR, lw=0.7) if h.get_label() not in shown
        )
    return handles


def _gap_zero_lines(ax, kind: _FigureKind, branch: xr.Dataset, frequency_range) -> list:
    handles = []
    gap_zero = gap_zero_frequencies(branch)
    for mode in kind.gap_zero_modes:
        value = float(gap_zero[mode - 1])
        if frequency_range is None or frequency_range[0] <= value <= frequency_range[1]:
            ax.axhline(value, zorder=1, **GAP_ZERO_STYLE)
            text = f"gap-0 linear mode {mode} ({value:.4f} Hz)"
            if kind.inset_gap_zero_mode == mode:
                text += ";\nits modal line dash-dotted in the insets"
            handles.append(Line2D([], [], label=text, **GAP_ZERO_STYLE))
    return handles


def _draw_fep(ax, kind: _FigureKind, branch, nnm2, spec, where, branch_label, window, exact=None, bifurcated=()):
    """Frequency-energy plot of ``branch`` with its companions in the energy ``window``; legend handles, limits."""
    color = NNM1_COLOR if kind.branch == "nnm1" else NNM2_COLOR
    handles = []
    if branch.sizes["point"]:
        drawn, others = plot_identities(ax, branch, color, lw=1.2, zorder=3)
        runs = identity_runs(branch)
        if not runs or any(run.family == kind.branch.upper() for run in runs):  # its own orbits are drawn
            handles.append(Line2D([], [], color=color, lw=1.2, label=branch_label))
        handles.extend(identity_legend_handles(others))
        handles.extend(stability_legend_handles(drawn, color=color))
    handles.extend(_companions(ax, kind, nnm2, exact, list(bifurcated)))
    frequency_range = _range(spec, "frequency_range", where)
    if frequency_range is None and branch.sizes["point"]:
        levels = gap_zero_frequencies(branch)[[m - 1 for m in kind.gap_zero_modes]]
        frequency_range = _auto_limits([branch], window, levels)
    if not branch.sizes["point"]:
        ax.text(0.5, 0.5, f"no orbit of {branch_label}", transform=ax.transAxes, ha="center", va="center", fontsize=11)
    handles.extend(_gap_zero_lines(ax, kind, branch, frequency_range))
    handles.extend(_bifurcation_legend(_bifurcation_markers(ax, branch)))
    frequency_energy_axes(ax)
    label_minor_decades(ax)
    if window is not None:
        ax.set_xlim(*window)
    if frequency_range is not None:
        ax.set_ylim(*frequency_range)
    return handles, frequency_range


def _inset_line(branch: xr.Dataset) -> str:
    """What the modal-line panels show, in words (their plane and the grey lines of the stops in it)."""
    ia, ib = modal_line_dofs(branch)
    a, b = (str(branch["dof_label"].values[k]) for k in (ia, ib))
    gaps = {int(d): float(g) for d, g in zip(branch["stop_dof"].values, branch["stop_gap"].values)}
    lines = [f"grey verticals: the stop at {a} = ±{gaps[ia]:g}"]
    if ib in gaps:
        lines.append(f"grey horizontals: the stop at {b} = ±{gaps[ib]:g}")
    others = [str(branch["dof_label"].values[d]) for d in gaps if d not in (ia, ib)]
    if others:
        lines.append(f"stops on {', '.join(others)} not in this plane")
    return f"modal lines below: one period in the ({a}, {b}) plane; " + "; ".join(lines)


def _inset_grid(n: int) -> tuple[int, int]:
    """(rows, columns) of the modal-line panels: one row up to 4, else rows of 3."""
    if n <= 4:
        return 1, max(n, 1)
    cols = 3 if n <= 6 else 4
    return int(np.ceil(n / cols)), cols


def _checked(name: str, branch, nnm2, exact, bifurcated) -> None:
    """The datasets of a figure: finite, of the right branches, of one structure."""
    kind, where = PAPER_FIGURES[name], name
    for ds in [branch] + [ds for ds in (nnm2, exact) if ds is not None] + bifurcated:
        check_finite(ds, where)
    _check_branch(branch, kind.branch, where)
    if kind.resonance is not None:
        if nnm2 is None:
            raise ValueError(f"{where}: the NNM2 dataset is needed for the f2/{kind.resonance} curve")
        _check_branch(nnm2, "nnm2", where)
    check_same_structure(*[ds for ds in (branch, nnm2) if ds is not None], *bifurcated, where=where)
    for ds in bifurcated:
        if ds.attrs.get("parent_branch") != kind.branch or "resonance" not in ds.attrs:
            raise ValueError(f"{where}: {dataset_name(ds)} is not a branch bifurcated from {kind.branch.upper()}")


def _placed_labels(name: str, branch: xr.Dataset, spec: dict, any_stage: bool = False):
    """The labels that land on ``branch`` with their points, and notes on those that do not.

    ``any_stage``: the branch drawn is the figure's scene by physics (its configured stages hold no orbit),
    and a label's ``stage`` is not asked for: it lands on the part drawn.
    """
    labels = label_specs(spec.get("labels"))
    if not labels:
        raise ValueError(f"{name}: no labelled points configured (figures.{name}.labels)")
    if any_stage:
        labels = [replace(label, stage=None) for label in labels]
    placed, missing = [], []
    for label in labels:
        place = locate_label(branch, label)
        if place.point is None:
            logger.info("%s: label %s not drawn: %s", name, label.describe(), place.missing)
            missing.append((label, place.missing))
        else:
            e, f = float(branch["energy"].values[place.point]), float(branch["frequency"].values[place.point])
            logger.info(
                "%s: label %s -> point %d, energy %.6g, frequency %.6g Hz", name, label.describe(), place.point, e, f
            )
            placed.append((label, place.point))
    return placed, missing


def _inside_window(branch, placed, missing, window):
    """The placed labels inside an energy ``window`` set by the configuration; the others noted as missing."""
    if window is None:
        return placed
    kept = []
    for label, point in placed:
        energy = float(branch["energy"].values[point])
        if window[0] <= energy <= window[1]:
            kept.append((label, point))
        else:
            missing.append((label, f"at E = {energy:.4g}, outside the configured energy_range"))
    return kept


def _inset_slope(kind: _FigureKind, branch: xr.Dataset) -> float | None:
    """Slope of the gap-0 modal line in the plane of the insets, for the figures that draw it."""
    if kind.inset_gap_zero_mode is None:
        return None
    a, b = modal_line_dofs(branch)
    shape = branch["gap_zero_shape"].values[:, kind.inset_gap_zero_mode - 1]
    return float(shape[b] / shape[a]) if shape[a] != 0 else None


def _points_of(ds: xr.Dataset, points: np.ndarray) -> xr.Dataset:
    """The consecutive ``points`` of a branch dataset, with its located branch points, folds and identity changes
    among them (their point indices renumbered)."""
    out = ds.isel(point=points).assign_coords(point=np.arange(len(points)))
    for dim, index in (
        ("located_branch_point", "branch_point_flagged_point"),
        ("located_fold", "fold_point"),
        ("identity_change", "identity_change_point"),
    ):
        if index in out:
            kept = np.flatnonzero(np.isin(out[index].values, points))
            out = out.isel({dim: kept})
            out[index] = out[index] - int(points[0])
    return out


def _scene(name: str, branch: xr.Dataset, spec: dict, whole: xr.Dataset | None):
    """The branch drawn, the mask of its focus points and a note, by the configuration or, failing it, by physics.

    The configured stages are drawn when they hold orbits, their ``focus_stages`` set the window; where those
    hold none, the focus is the figure's scene by physics within what is drawn (:func:`scene_part`); where the
    configured stages hold no orbit at all, the scene by physics of ``whole`` (every NNM1 stage read) is drawn
    instead, so that a stage the continuation did not reach at these parameters leaves no empty panel.
    """
    notes = []
    if branch.sizes["point"] == 0 and whole is not None and whole.sizes["point"] and name in SCENES:
        part, why = scene_part(whole, name)
        if part is None:  # the scene does not exist here: the branch is shown as it is, no letter placed
            notes.append(f"{why}: the whole branch is drawn, without the figure's labelled points")
            return whole, None, notes, "absent"
        notes.append(f"the configured stages hold no orbit: drawn instead {why}")
        return _points_of(whole, np.flatnonzero(part)), None, notes, "found"
    stages = spec.get("focus_stages")
    focus = np.isin(branch["stage"].values, stages) if stages else None
    if focus is not None and not focus.any() and branch.sizes["point"] and name in SCENES:
        part, why = scene_part(branch, name)
        focus = part
        if part is None:
            notes.append(f"focus stages {list(stages)} hold no orbit and {why}: the window spans what is drawn")
        else:
            notes.append(f"focus stages {list(stages)} hold no orbit: the window follows {why}")
    return branch, focus, notes, ""


def _figure_with_modal_lines(name, branch, spec, pdf_path, nnm2=None, png_dpi=150, **extra):
    """Frequency-energy plot of ``branch`` on top, the modal lines of its placed labels below.

    ``extra``: ``branch_label``, ``exact``, ``bifurcated`` (switched branches), ``stages`` (the stage
    datasets read, skipped ones included, for the notes) and ``whole`` (every NNM1 stage read, joined: the
    scene by physics where the configured stages hold no orbit, :func:`_scene`).
    """
    kind, where = PAPER_FIGURES[name], name
    bifurcated = list(extra.get("bifurcated") or [])
    exact = extra.get("exact")
    _checked(name, branch, nnm2, exact, bifurcated)
    branch, focus, scene_notes, by_physics = _scene(name, branch, spec, extra.get("whole"))
    if by_physics == "absent":
        placed, missing = (
            [],
            [(label, "no such scene at these parameters") for label in label_specs(spec.get("labels"))],
        )
    elif branch.sizes["point"]:
        placed, missing = _placed_labels(name, branch, spec, any_stage=by_physics == "found")
    else:
        placed, missing = [], []
    window = energy_window(branch, spec, [p for _, p in placed], where, focus)
    placed = _inside_window(branch, placed, missing, _range(spec, "energy_range", where))
    color = NNM1_COLOR if kind.branch == "nnm1" else NNM2_COLOR
    rows, cols = _inset_grid(max(len(placed), 1))
    below = spec.get("legend") == "below"
    fig = plt.figure(figsize=(FIGURE_WIDTH, 4.4 + 2.3 * rows), layout="constrained")
    try:
        fig.get_layout_engine().set(h_pad=0.06, w_pad=0.06, hspace=0.04, wspace=0.06)
        top = 2 if below else 1  # the first row of modal lines, under the plot and its legend row
        grid = fig.add_gridspec(top + rows, cols, height_ratios=[4.0] + [1.0] * (top - 1) + [2.3] * rows)
        ax = fig.add_subplot(grid[0, :])
        branch_label = extra.get("branch_label") or kind.branch.upper()
        if by_physics == "found":
            branch_label = f"{kind.branch.upper()} (the part of the continuation this figure is about)"
        elif by_physics == "absent":
            branch_label = f"{kind.branch.upper()} (every stage continued)"
        handles, _ = _draw_fep(ax, kind, branch, nnm2, spec, where, branch_label, window, exact, bifurcated)
        slope = _inset_slope(kind, branch)
        for i, (label, point) in enumerate(placed):
            mark_point(ax, branch, point, label)
            inset = fig.add_subplot(grid[top + i // cols, i % cols])
            draw_modal_line(inset, branch, point, label, color, reference_slope=slope)
        if handles and not below:
            ax.legend(handles=handles, loc=spec.get("legend", "best"), fontsize=7.5, framealpha=0.9)
        notes = scene_notes + _missing_notes(branch, extra.get("stages") or [], bifurcated, missing)
        scene = _scene_line(branch, window, kind.resonance)
        if placed:
            scene += ("\n" if scene else "") + _inset_line(branch)
        title = _title(kind, branch, scene, notes)
        fig.suptitle(wrapped_title(title, TITLE_FONTSIZE), fontsize=TITLE_FONTSIZE, linespacing=1.35)
        if handles and below:
            _legend_below(fig, grid, handles)
    except Exception:
        plt.close(fig)
        raise
    return save_figure(fig, pdf_path, png_dpi=png_dpi, description=title, after_layout=place_labels)


def _legend_below(fig, grid, handles) -> None:
    """The legend in its own row under the frequency-energy plot, off the data: two columns, or one where two
    would not fit the figure's width.

    The row is made as high as the legend measures: the figure is laid out (its title included, so call this
    last) and the row's height ratio and the figure's height corrected until the row holds the legend.
    """
    holder = fig.add_subplot(grid[1, :])
    holder.axis("off")
    renderer = fig.canvas.get_renderer()
    for ncols in (2, 1):  # one column where two would not fit the figure's width (less its margins)
        legend = holder.legend(handles=handles, loc="center", ncols=ncols, fontsize=7.5, frameon=False, borderaxespad=0)
        if legend.get_window_extent(renderer).width <= 0.88 * fig.get_figwidth() * fig.dpi:
            break
    legend.set_in_layout(False)  # sized here: the layout must not squeeze the columns to fit it
    need = legend.get_window_extent(renderer).height / fig.dpi + 0.05
    ratios = list(grid.get_height_ratios())
    ratios[1] = need
    grid.set_height_ratios(ratios)
    width, total = fig.get_size_inches()
    fig.set_size_inches(width, total + need)
    for _ in range(4):
        fig.get_layout_engine().execute(fig)
        have = holder.get_position().height * fig.get_figheight()
        if have >= 0.99 * need:
            break
        per_inch = sum(ratios) / (sum(ax.get_position().height for ax in _row_axes(fig, grid)) * fig.get_figheight())
        ratios[1] += (need - have) * per_inch
        grid.set_height_ratios(ratios)
        fig.set_size_inches(width, fig.get_figheight() + need - have)


def _row_axes(fig, grid) -> list:
    """One axes of each row of ``grid`` (for the rows' heights)."""
    rows = {}
    for ax in fig.axes:
        spec = ax.get_subplotspec()
        if spec is not None and spec.get_gridspec() is grid:
            rows.setdefault(spec.rowspan.start, ax)
    return list(rows.values())


def wrapped_title(title: str, fontsize: float, width_inches: float = FIGURE_WIDTH) -> str:
    """``title`` with each line wrapped to fit ``width_inches`` at ``fontsize`` points (a figure title that is
    cut at both edges says nothing).

    The width of a character of the figures' sans-serif font is taken as 0.6 of the font size, above the
    mean of lower-case text (about 0.5), so that a line of digits and capitals fits too.
    """
    import textwrap

    width = max(20, int(width_inches * 72.0 / (0.6 * fontsize)))
    return "\n".join(textwrap.fill(line, width) for line in title.split("\n"))


# --------------------------------------------------------------------------- the figures


def figure_05(nnm1: xr.Dataset, nnm2: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150):
    """Fig 5: FEP of NNM1 (blue) and NNM2 (green) over the whole energy range.

    Parameters
    ----------
    nnm1, nnm2 : xarray.Dataset
        Whole-branch datasets.
    spec : dict
        ``figures.fig05`` of the configuration (optional ``energy_range``, ``frequency_range``, ``legend``).
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
    check_same_structure(nnm1, nnm2, where=where)
    energy_range = _range(spec, "energy_range", where)
    gap_zero = gap_zero_frequencies(nnm1)[[m - 1 for m in kind.gap_zero_modes]]
    fig, (ax, zoom) = plt.subplots(2, 1, figsize=(FIGURE_WIDTH, 8.0), layout="constrained", height_ratios=[1.1, 1.0])
    try:
        zoom_window = _fig05_zoom_window(nnm1, energy_range)
        zoom_range = _auto_limits([nnm1], zoom_window, gap_zero[:1])
        handles = _fig05_whole(ax, nnm1, nnm2, kind, gap_zero, (zoom_window, zoom_range))
        frequency_range = _range(spec, "frequency_range", where) or _auto_limits([nnm1, nnm2], energy_range, gap_zero)
        ax.set_ylim(*frequency_range)
        if energy_range is not None:
            ax.set_xlim(*energy_range)
        ax.legend(handles=handles, loc=spec.get("legend", "best"), fontsize=8, framealpha=0.9)
        zoom_handles = _fig05_nnm1(zoom, nnm1, gap_zero[0], kind.gap_zero_modes[0])
        zoom.set_xlim(*zoom_window)
        zoom.set_ylim(*zoom_range)
        label_minor_decades(zoom)
        zoom.legend(handles=zoom_handles, loc="best", fontsize=7.5, framealpha=0.9)
        notes = _fig05_notes(nnm1)
        title = _title(kind, nnm1, "", notes)
        fig.suptitle(wrapped_title(title, 9.0), fontsize=9.0, linespacing=1.4)
    except Exception:
        plt.close(fig)
        raise
    return save_figure(fig, pdf_path, png_dpi=png_dpi, description=title)


def _fig05_notes(nnm1: xr.Dataset) -> list[str]:
    """What Fig 5 says of NNM1 beyond its curve: stages not continued and why; what its continuation ends as."""
    notes = []
    if "skip_reason" in nnm1.attrs:
        stages = ", ".join(str(int(k)) for k in np.atleast_1d(nnm1.attrs.get("skipped_stages", [])))
        reason = str(nnm1.attrs["skip_reason"]).removeprefix("skipped: ")
        notes.append(f"NNM1 stage(s) {stages} not continued: {reason}")
    runs = identity_runs(nnm1)
    if runs and runs[-1].label != "NNM1":
        energy = nnm1["energy"].values
        notes.append(
            f"the NNM1 continuation ends as {runs[-1].label} (from E = {energy[runs[-1].start]:.4g} to "
            f"{energy[-1]:.4g}): it crossed onto that family, this part is not NNM1"
        )
    return notes


def _fig05_zoom_window(nnm1: xr.Dataset, energy_range) -> tuple[float, float]:
    """Energy window of Fig 5 (b): from half the lowest located branch point or fold of NNM1 to its end.

    The whole branch (or ``energy_range``) when NNM1 holds none of them.
    """
    energy = nnm1["energy"].values
    features = np.concatenate([nnm1["branch_point_energy"].values, nnm1["fold_energy"].values])
    lo = float(features.min()) / 2.0 if features.size else float(energy.min())
    hi = float(energy.max())
    if energy_range is not None:
        lo, hi = max(lo, energy_range[0]), min(hi, energy_range[1])
    pad = WINDOW_MARGIN * max(np.log(hi / lo), np.log(2.0)) / 2.0
    return float(lo * np.exp(-pad)), float(hi * np.exp(pad))


def _fig05_whole(ax, nnm1, nnm2, kind: _FigureKind, gap_zero, zoom) -> list:
    """Panel (a) of Fig 5: both NNMs, the gap-0 modes and the frame enlarged in (b); legend handles."""
    handles, drawn, others = [], set(), {}
    for ds, color, label in ((nnm1, NNM1_COLOR, "NNM1 (enlarged in (b))"), (nnm2, NNM2_COLOR, "NNM2")):
        classes, found = plot_identities(ax, ds, color, lw=1.3, zorder=3)
        drawn |= classes
        others.update(found)
        handles.append(Line2D([], [], color=color, lw=1.3, label=label))
    handles.extend(identity_legend_handles(others, lw=1.3))
    handles.extend(stability_legend_handles(drawn, lw=1.3))
    _fig05_gap_zero(ax, kind.gap_zero_modes, gap_zero)
    handles.append(Line2D([], [], label="gap-0 linear modes (every stop engaged)", **GAP_ZERO_STYLE))
    (e0, e1), (f0, f1) = zoom
    frame = {"fill": False, "ec": "0.3", "lw": 0.8, "ls": (0, (2, 1.5))}
    ax.add_patch(Rectangle((e0, f0), e1 - e0, f1 - f0, zorder=2.5, **frame))
    handles.append(Patch(label="part enlarged in (b)", **frame))
    handles.extend(_bifurcation_legend(_bifurcation_markers(ax, nnm2)))
    frequency_energy_axes(ax)
    ax.set_title("(a) whole energy range", fontsize=8.5, loc="left")
    return handles


def _fig05_nnm1(ax, nnm1, gap_zero: float, mode: int) -> list:
    """Panel (b) of Fig 5: NNM1 alone on its own frequency scale, with its branch points and folds."""
    drawn, others = plot_identities(ax, nnm1, NNM1_COLOR, lw=1.2, zorder=3)
    handles = [Line2D([], [], color=NNM1_COLOR, lw=1.2, label="NNM1")]
    handles.extend(identity_legend_handles(others))
    handles.extend(stability_legend_handles(drawn, color=NNM1_COLOR))
    _fig05_gap_zero(ax, (mode,), [gap_zero])
    handles.extend(_bifurcation_legend(_bifurcation_markers(ax, nnm1)))
    frequency_energy_axes(ax)
    ax.set_title("(b) NNM1 from its first branch point or fold on (frame in (a))", fontsize=8.5, loc="left")
    return handles


def _fig05_gap_zero(ax, modes, values) -> None:
    """The gap-0 linear modes as horizontal lines, named at the right edge just above them."""
    for mode, value in zip(modes, values):
        ax.axhline(value, zorder=1, **GAP_ZERO_STYLE)
        ax.annotate(
            f"gap-0 linear mode {mode}: {value:.4f} Hz",
            xy=(1.0, value),
            xycoords=("axes fraction", "data"),
            xytext=(-4, 3),
            textcoords="offset points",
            fontsize=7.5,
            color="0.2",
            va="bottom",
            ha="right",
        )


def figure_06(nnm2: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150):
    """Fig 6: FEP of NNM2 with the modal lines a)-f) of ``spec['labels']``.

    Needs only the NNM2 dataset. Returns the PDF and PNG paths.
    """
    return _figure_with_modal_lines("fig06", nnm2, spec, pdf_path, png_dpi=png_dpi)


def _nnm1_figure(name, branch, spec, pdf_path, nnm2=None, png_dpi=150, exact=None, bifurcated=None, stages=None,
                 whole=None):  # fmt: skip
    held = np.unique(branch["stage"].values)
    if held.size == 0:  # every stage read was skipped
        held = [int(ds.attrs.get("skipped_stage", 0)) for ds in stages or [branch]]
    text = f"stage {held[0]}" if len(held) == 1 else f"stages {held[0]}-{held[-1]}"
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
        stages=stages,
        whole=whole,
    )


def figure_07(nnm1: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150, exact=None, stages=None, whole=None):
    """Fig 7: NNM1 at low energy, modal lines a)-c) (no impact, one impact per stop, secondary
    oscillation between impacts). ``nnm1``: the NNM1 stages of the figure, joined
    (``nnmstop.tasks.figures.combine_nnm1_stages``); ``stages``: those datasets, for the notes; ``whole``: every
    NNM1 stage read (up to the figure's last), joined, for the scene by physics (:func:`scene_part`)."""
    return _nnm1_figure("fig07", nnm1, spec, pdf_path, png_dpi=png_dpi, exact=exact, stages=stages, whole=whole)


def figure_08(nnm1, nnm2, spec: dict, pdf_path, png_dpi: int = 150, exact=None, bifurcated=None, stages=None,
              whole=None):  # fmt: skip
    """Fig 8: NNM1 with the NNM2 curve at ``f2/3``; the 3:1 internal resonance and the branch switched there,
    modal lines d)-i)."""
    return _nnm1_figure("fig08", nnm1, spec, pdf_path, nnm2, png_dpi, exact, bifurcated, stages, whole)


def figure_09(nnm1, nnm2, spec: dict, pdf_path, png_dpi: int = 150, exact=None, bifurcated=None, stages=None,
              whole=None):  # fmt: skip
    """Fig 9: NNM1 with the NNM2 curve at ``f2/5``; the 5:1 internal resonance, modal lines j)-m)."""
    return _nnm1_figure("fig09", nnm1, spec, pdf_path, nnm2, png_dpi, exact, bifurcated, stages, whole)


def figure_10(nnm1, nnm2, spec: dict, pdf_path, png_dpi: int = 150, exact=None, bifurcated=None, stages=None,
              whole=None):  # fmt: skip
    """Fig 10: NNM1 with the NNM2 curve at ``f2/5`` after the 5:1 resonance, modal lines o)-q)."""
    return _nnm1_figure("fig10", nnm1, spec, pdf_path, nnm2, png_dpi, exact, bifurcated, stages, whole)


def figure_11(nnm1: xr.Dataset, spec: dict, pdf_path, png_dpi: int = 150, exact=None, stages=None, whole=None):
    """Fig 11: NNM1 at high energy, tending to the gap-0 first linear mode (dash-dotted)."""
    return _nnm1_figure("fig11", nnm1, spec, pdf_path, png_dpi=png_dpi, exact=exact, stages=stages, whole=whole)
