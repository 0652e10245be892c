"""Shared pieces of the figures: colours, axes of a frequency-energy plot, orbit
reconstruction from a branch dataset (:mod:`nnmstop.fourier`), and deterministic saving."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from nnmstop.atomic import atomic_output  # noqa: E402
from nnmstop.fourier import fields_at_phases  # noqa: E402

__all__ = [
    "EXACT_COLOR",
    "REGULARIZED_COLOR",
    "NNM2_COLOR",
    "RESONANCE_COLOR",
    "EXACT_OVERLAY_COLOR",
    "frequency_energy_axes",
    "plot_branch",
    "stability_legend_handles",
    "orbit",
    "save_figure",
]

EXACT_COLOR = "tab:red"  # non-smooth model
REGULARIZED_COLOR = "tab:blue"  # regularized NNM1
NNM2_COLOR = "tab:green"
RESONANCE_COLOR = "tab:red"  # f2/5 curve, as in the paper's Figs 9-10
EXACT_OVERLAY_COLOR = "black"  # optional exact multi-impact NNM1 on Figs 7-11

plt.rcParams.update(
    {
        "font.size": 9,
        "axes.grid": True,
        "grid.alpha": 0.3,
        "savefig.bbox": "standard",
        "path.simplify": False,
        "svg.hashsalt": "nnmstop",
    }
)


def frequency_energy_axes(ax, title: str | None = None):
    """Logarithmic energy axis, frequency in Hz of the nondimensional time."""
    ax.set_xscale("log")
    ax.set_xlabel("energy (nondimensional)")
    ax.set_ylabel("frequency (Hz, nondimensional time)")
    if title:
        ax.set_title(title)
    return ax


def orbit(ds: xr.Dataset, point: int, samples: int = 512) -> dict:
    """Time history of one period of HBM point ``point`` of a branch dataset.

    Evaluates the Fourier series of Eq. (13) on ``samples`` instants; returns ``t``
    and ``x, u, xdot, udot, f`` (velocities by differentiating the series).
    """
    p = ds.isel(point=point)
    omega = float(np.sqrt(p["omega_squared"]))
    t = np.arange(samples + 1) * (2 * np.pi / omega) / samples
    series = {symbol: (p[f"{symbol}_cos"].values, p[f"{symbol}_sin"].values) for symbol in ("x", "u", "f")}
    return {"t": t, **fields_at_phases(omega * t, omega, series)}


STABILITY_LINESTYLES = {"stable": "-", "unstable": "--", "unresolved": ":"}


def plot_branch(ax, ds: xr.Dataset, color, lw: float = 1.2, zorder: float = 3, frequency_divisor: float = 1.0):
    """Frequency-energy curve of a branch, its line style telling the orbits' stability.

    Solid where stable, dashed where unstable, dotted where the verdict is not resolved
    at the dataset's number of harmonics (``stability_resolved = 0``), from the Floquet
    variables of the dataset; without them the whole curve is solid. Consecutive runs
    share their end points so the curve stays continuous. Returns the set of stability
    classes drawn (for the legend).
    """
    energy = ds["energy"].values
    frequency = ds["frequency"].values / frequency_divisor
    if "stable" not in ds:
        ax.plot(energy, frequency, color=color, lw=lw, zorder=zorder)
        return set()
    classes = np.where(ds["stable"].values.astype(bool), "stable", "unstable").astype(object)
    if "stability_resolved" in ds:
        classes[~ds["stability_resolved"].values.astype(bool)] = "unresolved"
    breaks = np.flatnonzero(classes[1:] != classes[:-1]) + 1
    start = 0
    for stop in list(breaks) + [len(classes)]:
        run = slice(start, min(stop + 1, len(classes)))
        ax.plot(energy[run], frequency[run], color=color, lw=lw, zorder=zorder, ls=STABILITY_LINESTYLES[classes[start]])
        start = stop
    return set(classes)


def stability_legend_handles(drawn: set, color="0.3", lw: float = 1.2) -> list:
    """Legend entries for the non-solid stability classes that were drawn."""
    from matplotlib.lines import Line2D

    text = {"unstable": "unstable orbits (Floquet multipliers)", "unresolved": "stability not resolved at this H"}
    return [
        Line2D([], [], color=color, lw=lw, ls=STABILITY_LINESTYLES[c], label=text[c])
        for c in ("unstable", "unresolved")
        if c in drawn
    ]


def save_figure(fig, pdf_path, png_dpi: int = 150) -> tuple[Path, Path]:
    """Save ``fig`` as PDF and PNG (same stem), byte-reproducibly, and close it.

    No creation date, creator or software tags: two runs give identical files. The
    figure's layout engine (constrained layout) runs once, on the PNG's renderer, and is
    then switched off, so both files share one layout: left on, ``savefig`` would redo
    the layout and a draw without output for each format, most of the cost of a figure,
    and lay the PDF out a few points differently from its PNG.
    """
    pdf_path = Path(pdf_path)
    png_path = pdf_path.with_suffix(".png")
    pdf_path.parent.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
    engine = fig.get_layout_engine()
    if engine is not None:
        fig.set_dpi(png_dpi)  # text measured as the PNG draws it
        engine.execute(fig)
        fig.set_layout_engine(None)  # None, not "none": savefig then skips its draw without output
    for path, meta, kwargs in (
        (pdf_path, {"CreationDate": None, "ModDate": None, "Creator": None, "Producer": None}, {}),
        (png_path, {"Software": None}, {"dpi": png_dpi}),
    ):
        with atomic_output(path) as tmp:
            fig.savefig(tmp, metadata=meta, **kwargs)
    plt.close(fig)
    return pdf_path, png_path
