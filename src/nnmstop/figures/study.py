"""Figures of the study (issue 5): error against run time, and the stiff cases.

Both are drawn from the gathered study datasets only (``results/study/*.nc``); they are
measurements (run times), kept apart from the paper's Figs 2-11. A value the study did not
compute is never a silent gap: every setting that is not drawn, or drawn in part, is listed
under the panels with the reason its dataset stores (the ``status`` flags and their
``flag_meanings``, ``docs/methods/study.md``).

* :func:`error_vs_runtime_figure`: error against run time, log-log, one marker per
  setting (colour: ``eta``; label: ``H``), the Pareto front (no other setting is both
  faster and more accurate) ringed and joined; the regularization part of each ``eta`` as a
  dashed floor (dotted where its reference covers part of the energies only), the truncation
  part of each setting as a small triangle; settings compared on part of the energies only
  are hollow (largest error over the energies compared). A third panel shows the ANM order
  and tolerance sweep: the accuracy of the stored path itself (relative frequency shift of
  its worst point from the HBM solution curve, which the errors against the exact orbits do
  not see since matched orbits are Newton-solved) against run time.
* :func:`stiff_cases_figure`: harmonics needed per ``(alpha, eta)``, exactness of the
  exact solver, errors against the exact orbits, and the extreme-energy sweep.

Run time on these figures is the CPU time of each job (one BLAS thread), which is close
to the wall-clock time on an idle core and far less sensitive to the machine's load.
"""

from __future__ import annotations

import textwrap
import warnings

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from nnmstop.figures.labels import add_label, mark_obstacle
from nnmstop.study.status import status_words

__all__ = [
    "pareto_front",
    "error_vs_runtime_figure",
    "stiff_cases_figure",
]

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


def _listing(groups: dict) -> list[str]:
    """``{reason: {key: [value, ...]}}`` as lines ``reason: key (value, value); key (value)``."""
    lines = []
    for reason, keys in groups.items():
        parts = [f"{key} ({', '.join(values)})" if values else key for key, values in keys.items()]
        lines.append(f"{reason}: {'; '.join(parts)}")
    return lines


def _add(groups: dict, reason: str, key: str, value: str) -> None:
    groups.setdefault(reason, {}).setdefault(key, []).append(value)


def _add_notes(ax, lines: list[str], title: str, width: int = 95) -> None:
    """Text under a panel (an axes of its own, turned off) saying what is not drawn and why."""
    ax.axis("off")
    text = "\n".join(textwrap.fill(line, width, subsequent_indent="    ") for line in lines) or "every setting drawn"
    ax.text(0.0, 1.0, f"{title}\n{text}", va="top", ha="left", fontsize=6.5, transform=ax.transAxes)


def _partial_errors(ds: xr.Dataset, key: str) -> np.ndarray:
    """Largest error over the energies compared (for the settings compared on part of them)."""
    values = np.abs(ds[f"{key}_at_energy"].values)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: settings never compared
        return np.nanmax(values, axis=-1)


def _floor(ax, ds: xr.Dataset, key: str, summary: str, j: int, color) -> None:
    """The regularization part of eta ``j``: dashed over every energy, dotted over those compared."""
    full = ds[f"{summary}_regularization"].values[j]
    if np.isfinite(full):
        ax.axhline(full, color=color, ls="--", lw=0.8, alpha=0.8)
        return
    partial = np.abs(ds[f"{key}_regularization_at_energy"].values[j])
    if np.isfinite(partial).any():
        ax.axhline(np.nanmax(partial), color=color, ls=":", lw=0.9, alpha=0.9)


def _sweep_panel(ax, ds: xr.Dataset, key: str, summary: str, ylabel: str) -> None:
    Hs, etas = ds["harmonics"].values, ds["eta"].values
    time, full, partial = ds["cpu_time"].values, ds[summary].values, _partial_errors(ds, key)
    truncation = ds[f"{summary}_truncation"].values
    compared = ds["status"].values == 0
    drawn_partial = ~compared & np.isfinite(partial)
    for j, eta in enumerate(etas):
        color = _ETA_COLORS[j % len(_ETA_COLORS)]
        ok, part = compared[:, j], drawn_partial[:, j]
        mark_obstacle(ax.plot(time[ok, j], full[ok, j], "o-", color=color, ms=4, lw=0.8, label=f"eta = {eta:g}")[0])
        mark_obstacle(ax.plot(time[part, j], partial[part, j], "o", mfc="none", color=color, ms=5)[0])
        mark_obstacle(ax.plot(time[:, j], truncation[:, j], "v", color=color, ms=3, alpha=0.6)[0])
        _floor(ax, ds, key, summary, j, color)
        for i, H in enumerate(Hs):
            if ok[i] or part[i]:
                y = full[i, j] if ok[i] else partial[i, j]
                add_label(ax, f"{H}", (time[i, j], y), offset=(0, 7), fontsize=6, circled=False, color=color)
    cost = np.where(compared, time, np.nan).ravel()
    front = pareto_front(cost, np.where(compared, full, np.nan).ravel())
    if front.size:
        ax.step(cost[front], full.ravel()[front], where="post", color="k", lw=0.8, alpha=0.6, label="Pareto front")
        mark_obstacle(ax.plot(cost[front], full.ravel()[front], "o", mfc="none", mec="k", ms=9, mew=0.8)[0])
    ax.plot([], [], "o", mfc="none", color="gray", ms=5, label="part of the energies (hollow)")
    ax.plot([], [], "v", color="gray", ms=3, label="truncation part (H vs H_ref)")
    ax.plot([], [], "--", color="gray", lw=0.8, label="regularization part (H_ref vs exact)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("run time (CPU s of the job, 1 BLAS thread)")
    ax.set_ylabel(ylabel)


def _sweep_notes(ds: xr.Dataset) -> list[str]:
    """Which settings of the (H, eta) grid are not drawn, or drawn in part, and why."""
    words, groups = status_words(ds["status"]), {}
    partial = np.isfinite(_partial_errors(ds, "relative_frequency_difference"))
    for i, H in enumerate(ds["harmonics"].values):
        for j, eta in enumerate(ds["eta"].values):
            if words[i, j]:
                shown = "hollow: largest error over the energies compared" if partial[i, j] else "not drawn"
                _add(groups, f"{words[i, j]}, {shown}", f"H = {H}", f"eta = {eta:g}")
    lines = _listing(groups)
    ref_words = status_words(ds["reference_status"])
    for j, eta in enumerate(ds["eta"].values):
        if ref_words[j]:
            H_ref = ds.attrs.get("reference_harmonics", "?")
            lines.append(
                f"regularization part of eta = {eta:g} (dotted: over the energies its H_ref = {H_ref} "
                f"reference covers): {ref_words[j]}"
            )
    return lines


def _anm_panel(ax, ds: xr.Dataset) -> list[str]:
    orders, tols = ds["order"].values, ds["tolerance"].values
    time, residual = ds["anm_cpu_time"].values, ds["anm_path_frequency_error"].values
    words = status_words(ds["anm_status"])
    markers, notes = "osD^v<>p", {}
    for j, tol in enumerate(tols):
        ok = np.isfinite(residual[:, j])
        (line,) = ax.plot(
            time[ok, j], residual[ok, j], markers[j % len(markers)] + "-", ms=4, lw=0.8, label=f"tol {tol:g}"
        )
        mark_obstacle(line)
        for i, order in enumerate(orders):
            if ok[i]:
                xy = (time[i, j], residual[i, j])
                add_label(ax, f"N{order}", xy, offset=(0, 7), fontsize=6, circled=False, color=line.get_color())
            if words[i, j]:
                drawn = "drawn (its path is measured)" if ok[i] else "not drawn"
                _add(notes, f"{words[i, j]}, {drawn}", f"N{order}", f"tol {tol:g}")
    ok = np.isfinite(residual)
    front = pareto_front(np.where(ok, time, np.nan).ravel(), np.where(ok, residual, np.nan).ravel())
    if front.size:
        mark_obstacle(
            ax.plot(
                time.ravel()[front],
                residual.ravel()[front],
                "o",
                mfc="none",
                mec="k",
                ms=9,
                mew=0.8,
                label="Pareto front",
            )[0]
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("run time (CPU s of the job, 1 BLAS thread)")
    ax.set_ylabel("relative frequency error of the worst stored point\n(against the HBM solution curve)")
    ax.set_title(
        f"(c) ANM order N and tolerance (H = {ds.attrs.get('anm_sweep_harmonics', '?')}, eta = "
        f"{ds.attrs.get('anm_sweep_eta', '?')})",
        fontsize=8,
    )
    ax.legend(fontsize=7, loc="best")
    return _listing(notes)


def error_vs_runtime_figure(ds: xr.Dataset):
    """The error-against-run-time figure (see the module docstring); returns the figure."""
    for name in ("harmonics", "eta", "cpu_time", "frequency_error", "x_error", "status", "reference_status"):
        if name not in ds.variables:
            raise ValueError(f"the error_vs_runtime dataset lacks the variable {name!r}")
    fig = plt.figure(figsize=(13.5, 6.0), constrained_layout=True)
    grid = fig.add_gridspec(2, 3, height_ratios=[1.0, 0.28])
    axes = [fig.add_subplot(grid[0, k]) for k in range(3)]
    _sweep_panel(axes[0], ds, "relative_frequency_difference", "frequency_error", "largest |relative frequency error|")
    _sweep_panel(axes[1], ds, "max_x_difference", "x_error", "largest |x error| over the orbit (nondim.)")
    axes[0].set_title("(a) frequency against the exact orbits (labels: H)", fontsize=8)
    axes[1].set_title("(b) displacement x against the exact orbits (labels: H)", fontsize=8)
    axes[0].legend(fontsize=6.5, loc="lower left")
    anm_notes = _anm_panel(axes[2], ds)
    _add_notes(fig.add_subplot(grid[1, :2]), _sweep_notes(ds), "(a), (b): settings not compared at every energy")
    _add_notes(fig.add_subplot(grid[1, 2]), anm_notes, "(c): settings not compared at every energy", width=60)
    return fig


# --------------------------------------------------------------------------- stiff cases


def _harmonics_panel(ax, ds: xr.Dataset) -> None:
    alphas, etas = ds["alpha"].values, ds["eta"].values
    H = ds["harmonics"].values.astype(float)
    converged = ds["converged"].values
    shown = np.where(converged, np.log2(np.where(H > 0, H, np.nan)), np.nan)
    image = ax.imshow(shown.T, origin="lower", cmap="viridis", aspect="auto", vmin=np.log2(16), vmax=np.log2(1024))
    bar = ax.figure.colorbar(image, ax=ax, fraction=0.05)
    ticks = np.arange(4, 11)
    bar.set_ticks(ticks, labels=[f"{2**k}" for k in ticks])
    bar.set_label("harmonics H needed (white: not resolved)")
    tried = ds.attrs.get("harmonics_tried", "?").split(",")[-1].strip()
    words = status_words(ds["status"])
    for i in range(alphas.size):
        for j in range(etas.size):
            if converged[i, j]:
                text, color = f"H={int(H[i, j])}\n{int(ds['steps'].values[i, j])} steps", "w"
            elif "resolved" in words[i, j]:
                text, color = f"not resolved\n(H <= {tried})", "k"
            else:
                text, color = "\n".join(textwrap.wrap(words[i, j], 18)), "k"
            ax.text(i, j, text, ha="center", va="center", fontsize=7, color=color)
    ax.set_xticks(range(alphas.size), [f"{a:g}" for a in alphas])
    ax.set_yticks(range(etas.size), [f"{e:g}" for e in etas])
    ax.set_xlabel("alpha")
    ax.set_ylabel("eta")
    ax.grid(False)
    ax.set_title("(a) harmonics needed for NNM1 stage 1 (guarded continuation)", fontsize=8)


def _exact_panel(ax, ds: xr.Dataset) -> None:
    labels = [f"α = {a:g}" for a in ds["alpha"].values]
    res, per = list(ds["exact_relative_residual"].values), list(ds["exact_periodicity_error"].values)
    for b in ds["beta"].values:
        for d in ds["delta"].values:
            labels.append(f"β = {b:g}, δ = {d:g}")
            res.append(float(ds["ratio_exact_relative_residual"].sel(beta=b, delta=d)))
            per.append(float(ds["ratio_exact_periodicity_error"].sel(beta=b, delta=d)))
    x = np.arange(len(labels))
    ax.bar(x - 0.2, np.maximum(res, 1e-18), width=0.4, label="relative residual of the closed form")
    ax.bar(x + 0.2, np.maximum(per, 1e-18), width=0.4, label="periodicity error by event-located integration")
    ax.set_yscale("log")
    ax.set_xticks(x, labels, rotation=60, ha="right", fontsize=7)
    ax.axhline(np.finfo(float).eps, color="k", lw=0.6, ls=":")
    ax.set_ylabel("relative error of the exact orbits")
    ax.set_title("(b) exact solver: residuals and periodicity (dotted: machine epsilon)", fontsize=8)
    low, high = ax.get_ylim()
    ax.set_ylim(low, high * (high / low) ** 0.5)  # headroom: the legend above the bars, off them
    ax.legend(fontsize=7, loc="upper left")


def _error_panel(ax, ds: xr.Dataset) -> list[str]:
    alphas, etas = ds["alpha"].values, ds["eta"].values
    words, groups = status_words(ds["status"]), {}
    for j, eta in enumerate(etas):
        err = ds["frequency_error"].values[:, j]
        ax.plot(alphas, err, "o-", color=_ETA_COLORS[(j + 1) % len(_ETA_COLORS)], label=f"eta = {eta:g}")
        for i, a in enumerate(alphas):
            if words[i, j]:
                _add(groups, words[i, j], f"alpha = {a:g}", f"eta = {eta:g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    if not np.any(ds["frequency_error"].values > 0):  # no case compared: a decade range for the notes, not an error
        ax.set_ylim(1e-6, 1e-1)
    ax.set_xticks(alphas, [f"{a:g}" for a in alphas])
    missing = [a for i, a in enumerate(alphas) if not np.isfinite(ds["frequency_error"].values[i]).any()]
    for a in missing:  # a column with no point says so where the points would be
        ax.annotate(
            "no point:\nnot compared\n(see below)",
            (a, 0.5),
            xycoords=("data", "axes fraction"),
            ha="center",
            va="center",
            fontsize=7,
            color="0.35",
        )
    ax.set_xlabel("alpha")
    ax.set_ylabel("largest |relative frequency error|")
    ax.set_title("(c) regularized vs exact NNM1 with the H of (a)", fontsize=8)
    ax.legend(fontsize=7)
    ratio_words = status_words(ds["ratio_status"])
    for i, b in enumerate(ds["beta"].values):
        for k, d in enumerate(ds["delta"].values):
            if ratio_words[i, k]:
                grid_name = f"beta x delta grid (alpha = {ds.attrs.get('alpha_of_ratio_grid', '?'):g})"
                _add(groups, f"{grid_name}, {ratio_words[i, k]}", f"beta = {b:g}", f"delta = {d:g}")
    return _listing(groups)


def _energy_panel(ax, ds: xr.Dataset) -> list[str]:
    energies, groups = ds["energy"].values, {}
    for k, a in enumerate(ds["energy_alpha"].values):
        case = ds.isel(energy_alpha=k)
        color = _ETA_COLORS[k % len(_ETA_COLORS)]
        size = 9 - 3 * (k % 2)  # the alphas coincide below grazing (the linear mode): both stay visible
        ax.plot(
            energies,
            case["energy_periodicity_error"].values,
            "s-",
            color=color,
            ms=size - 2,
            label=f"alpha = {a:g}: exact orbit, periodicity error",
        )
        ax.plot(
            energies,
            np.abs(case["energy_hbm_frequency_difference"].values),
            "o--",
            color=color,
            mfc="none",
            ms=size,
            label=f"alpha = {a:g}: |HBM - exact| / exact frequency",
        )
        for name, what in (("energy_exact_status", "exact orbit"), ("energy_hbm_status", "HBM orbit")):
            words = status_words(case[name])
            for e, word in zip(energies, words):
                if word and not (what == "HBM orbit" and "exact" in word):
                    _add(groups, f"{what}: {word}", f"alpha = {a:g}", f"E = {e:g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("energy (nondimensional)")
    ax.set_ylabel("relative error (periodicity; frequency)")
    ax.set_title(f"(d) extreme energies (eta = {ds.attrs.get('energy_sweep_eta', '?')})", fontsize=8)
    ax.legend(fontsize=6)
    return _listing(groups)


def stiff_cases_figure(ds: xr.Dataset):
    """The stiff-cases figure (see the module docstring); returns the figure."""
    for name in ("alpha", "eta", "status", "harmonics", "exact_relative_residual", "energy_periodicity_error"):
        if name not in ds.variables:
            raise ValueError(f"the stiff_cases dataset lacks the variable {name!r}")
    fig = plt.figure(figsize=(11.5, 9.4), constrained_layout=True)
    grid = fig.add_gridspec(3, 2, height_ratios=[1.0, 1.0, 0.22])
    axes = [[fig.add_subplot(grid[r, c]) for c in range(2)] for r in range(2)]
    _harmonics_panel(axes[0][0], ds)
    _exact_panel(axes[0][1], ds)
    error_notes = _error_panel(axes[1][0], ds)
    energy_notes = _energy_panel(axes[1][1], ds)
    _add_notes(fig.add_subplot(grid[2, 0]), error_notes, "(c) and the beta x delta grid: cases not compared", width=80)
    _add_notes(fig.add_subplot(grid[2, 1]), energy_notes, "(d): points not drawn", width=80)
    return fig
