"""Figures of the study (issue 5): error against run time, and the stiff cases.

Both are drawn from the gathered study datasets only (``results/study/*.nc``); they are
measurements (run times), kept apart from the paper's Figs 2-11.

* :func:`error_vs_runtime_figure`: error against run time, log-log, one marker per
  setting (colour: ``eta``; label: ``H``), the Pareto front (no other setting is both
  faster and more accurate) ringed and joined, the regularization part of each ``eta``
  as a dashed floor; settings that did not converge are crosses at the top, at their
  measured time; settings compared on part of the energies only are hollow. A third
  panel shows the ANM order and tolerance sweep: the accuracy of the stored path itself
  (relative frequency shift of its worst point from the HBM solution curve, which the
  errors against the exact orbits do not see since matched orbits are Newton-solved)
  against run time.
* :func:`stiff_cases_figure`: harmonics needed per ``(alpha, eta)``, exactness of the
  exact solver, errors against the exact orbits, and the extreme-energy sweep.

Run time on these figures is the CPU time of each job (one BLAS thread), which is close
to the wall-clock time on an idle core and far less sensitive to the machine's load.
"""

from __future__ import annotations

import logging
import warnings

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib import transforms

__all__ = [
    "pareto_front",
    "error_vs_runtime_figure",
    "stiff_cases_figure",
]

logger = logging.getLogger("nnmstop.figures.study")

_ETA_COLORS = ("tab:purple", "tab:blue", "tab:green", "tab:orange", "tab:red", "tab:brown")


def pareto_front(cost, error) -> np.ndarray:
    """Indices of the Pareto-optimal points (lowest error for their cost), by increasing cost.

    A point is on the front when no other point has a cost and an error both at most its
    own with one of them strictly smaller. NaN entries are ignored.

    Examples
    --------
    >>> pareto_front([1.0, 2.0, 3.0, 4.0], [5.0, 6.0, 1.0, 1.0]).tolist()
    [0, 2]
    """
    cost, error = np.asarray(cost, dtype=float), np.asarray(error, dtype=float)
    if cost.shape != error.shape:
        raise ValueError(f"cost and error must have the same shape, got {cost.shape} and {error.shape}")
    valid = np.flatnonzero(np.isfinite(cost) & np.isfinite(error))
    order = valid[np.lexsort((error[valid], cost[valid]))]
    front, best = [], np.inf
    for i in order:
        if error[i] < best:
            front.append(int(i))
            best = error[i]
    return np.array(front, dtype=int)


def _partial_errors(ds: xr.Dataset, key: str) -> np.ndarray:
    """Largest error over the matched energies only (for the settings compared on part of them)."""
    values = np.abs(ds[f"{key}_at_energy"].values)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: settings never compared
        return np.nanmax(values, axis=-1)


def _sweep_panel(ax, ds: xr.Dataset, key: str, summary: str, ylabel: str, time_var: str):
    Hs, etas = ds["harmonics"].values, ds["eta"].values
    time = ds[time_var].values
    full = ds[summary].values
    partial = _partial_errors(ds, key)
    converged, compared = ds["converged"].values, ds["compared"].values
    top = transforms.blended_transform_factory(ax.transData, ax.transAxes)
    for j, eta in enumerate(etas):
        color = _ETA_COLORS[j % len(_ETA_COLORS)]
        ok = compared[:, j]
        ax.plot(time[ok, j], full[ok, j], "o-", color=color, ms=4, lw=0.8, label=f"eta = {eta:g}")
        part = converged[:, j] & ~compared[:, j] & np.isfinite(partial[:, j])
        if part.any():
            ax.plot(time[part, j], partial[part, j], "o", mfc="none", color=color, ms=5)
        floor = ds[summary + "_regularization"].values[j] if summary + "_regularization" in ds else np.nan
        if np.isfinite(floor):
            ax.axhline(floor, color=color, ls="--", lw=0.6, alpha=0.7)
        for i, H in enumerate(Hs):
            if ok[i] or part[i]:
                y = full[i, j] if ok[i] else partial[i, j]
                ax.annotate(f"{H}", (time[i, j], y), textcoords="offset points", xytext=(3, 2), fontsize=6, color=color)
            elif not converged[i, j] and np.isfinite(time[i, j]):
                ax.plot(time[i, j], 0.97, "x", color=color, ms=6, transform=top, clip_on=False)
                ax.annotate(
                    f"{H}",
                    (time[i, j], 0.97),
                    xycoords=top,
                    textcoords="offset points",
                    xytext=(3, -8),
                    fontsize=6,
                    color=color,
                )
    # room above the data for the crosses of the settings that did not converge
    shown = np.concatenate([full[compared], partial[converged & ~compared]])
    shown = shown[np.isfinite(shown) & (shown > 0)]
    if shown.size:
        ax.set_ylim(shown.min() / 3.0, shown.max() * 30.0)
    cost = np.where(compared, time, np.nan).ravel()
    front = pareto_front(cost, np.where(compared, full, np.nan).ravel())
    if front.size:
        ax.step(cost[front], full.ravel()[front], where="post", color="k", lw=0.8, alpha=0.6, label="Pareto front")
        ax.plot(cost[front], full.ravel()[front], "o", mfc="none", mec="k", ms=9, mew=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("run time (CPU s of the job, 1 BLAS thread)")
    ax.set_ylabel(ylabel)


def error_vs_runtime_figure(ds: xr.Dataset):
    """The error-against-run-time figure (see the module docstring); returns the figure."""
    for name in ("harmonics", "eta", "cpu_time", "frequency_error", "x_error", "converged", "compared"):
        if name not in ds.variables:
            raise ValueError(f"the error_vs_runtime dataset lacks the variable {name!r}")
    fig, axes = plt.subplots(1, 3, figsize=(13.5, 4.4), constrained_layout=True)
    _sweep_panel(
        axes[0],
        ds,
        "relative_frequency_difference",
        "frequency_error",
        "largest |relative frequency error|",
        "cpu_time",
    )
    _sweep_panel(axes[1], ds, "max_x_difference", "x_error", "largest |x error| over the orbit", "cpu_time")
    axes[0].set_title("(a) frequency (labels: H; dashed: regularization part)", fontsize=8)
    axes[1].set_title("(b) displacement x (x: not resolved; hollow: partial range)", fontsize=8)
    axes[0].legend(fontsize=7, loc="lower left")
    ax = axes[2]
    orders, tols = ds["order"].values, ds["tolerance"].values
    time, residual, conv = ds["anm_cpu_time"].values, ds["anm_path_frequency_error"].values, ds["anm_converged"].values
    markers = "osD^v<>p"
    for j, tol in enumerate(tols):
        ok = conv[:, j] & np.isfinite(residual[:, j])
        ax.plot(time[ok, j], residual[ok, j], markers[j % len(markers)] + "-", ms=4, lw=0.8, label=f"tol {tol:g}")
        for i, order in enumerate(orders):
            if ok[i]:
                ax.annotate(
                    f"N{order}", (time[i, j], residual[i, j]), textcoords="offset points", xytext=(3, 2), fontsize=6
                )
            elif np.isfinite(time[i, j]):
                ax.plot(
                    time[i, j],
                    0.97,
                    "x",
                    color="k",
                    transform=transforms.blended_transform_factory(ax.transData, ax.transAxes),
                )
    ok = conv & np.isfinite(residual)
    if ok.any():
        ax.set_ylim(residual[ok].min() / 3.0, residual[ok].max() * 30.0)
    front = pareto_front(np.where(ok, time, np.nan).ravel(), np.where(ok, residual, np.nan).ravel())
    if front.size:
        ax.plot(
            time.ravel()[front], residual.ravel()[front], "o", mfc="none", mec="k", ms=9, mew=0.8, label="Pareto front"
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("run time (CPU s of the job, 1 BLAS thread)")
    ax.set_ylabel("frequency error of the worst stored point vs the HBM curve")
    ax.set_title(
        f"(c) ANM order N and tolerance (H = {ds.attrs.get('anm_sweep_harmonics', '?')}, eta = "
        f"{ds.attrs.get('anm_sweep_eta', '?')})",
        fontsize=8,
    )
    ax.legend(fontsize=7, loc="best")
    return fig


def stiff_cases_figure(ds: xr.Dataset):
    """The stiff-cases figure (see the module docstring); returns the figure."""
    for name in ("alpha", "eta", "converged", "harmonics", "exact_relative_residual", "energy_periodicity_error"):
        if name not in ds.variables:
            raise ValueError(f"the stiff_cases dataset lacks the variable {name!r}")
    fig, axes = plt.subplots(2, 2, figsize=(11.5, 8.0), constrained_layout=True)
    _harmonics_needed(axes[0, 0], ds)
    _exact_solver(axes[0, 1], ds)
    _error_against_exact(axes[1, 0], ds)
    _extreme_energies(axes[1, 1], ds)
    return fig


def _at_top(ax):
    """Transform of markers at a height in axes units above a data abscissa."""
    return transforms.blended_transform_factory(ax.transData, ax.transAxes)


def _harmonics_needed(ax, ds: xr.Dataset) -> None:
    """(a) harmonics needed on the alpha x eta grid."""
    alphas, etas = ds["alpha"].values, ds["eta"].values
    H = ds["harmonics"].values.astype(float)
    shown = np.where(ds["converged"].values, np.log2(np.where(H > 0, H, np.nan)), np.nan)
    ax.imshow(shown.T, origin="lower", cmap="viridis", aspect="auto", vmin=np.log2(16), vmax=np.log2(1024))
    for i in range(alphas.size):
        for j in range(etas.size):
            if ds["converged"].values[i, j]:
                text = f"H={int(H[i, j])}\n{int(ds['steps'].values[i, j])} steps"
                color = "w"
            else:
                text = "not resolved\n(H <= " + ds.attrs.get("harmonics_tried", "?").split(",")[-1].strip() + ")"
                color = "k"
            ax.text(i, j, text, ha="center", va="center", fontsize=7, color=color)
    ax.set_xticks(range(alphas.size), [f"{a:g}" for a in alphas])
    ax.set_yticks(range(etas.size), [f"{e:g}" for e in etas])
    ax.set_xlabel("alpha")
    ax.set_ylabel("eta")
    ax.grid(False)
    ax.set_title("(a) harmonics needed for NNM1 stage 1 (guarded continuation)", fontsize=8)


def _exact_solver(ax, ds: xr.Dataset) -> None:
    """(b) exactness of the exact solver."""
    labels = [f"a={a:g}" for a in ds["alpha"].values]
    res = list(ds["exact_relative_residual"].values)
    per = list(ds["exact_periodicity_error"].values)
    for b in ds["beta"].values:
        for d in ds["delta"].values:
            labels.append(f"b={b:g},d={d:g}")
            res.append(float(ds["ratio_exact_relative_residual"].sel(beta=b, delta=d)))
            per.append(float(ds["ratio_exact_periodicity_error"].sel(beta=b, delta=d)))
    x = np.arange(len(labels))
    ax.bar(x - 0.2, np.maximum(res, 1e-18), width=0.4, label="relative residual of the closed form")
    ax.bar(x + 0.2, np.maximum(per, 1e-18), width=0.4, label="periodicity error by event-located integration")
    ax.set_yscale("log")
    ax.set_xticks(x, labels, rotation=60, ha="right", fontsize=6)
    ax.axhline(np.finfo(float).eps, color="k", lw=0.6, ls=":")
    ax.set_title("(b) exact solver: residuals and periodicity (dotted: machine epsilon)", fontsize=8)
    ax.legend(fontsize=7)


def _error_against_exact(ax, ds: xr.Dataset) -> None:
    """(c) error against the exact orbits."""
    alphas = ds["alpha"].values
    for j, eta in enumerate(ds["eta"].values):
        color = _ETA_COLORS[(j + 1) % len(_ETA_COLORS)]
        ax.plot(alphas, ds["frequency_error"].values[:, j], "o-", color=color, label=f"eta = {eta:g}")
        for i, a in enumerate(alphas):
            if not ds["converged"].values[i, j]:
                ax.plot(a, 0.97, "x", color=color, transform=_at_top(ax))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("alpha")
    ax.set_ylabel("largest |relative frequency error|")
    ax.set_title("(c) regularized vs exact NNM1 with the H of (a) (x at the top: not resolved)", fontsize=8)
    ax.legend(fontsize=7)


def _extreme_energies(ax, ds: xr.Dataset) -> None:
    """(d) extreme energies."""
    energies = ds["energy"].values
    for k, a in enumerate(ds["energy_alpha"].values):
        per = ds["energy_periodicity_error"].values[:, k]
        freq = np.abs(ds["energy_hbm_frequency_difference"].values[:, k])
        ax.plot(energies, per, "s-", color=_ETA_COLORS[k], label=f"alpha = {a:g}: exact orbit, periodicity error")
        label = f"alpha = {a:g}: |HBM - exact| / exact frequency"
        ax.plot(energies, freq, "o--", color=_ETA_COLORS[k], mfc="none", label=label)
        for e, kind in zip(energies, ds["energy_kind"].values[:, k]):
            if kind == "none":
                ax.plot(e, 0.97 - 0.05 * k, "x", color=_ETA_COLORS[k], transform=_at_top(ax))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("energy")
    ax.set_title(
        f"(d) extreme energies (eta = {ds.attrs.get('energy_sweep_eta', '?')}; x: no two-impact orbit)", fontsize=8
    )
    ax.legend(fontsize=6)
