"""Extra figure: Floquet stability along NNM1, exact (red) against regularized (blue).

Frequency-energy plot of both branches, solid where stable, dashed where unstable (dotted
where the regularized dataset has no verdict), with their stability changes marked (located
between consecutive orbits by :func:`nnmstop.compare.stability.stability_changes`). Left
panel (a): the whole branch, with the zoomed windows framed; the others zoom where the
stability changes crowd (:func:`change_clusters`, or configured windows). The title gives
the agreement counts of the comparison dataset (``results/compare/nnm1_stability.nc``).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from nnmstop.compare.stability import stability_changes, verdicts
from nnmstop.figures.common import (
    EXACT_COLOR,
    REGULARIZED_COLOR,
    frequency_energy_axes,
    label_minor_decades,
    plot_branch,
)

__all__ = ["CLUSTER_GAP_DECADES", "change_clusters", "stability_figure"]

#: Stability changes further apart than this in log10 energy start a new zoomed panel.
CLUSTER_GAP_DECADES = 0.5
#: Most zoomed panels drawn from the data (the clusters holding most changes).
MAX_ZOOMS = 5
#: Panels per row.
PANEL_COLUMNS = 3


def change_clusters(energies, gap_decades: float = CLUSTER_GAP_DECADES, max_windows: int = MAX_ZOOMS):
    """Energy windows around the groups of stability changes, in increasing energy.

    Changes closer than ``gap_decades`` in log10 energy form one group; each group's window is its
    log span widened by 30 % (at least a factor 1.6) on each side. The ``max_windows`` groups that hold
    most changes are kept.

    Examples
    --------
    >>> [tuple(round(v, 2) for v in w) for w in change_clusters([5.0, 10.0, 20.0, 300.0, 3000.0], max_windows=2)]
    [(3.13, 32.0), (187.5, 480.0)]
    """
    energy = np.sort(np.asarray(energies, dtype=float))
    if energy.size == 0:
        return []
    log = np.log10(energy)
    groups = np.split(log, np.flatnonzero(np.diff(log) > gap_decades) + 1)
    kept = sorted(sorted(range(len(groups)), key=lambda k: (-groups[k].size, k))[:max_windows])
    windows = []
    for k in kept:
        lo, hi = groups[k][0], groups[k][-1]
        pad = max(0.3 * (hi - lo), np.log10(1.6))
        windows.append((float(10 ** (lo - pad)), float(10 ** (hi + pad))))
    return windows


def _check(name: str, ds: xr.Dataset) -> None:
    missing = [v for v in ("energy", "frequency", "stable") if v not in ds]
    if missing:
        raise ValueError(f"the {name} dataset lacks {missing}")
    for v in ("energy", "frequency"):
        if not np.all(np.isfinite(ds[v].values)):
            raise ValueError(f"the {name} dataset's {v!r} holds NaN or infinite values")


def stability_figure(
    exact: xr.Dataset, regularized: xr.Dataset, comparison: xr.Dataset | None = None, zoom_energy=None
):
    """The figure (not saved).

    Parameters
    ----------
    exact, regularized : xarray.Dataset
        NNM1 branches with ``energy``, ``frequency`` and ``stable``.
    comparison : xarray.Dataset, optional
        From :func:`nnmstop.compare.stability.stability_comparison_dataset`; its agreement
        counts go in the title.
    zoom_energy : sequence of (low, high), optional
        Energy windows of the zoomed panels, ``0 < low < high``; by default where the stability
        changes of either branch crowd (:func:`change_clusters`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check("exact", exact)
    _check("regularized", regularized)
    if zoom_energy is None:
        zoom_energy = change_clusters([c["energy"] for ds in (exact, regularized) for c in _changes(ds)])
    for window in zoom_energy:
        if len(window) != 2 or not 0 < window[0] < window[1]:
            raise ValueError(f"a zoom window is [low, high] with 0 < low < high, got {window!r}")
    panels = 1 + len(zoom_energy)
    columns = min(panels, PANEL_COLUMNS)
    rows = -(-panels // columns)
    fig, grid = plt.subplots(rows, columns, figsize=(4.7 * columns, 4.6 * rows + 0.4), squeeze=False)
    axes, spare = list(grid.ravel()[:panels]), list(grid.ravel()[panels:])
    drawn = set()
    for ax in axes:
        drawn |= _branches_with_changes(ax, exact, regularized)
    axes[0].set_title("(a) NNM1, whole branch (frames: the zoomed panels)", fontsize=9)
    for k, (ax, window) in enumerate(zip(axes[1:], zoom_energy)):
        letter = "bcdefg"[k]
        _zoom(ax, window, (exact, regularized), letter)
        _frame(axes[0], ax, letter)
    handles = _legend(regularized, "unresolved" in drawn)
    for ax in spare:
        ax.axis("off")
    if spare:  # the legend in an empty slot of the grid, off the data
        spare[0].legend(handles=handles, fontsize=8, loc="center")
    else:
        axes[0].legend(handles=handles, fontsize=7, loc="lower right")
    title = "Floquet stability of NNM1: exact vs regularized"
    if comparison is not None:
        title += (
            f" (same verdict at {comparison.attrs['agreeing_orbits']} of {comparison.attrs['compared_orbits']} "
            "regularized orbits compared at equal energy)"
        )
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def _branches_with_changes(ax, exact: xr.Dataset, regularized: xr.Dataset) -> set:
    """Both branches, line style by verdict, their stability changes marked; the stability classes drawn."""
    frequency_energy_axes(ax)
    drawn = set()
    for ds, color, marker in ((regularized, REGULARIZED_COLOR, "s"), (exact, EXACT_COLOR, "o")):
        drawn |= plot_branch(
            ax, ds, color, lw=0.9 if color == EXACT_COLOR else 2.4, zorder=4 if color == EXACT_COLOR else 3
        )
        changes = _changes(ds)
        if changes:
            e, f = [c["energy"] for c in changes], [c["frequency"] for c in changes]
            ax.plot(e, f, marker, ms=6, mfc="none", mec=color, mew=1.3, ls="none", zorder=5)
    return drawn


def _changes(ds: xr.Dataset) -> list:
    return stability_changes(ds["energy"].values, ds["frequency"].values, verdicts(ds))


def _frame(whole, zoomed, letter: str) -> None:
    """The window of a zoomed panel as a frame on the whole branch, with its letter."""
    (e0, e1), (f0, f1) = zoomed.get_xlim(), zoomed.get_ylim()
    whole.add_patch(Rectangle((e0, f0), e1 - e0, f1 - f0, fill=False, ec="0.3", lw=0.8, ls=(0, (2, 1.5)), zorder=6))
    whole.annotate(f"({letter})", (e0, f1), xytext=(0, 2), textcoords="offset points", fontsize=7, va="bottom")


def _zoom(ax, window, datasets, letter: str) -> None:
    lo, hi = window
    ax.set_xlim(lo, hi)
    inside = [ds["frequency"].values[(ds["energy"].values >= lo) & (ds["energy"].values <= hi)] for ds in datasets]
    frequency = np.concatenate(inside)
    if frequency.size:
        pad = 0.05 * (frequency.max() - frequency.min())
        ax.set_ylim(frequency.min() - pad, frequency.max() + pad)
    ax.set_title(f"({letter}) zoom: energy {lo:.3g} to {hi:.3g}", fontsize=9)
    label_minor_decades(ax)


def _legend(regularized: xr.Dataset, unresolved: bool) -> list:
    eta = regularized.attrs.get("eta", "?")
    handles = [
        Line2D([], [], color=EXACT_COLOR, lw=0.9, label="exact (non-smooth model)"),
        Line2D([], [], color=REGULARIZED_COLOR, lw=2.4, label=f"regularized (HBM, eta = {eta})"),
        Line2D([], [], color="0.3", lw=1.2, label="stable"),
        Line2D([], [], color="0.3", lw=1.2, ls="--", label="unstable"),
    ]
    if unresolved:
        handles.append(Line2D([], [], color="0.3", lw=1.2, ls=":", label="regularized: no verdict"))
    return handles + [
        Line2D([], [], marker="o", mfc="none", mec=EXACT_COLOR, ls="none", label="stability change, exact"),
        Line2D([], [], marker="s", mfc="none", mec=REGULARIZED_COLOR, ls="none", label="stability change, regularized"),
    ]
