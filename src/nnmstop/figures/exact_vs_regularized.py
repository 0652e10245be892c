"""Figs 2-4 of the paper: exact (non-smooth) versus regularized NNM1, Section 4.1.

* Fig 2: frequency-energy plot of NNM1 over the range with zero or one impact per stop
  per period. Red: the non-smooth system, i.e. its linear mode (no impact, closed form)
  up to the grazing orbit, then the exact two-impact family up to its end, where the
  secondary oscillation of x strikes the other stop. Blue: regularized NNM1 stage 1
  (HBM), from the linear mode of the regularized system to its last orbit with at most
  one impact per stop. Points a) (intermediate energy) and b) (high energy) are the
  labelled compared orbits; an inset enlarges the grazing neighbourhood, where the exact
  family first loses energy (the energy fold) and a) lies.
* Fig 3: the orbits at a) and b): x-phase plane ``(x, xdot)``, u-phase plane
  ``(u, udot)`` and modal line ``(x, u)``; exact red, regularized blue.
* Fig 4: the contact force at a) and b): over one period against ``t/T`` (origin at the
  maximum of x), and the ``(x, f)`` curve of the regularized orbit (blue) against the
  piecewise-linear law, Eq. (4) (red).

Inputs are datasets only: the exact family, NNM1 stage 1 and the comparison at matched
energies (:mod:`nnmstop.compare.dataset`), which holds both orbits at a) and b). Orbits are
evaluated in closed form (exact: :meth:`nnmstop.exact.problem.TwoImpactProblem.time_history` of the stored
unknowns; regularized: the stored Fourier series, :mod:`nnmstop.fourier`); nothing is solved.
"""

from __future__ import annotations

import logging

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from nnmstop.compare.matching import MAX_IMPACTS
from nnmstop.exact.problem import TwoImpactProblem
from nnmstop.figures.common import (
    EXACT_COLOR,
    GAP_ZERO_STYLE,
    NONDIMENSIONAL,
    REGULARIZED_COLOR,
    frequency_energy_axes,
    orbit_series,
    save_figure,
)
from nnmstop.fourier import fields_at_phases
from nnmstop.models.two_dof import ModelParameters, linear_modes, piecewise_contact_force

__all__ = [
    "FIGURES",
    "marked_points",
    "aligned_orbits",
    "figure_02",
    "figure_03",
    "figure_04",
]

logger = logging.getLogger("nnmstop.figures")

FIGURES = ("fig02", "fig03", "fig04")
LABELS = ("a", "b")
STOP_STYLE = {"color": "0.55", "lw": 0.7, "ls": ":", "zorder": 0}
REG_LINE = {"color": REGULARIZED_COLOR, "lw": 1.3, "zorder": 3}
EXACT_LINE = {"color": EXACT_COLOR, "lw": 1.3, "ls": (0, (5, 2.2)), "zorder": 4}


# --------------------------------------------------------------------------- checks and data


def _check(ds: xr.Dataset, where: str, required: tuple) -> None:
    """Required variables present, numeric values finite (but where the catalogue lets a value be missing and
    names the variable saying why: the differences of orbits that are no counterparts)."""
    missing = [v for v in required if v not in ds.variables]
    if missing:
        raise ValueError(f"{where}: the dataset lacks the variable(s) {missing}")
    for name, var in {**ds.coords, **ds.data_vars}.items():
        if "ancillary_variables" in var.attrs:
            continue
        if np.issubdtype(var.dtype, np.number) and not np.all(np.isfinite(var.values)):
            raise ValueError(f"{where}: variable {name!r} holds NaN or infinite values; refusing to draw it")


def _parameters(*datasets: xr.Dataset, where: str) -> ModelParameters:
    """Model parameters of the datasets, checked to agree (the exact family has no eta)."""
    values: dict = {}
    for ds in datasets:
        for key in ("alpha", "beta", "delta", "eta"):
            if key not in ds.attrs:
                continue
            v = float(ds.attrs[key])
            if key in values and not np.isclose(values[key], v, rtol=1e-12, atol=0):
                raise ValueError(f"{where}: datasets disagree on {key}: {values[key]!r} and {v!r}")
            values[key] = v
    missing = [k for k in ("alpha", "beta", "delta", "eta") if k not in values]
    if missing:
        raise ValueError(f"{where}: no dataset gives the model parameter(s) {missing}")
    return ModelParameters(**values)


def _parameter_text(params: ModelParameters, comparison: xr.Dataset) -> str:
    return (
        f"α = {params.alpha:g}, β = {params.beta:g}, δ = {params.delta:g}, η = {params.eta:g}, "
        f"H = {int(comparison.attrs['harmonics'])}"
    )


def marked_points(comparison: xr.Dataset, where: str = "figure") -> dict:
    """Label -> point index of the labelled points a) and b) of a comparison dataset."""
    _check(comparison, where, ("marked", "energy"))
    flags = comparison["marked"]
    meanings = str(flags.attrs.get("flag_meanings", "")).split()
    values = list(np.asarray(flags.attrs.get("flag_values", [])).tolist())
    out = {}
    for label in LABELS:
        name = f"point_{label}"
        if name not in meanings:
            raise ValueError(
                f"{where}: the comparison dataset has no labelled point {label}) (flag_meanings {meanings})"
            )
        hits = np.flatnonzero(flags.values == values[meanings.index(name)])
        if hits.size != 1:
            raise ValueError(f"{where}: point {label}) is flagged {hits.size} times in the comparison dataset")
        out[label] = int(hits[0])
    return out


def counterpart_note(comparison: xr.Dataset, point: int) -> str:
    """Why the regularized orbit of a compared point is no counterpart of the exact one ('' when it is)."""
    if "counterpart" not in comparison or int(comparison["counterpart"].values[point]) == 0:
        return ""
    p = comparison.isel(point=point)
    impacts = (int(p["regularized_contacts_per_period"]), int(p["exact_impacts_per_period"]))
    harmonic = (int(p["regularized_dominant_harmonic"]), int(p["exact_dominant_harmonic"]))
    tongue = (int(p["regularized_tongue_harmonic"]), int(p["exact_tongue_harmonic"]))

    def kind(dominant, n):
        return f"harmonic {dominant} dominant" if dominant > 1 else (f"{n}:1 tongue" if n else "fundamental")

    return (
        f"no counterpart: regularized orbit {impacts[0]} contacts/period, {kind(harmonic[0], tongue[0])}; "
        f"exact {impacts[1]}, {kind(harmonic[1], tongue[1])}"
    )


def aligned_orbits(comparison: xr.Dataset, point: int, phase) -> tuple[dict, dict]:
    """Exact and regularized orbits of a compared point on the phase ``t/T``.

    Origin on the symmetry axis where x is maximum (as in :mod:`nnmstop.compare.matching`): the
    turning point ``T1`` of the exact orbit, ``t = 0`` of the cosine series shifted by
    ``regularized_origin_shift`` periods.

    Returns
    -------
    exact, regularized : dict
        ``x, u, xdot, udot, f`` on ``phase`` (exact force: the piecewise-linear law).
    """
    phase = np.asarray(phase, dtype=float)
    p = comparison.isel(point=point)
    params = _parameters(comparison, where="aligned_orbits")
    y = np.array([float(p[v]) for v in ("exact_xdot0", "exact_udot0", "exact_tau1", "exact_T1")])
    h = TwoImpactProblem(params).time_history(y, y[3] + phase * 4.0 * y[3])
    exact = {"x": h.x, "u": h.u, "xdot": h.xdot, "udot": h.udot, "f": h.force}
    omega = float(np.sqrt(p["omega_squared"]))
    theta = 2.0 * np.pi * (phase + float(p["regularized_origin_shift"]))
    series = {key: value for key, value in orbit_series(p).items() if key in ("x", "u", "f")}
    return exact, fields_at_phases(theta, omega, series)


def _title(comparison: xr.Dataset, label: str, point: int) -> str:
    e = float(comparison["energy"].values[point])
    fe = float(comparison["frequency_exact"].values[point])
    fr = float(comparison["frequency_regularized"].values[point])
    note = counterpart_note(comparison, point)
    if note:
        return f"{label})  E = {e:.3g}: exact {fe:.4f} Hz\n" + _wrapped(note, 44)
    return f"{label})  E = {e:.3g}\nexact {fe:.4f} Hz, regularized {fr:.4f} Hz"


def _legend_handles():
    return [
        plt.Line2D([], [], **{**EXACT_LINE, "zorder": None}, label="non-smooth (exact)"),
        plt.Line2D([], [], **{**REG_LINE, "zorder": None}, label="regularized (HBM)"),
    ]


# --------------------------------------------------------------------------- Fig 2


def _regularized_range(stage1: xr.Dataset) -> int:
    """Number of leading points of stage 1 with at most one impact per stop per period."""
    impacts = np.asarray(stage1["impacts_per_period"].values)
    above = np.flatnonzero(impacts > MAX_IMPACTS)
    return int(above[0]) if above.size else impacts.size


def _fig02_curves(axis, curves: dict, comparison: xr.Dataset, marks: dict, lw: float = 1.3) -> None:
    """The non-smooth NNM1 (linear mode to grazing, then the exact family), the regularized one, a) and b)."""
    e_ex, f_ex, e_reg, f_reg = curves["e_ex"], curves["f_ex"], curves["e_reg"], curves["f_reg"]
    axis.axhline(curves["f_gap0"], **GAP_ZERO_STYLE)
    axis.plot([curves["e_lo"], e_ex[0]], [curves["f_lin"]] * 2, color=EXACT_COLOR, lw=lw, zorder=3)
    axis.plot(e_ex, f_ex, color=EXACT_COLOR, lw=lw, zorder=3)
    axis.plot(e_reg, f_reg, color=REGULARIZED_COLOR, lw=2.0 * lw, zorder=2)  # wider: visible under red
    end = {"ms": 5, "mfc": "white", "mew": 1.3, "ls": "none", "zorder": 6}
    axis.plot([e_ex[0]], [f_ex[0]], marker="o", mec=EXACT_COLOR, **end)
    axis.plot([e_ex[-1]], [f_ex[-1]], marker="s", mec=EXACT_COLOR, **end)
    axis.plot([e_reg[-1]], [f_reg[-1]], marker="s", mec=REGULARIZED_COLOR, **end)
    for i in marks.values():
        e = float(comparison["energy"].values[i])
        alike = not counterpart_note(comparison, i)
        for key, colour in (("frequency_exact", EXACT_COLOR), ("frequency_regularized", REGULARIZED_COLOR)):
            f = float(comparison[key].values[i])
            face = colour if alike or key == "frequency_exact" else "white"  # hollow: no counterpart
            axis.plot([e], [f], marker="o", ms=4.5, color=colour, mfc=face, mec="black", mew=0.6, ls="none", zorder=7)


def _fig02_annotations(ax, curves: dict, comparison: xr.Dataset, marks: dict) -> None:
    """Letters a) and b), and what ends each curve."""
    for label, i in marks.items():
        e, f = float(comparison["energy"].values[i]), float(comparison["frequency_regularized"].values[i])
        ax.annotate(
            f"{label})", xy=(e, f), xytext=(-14, 12), textcoords="offset points", fontsize=10, fontweight="bold",
            ha="center", va="center", zorder=8,
            arrowprops={"arrowstyle": "-", "lw": 0.6, "color": "black", "shrinkA": 0, "shrinkB": 3},
        )  # fmt: skip
    ax.annotate(
        "gap-0 first linear mode (stop always engaged)", xy=(curves["e_lo"], curves["f_gap0"]), xytext=(4, -3),
        textcoords="offset points", fontsize=7.5, color="0.3", ha="left", va="top",
    )  # fmt: skip
    for text, (e, f), colour, offset, ha in (
        (
            "end of the exact family:\nx reaches the other stop\nbetween the impacts",
            (curves["e_ex"][-1], curves["f_ex"][-1]),
            EXACT_COLOR,
            (0, -62),
            "center",
        ),
        (
            "regularized: last orbit with\none impact per stop",
            (curves["e_reg"][-1], curves["f_reg"][-1]),
            REGULARIZED_COLOR,
            (-6, -20),
            "right",
        ),
    ):
        ax.annotate(
            text, xy=(e, f), xytext=offset, textcoords="offset points", fontsize=7.5, ha=ha, va="top", color=colour,
            arrowprops={"arrowstyle": "-", "lw": 0.6, "color": colour, "shrinkB": 4},
        )  # fmt: skip


def _fig02_inset(ax, curves: dict, comparison: xr.Dataset, marks: dict) -> None:
    """The grazing neighbourhood: the energy fold of the exact family, and point a)."""
    e_ex, f_ex, e_reg, f_reg = curves["e_ex"], curves["f_ex"], curves["e_reg"], curves["f_reg"]
    ia = ax.inset_axes([0.655, 0.07, 0.33, 0.36])
    _fig02_curves(ia, curves, comparison, marks, lw=1.2)
    i_a = marks["a"]
    e_a = float(comparison["energy"].values[i_a])
    fold = int(np.argmin(e_ex))
    win_e = (min(e_ex[fold], e_a) / 1.2, max(e_ex[0], e_a) * 1.25)
    ia.set_xscale("log")
    ia.set_xlim(*win_e)
    inside = lambda e: (e >= win_e[0]) & (e <= win_e[1])  # noqa: E731
    f_win = np.concatenate([f_ex[inside(e_ex)], f_reg[inside(e_reg)], [curves["f_lin"]]])
    fpad = 0.08 * (f_win.max() - f_win.min())
    ia.set_ylim(f_win.min() - fpad, f_win.max() + fpad)
    ia.tick_params(labelsize=6.5)
    ia.minorticks_off()
    ticks = [t for t in np.geomspace(win_e[0], win_e[1], 4)[1:-1]]
    ia.set_xticks(ticks)
    ia.set_xticklabels([f"{t:.2g}" for t in ticks])
    ia.annotate(
        "grazing", xy=(e_ex[0], f_ex[0]), xytext=(5, 4), textcoords="offset points", fontsize=7, color=EXACT_COLOR
    )
    ia.annotate(
        "energy fold", xy=(e_ex[fold], f_ex[fold]), xytext=(-3, 12), textcoords="offset points", fontsize=7,
        color=EXACT_COLOR, ha="right", arrowprops={"arrowstyle": "-", "lw": 0.5, "color": EXACT_COLOR, "shrinkB": 2},
    )  # fmt: skip
    f_a = float(comparison["frequency_regularized"].values[i_a])
    ia.annotate("a)", xy=(e_a, f_a), xytext=(-10, 8), textcoords="offset points", fontsize=8, fontweight="bold")
    ax.indicate_inset_zoom(ia, edgecolor="0.4", lw=0.6)


def _fig02_data(exact: xr.Dataset, stage1: xr.Dataset, params: ModelParameters) -> dict:
    n_reg = _regularized_range(stage1)
    curves = {
        "e_reg": stage1["energy"].values[:n_reg],
        "f_reg": stage1["frequency"].values[:n_reg],
        "e_ex": exact["energy"].values,
        "f_ex": exact["frequency"].values,
        "f_lin": linear_modes(params, "no_contact")[0][0] / (2 * np.pi),
        "f_gap0": linear_modes(params, "gap_zero")[0][0] / (2 * np.pi),
    }
    curves["e_lo"] = 0.5 * min(curves["e_reg"][0], curves["e_ex"].min())
    curves["e_hi"] = 1.6 * max(curves["e_reg"][-1], curves["e_ex"].max())
    return curves


def figure_02(exact: xr.Dataset, stage1: xr.Dataset, comparison: xr.Dataset, pdf_path, png_dpi: int = 150):
    """Fig 2: FEP of NNM1, non-smooth (red) vs regularized (blue), with a) and b).

    Parameters
    ----------
    exact, stage1, comparison : xarray.Dataset
        Exact two-impact family, regularized NNM1 stage 1, comparison at matched energies (with no point
        when the two share no energy: then the curves are drawn without a) and b), and the title says why).
    pdf_path : str or Path
        The PDF; the PNG is written beside it.
    png_dpi : int
    """
    where = "fig02"
    _check(exact, where + " (exact family)", ("energy", "frequency"))
    _check(stage1, where + " (NNM1 stage 1)", ("energy", "frequency", "impacts_per_period"))
    _check(comparison, where + " (comparison)", ("frequency_exact", "frequency_regularized"))
    params = _parameters(exact, stage1, comparison, where=where)
    compared = not int(comparison.attrs.get("skipped", 0))
    marks = marked_points(comparison, where) if compared else {}
    curves = _fig02_data(exact, stage1, params)
    fig, ax = plt.subplots(figsize=(6.4, 4.6), layout="constrained")
    frequency_energy_axes(ax)
    _fig02_curves(ax, curves, comparison, marks)
    ax.set_xlim(curves["e_lo"], curves["e_hi"])
    f_all = np.concatenate([curves["f_reg"], curves["f_ex"], [curves["f_lin"], curves["f_gap0"]]])
    pad = 0.04 * (f_all.max() - f_all.min())
    ax.set_ylim(f_all.min() - pad, f_all.max() + pad)
    _fig02_annotations(ax, curves, comparison, marks)
    if compared:
        _fig02_inset(ax, curves, comparison, marks)
    handles = [
        plt.Line2D([], [], color=EXACT_COLOR, lw=1.3, label="non-smooth (linear mode, then exact family)"),
        plt.Line2D([], [], color=REGULARIZED_COLOR, lw=2.6, label="regularized (HBM)"),
        plt.Line2D([], [], marker="o", ms=5, mfc="white", mec=EXACT_COLOR, mew=1.3, ls="none", label="grazing orbit"),
        plt.Line2D([], [], marker="s", ms=5, mfc="white", mec="0.3", mew=1.3, ls="none", label="end of the range"),
    ]
    ax.legend(handles=handles, loc="center left", fontsize=7.5, framealpha=0.95)
    title = f"NNM1, non-smooth vs regularized   ({_parameter_text(params, comparison)})"
    if not compared:
        title += f"\nno points a), b) compared: {comparison.attrs['end_reason']}"
    for label, i in marks.items():
        note = counterpart_note(comparison, i)
        if note:
            title += f"\n{label}) (hollow blue) {note}"
    ax.set_title(_wrapped(title, 100), fontsize=8.5)
    return save_figure(fig, pdf_path, png_dpi, description=title)


def _wrapped(text: str, width: int) -> str:
    import textwrap

    return "\n".join(textwrap.fill(line, width) for line in text.split("\n"))


def _no_comparison(comparison: xr.Dataset, title: str, pdf_path, png_dpi: int):
    """Figs 3 and 4 when the exact and regularized NNM1 share no energy: the reason, no orbit."""
    fig, ax = plt.subplots(figsize=(6.6, 3.0), layout="constrained")
    ax.set_axis_off()
    reason = f"no orbits compared: {comparison.attrs['end_reason']}"
    ax.text(0.5, 0.5, _wrapped(reason, 80), ha="center", va="center", fontsize=9, transform=ax.transAxes)
    fig.suptitle(title, fontsize=8.5)
    return save_figure(fig, pdf_path, png_dpi, description=f"{title}\n{reason}")


# --------------------------------------------------------------------------- Figs 3 and 4


_ORBIT_VARS = (
    "marked",
    "energy",
    "exact_xdot0",
    "exact_udot0",
    "exact_tau1",
    "exact_T1",
    "omega_squared",
    "q_cos",
    "q_sin",
    "f_cos",
    "f_sin",
    "dof_label",
    "regularized_origin_shift",
    "frequency_exact",
    "frequency_regularized",
)


def _phase(samples: int = 2000, start: float = 0.0) -> np.ndarray:
    return start + np.arange(samples + 1) / samples


def figure_03(comparison: xr.Dataset, pdf_path, png_dpi: int = 150):
    """Fig 3: orbits at a) and b): (x, xdot), (u, udot) and (x, u); exact red, regularized blue."""
    where = "fig03"
    if int(comparison.attrs.get("skipped", 0)):
        params = _parameters(comparison, where=where)
        title = f"NNM1 orbits at the same energy ({_parameter_text(params, comparison)})"
        return _no_comparison(comparison, title, pdf_path, png_dpi)
    _check(comparison, where, _ORBIT_VARS)
    params = _parameters(comparison, where=where)
    marks = marked_points(comparison, where)
    rows = (("x", "xdot", "x", "ẋ"), ("u", "udot", "u", "u̇"), ("x", "u", "x", "u"))
    fig, axes = plt.subplots(3, 2, figsize=(6.6, 8.6), layout="constrained")
    phase = _phase()
    for col, (label, i) in enumerate(marks.items()):
        exact, reg = aligned_orbits(comparison, i, phase)
        alike = not counterpart_note(comparison, i)  # no counterpart: the exact orbit alone
        axes[0, col].set_title(_title(comparison, label, i), fontsize=8.5)
        for row, (a, b, la, lb) in enumerate(rows):
            ax = axes[row, col]
            if alike:
                ax.plot(reg[a], reg[b], **REG_LINE)
            ax.plot(exact[a], exact[b], **EXACT_LINE)
            ax.set_xlabel(f"{la} {NONDIMENSIONAL}")
            ax.set_ylabel(f"{lb} {NONDIMENSIONAL}")
            if a == "x":
                for stop in (-1.0, 1.0):
                    ax.axvline(stop, **STOP_STYLE)
    drawn = (
        _legend_handles() if any(not counterpart_note(comparison, i) for i in marks.values()) else _legend_handles()[:1]
    )
    axes[1, 0].legend(handles=drawn, loc="center", fontsize=7, framealpha=0.9)
    title = (
        "NNM1 orbits at the same energy: x-phase plane, u-phase plane, modal line\n"
        f"({_parameter_text(params, comparison)}; dotted: stops x = ±1)"
    )
    fig.suptitle(title, fontsize=8.5)
    return save_figure(fig, pdf_path, png_dpi, description=title)


def figure_04(comparison: xr.Dataset, pdf_path, png_dpi: int = 150):
    """Fig 4: contact force at a) and b): f over one period, and (x, f) vs the piecewise law."""
    where = "fig04"
    if int(comparison.attrs.get("skipped", 0)):
        params = _parameters(comparison, where=where)
        title = f"NNM1 contact force at the same energy ({_parameter_text(params, comparison)})"
        return _no_comparison(comparison, title, pdf_path, png_dpi)
    _check(comparison, where, _ORBIT_VARS)
    params = _parameters(comparison, where=where)
    marks = marked_points(comparison, where)
    fig, axes = plt.subplots(2, 2, figsize=(6.6, 5.8), layout="constrained")
    phase = _phase(start=-0.25)
    for col, (label, i) in enumerate(marks.items()):
        exact, reg = aligned_orbits(comparison, i, phase)
        if counterpart_note(comparison, i):  # no counterpart: the exact orbit alone
            reg = {key: np.full_like(value, np.nan) for key, value in reg.items()}
        ax = axes[0, col]
        ax.plot(phase, reg["f"], **REG_LINE)
        ax.plot(phase, exact["f"], **EXACT_LINE)
        ax.set_xlim(phase[0], phase[-1])
        ax.set_xlabel("t / T   (t = 0 at the turning point in contact)")
        ax.set_ylabel(f"contact force f {NONDIMENSIONAL}")
        ax.set_title(_title(comparison, label, i), fontsize=8.5)
        ax = axes[1, col]
        xmax = 1.08 * np.nanmax(np.abs(np.concatenate([reg["x"], exact["x"]])))
        xs = np.linspace(-xmax, xmax, 2001)
        ax.plot(reg["x"], reg["f"], **REG_LINE)
        ax.plot(xs, piecewise_contact_force(xs, params.alpha), **EXACT_LINE)
        for stop in (-1.0, 1.0):
            ax.axvline(stop, **STOP_STYLE)
        fmax = 1.25 * np.nanmax(np.abs(np.concatenate([reg["f"], exact["f"]])))
        ax.set_xlim(-xmax, xmax)
        ax.set_ylim(-fmax, fmax)
        ax.set_xlabel(f"x {NONDIMENSIONAL}")
        ax.set_ylabel(f"f {NONDIMENSIONAL}")
    handles = [
        plt.Line2D([], [], **{**EXACT_LINE, "zorder": None}, label="piecewise law (exact orbit)"),
        plt.Line2D([], [], **{**REG_LINE, "zorder": None}, label="regularized (HBM)"),
    ]
    axes[0, 0].legend(handles=handles, loc="lower left", fontsize=7, framealpha=0.9)
    title = f"NNM1 contact force at the same energy ({_parameter_text(params, comparison)})"
    fig.suptitle(title, fontsize=8.5)
    return save_figure(fig, pdf_path, png_dpi, description=title)
