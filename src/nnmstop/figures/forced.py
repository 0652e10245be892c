"""Figures of the forced responses (paper_figures/forced_*), drawn from the datasets only.

* :func:`frequency_response_figure`: ``max |x|`` and ``max |u|`` against the forcing frequency at every force
  level, regularized (coloured) under exact (black), stable solid and unstable dashed, the located
  stability changes marked by kind, the NNM backbones (grey) and the peaks they predict (stars);
* :func:`phase_lag_figure`: the lag of the forced DOF's fundamental behind the force;
* :func:`orbits_figure`: exact and regularized orbits and contact force at chosen frequencies past grazing;
* :func:`tube_figure`: the tube's response at its stop and at the forced DOF;
* :func:`prediction_error_figure`: the backbone's prediction error and the phase lag at the peak against damping.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D

from nnmstop import fourier
from nnmstop.figures.common import save_figure, unit_text
from nnmstop.forced.stability_changes import KINDS

__all__ = ["frequency_response_figure", "phase_lag_figure", "orbits_figure", "tube_figure", "prediction_error_figure"]

#: Marker of each kind of located stability change.
CHANGE_MARKERS = {"fold": "^", "symmetry_breaking": "D", "period_doubling": "s", "neimark_sacker": "o"}
EXACT_LINE = "black"


def _first_stop(ds) -> tuple[int, float]:
    """The first stop's degree of freedom and gap (a dataset of several stops records one of each per stop)."""
    return int(np.atleast_1d(ds.attrs["stop_dof"])[0]), float(np.atleast_1d(ds.attrs["stop_gap"])[0])


def _level_colors(n: int):
    return plt.cm.viridis(np.linspace(0.05, 0.85, max(n, 1)))


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


def _draw_response(ax, ds: xr.Dataset, y, color, lw: float, zorder: float):
    """A response curve: solid where stable, dashed where unstable, dotted where the verdict is unresolved, one
    piece (segment) at a time."""
    classes = _stability_classes(ds)
    for piece in _runs(ds["segment"].values):
        for run in _runs(classes[piece]):
            sl = slice(piece.start + run.start, min(piece.start + run.stop + 1, piece.stop))
            style = CLASS_STYLES[int(classes[sl.start])]
            ax.plot(ds["frequency"].values[sl], y[sl], color=color, lw=lw, ls=style, zorder=zorder)


def _draw_changes(ax, ds: xr.Dataset, dof: int, color, size: float = 5):
    if "change_kind" not in ds:
        return
    for kind, f, a in zip(ds["change_kind"].values, ds["change_frequency"].values, ds["change_amplitude"].values):
        ax.plot(f, a[dof], CHANGE_MARKERS[KINDS[int(kind)]], color=color, ms=size, mec="black", mew=0.5, zorder=5)


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
    for color, reg, ex in zip(colors, regularized, exact):
        _draw_response(ax, reg, reg["amplitude"].values[:, dof], color, 1.8, 2)
        _draw_response(ax, ex, ex["amplitude"].values[:, dof], EXACT_LINE, 0.7, 3)
        _draw_changes(ax, reg, dof, color)
        _draw_changes(ax, ex, dof, "white", 4)
    for i, color in enumerate(colors):
        f = backbone["predicted_frequency"].values[i]
        a = backbone["predicted_amplitude"].values[i, :, dof]
        ok = f > 0
        ax.plot(f[ok], a[ok], "*", color=color, mec="black", mew=0.5, ms=10, zorder=6)
    if dof == _first_stop(regularized[0])[0]:
        ax.axhline(_first_stop(regularized[0])[1], color="0.4", lw=0.6, ls=":")
    ax.set_xlabel("forcing frequency (Hz, nondimensional time)")


def _legend_handles(colors, regularized) -> list:
    handles = [
        Line2D([], [], color=c, lw=1.8, label=f"F = {r.attrs['forcing_amplitude']:g} (regularized)")
        for c, r in zip(colors, regularized)
    ]
    handles += [
        Line2D([], [], color=EXACT_LINE, lw=0.7, label="exact (piecewise-linear law)"),
        Line2D([], [], color="0.3", lw=1.0, ls="--", label="unstable"),
        Line2D([], [], color="0.3", lw=1.0, ls=":", label="stability unresolved"),
        Line2D([], [], color="0.6", lw=1.0, label="NNM backbones (regularized)"),
        Line2D([], [], ls="", marker="*", color="0.5", mec="black", ms=10, label="peak predicted by the backbone"),
    ]
    return handles + [
        Line2D([], [], ls="", marker=m, color="0.8", mec="black", label=k.replace("_", " "))
        for k, m in CHANGE_MARKERS.items()
    ]


def frequency_response_figure(
    exact: list, regularized: list, backbone: xr.Dataset, pdf_path, png_dpi: int = 150, zoom=None
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
    fig.legend(handles=_legend_handles(colors, regularized), loc="outside lower center", ncol=4, fontsize=7)
    return save_figure(fig, pdf_path, png_dpi)


def phase_lag_figure(exact: list, regularized: list, pdf_path, png_dpi: int = 150):
    """Lag of the forced DOF's fundamental behind the force, against frequency (90 degrees: phase resonance)."""
    fig, ax = plt.subplots(figsize=(6.0, 4.0), layout="constrained")
    colors = _level_colors(len(regularized))
    dof = int(np.atleast_1d(regularized[0].attrs["forcing_dofs"])[0])
    for color, reg, ex in zip(colors, regularized, exact):
        _draw_response(ax, reg, reg["phase_lag"].values[:, dof], color, 1.8, 2)
        _draw_response(ax, ex, ex["phase_lag"].values[:, dof], EXACT_LINE, 0.7, 3)
    ax.axhline(90.0, color="0.4", lw=0.6, ls=":")
    ax.set_xlabel("forcing frequency (Hz, nondimensional time)")
    ax.set_ylabel(f"phase lag of {regularized[0]['dof_label'].values[dof]} behind the force (degrees)")
    ax.legend(
        handles=[
            Line2D([], [], color=c, lw=1.8, label=f"F = {r.attrs['forcing_amplitude']:g}")
            for c, r in zip(colors, regularized)
        ]
        + [Line2D([], [], color=EXACT_LINE, lw=0.7, label="exact")],
        fontsize=7,
    )
    return save_figure(fig, pdf_path, png_dpi)


def _regularized_orbit(ds: xr.Dataset, i: int, samples: int):
    H = ds.sizes["harmonic"] - 1
    q = fourier.to_time(fourier.from_cos_sin(ds["q_cos"].values[i], ds["q_sin"].values[i]), H, samples)
    f = fourier.to_time(fourier.from_cos_sin(ds["f_cos"].values[i], ds["f_sin"].values[i]), H, samples)
    return 2 * np.pi * np.arange(samples) / samples, q, f[0] * _first_stop(ds)[1]


def orbits_figure(
    exact_ds: xr.Dataset,
    regularized_ds: xr.Dataset,
    excitation,
    frequencies,
    pdf_path,
    png_dpi: int = 150,
    samples: int = 1024,
):
    """Orbits (stop DOF, forced DOF) and contact force over one period at each frequency of ``frequencies``:
    the first point of the one-contact exact response (rebuilt from the dataset of ``excitation``,
    :func:`nnmstop.forced.dataset.exact_time_history`) and of the regularized one at that frequency."""
    from nnmstop.forced.dataset import exact_time_history

    fig, axes = plt.subplots(
        2, len(frequencies), figsize=(4.2 * len(frequencies), 5.6), layout="constrained", squeeze=False
    )
    stop, forced = _first_stop(regularized_ds)[0], int(np.atleast_1d(regularized_ds.attrs["forcing_dofs"])[0])
    for column, target in enumerate(frequencies):
        top, bottom = axes[0, column], axes[1, column]
        index = exact_ds["contact_point_index"].values
        crossing = np.flatnonzero(np.diff(np.sign(exact_ds["frequency"].values[index] - target)))
        if crossing.size:
            history = exact_time_history(exact_ds, excitation, int(crossing[0]), samples)
            phase = np.mod(history["theta"], 2 * np.pi)
            order = np.argsort(phase)
            top.plot(phase[order], history["q"][stop][order], color=EXACT_LINE, lw=1.0, label="exact, stop DOF")
            top.plot(
                phase[order], history["q"][forced][order], color=EXACT_LINE, lw=1.0, ls="--", label="exact, forced DOF"
            )
            bottom.plot(phase[order], history["contact_force"][order], color=EXACT_LINE, lw=1.0, label="exact")
        if not crossing.size:  # said on the panel, not left empty
            top.text(0.5, 0.9, "no exact one-contact response at this frequency", transform=top.transAxes,
                     ha="center", fontsize=7, color=EXACT_LINE)  # fmt: skip
        frequency = regularized_ds["frequency"].values
        crossing = np.flatnonzero(np.diff(np.sign(frequency - target)))
        if not crossing.size:
            top.text(0.5, 0.8, "no regularized response at this frequency", transform=top.transAxes, ha="center",
                     fontsize=7, color="tab:blue")  # fmt: skip
        if crossing.size:
            theta, q, f = _regularized_orbit(regularized_ds, int(crossing[0]), samples)
            top.plot(theta, q[stop], color="tab:blue", lw=2.0, alpha=0.6, label="regularized, stop DOF")
            top.plot(theta, q[forced], color="tab:blue", lw=2.0, alpha=0.6, ls="--", label="regularized, forced DOF")
            bottom.plot(theta, f, color="tab:blue", lw=2.0, alpha=0.6, label="regularized")
        top.set_title(f"{target:g} Hz, F = {regularized_ds.attrs['forcing_amplitude']:g}")
        top.set_ylabel(f"displacement {unit_text(regularized_ds, 'q_cos')}")
        bottom.set_ylabel(f"contact force {unit_text(regularized_ds, 'f_cos')}")
        bottom.set_xlabel("phase Omega t of the force (rad)")
        top.legend(fontsize=7)
        bottom.legend(fontsize=7)
    return save_figure(fig, pdf_path, png_dpi)


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
    return save_figure(fig, pdf_path, png_dpi)


def prediction_error_figure(ds: xr.Dataset, pdf_path, png_dpi: int = 150):
    """Relative errors of the backbone's predicted peak (frequency, amplitude of the stop DOF) and the forced DOF's
    lag behind the force at the peak minus 90 degrees, against the damping ratio (log-log), with a slope-1 line."""
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.8), layout="constrained")
    zeta = ds["damping_ratio"].values
    forced = int(np.atleast_1d(ds.attrs["forcing_dofs"])[0])
    label = str(ds["dof_label"].values[forced])
    ax = axes[0]
    ax.loglog(zeta, ds["frequency_error"].values, "o-", label="peak frequency")
    ax.loglog(
        zeta,
        ds["amplitude_error"].values,
        "s-",
        label=f"peak max |{ds['dof_label'].values[_first_stop(ds)[0]]}|",
    )
    top = max(ds["frequency_error"].values.max(), ds["amplitude_error"].values.max())
    ax.loglog(zeta, top * zeta / zeta.max(), color="0.5", ls=":", label="slope 1 (first order)")
    ax.set_xlabel("damping ratio of the linear modes (force in proportion)")
    ax.set_ylabel("relative error of the backbone's prediction")
    ax.legend(fontsize=7)
    ax = axes[1]
    ax.loglog(zeta, np.abs(ds["peak_phase_lag"].values[:, forced] - 90.0), "o-", color="tab:green")
    ax.set_xlabel("damping ratio of the linear modes (force in proportion)")
    ax.set_ylabel(f"|lag of {label} at the peak - 90| (degrees)")
    fig.suptitle(f"NNM1 peak, F / damping ratio = {float(ds.attrs['force_per_ratio']):g}, H = {ds.attrs['harmonics']}")
    return save_figure(fig, pdf_path, png_dpi)
