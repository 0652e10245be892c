"""Labelled points of a branch and their modal lines (the insets of Figs 6-11), placed by what the data hold.

A labelled point is requested by what it shows, as in the paper ("point e) at the 3:1 internal
resonance", "f) the first orbit with two impacts per stop"): each label names one *anchor*
(:data:`ANCHORS`) among the points of its *scope* (an optional continuation ``stage`` and number of
``impacts`` per period):

* ``energy: E`` — the point nearest to the energy ``E`` at its ``occurrence``-th crossing along the
  branch (the energy of NNM1 is not monotone: it turns back at the internal resonances);
* ``energy_fraction: r`` — the same at the energy ``E_lo**(1 - r) E_hi**r`` of the scope's range;
* ``branch_point: n`` — the point nearest to the located branch point of the ``n:1`` resonance;
* ``regime_start: n`` — the first point (``occurrence``-th) of a run with ``n`` impacts per period;
* ``energy_minimum: true`` — the point of least energy of the scope.

:func:`locate_label` returns the point, or none and why (a feature that does not exist for these
parameters, a skipped stage): the figure then says so instead of failing. The modal line of a point is
its orbit over one period in the plane of two degrees of freedom (``x, u`` for the paper's
oscillator; :func:`modal_line_dofs`), from the Fourier coefficients of the dataset
(:func:`nnmstop.figures.common.orbit`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import xarray as xr
from matplotlib.ticker import MaxNLocator

from nnmstop.figures.common import GAP_ZERO_STYLE, orbit, unit_text
from nnmstop.figures.labels import add_label, mark_obstacle

__all__ = [
    "ANCHORS",
    "LabelSpec",
    "LabelPlace",
    "label_specs",
    "energy_crossings",
    "locate_label",
    "select_point",
    "modal_line_dofs",
    "impact_text",
    "identity_text",
    "mark_point",
    "draw_modal_line",
]

logger = logging.getLogger("nnmstop.figures")

STOP_COLOR = "0.45"

#: What a label can be anchored to (one per label).
ANCHORS = ("energy", "energy_fraction", "branch_point", "regime_start", "energy_minimum")


@dataclass(frozen=True)
class LabelSpec:
    """A labelled point of a branch, as configured under ``figures.<fig>.labels``.

    Parameters
    ----------
    label : str
        The letter of the paper (``"e"`` is shown as ``e)``).
    anchor : str
        One of :data:`ANCHORS`.
    value : float
        The anchor's value (an energy, a fraction, ``n``; 1 for ``energy_minimum``).
    stage : int, optional
        Continuation stage the point must belong to (``None``: any stage).
    impacts : int, optional
        Number of impacts per period the point must have (``None``: any).
    occurrence : int
        Which crossing of the energy, start of the regime or branch point: 1 the first along the branch,
        -1 the last.
    offset : tuple of float
        Offset of the letter from its marker on the frequency-energy plot, in points.
    """

    label: str
    anchor: str
    value: float
    stage: int | None = None
    impacts: int | None = None
    occurrence: int = 1
    offset: tuple[float, float] = (6.0, 6.0)

    @property
    def energy(self) -> float:
        """The requested energy of an ``energy`` anchor."""
        return self.value

    def describe(self) -> str:
        """Human-readable request, for messages and notes (``"e) at the 3:1 branch point (stage 2)"``)."""
        what = {
            "energy": f"at energy {self.value:g}",
            "energy_fraction": f"at {self.value:g} of the energy range",
            "branch_point": f"at the {int(self.value)}:1 branch point",
            "regime_start": f"where {int(self.value)} impacts per period begin",
            "energy_minimum": "at the lowest energy",
        }[self.anchor]
        extra = []
        if self.stage is not None:
            extra.append(f"stage {self.stage}")
        if self.impacts is not None:
            extra.append(f"{self.impacts} impacts/period")
        if self.occurrence != 1:
            extra.append(f"occurrence {self.occurrence}")
        return f"{self.label}) {what}" + (f" ({', '.join(extra)})" if extra else "")


@dataclass(frozen=True)
class LabelPlace:
    """Where a label lands: ``point`` (index into the dataset), or None and ``missing`` saying why."""

    point: int | None
    missing: str = ""


def _spec_from_entry(entry: dict) -> LabelSpec:
    anchors = [key for key in ANCHORS if key in entry]
    label = str(entry.get("label"))
    if len(anchors) != 1:
        raise ValueError(f"label {label}): give exactly one of {ANCHORS}, got {anchors or 'none'}")
    anchor = anchors[0]
    return LabelSpec(
        label=label,
        anchor=anchor,
        value=float(entry[anchor]),
        stage=None if entry.get("stage") is None else int(entry["stage"]),
        impacts=None if entry.get("impacts") is None else int(entry["impacts"]),
        occurrence=int(entry.get("occurrence", 1)),
        offset=tuple(float(v) for v in entry.get("offset", (6.0, 6.0))),
    )


def label_specs(entries) -> list[LabelSpec]:
    """:class:`LabelSpec` list from the ``labels`` list of a figure's configuration.

    Raises
    ------
    ValueError
        If two entries share a letter, an entry has no or several anchors, or a value is out of range.
    """
    specs = []
    for entry in entries or []:
        spec = _spec_from_entry(entry)
        if not np.isfinite(spec.value) or (spec.anchor == "energy" and spec.value <= 0):
            raise ValueError(f"label {spec.label}): energy must be finite and > 0, got {spec.value!r}")
        if spec.anchor == "energy_fraction" and not 0.0 <= spec.value <= 1.0:
            raise ValueError(f"label {spec.label}): energy_fraction must lie in [0, 1], got {spec.value!r}")
        if spec.occurrence == 0:
            raise ValueError(f"label {spec.label}): occurrence must be >= 1 (or < 0 from the end), got 0")
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


def _scope(ds: xr.Dataset, spec: LabelSpec) -> tuple[np.ndarray, str, str]:
    """Mask of the points a label may take, words for it, and why it is empty (or "")."""
    allowed = np.ones(ds.sizes["point"], dtype=bool)
    scope = []
    if spec.stage is not None:
        allowed &= ds["stage"].values == spec.stage
        scope.append(f"stage {spec.stage}")
        if not allowed.any():
            held = ", ".join(str(int(s)) for s in np.unique(ds["stage"].values)) or "none"
            return allowed, "", f"no orbit of stage {spec.stage} (stages with orbits: {held})"
    if spec.impacts is not None:
        allowed &= ds["impacts_per_period"].values == spec.impacts
        scope.append(f"{spec.impacts} impacts/period")
        if not allowed.any():
            return allowed, "", f"no orbit of {' with '.join(scope)}"
    if not allowed.any():
        return allowed, "", "no point"
    return allowed, " with ".join(scope) if scope else "the whole dataset", ""


def _at_energy(ds, spec: LabelSpec, allowed, scope: str, target: float) -> LabelPlace:
    energy = ds["energy"].values
    lo, hi = float(energy[allowed].min()), float(energy[allowed].max())
    if not lo <= target <= hi:
        return LabelPlace(None, f"energy {target:g} outside the energy range [{lo:.6g}, {hi:.6g}] of {scope}")
    picks = energy_crossings(energy, allowed, target)
    if len(picks) < abs(spec.occurrence):
        found = ", ".join(f"point {k} (E = {energy[k]:.6g})" for k in picks) or "none"
        return LabelPlace(
            None, f"energy {target:g} met {len(picks)} time(s) in {scope} ({found}), fewer than {abs(spec.occurrence)}"
        )
    return LabelPlace(_nth(picks, spec.occurrence))


def _nth(items: list, occurrence: int):
    """The ``occurrence``-th item (1 the first, -1 the last)."""
    return items[occurrence - 1] if occurrence > 0 else items[occurrence]


def _at_branch_point(ds, spec: LabelSpec, allowed) -> LabelPlace:
    n = int(spec.value)
    resonance = ds["branch_point_resonance"].values if "branch_point_resonance" in ds else np.zeros(0)
    match = list(np.flatnonzero(resonance == n))
    if len(match) < abs(spec.occurrence):
        return LabelPlace(None, f"no {n}:1 branch point located on this branch")
    k = _nth(match, spec.occurrence)
    e, f = float(ds["branch_point_energy"].values[k]), float(ds["branch_point_frequency"].values[k])
    candidates = np.flatnonzero(allowed)
    energy, frequency = ds["energy"].values[candidates], ds["frequency"].values[candidates]
    distance = np.hypot(np.log(energy / e), (frequency - f) / f)
    return LabelPlace(int(candidates[np.argmin(distance)]))


def _at_regime_start(ds, spec: LabelSpec, allowed) -> LabelPlace:
    n = int(spec.value)
    impacts = ds["impacts_per_period"].values
    starts = [i for i in np.flatnonzero(allowed & (impacts == n)) if i == 0 or impacts[i - 1] != n]
    if not starts:
        return LabelPlace(None, f"no orbit with {n} impacts per period")
    if len(starts) < abs(spec.occurrence):
        return LabelPlace(None, f"{len(starts)} run(s) of {n} impacts per period, fewer than {abs(spec.occurrence)}")
    return LabelPlace(int(_nth(starts, spec.occurrence)))


def locate_label(ds: xr.Dataset, spec: LabelSpec) -> LabelPlace:
    """Where ``spec`` lands on the branch dataset ``ds`` (one or several stages), or why it does not.

    A label that cannot be placed (its stage skipped, no point with its impacts, no such branch
    point, an energy outside the data) is not an error: the figure notes it.
    """
    allowed, scope, empty = _scope(ds, spec)
    if empty:
        return LabelPlace(None, empty)
    if spec.anchor == "energy":
        return _at_energy(ds, spec, allowed, scope, spec.value)
    if spec.anchor == "energy_fraction":
        lo, hi = (float(f(ds["energy"].values[allowed])) for f in (np.min, np.max))
        return _at_energy(ds, spec, allowed, scope, lo ** (1.0 - spec.value) * hi**spec.value)
    if spec.anchor == "branch_point":
        return _at_branch_point(ds, spec, allowed)
    if spec.anchor == "regime_start":
        return _at_regime_start(ds, spec, allowed)
    candidates = np.flatnonzero(allowed)
    return LabelPlace(int(candidates[np.argmin(ds["energy"].values[candidates])]))


def select_point(ds: xr.Dataset, spec: LabelSpec, where: str) -> int:
    """Index of the dataset point that labels ``spec``; :class:`ValueError` naming it where there is none."""
    place = locate_label(ds, spec)
    if place.point is None:
        raise ValueError(f"{where}: label {spec.describe()}: {place.missing}")
    point = place.point
    logger.info(
        "%s: label %s -> point %d, energy %.6g, frequency %.6g Hz, stage %d, %d impacts/period",
        where,
        spec.describe(),
        point,
        float(ds["energy"].values[point]),
        float(ds["frequency"].values[point]),
        int(ds["stage"].values[point]),
        int(ds["impacts_per_period"].values[point]),
    )
    return point


def modal_line_dofs(ds: xr.Dataset) -> tuple[int, int]:
    """The two degrees of freedom of the modal lines: those of the first two stops on distinct degrees of freedom
    (every stop of a two-stop structure then shows as lines of the plane), else the first stop's and the other
    that moves most.

    ``(x, u)`` for the paper's oscillator.
    """
    dofs = list(dict.fromkeys(int(d) for d in ds["stop_dof"].values))
    if len(dofs) >= 2:
        return dofs[0], dofs[1]
    first = dofs[0]
    amplitude = np.abs(ds["q_max"].values).max(axis=0) if ds.sizes["point"] else np.zeros(ds.sizes["dof"])
    amplitude[first] = -np.inf
    return first, int(np.argmax(amplitude)) if ds.sizes["dof"] > 1 else first


def impact_text(ds: xr.Dataset, point: int) -> str:
    """Impacts per period of an orbit: the total for one stop, each stop's for several (``x1 2, x4 2 impacts``)."""
    total = int(ds["impacts_per_period"].values[point])
    if ds.sizes.get("stop", 1) < 2 or "stop_impacts" not in ds:
        return f"{total} {'impact' if total == 1 else 'impacts'}/period"
    names = [str(ds["dof_label"].values[int(d)]) for d in ds["stop_dof"].values]
    each = ", ".join(f"{n} {int(k)}" for n, k in zip(names, ds["stop_impacts"].values[point]))
    return f"impacts/period {each}"


def identity_text(ds: xr.Dataset, point: int) -> str:
    """``", NNM2 at 1/3"``: what the orbit is, where it is not the branch's own mode (:mod:`nnmstop.hbm.identity`)."""
    if "orbit_kind" not in ds:
        return ""
    kind, mode = int(ds["orbit_kind"].values[point]), int(ds["dominant_mode"].values[point])
    if kind == 2:
        return f", NNM{mode} at 1/{int(ds['dominant_harmonic'].values[point])}"
    if kind == 1:
        return f", {int(ds['tongue_harmonic'].values[point])}:1 tongue"
    own = int(ds.attrs.get("mode", mode))
    return "" if mode == own else f", NNM{mode}"


def mark_point(ax, ds: xr.Dataset, point: int, spec: LabelSpec) -> None:
    """A small dot on a labelled point and its letter in a circle beside it, joined by a short leader.

    The letter goes at ``spec.offset`` if that spot is free, else at the nearest free spot around
    the point (:func:`nnmstop.figures.labels.place_labels`, once the figure is laid out): it never
    covers the point, a branch point or fold marker, or another letter.
    """
    e = float(ds["energy"].values[point])
    f = float(ds["frequency"].values[point])
    (dot,) = ax.plot([e], [f], marker="o", ms=2.8, mfc="black", mec="none", ls="none", zorder=4.4)
    mark_obstacle(dot)
    add_label(ax, f"{spec.label}", (e, f), spec.offset)


def draw_modal_line(
    ax,
    ds: xr.Dataset,
    point: int,
    spec: LabelSpec,
    color: str,
    reference_slope: float | None = None,
    samples: int = 2048,
) -> None:
    """Modal line of one period of ``point`` in the plane of :func:`modal_line_dofs`, in a small square axes.

    Each axis has its own scale (symmetric about 0), so the shape of the line stays
    readable whatever the amplitude ratio; the ratio of the amplitudes is printed in the title with
    the letter, the number of impacts per period, the energy and the frequency. The first stop's
    gap ``+-gap`` is drawn as thin vertical lines.

    Parameters
    ----------
    reference_slope : float, optional
        If given, the straight modal line of a linear mode (e.g. of the gap-0 system) of this slope
        is drawn dash-dotted for comparison.
    """
    a, b = modal_line_dofs(ds)
    names = [str(v) for v in ds["dof_label"].values]
    o = orbit(ds, point, samples)
    x, u = o[names[a]], o[names[b]]
    e = float(ds["energy"].values[point])
    f = float(ds["frequency"].values[point])
    gaps = {int(d): float(g) for d, g in zip(ds["stop_dof"].values, ds["stop_gap"].values)}
    x_amp = float(np.max(np.abs(x)))
    u_amp = float(np.max(np.abs(u)))
    xlim = 1.15 * max(x_amp, gaps.get(a, 0.0))
    ulim = 1.15 * max(u_amp, gaps.get(b, 0.0)) if max(u_amp, gaps.get(b, 0.0)) > 0 else 1.0
    if reference_slope is not None:
        ax.plot(
            [-xlim, xlim],
            [-reference_slope * xlim, reference_slope * xlim],
            zorder=1,
            **GAP_ZERO_STYLE,
        )
    ax.plot(x, u, color=color, lw=1.1, zorder=2)
    ax.set_xlim(-xlim, xlim)
    ax.set_ylim(-ulim, ulim)
    for dof, line in ((a, ax.axvline), (b, ax.axhline)):
        if dof in gaps:  # every stop on a degree of freedom of the plane: its gap as two grey lines
            for stop in (-gaps[dof], gaps[dof]):
                line(stop, color=STOP_COLOR, lw=0.7, ls="-", zorder=0)
    ax.set_box_aspect(1.0)
    ax.xaxis.set_major_locator(MaxNLocator(nbins=4, symmetric=True))
    ax.yaxis.set_major_locator(MaxNLocator(nbins=4, symmetric=True))
    ax.tick_params(labelsize=6.5, length=2, pad=1.5)
    unit = unit_text(ds, "q_cos")
    ax.set_xlabel(f"{names[a]} {unit}", fontsize=7.5, labelpad=1)
    ax.set_ylabel(f"{names[b]} {unit}", fontsize=7.5, labelpad=1)
    ax.set_title(
        f"{spec.label}) {impact_text(ds, point)}{identity_text(ds, point)}\nE = {e:.4g}, f = {f:.4f} Hz\n"
        f"max|{names[b]}| / max|{names[a]}| = {u_amp / x_amp:.3g}",
        fontsize=7.5,
        pad=3,
        linespacing=1.25,
    )
