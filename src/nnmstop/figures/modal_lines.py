"""Labelled points of a branch and their modal lines (the insets of Figs 6-11).

A labelled point is requested by its energy, as in the paper ("point c) at
intermediate energy"). Along NNM1 the energy is not monotone (it turns back at the
3:1 and 5:1 internal resonances), so one energy can be met several times; a
:class:`LabelSpec` therefore also names the continuation ``stage``, an optional
number of ``impacts`` per period, and which ``occurrence`` (in the order of the
points along the branch) of that energy is meant. :func:`select_point` picks the
dataset point nearest to the requested energy at that occurrence, and refuses,
with a :class:`ValueError` naming the label, anything it cannot honour (an energy
outside the data, a stage the dataset does not hold, too few occurrences).

The modal line of a point is its orbit over one period in the configuration plane
``(x, u)``, reconstructed from the Fourier coefficients of the dataset by
:func:`nnmstop.figures.common.orbit`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import xarray as xr
from matplotlib.ticker import MaxNLocator

from nnmstop.figures.common import orbit

__all__ = [
    "LabelSpec",
    "label_specs",
    "energy_crossings",
    "select_point",
    "mark_point",
    "draw_modal_line",
]

logger = logging.getLogger("nnmstop.figures")

STOP_COLOR = "0.45"


@dataclass(frozen=True)
class LabelSpec:
    """A labelled point of a branch, as configured under ``figures.<fig>.labels``.

    Parameters
    ----------
    label : str
        The letter of the paper (``"e"`` is shown as ``e)``).
    energy : float
        Requested total energy; the nearest dataset point is used.
    stage : int, optional
        Continuation stage the point must belong to (``None``: any stage).
    impacts : int, optional
        Number of impacts per period the point must have (``None``: any).
    occurrence : int
        Which crossing of ``energy`` (1 = first along the branch) among the points
        allowed by ``stage`` and ``impacts``.
    offset : tuple of float
        Offset of the letter from its marker on the frequency-energy plot, in points.
    """

    label: str
    energy: float
    stage: int | None = None
    impacts: int | None = None
    occurrence: int = 1
    offset: tuple[float, float] = (6.0, 6.0)

    def describe(self) -> str:
        """Human-readable request, for messages (``"e) at energy 7.1 (stage 2, occurrence 1)"``)."""
        extra = []
        if self.stage is not None:
            extra.append(f"stage {self.stage}")
        if self.impacts is not None:
            extra.append(f"{self.impacts} impacts/period")
        extra.append(f"occurrence {self.occurrence}")
        return f"{self.label}) at energy {self.energy:g} ({', '.join(extra)})"


def label_specs(entries) -> list[LabelSpec]:
    """:class:`LabelSpec` list from the ``labels`` list of a figure's configuration.

    Raises
    ------
    ValueError
        If two entries share a letter or a value is out of range.
    """
    specs = []
    for entry in entries or []:
        spec = LabelSpec(
            label=str(entry["label"]),
            energy=float(entry["energy"]),
            stage=None if entry.get("stage") is None else int(entry["stage"]),
            impacts=None if entry.get("impacts") is None else int(entry["impacts"]),
            occurrence=int(entry.get("occurrence", 1)),
            offset=tuple(float(v) for v in entry.get("offset", (6.0, 6.0))),
        )
        if not (np.isfinite(spec.energy) and spec.energy > 0):
            raise ValueError(f"label {spec.label}): energy must be finite and > 0, got {spec.energy!r}")
        if spec.occurrence < 1:
            raise ValueError(f"label {spec.label}): occurrence must be >= 1, got {spec.occurrence!r}")
        if len(spec.offset) != 2:
            raise ValueError(f"label {spec.label}): offset must be two numbers (points), got {spec.offset!r}")
        specs.append(spec)
    letters = [s.label for s in specs]
    duplicates = sorted({a for a in letters if letters.count(a) > 1})
    if duplicates:
        raise ValueError(f"labels used twice in one figure: {duplicates}")
    return specs


def energy_crossings(energy: np.ndarray, allowed: np.ndarray, target: float) -> list[int]:
    """Indices of the points nearest to each crossing of ``target`` along a branch.

    The branch is split into runs of consecutive ``allowed`` points; within each
    run every segment ``[E_i, E_i+1]`` containing ``target`` is a crossing, and the
    endpoint nearer in ``log(E)`` is kept. Crossings that select the same point
    (a point exactly at ``target``, or both sides of a turning point) count once.

    Returns
    -------
    list of int
        Point indices in the order of the branch.
    """
    energy = np.asarray(energy, dtype=float)
    allowed = np.asarray(allowed, dtype=bool)
    log_target = np.log(target)
    picks: list[int] = []
    for i in np.flatnonzero(allowed):
        if energy[i] == target and (not picks or picks[-1] != i):
            picks.append(int(i))
            continue
        j = i + 1
        if j >= energy.size or not allowed[j]:
            continue
        lo, hi = sorted((energy[i], energy[j]))
        if lo <= target <= hi:
            k = i if abs(np.log(energy[i]) - log_target) <= abs(np.log(energy[j]) - log_target) else j
            if not picks or picks[-1] != k:
                picks.append(int(k))
    return picks


def select_point(ds: xr.Dataset, spec: LabelSpec, where: str) -> int:
    """Index of the dataset point that labels ``spec``.

    Parameters
    ----------
    ds : xarray.Dataset
        Branch dataset (layout of :mod:`nnmstop.hbm.dataset`), one or several stages.
    spec : LabelSpec
        The requested point.
    where : str
        Name of the figure and dataset, for messages (``"fig08, NNM1 stages 1-2"``).

    Raises
    ------
    ValueError
        If no point has the requested stage/impacts, if the energy lies outside
        the energies of those points, or if it is met fewer than
        ``spec.occurrence`` times.
    """
    energy = ds["energy"].values
    allowed = np.ones(energy.shape, dtype=bool)
    scope = []
    if spec.stage is not None:
        stages = ds["stage"].values
        allowed &= stages == spec.stage
        scope.append(f"stage {spec.stage}")
        if not allowed.any():
            held = ", ".join(str(int(s)) for s in np.unique(stages))
            raise ValueError(
                f"{where}: label {spec.describe()}: the dataset holds no stage {spec.stage} (stages held: {held})"
            )
    if spec.impacts is not None:
        allowed &= ds["impacts_per_period"].values == spec.impacts
        scope.append(f"{spec.impacts} impacts/period")
        if not allowed.any():
            raise ValueError(f"{where}: label {spec.describe()}: no point of {' with '.join(scope)}")
    scope_text = " with ".join(scope) if scope else "the whole dataset"
    lo, hi = float(energy[allowed].min()), float(energy[allowed].max())
    if not lo <= spec.energy <= hi:
        raise ValueError(
            f"{where}: label {spec.describe()}: energy {spec.energy:g} is outside the energy range "
            f"[{lo:.6g}, {hi:.6g}] of {scope_text}"
        )
    picks = energy_crossings(energy, allowed, spec.energy)
    if len(picks) < spec.occurrence:
        found = ", ".join(f"point {k} (E = {energy[k]:.6g})" for k in picks) or "none"
        raise ValueError(
            f"{where}: label {spec.describe()}: energy {spec.energy:g} is met {len(picks)} time(s) in "
            f"{scope_text} ({found}), fewer than occurrence {spec.occurrence}"
        )
    point = picks[spec.occurrence - 1]
    logger.info(
        "%s: label %s -> point %d, energy %.6g, frequency %.6g Hz, stage %d, %d impacts/period",
        where,
        spec.describe(),
        point,
        energy[point],
        float(ds["frequency"].values[point]),
        int(ds["stage"].values[point]),
        int(ds["impacts_per_period"].values[point]),
    )
    return point


def mark_point(ax, ds: xr.Dataset, point: int, spec: LabelSpec) -> None:
    """Marker and letter of a labelled point on a frequency-energy plot."""
    e = float(ds["energy"].values[point])
    f = float(ds["frequency"].values[point])
    ax.plot([e], [f], marker="o", ms=4.5, mfc="white", mec="black", mew=1.0, ls="none", zorder=6)
    ax.annotate(
        f"{spec.label})",
        xy=(e, f),
        xytext=spec.offset,
        textcoords="offset points",
        fontsize=9,
        fontweight="bold",
        ha="center",
        va="center",
        zorder=7,
        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85},
        arrowprops={"arrowstyle": "-", "lw": 0.6, "color": "black", "shrinkA": 0, "shrinkB": 3},
    )


def draw_modal_line(
    ax,
    ds: xr.Dataset,
    point: int,
    spec: LabelSpec,
    color: str,
    reference_slope: float | None = None,
    samples: int = 2048,
) -> None:
    """Modal line ``(x, u)`` of one period of ``point`` in a small square axes.

    Each axis has its own scale (symmetric about 0), so the shape of the line stays
    readable whatever the amplitude ratio; the ratio ``max|u| / max|x|`` is printed
    in the title with the letter, the number of impacts per period, the energy and
    the frequency. The stops ``x = +-1`` are thin vertical lines.

    Parameters
    ----------
    reference_slope : float, optional
        If given, the straight modal line ``u = reference_slope * x`` of a linear
        mode (e.g. of the gap-0 system) is drawn dashed for comparison.
    """
    o = orbit(ds, point, samples)
    x, u = o["x"], o["u"]
    impacts = int(ds["impacts_per_period"].values[point])
    e = float(ds["energy"].values[point])
    f = float(ds["frequency"].values[point])
    x_amp = float(np.max(np.abs(x)))
    u_amp = float(np.max(np.abs(u)))
    xlim = 1.15 * max(x_amp, 1.0)
    ulim = 1.15 * u_amp
    if reference_slope is not None:
        ax.plot(
            [-xlim, xlim],
            [-reference_slope * xlim, reference_slope * xlim],
            color="0.3",
            lw=0.8,
            ls=(0, (4, 2.5)),
            zorder=1,
        )
    ax.plot(x, u, color=color, lw=1.1, zorder=2)
    ax.set_xlim(-xlim, xlim)
    ax.set_ylim(-ulim, ulim)
    for stop in (-1.0, 1.0):
        ax.axvline(stop, color=STOP_COLOR, lw=0.7, ls="-", zorder=0)
    ax.set_box_aspect(1.0)
    ax.xaxis.set_major_locator(MaxNLocator(nbins=4, symmetric=True))
    ax.yaxis.set_major_locator(MaxNLocator(nbins=4, symmetric=True))
    ax.tick_params(labelsize=6.5, length=2, pad=1.5)
    ax.set_xlabel("x", fontsize=7.5, labelpad=1)
    ax.set_ylabel("u", fontsize=7.5, labelpad=1, rotation=0)
    noun = "impact" if impacts == 1 else "impacts"
    ax.set_title(
        f"{spec.label}) {impacts} {noun}/period\nE = {e:.4g}, f = {f:.4f} Hz\nmax|u| / max|x| = {u_amp / x_amp:.3g}",
        fontsize=7.5,
        pad=3,
        linespacing=1.25,
    )
