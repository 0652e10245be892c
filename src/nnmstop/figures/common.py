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
    "GAP_ZERO_STYLE",
    "NONDIMENSIONAL",
    "unit_text",
    "frequency_energy_axes",
    "label_minor_decades",
    "plot_branch",
    "plot_identities",
    "identity_legend_handles",
    "branch_identity_name",
    "stability_legend_handles",
    "orbit",
    "orbit_series",
    "save_figure",
]

EXACT_COLOR = "tab:red"  # non-smooth model
REGULARIZED_COLOR = "tab:blue"  # regularized NNM1
NNM2_COLOR = "tab:green"
RESONANCE_COLOR = "tab:red"  # f2/5 curve, as in the paper's Figs 9-10
EXACT_OVERLAY_COLOR = "black"  # optional exact multi-impact NNM1 on Figs 7-11
#: The gap-0 linear modes (every stop engaged): dash-dot, unlike the dashes of unstable orbits.
GAP_ZERO_STYLE = {"color": "0.35", "ls": (0, (7, 2, 1.5, 2)), "lw": 0.9}

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


def label_minor_decades(ax) -> None:
    """Label some minor ticks of a logarithmic x axis spanning few decades, as plain numbers.

    A window of one or two decades would otherwise show one or two labelled ticks. Over at most
    0.6 decades every minor tick is labelled, up to 1.2 decades those at 2, 3 and 5 x 10^n, up to 2.5
    decades those at 2 and 5 x 10^n; wider axes keep their decades only.
    """
    from matplotlib.ticker import FuncFormatter

    def minor_label(value, _position):
        low, high = ax.get_xlim()
        decades = np.log10(high / low) if low > 0 and high > low else np.inf
        mantissa = value / 10.0 ** np.floor(np.log10(value) + 1e-9)
        digit = int(round(mantissa))
        if decades > 2.5 or abs(mantissa - digit) > 1e-6:
            return ""
        kept = range(2, 10) if decades <= 0.6 else (2, 3, 5) if decades <= 1.2 else (2, 5)
        return f"{value:g}" if digit in kept else ""

    ax.xaxis.set_minor_formatter(FuncFormatter(minor_label))
    ax.tick_params(axis="x", which="minor", labelsize=7)


def orbit_series(p: xr.Dataset) -> dict:
    """Cos/sin pairs of one point of a branch (or comparison) dataset, by degree-of-freedom label, and ``f``.

    ``p`` is one point (``ds.isel(point=i)``); ``f`` is the force of the first stop.
    """
    labels = [str(label) for label in p["dof_label"].values]
    series = {label: (p["q_cos"].values[j], p["q_sin"].values[j]) for j, label in enumerate(labels)}
    series["f"] = (p["f_cos"].values[0], p["f_sin"].values[0])
    return series


def orbit(ds: xr.Dataset, point: int, samples: int = 512) -> dict:
    """Time history of one period of HBM point ``point`` of a branch dataset.

    Evaluates the Fourier series of Eq. (13) on ``samples`` instants; returns ``t``, each degree of
    freedom by its label and its velocity (``x, u, xdot, udot`` for the paper's oscillator; velocities by
    differentiating the series) and ``f``, the force of the first stop.
    """
    p = ds.isel(point=point)
    omega = float(np.sqrt(p["omega_squared"]))
    t = np.arange(samples + 1) * (2 * np.pi / omega) / samples
    series = orbit_series(p)
    return {"t": t, **fields_at_phases(omega * t, omega, series, velocities=tuple(series)[:-1])}


#: How an axis label states a nondimensional quantity (dataset units "1": gap = 1, first mass = 1, k1 = 1).
NONDIMENSIONAL = "(nondim.)"


def unit_text(ds: xr.Dataset, name: str) -> str:
    """The units of variable ``name`` of ``ds`` for an axis label: ``(nondim.)`` for "1", else ``(units)``."""
    units = str(ds[name].attrs.get("units", "1")) if name in ds else "1"
    return NONDIMENSIONAL if units == "1" else f"({units})"


STABILITY_LINESTYLES = {"stable": "-", "unstable": "--", "unresolved": ":"}


#: Under the orbits of a branch in an n:1 tongue: a wide pale band (the curve keeps its family's colour on top).
TONGUE_STYLE = {"color": "gold", "alpha": 0.6, "lw": 6.0, "solid_capstyle": "butt"}
#: Colours of the other families a branch crosses onto (an NNM seen at 1/n of its frequency), in order of appearance.
OTHER_FAMILY_COLORS = ("tab:purple", "tab:orange", "tab:brown", "tab:pink", "tab:olive")


def branch_identity_name(ds: xr.Dataset) -> str:
    """What most of a branch's orbits are (:func:`nnmstop.hbm.identity.identity_label`), e.g. for a switched branch
    ``"NNM2 seen at 1/3 of its frequency"``; the branch's own name where the dataset holds no identity."""
    from nnmstop.hbm.identity import identity_runs

    runs = identity_runs(ds)
    if not runs:
        return str(ds.attrs.get("branch", "branch")).upper()
    lengths: dict[str, int] = {}
    for run in runs:
        lengths[run.label] = lengths.get(run.label, 0) + run.stop - run.start
    return max(lengths, key=lengths.get)


def plot_identities(ax, ds: xr.Dataset, color, lw: float = 1.2, zorder: float = 3, own: str | None = None):
    """A branch drawn by what its orbits are (:mod:`nnmstop.hbm.identity`), stability in the line style.

    The runs that are NNM ``own`` (``"NNM1"``; by default the branch's ``mode`` attribute) and its tongues
    are drawn in ``color``, a tongue with a pale band under it (:data:`TONGUE_STYLE`); the runs where the
    branch has crossed onto another family (an NNM seen at 1/n of its frequency, or another NNM) in a colour
    of their own (:data:`OTHER_FAMILY_COLORS`). Consecutive runs share their end points. Without identity
    variables the whole branch is drawn in ``color`` (:func:`plot_branch`).

    Returns
    -------
    drawn : set
        Stability classes drawn (:func:`stability_legend_handles`).
    others : dict
        Label of each other family drawn -> ``(colour, first energy)``; plus ``"tongue"`` -> the tongue
        orders drawn, when any (:func:`identity_legend_handles`).
    """
    from nnmstop.hbm.identity import identity_runs

    runs = identity_runs(ds)
    if not runs:
        return plot_branch(ax, ds, color, lw=lw, zorder=zorder), {}
    own = own or (f"NNM{int(ds.attrs['mode'])}" if "mode" in ds.attrs else None)
    drawn, others, tongues = set(), {}, set()
    energy, frequency = ds["energy"].values, ds["frequency"].values
    n = ds.sizes["point"]
    for run in runs:
        part = slice(run.start, min(run.stop + 1, n))
        if run.family == own or own is None:
            run_color = color
        else:
            if run.label not in others:
                others[run.label] = (OTHER_FAMILY_COLORS[len(others) % len(OTHER_FAMILY_COLORS)], energy[run.start])
            run_color = others[run.label][0]
        if run.kind == 1:
            ax.plot(energy[part], frequency[part], zorder=zorder - 0.2, **TONGUE_STYLE)
            tongues.add(run.tongue)
        drawn |= plot_branch(ax, ds.isel(point=part), run_color, lw=lw, zorder=zorder)
    if tongues:
        others["tongue"] = tuple(sorted(tongues))
    return drawn, others


def identity_legend_handles(others: dict, lw: float = 1.2) -> list:
    """Legend entries of the other families and the tongues drawn by :func:`plot_identities`."""
    from matplotlib.lines import Line2D

    from nnmstop.hbm.identity import TONGUE_SHARE

    handles = []
    for label, value in others.items():
        if label == "tongue":
            orders = ", ".join(f"{n}:1" for n in value)
            text = f"{orders} tongue: harmonic n > {TONGUE_SHARE:.0%} of the motion"
            handles.append(Line2D([], [], label=text, **TONGUE_STYLE))
        else:
            color, energy = value
            handles.append(Line2D([], [], color=color, lw=lw, label=f"{label} (from E = {energy:.4g})"))
    return handles


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


def save_figure(
    fig, pdf_path, png_dpi: int = 150, description: str | None = None, after_layout=None
) -> tuple[Path, Path]:
    """Save ``fig`` as PDF and PNG (same stem), byte-reproducibly, and close it.

    ``description``: what the figure shows and what it could not (its title text), stored in the files
    (PDF ``Subject``, PNG text chunk ``Description``) so that a reader or a test finds it without the picture.
    ``after_layout``: called with ``fig`` once the layout is fixed, before saving (e.g.
    :func:`nnmstop.figures.labels.place_labels`, which needs the final axes).

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

    def text(key):
        return {key: description} if description else {}

    engine = fig.get_layout_engine()
    if engine is not None:
        fig.set_dpi(png_dpi)  # text measured as the PNG draws it
        engine.execute(fig)
        fig.set_layout_engine(None)  # None, not "none": savefig then skips its draw without output
    if after_layout is not None:
        fig.set_dpi(png_dpi)
        after_layout(fig)
    for path, meta, kwargs in (
        (pdf_path, {"CreationDate": None, "ModDate": None, "Creator": None, "Producer": None, **text("Subject")}, {}),
        (png_path, {"Software": None, **text("Description")}, {"dpi": png_dpi}),
    ):
        with atomic_output(path) as tmp:
            fig.savefig(tmp, metadata=meta, **kwargs)
    plt.close(fig)
    return pdf_path, png_path
