"""Extra figure: Floquet stability along NNM1, exact (red) against regularized (blue).

Frequency-energy plot of both branches, solid where stable, dashed where unstable (dotted
where the regularized dataset has no verdict), with their stability changes marked (located
between consecutive orbits by :func:`nnmstop.compare.stability.stability_changes`). Left
panel: the whole branch; the others zoom on the multi-impact regimes, where the changes crowd.
The title gives the agreement counts of the comparison dataset
(``results/compare/nnm1_stability.nc``).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.ticker import NullFormatter

from nnmstop.compare.stability import stability_changes, verdicts
from nnmstop.figures.common import EXACT_COLOR, REGULARIZED_COLOR, frequency_energy_axes, plot_branch

__all__ = ["ZOOM_ENERGY", "stability_figure"]

#: Default energy windows of the zoomed panels (``figures.extra_stability.zoom_energy`` in the
#: configuration): the regimes around the 3:1 and the 5:1 internal resonances of NNM1 for the
#: paper's values, where the stability changes crowd.
ZOOM_ENERGY = ((3.0, 70.0), (150.0, 6000.0))


def _check(name: str, ds: xr.Dataset) -> None:
    missing = [v for v in ("energy", "frequency", "stable") if v not in ds]
    if missing:
        raise ValueError(f"the {name} dataset lacks {missing}")
    for v in ("energy", "frequency"):
        if not np.all(np.isfinite(ds[v].values)):
            raise ValueError(f"the {name} dataset's {v!r} holds NaN or infinite values")


def stability_figure(
    exact: xr.Dataset, regularized: xr.Dataset, comparison: xr.Dataset | None = None, zoom_energy=ZOOM_ENERGY
):
    """The figure (not saved).

    Parameters
    ----------
    exact, regularized : xarray.Dataset
        NNM1 branches with ``energy``, ``frequency`` and ``stable``.
    comparison : xarray.Dataset, optional
        From :func:`nnmstop.compare.stability.stability_comparison_dataset`; its agreement
        counts go in the title.
    zoom_energy : sequence of (low, high)
        Energy windows of the zoomed panels, ``0 < low < high``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check("exact", exact)
    _check("regularized", regularized)
    for window in zoom_energy:
        if len(window) != 2 or not 0 < window[0] < window[1]:
            raise ValueError(f"a zoom window is [low, high] with 0 < low < high, got {window!r}")
    fig, axes = plt.subplots(1, 1 + len(zoom_energy), figsize=(4.7 * (1 + len(zoom_energy)), 5.0), squeeze=False)
    axes = axes[0]
    drawn = set()
    for ax in axes:
        drawn |= _branches_with_changes(ax, exact, regularized)
    axes[0].set_title("NNM1, whole branch", fontsize=9)
    for ax, window in zip(axes[1:], zoom_energy):
        _zoom(ax, window, (exact, regularized))
    axes[0].legend(handles=_legend(regularized, "unresolved" in drawn), fontsize=7, loc="lower right")
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
        changes = stability_changes(ds["energy"].values, ds["frequency"].values, verdicts(ds))
        if changes:
            e, f = [c["energy"] for c in changes], [c["frequency"] for c in changes]
            ax.plot(e, f, marker, ms=6, mfc="none", mec=color, mew=1.3, ls="none", zorder=5)
    return drawn


def _zoom(ax, window, datasets) -> None:
    lo, hi = window
    ax.set_xlim(lo, hi)
    inside = [ds["frequency"].values[(ds["energy"].values >= lo) & (ds["energy"].values <= hi)] for ds in datasets]
    frequency = np.concatenate(inside)
    if frequency.size:
        pad = 0.05 * (frequency.max() - frequency.min())
        ax.set_ylim(frequency.min() - pad, frequency.max() + pad)
    ax.set_title(f"zoom: energy {lo:g} to {hi:g}", fontsize=9)
    ax.xaxis.set_minor_formatter(NullFormatter())  # the minor labels of a short log axis collide


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
