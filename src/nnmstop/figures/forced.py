"""Figures of the forced responses (paper_figures/forced_*), drawn from the datasets only.

* :func:`frequency_response_figure`: ``max |x|`` and ``max |u|`` against the forcing frequency at every force
  level, the regularized response wide and pale in the level's colour under the exact one thin and dark in the
  same colour, stable solid and unstable dashed, the located stability changes marked by kind (filled in the
  level's colour: regularized; white: exact), the NNM backbones (grey) and the peaks they predict (stars);
* :func:`phase_lag_figure`: the lag of the forced DOF's fundamental behind the force;
* :func:`orbits_figure`: exact and regularized orbits and contact force at chosen frequencies past grazing;
* :func:`tube_figure`: the tube's response at its stop and at the forced DOF;
* :func:`prediction_error_figure`: the backbone's prediction error and the phase lag at the peak against damping,
  with the order measured on the data.

Every figure says which structure, damping and ``H`` it shows (:func:`scene_text`).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import to_rgb
from matplotlib.lines import Line2D

from nnmstop import fourier
from nnmstop.figures.common import save_figure, unit_text
from nnmstop.figures.frequency_energy import wrapped_title
from nnmstop.forced.stability_changes import KINDS

__all__ = [
    "scene_text",
    "measured_order",
    "frequency_response_figure",
    "phase_lag_figure",
    "orbits_figure",
    "tube_figure",
    "prediction_error_figure",
]

#: Marker of each kind of located stability change.
CHANGE_MARKERS = {"fold": "^", "symmetry_breaking": "D", "period_doubling": "s", "neimark_sacker": "o"}
EXACT_LINE = "black"
#: The regularized response of a level: wide and pale; the exact one over it thin and dark, in the same hue.
REGULARIZED_STYLE = {"lw": 3.0, "alpha": 0.45}
EXACT_STYLE = {"lw": 0.9}


def _first_stop(ds) -> tuple[int, float]:
    """The first stop's degree of freedom and gap (a dataset of several stops records one of each per stop)."""
    return int(np.atleast_1d(ds.attrs["stop_dof"])[0]), float(np.atleast_1d(ds.attrs["stop_gap"])[0])


def _level_colors(n: int):
    return plt.cm.viridis(np.linspace(0.05, 0.85, max(n, 1)))


def _dark(color, factor: float = 0.6):
    """A darker shade of ``color`` (the exact response of a level over its pale regularized one)."""
    return tuple(factor * np.asarray(to_rgb(color)))


def scene_text(ds: xr.Dataset) -> str:
    """The structure, its damping and ``H`` of a forced dataset, in a line for a figure's title."""
    a = ds.attrs
    if a.get("structure") == "two_dof":
        structure = f"α = {a['alpha']:g}, β = {a['beta']:g}, δ = {a['delta']:g}, η = {a['eta']:g}"
    else:
        dofs = np.atleast_1d(a["stop_dof"]).astype(int)
        labels = [str(ds["dof_label"].values[d]) if "dof_label" in ds else f"DOF {d}" for d in dofs]
        kinds = {"beam": "finite-element beam", "matrices": "structure from matrices"}
        kind = kinds.get(a.get("structure"), "structure")

        def values(name):
            return ", ".join(f"{v:g}" for v in np.atleast_1d(a[name]))

        stops = f"stop on {labels[0]}" if len(dofs) == 1 else f"{len(dofs)} stops on {', '.join(labels)}"
        gaps = "gap" if len(dofs) == 1 else "gaps"
        structure = (
            f"{ds.sizes.get('dof', 0)}-DOF {kind}, {stops}: {gaps} {values('stop_gap')}, "
            f"α = {values('stop_stiffness')}, η = {values('stop_eta')}"
        )
    damping = ""
    if "damping_ratio" in a:
        ratios = ", ".join(f"{r:g}" for r in np.atleast_1d(a["damping_ratio"]))
        damping = f"damping ratios {ratios} (Rayleigh"
    if "rayleigh_mass_coefficient" in a:
        damping += f"{', ' if damping else '(Rayleigh '}C = {a['rayleigh_mass_coefficient']:.3g} M + "
        damping += f"{a['rayleigh_stiffness_coefficient']:.3g} K)"
    elif damping:
        damping += ")"
    harmonics = f"H = {int(a['harmonics'])}" if "harmonics" in a else ""
    return "; ".join(part for part in (structure, damping, harmonics) if part)


def measured_order(x, y) -> float:
    """Slope of ``log y`` against ``log x`` by least squares (the order of ``y`` in ``x``)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    keep = (x > 0) & (y > 0)
    return float(np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)[0])


def _runs(values):
    """Slices of consecutive equal values."""
    values = np.asarray(values)
    edges = np.flatnonzero(np.diff(values) != 0) + 1
    starts, ends = np.r_[0, edges], np.r_[edges, len(values)]
    return [slice(a, b) for a, b in zip(starts, ends)]


#: Line style of each stability class of a point: unstable, stable, verdict unresolved.
CLASS_STYLES = {0: "--", 1: "-", 2: ":"}


def _stability_classes(ds: xr.Dataset) -> np.ndarray:
    """Per point: 1 stable, 0 unstable, 2 where the verdict is unresolved (``stability_resolved = 0``)."""
    classes = ds["stable"].values.astype(int)
    if "stability_resolved" in ds:
        classes = np.where(ds["stability_resolved"].values.astype(bool), classes, 2)
    return classes


def _draw_response(ax, ds: xr.Dataset, y, color, lw: float, zorder: float, alpha: float = 1.0):
    """A response curve: solid where stable, dashed where unstable, dotted where the verdict is unresolved, one
    piece (segment) at a time."""
    classes = _stability_classes(ds)
    for piece in _runs(ds["segment"].values):
        for run in _runs(classes[piece]):
            sl = slice(piece.start + run.start, min(piece.start + run.stop + 1, piece.stop))
            style = CLASS_STYLES[int(classes[sl.start])]
            ax.plot(ds["frequency"].values[sl], y[sl], color=color, lw=lw, ls=style, zorder=zorder, alpha=alpha)


def _draw_changes(ax, ds: xr.Dataset, dof: int, color, size: float = 5, edge="black"):
    """The located stability changes of a response, one marker shape per kind, filled with ``color``."""
    if "change_kind" not in ds:
        return
    for kind, f, a in zip(ds["change_kind"].values, ds["change_frequency"].values, ds["change_amplitude"].values):
        ax.plot(f, a[dof], CHANGE_MARKERS[KINDS[int(kind)]], color=color, ms=size, mec=edge, mew=0.7, zorder=5)


def _response_panel(ax, exact, regularized, backbone, dof: int, colors):
    """One panel of :func:`frequency_response_figure`: responses, changes, backbones and predicted peaks."""
    for mode in np.unique(backbone["backbone_mode"].values):
        on = backbone["backbone_mode"].values == mode
        ax.plot(
            backbone["backbone_frequency"].values[on],
            backbone["backbone_amplitude"].values[on, dof],
            color="0.6",
            lw=1.0,
            zorder=1,
        )
    for color, reg, ex in zip(colors, regularized, _paired(exact, regularized)):
        _draw_response(ax, reg, reg["amplitude"].values[:, dof], color, zorder=2, **REGULARIZED_STYLE)
        _draw_changes(ax, reg, dof, color)
        if ex is not None:
            _draw_response(ax, ex, ex["amplitude"].values[:, dof], _dark(color), zorder=3, **EXACT_STYLE)
            _draw_changes(ax, ex, dof, "white", 4.5, edge=_dark(color))
    for i, color in enumerate(colors):
        f = backbone["predicted_frequency"].values[i]
        a = backbone["predicted_amplitude"].values[i, :, dof]
        ok = f > 0
        ax.plot(f[ok], a[ok], "*", color=color, mec="black", mew=0.5, ms=10, zorder=6)
    if dof == _first_stop(regularized[0])[0]:
        ax.axhline(_first_stop(regularized[0])[1], color="0.4", lw=0.6, ls=":")
    ax.set_xlabel("forcing frequency (Hz, nondimensional time)")


def _paired(exact: list, regularized: list) -> list:
    """The exact response of each level of ``regularized`` (None where there is none: a structure the exact forced
    solver does not cover, :func:`nnmstop.forced.scenes.exact_response_gap`)."""
    return list(exact) if exact else [None] * len(regularized)


def _level_handles(colors, regularized, exact=True) -> list:
    """Each force level's pair: its regularized response (wide, pale) and its exact one (thin, dark)."""
    handles = []
    for c, r in zip(colors, regularized):
        level = f"F = {r.attrs['forcing_amplitude']:g}"
        handles.append(Line2D([], [], color=c, label=f"{level}: regularized (HBM)", **REGULARIZED_STYLE))
        if exact:
            handles.append(
                Line2D([], [], color=_dark(c), label=f"{level}: exact (piecewise-linear law)", **EXACT_STYLE)
            )
    return handles


def _legend_handles(colors, regularized, exact=True) -> list:
    handles = _level_handles(colors, regularized, exact)
    handles += [
        Line2D([], [], color="0.3", lw=1.0, ls="--", label="unstable"),
        Line2D([], [], color="0.3", lw=1.0, ls=":", label="stability unresolved"),
        Line2D([], [], color="0.6", lw=1.0, label="NNM backbones (regularized)"),
        Line2D([], [], ls="", marker="*", color="0.5", mec="black", ms=10, label="peak predicted by the backbone"),
        Line2D([], [], ls="", marker="o", color=colors[0], mec="black", mew=0.7, label="change filled: regularized"),
        Line2D([], [], ls="", marker="o", color="white", mec=_dark(colors[0]), mew=0.7, label="change white: exact"),
    ]
    return handles + [
        Line2D([], [], ls="", marker=m, color="white", mec="black", mew=0.7, label=k.replace("_", " "))
        for k, m in CHANGE_MARKERS.items()
    ]


def frequency_response_figure(
    exact: list, regularized: list, backbone: xr.Dataset, pdf_path, png_dpi: int = 150, zoom=None, no_exact: str = ""
):
    """``max |x|`` and ``max |u|`` against frequency at every force level (see the module docstring).

    Top row: the whole range, logarithmic amplitudes; bottom row: ``zoom`` (Hz; default the frequencies of the
    one-contact exact responses, widened) on linear amplitudes.
    """
    fig, axes = plt.subplots(2, 2, figsize=(10.0, 8.6), layout="constrained")
    colors = _level_colors(len(regularized))
    dofs = [_first_stop(regularized[0])[0], int(np.atleast_1d(regularized[0].attrs["forcing_dofs"])[0])]
    if zoom is None:  # the one-contact exact responses and the NNM1 peaks
        first = backbone["predicted_frequency"].values[:, 0]
        contact = np.concatenate(
            [ex["frequency"].values[ex["contact_point_index"].values] for ex in exact if "contact_point_index" in ex]
            + [first[first > 0]]
        )
        zoom = (0.9 * contact.min(), 1.05 * contact.max()) if contact.size else None
    for column, dof in enumerate(dofs):
        label = str(regularized[0]["dof_label"].values[dof])
        for row in (0, 1):
            ax = axes[row, column]
            _response_panel(ax, exact, regularized, backbone, dof, colors)
            ax.set_ylabel(f"max |{label}| over the period {unit_text(regularized[0], 'q_cos')}")
        axes[0, column].set_yscale("log")
        if zoom is not None:
            axes[1, column].set_xlim(*zoom)
            axes[1, column].set_ylim(0.0, None)
    axes[0, 0].set_title("stop DOF (the gap dotted)")
    axes[0, 1].set_title("forced DOF")
    axes[1, 0].set_title("the primary resonance of NNM1 past grazing")
    fig.legend(
        handles=_legend_handles(colors, regularized, bool(exact)), loc="outside lower center", ncol=4, fontsize=7
    )
    title = f"Frequency responses at {len(regularized)} force levels: {scene_text(regularized[0])}"
    if not exact:
        title += f"\nno exact responses: {no_exact}"
    fig.suptitle(wrapped_title(title, 9, fig.get_figwidth()), fontsize=9)
    return save_figure(fig, pdf_path, png_dpi, description=title)


def phase_lag_figure(exact: list, regularized: list, pdf_path, png_dpi: int = 150, no_exact: str = ""):
    """Lag of the forced DOF's fundamental behind the force, against frequency (90 degrees: phase resonance)."""
    fig, ax = plt.subplots(figsize=(6.4, 4.6), layout="constrained")
    colors = _level_colors(len(regularized))
    dof = int(np.atleast_1d(regularized[0].attrs["forcing_dofs"])[0])
    for color, reg, ex in zip(colors, regularized, _paired(exact, regularized)):
        _draw_response(ax, reg, reg["phase_lag"].values[:, dof], color, zorder=2, **REGULARIZED_STYLE)
        if ex is not None:
            _draw_response(ax, ex, ex["phase_lag"].values[:, dof], _dark(color), zorder=3, **EXACT_STYLE)
    ax.axhline(90.0, color="0.4", lw=0.6, ls=":")
    ax.set_xlabel("forcing frequency (Hz, nondimensional time)")
    ax.set_ylabel(f"phase lag of {regularized[0]['dof_label'].values[dof]} behind the force (degrees)")
    ax.legend(handles=_level_handles(colors, regularized, bool(exact)), fontsize=6.5)
    title = f"Phase lag behind the force\n{scene_text(regularized[0])}"
    if not exact:
        title += f"\nno exact responses: {no_exact}"
    ax.set_title(wrapped_title(title, 7.5, fig.get_figwidth()), fontsize=7.5)
    return save_figure(fig, pdf_path, png_dpi, description=title)


def _regularized_orbit(ds: xr.Dataset, i: int, samples: int):
    H = ds.sizes["harmonic"] - 1
    q = fourier.to_time(fourier.from_cos_sin(ds["q_cos"].values[i], ds["q_sin"].values[i]), H, samples)
    f = fourier.to_time(fourier.from_cos_sin(ds["f_cos"].values[i], ds["f_sin"].values[i]), H, samples)
    return 2 * np.pi * np.arange(samples) / samples, q, f[0] * _first_stop(ds)[1]


def _crossings(frequency, target: float) -> np.ndarray:
    """Indices ``i`` where a response passes ``target`` between its points ``i`` and ``i + 1`` (each coexisting
    response at that frequency, in the order of the continuation)."""
    return np.flatnonzero(np.diff(np.sign(np.asarray(frequency) - target)) != 0)


def _verdict(ds: xr.Dataset, i: int) -> str:
    if "stable" not in ds:
        return ""
    if "stability_resolved" in ds and not int(ds["stability_resolved"].values[i]):
        return "stability unresolved"
    return "stable" if int(ds["stable"].values[i]) else "unstable"


def orbits_figure(
    exact_ds: xr.Dataset,
    regularized_ds: xr.Dataset,
    excitation,
    frequencies,
    pdf_path,
    png_dpi: int = 150,
    samples: int = 1024,
):
    """Orbits (stop DOF, forced DOF) and contact force over one period at each frequency of ``frequencies``.

    Several responses coexist at a frequency past grazing (on either side of the folds): each panel shows the
    first one reached along each continuation, the exact one with one contact per stop side and the
    regularized one, and says which it is among how many, with its amplitude at the stop and its stability.
    """
    from nnmstop.forced.dataset import exact_time_history

    fig, axes = plt.subplots(
        2, len(frequencies), figsize=(4.6 * len(frequencies), 6.2), layout="constrained", squeeze=False
    )
    stop, forced = _first_stop(regularized_ds)[0], int(np.atleast_1d(regularized_ds.attrs["forcing_dofs"])[0])
    for column, target in enumerate(frequencies):
        top, bottom = axes[0, column], axes[1, column]
        notes = []
        has_contacts = exact_ds is not None and "contact_point_index" in exact_ds
        index = exact_ds["contact_point_index"].values if has_contacts else np.zeros(0, int)
        crossing = _crossings(exact_ds["frequency"].values[index], target) if index.size else np.zeros(0, int)
        if crossing.size:
            history = exact_time_history(exact_ds, excitation, int(crossing[0]), samples)
            phase = np.mod(history["theta"], 2 * np.pi)
            order = np.argsort(phase)
            top.plot(phase[order], history["q"][stop][order], color=EXACT_LINE, lw=1.0, label="exact, stop DOF")
            top.plot(
                phase[order], history["q"][forced][order], color=EXACT_LINE, lw=1.0, ls="--", label="exact, forced DOF"
            )
            bottom.plot(phase[order], history["contact_force"][order], color=EXACT_LINE, lw=1.0, label="exact")
            point = int(index[crossing[0]])
            amplitude = float(exact_ds["amplitude"].values[point, stop])
            notes.append(
                f"exact: 1st of {crossing.size} with one contact per stop side (max|q| {amplitude:.3g}, "
                f"{_verdict(exact_ds, point)})"
            )
        else:
            notes.append("exact: not computed" if exact_ds is None else "exact: no response with contact here")
        crossing = _crossings(regularized_ds["frequency"].values, target)
        if crossing.size:
            i = int(crossing[0])
            theta, q, f = _regularized_orbit(regularized_ds, i, samples)
            top.plot(theta, q[stop], color="tab:blue", lw=2.0, alpha=0.6, label="regularized, stop DOF")
            top.plot(theta, q[forced], color="tab:blue", lw=2.0, alpha=0.6, ls="--", label="regularized, forced DOF")
            bottom.plot(theta, f, color="tab:blue", lw=2.0, alpha=0.6, label="regularized")
            amplitude = float(regularized_ds["amplitude"].values[i, stop])
            notes.append(f"regularized: 1st of {crossing.size} (max|q| {amplitude:.3g}, {_verdict(regularized_ds, i)})")
        else:
            notes.append("regularized: no response at this frequency")
        top.set_title(f"{target:g} Hz, F = {regularized_ds.attrs['forcing_amplitude']:g}\n" + "\n".join(notes),
                      fontsize=7.5)  # fmt: skip
        top.set_ylabel(f"displacement {unit_text(regularized_ds, 'q_cos')}")
        bottom.set_ylabel(f"contact force {unit_text(regularized_ds, 'f_cos')}")
        bottom.set_xlabel("phase Omega t of the force (rad)")
        top.legend(fontsize=7)
        bottom.legend(fontsize=7)
    title = (
        "Coexisting responses: the first reached along each continuation is drawn (max|q| at the stop)\n"
        + scene_text(regularized_ds)
    )
    fig.suptitle(wrapped_title(title, 8.5, fig.get_figwidth()), fontsize=8.5)
    return save_figure(fig, pdf_path, png_dpi, description=title)


def tube_figure(regularized: list, pdf_path, png_dpi: int = 150):
    """The tube's response: ``max |q|`` at the stop and at the forced DOF against frequency."""
    fig, ax = plt.subplots(figsize=(6.0, 4.0), layout="constrained")
    for ds in regularized:
        for dof, style in ((_first_stop(ds)[0], "-"), (int(np.atleast_1d(ds.attrs["forcing_dofs"])[0]), "-")):
            label = str(ds["dof_label"].values[dof])
            color = "tab:red" if dof == _first_stop(ds)[0] else "tab:blue"
            _draw_response(ax, ds, ds["amplitude"].values[:, dof], color, 1.5, 2)
            role = "stop DOF" if dof == _first_stop(ds)[0] else "forced DOF"
            ax.plot([], [], color=color, ls=style, label=f"{label}, {role} (F = {ds.attrs['forcing_amplitude']:g})")
            _draw_changes(ax, ds, dof, color)
        ax.axhline(_first_stop(ds)[1], color="0.4", lw=0.6, ls=":")
    ax.set_yscale("log")
    ax.set_xlabel("forcing frequency (Hz, nondimensional time)")
    ax.set_ylabel("max |q| over the period (gaps)")
    ax.legend(fontsize=7)
    title = "The tube's frequency response\n" + scene_text(regularized[0])
    ax.set_title(wrapped_title(title, 7.5, fig.get_figwidth()), fontsize=7.5)
    return save_figure(fig, pdf_path, png_dpi, description=title)


def prediction_error_figure(ds: xr.Dataset, pdf_path, png_dpi: int = 150):
    """Relative errors of the backbone's predicted peak (frequency, amplitude of the stop DOF) and the forced DOF's
    lag behind the force at the peak minus 90 degrees, against the damping ratio (log-log).

    The order of each is measured on the data (:func:`measured_order`, least squares in log-log) and a reference
    line of the nearest integer slope is drawn through the smallest damping's point. The errors fall as the
    square of the damping: the damping and the force (in proportion to it) add to the NNM orbit a component of
    order zeta in quadrature with it, which moves the orbit's amplitude and frequency only at second order.
    """
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 4.2), layout="constrained")
    zeta = ds["damping_ratio"].values
    forced = int(np.atleast_1d(ds.attrs["forcing_dofs"])[0])
    label = str(ds["dof_label"].values[forced])
    ax = axes[0]
    errors = {
        "peak frequency": ds["frequency_error"].values,
        f"peak max |{ds['dof_label'].values[_first_stop(ds)[0]]}|": ds["amplitude_error"].values,
    }
    orders = {name: measured_order(zeta, error) for name, error in errors.items()}
    for (name, error), marker in zip(errors.items(), ("o-", "s-")):
        ax.loglog(zeta, error, marker, label=f"{name} (measured order {orders[name]:.2f})")
    order = int(round(float(np.mean(list(orders.values())))))
    smallest = int(np.argmin(zeta))
    anchor = max(float(error[smallest]) for error in errors.values())
    ax.loglog(zeta, anchor * (zeta / zeta[smallest]) ** order, color="0.5", ls=":", label=f"slope {order} (reference)")
    ax.set_xlabel("damping ratio of the linear modes (force in proportion)")
    ax.set_ylabel("relative error of the backbone's prediction")
    ax.legend(fontsize=7)
    ax = axes[1]
    lag = np.abs(ds["peak_phase_lag"].values[:, forced] - 90.0)
    ax.loglog(zeta, lag, "o-", color="tab:green", label=f"measured order {measured_order(zeta, lag):.2f}")
    ax.set_xlabel("damping ratio of the linear modes (force in proportion)")
    ax.set_ylabel(f"|lag of {label} at the peak - 90| (degrees)")
    ax.legend(fontsize=7)
    title = (
        f"NNM1 peak, F / damping ratio = {float(ds.attrs['force_per_ratio']):g}: the backbone's prediction errs by "
        f"order {order} in the damping\n(damping and force add a component of order zeta in quadrature with the NNM "
        "orbit, which moves its amplitude and frequency at second order)\n" + scene_text(ds)
    )
    fig.suptitle(wrapped_title(title, 8.5, fig.get_figwidth()), fontsize=8.5)
    return save_figure(fig, pdf_path, png_dpi, description=title)
