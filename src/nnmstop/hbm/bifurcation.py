r"""Branch points of the harmonic-balance branches: what crosses there (HBM-specific parts).

Location of a simple branch point, the tangents of both curves through it and branch switching
are method-generic and live in :mod:`nnmstop.continuation.branch_points` (moved from here; the
names are re-exported unchanged). What stays here needs the harmonic-balance unknowns:

* :func:`quadratic_form`, the exact bilinear part ``Q`` of the quadratic recast ``S = L + Q``,
  which :func:`bifurcation_tangents` uses for Keller's bifurcation equation;
* :func:`subharmonic_share` and :func:`classify_branch_point`: an ``n:1`` internal resonance (the
  crossing curve holds the orbits of period ``T/n``) or a symmetry breaking; :func:`is_whirl_branch_point`:
  planar motion in a circular clearance giving way to whirl (the crossing curve goes round the hole);
* :func:`locate_flagged_branch_points`: locate and classify every flagged step of a branch.

Method notes: ``docs/methods/continuation.md`` (location, switching), ``docs/methods/hbm.md``.
"""

from __future__ import annotations

import logging

import numpy as np

from nnmstop.continuation import branch_points as generic
from nnmstop.continuation.branch_points import (
    BranchPoint,
    continue_bifurcated_branch,
    locate_branch_point,
    project_onto_branch,
    switch_branch,
)

__all__ = [
    "BranchPoint",
    "quadratic_form",
    "locate_branch_point",
    "project_onto_branch",
    "bifurcation_tangents",
    "switch_branch",
    "subharmonic_share",
    "continue_bifurcated_branch",
    "branch_point_kind",
    "classify_branch_point",
    "circular_pair",
    "swept_area",
    "is_whirl_branch_point",
    "locate_flagged_branch_points",
]

logger = logging.getLogger("nnmstop.hbm.bifurcation")


def quadratic_form(system, a, b) -> np.ndarray:
    """``Q(a, b)``, the symmetric bilinear part of ``S = L + Q``.

    The ANM's right-hand side :meth:`~nnmstop.hbm.system.HarmonicBalanceSystem.series_products`
    of order 3 for the terms ``(0, a, b)`` is ``Q(a, b) + Q(b, a) = 2 Q(a, b)``.
    """
    terms = np.zeros((3, system.n_unknowns))
    terms[1], terms[2] = a, b
    return 0.5 * system.series_products(terms, 3)


def bifurcation_tangents(system, U_star, reference) -> BranchPoint:
    """:func:`nnmstop.continuation.branch_points.bifurcation_tangents` with the exact :func:`quadratic_form`."""
    return generic.bifurcation_tangents(system, U_star, reference, lambda a, b: quadratic_form(system, a, b))


def subharmonic_share(system, U, n: int) -> float:
    """Share of the mean square of the degrees of freedom in harmonics that are not multiples of ``n``.

    Zero for an orbit of period ``T / n`` (an orbit of frequency ``n`` times that of
    the unknown ``lam``), which is what NNM1 crosses at an ``n:1`` internal resonance.
    """
    dofs = system.split(U)[: system.n_dofs]
    k = np.arange(system.nc) % system.nfull  # index in the kept layout
    harmonic = np.where(k <= system.H, k, k - system.H)
    off = (harmonic % n) != 0
    total = sum(np.sum(q[1:] ** 2) for q in dofs)
    return float(sum(np.sum(q[off] ** 2) for q in dofs) / total) if total > 0 else 0.0


def classify_branch_point(system, point: BranchPoint, max_resonance: int = 20, share_tol: float = 1e-6):
    """What crosses the branch at ``point``: ``(n, symmetry_breaking)``.

    ``n`` is the smallest ``n >= 2`` such that the orbit at the branch point has period
    ``T/n`` (an ``n:1`` internal resonance: the crossing curve is the family of those
    orbits), else 0. ``symmetry_breaking`` is True when the bifurcated tangent holds
    even harmonics only: the crossing curve breaks the half-period symmetry
    ``x(t + T/2) = -x(t)`` of the odd-harmonic orbits (never with a law that is not odd, whose orbits have
    no such symmetry).
    """
    for n in range(2, max_resonance + 1):
        if subharmonic_share(system, point.U, n) < share_tol:
            return n, False
    if not system.contact.odd:  # no half-period symmetry to break: a law that is not odd (a one-sided stop)
        return 0, False
    return 0, bool(subharmonic_share(system, point.bifurcated, 2) < share_tol)


def circular_pair(system):
    """The two stop components (indices) of the first circular clearance of ``system``'s structure, or None."""
    for stop, components in zip(system.structure.stops, system.contact.components):
        if stop.kind == "circular":
            return components.start, components.start + 1
    return None


def _pair_samples(system, U, samples: int = 256):
    """Samples of the first circular clearance's two scaled coordinates and their theta-derivatives, (2, samples)
    each."""
    a, b = circular_pair(system)
    Q = np.asarray(U, dtype=float)[: system.n_dofs * system.nc].reshape(system.n_dofs, system.nc)
    X = system.stop_coordinates(Q)[[a, b]]
    return system.to_time(system.to_full(X), samples), system.to_time(system.derivative(X), samples)


def swept_area(system, U, tangent=None) -> float:
    """Area swept per period by the first circular clearance's coordinates, ``int (x y' - y x') dtheta``, relative
    to ``2 pi max(x^2 + y^2)`` (scaled coordinates): zero for planar motion, 1 for a whirl round a circle.

    With ``tangent``, the first-order change of the swept area along it (relative to the orbit's size times the
    tangent's): nonzero when a curve leaving a planar orbit along ``tangent`` goes round the hole.
    """
    (x, y), (dx, dy) = _pair_samples(system, U)
    if tangent is None:
        size = 2 * np.pi * float(np.max(x * x + y * y))
        return float(2 * np.pi * np.mean(x * dy - y * dx) / size) if size > 0 else 0.0
    (tx, ty), (dtx, dty) = _pair_samples(system, tangent)
    change = 2 * np.pi * np.mean(x * dty + tx * dy - y * dtx - ty * dx)
    size = 2 * np.pi * np.sqrt(np.max(x * x + y * y) * np.max(tx * tx + ty * ty))
    return float(change / size) if size > 0 else 0.0


#: Relative first-order swept area (:func:`swept_area` along the crossing tangent) above which a branch point of a
#: planar orbit gives way to whirl.
WHIRL_AREA_TOL = 1e-3


def is_whirl_branch_point(system, point: BranchPoint) -> bool:
    """Whether the curve crossing a planar orbit in a circular clearance at ``point`` goes round the hole.

    The orbit at the branch point sweeps no area (planar motion, :func:`swept_area` below
    :data:`WHIRL_AREA_TOL`) and the crossing curve's tangent sweeps some at first order: leaving the branch point
    along it the clearance's coordinates turn round the hole (an elliptic whirl that grows into the whirling
    orbits). False for a structure without a circular clearance.
    """
    if circular_pair(system) is None:
        return False
    if abs(swept_area(system, point.U)) > WHIRL_AREA_TOL:
        return False
    return abs(swept_area(system, point.U, point.bifurcated)) > WHIRL_AREA_TOL


def locate_flagged_branch_points(system, points, steps, flagged, method=None) -> list:
    """Locate and classify the branch points of the steps flagged by a continuation.

    Parameters
    ----------
    points, steps : sequences
        Points of the branch and the index of the continuation step that produced each.
    flagged : sequence of int
        Indices of the points ending a step across which ``det [J; t^T]`` changed sign.
    method : Stepper or settings, optional
        The continuation method that took the steps
        (:func:`nnmstop.continuation.branch_points.locate_branch_point`).

    Returns
    -------
    list of (int, BranchPoint, int, bool)
        ``(flagged index, point, n, symmetry_breaking)`` (see :func:`classify_branch_point`).
    """

    def exact_form(U_star):
        return lambda a, b: quadratic_form(system, a, b)

    out = []
    for i, point in generic.locate_flagged(system, points, steps, flagged, method, quadratic=exact_form):
        n, breaking = classify_branch_point(system, point)
        logger.info(
            "branch point at energy %.6g, frequency %.6g Hz: %s",
            system.diagnostics(point.U)["energy"],
            system.frequency_hz(point.U),
            branch_point_kind(n, breaking, not n and is_whirl_branch_point(system, point)),
        )
        out.append((i, point, n, breaking))
    return out


def branch_point_kind(n: int, symmetry_breaking: bool, whirl: bool = False) -> str:
    """Words for the classification of :func:`classify_branch_point` (and :func:`is_whirl_branch_point`)."""
    if n:
        return f"{n}:1 resonance"
    if whirl:
        return "planar motion giving way to whirl"
    return "symmetry breaking" if symmetry_breaking else "unclassified"
