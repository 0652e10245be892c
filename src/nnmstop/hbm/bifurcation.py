r"""Branch points of the harmonic-balance branches: what crosses there (HBM-specific parts).

Location of a simple branch point, the tangents of both curves through it and branch switching
are method-generic and live in :mod:`nnmstop.continuation.branch_points` (moved from here; the
names are re-exported unchanged). What stays here needs the harmonic-balance unknowns:

* :func:`quadratic_form`, the exact bilinear part ``Q`` of the quadratic recast ``S = L + Q``,
  which :func:`bifurcation_tangents` uses for Keller's bifurcation equation;
* :func:`subharmonic_share` and :func:`classify_branch_point`: an ``n:1`` internal resonance (the
  crossing curve holds the orbits of period ``T/n``) or a symmetry breaking;
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
            branch_point_kind(n, breaking),
        )
        out.append((i, point, n, breaking))
    return out


def branch_point_kind(n: int, symmetry_breaking: bool) -> str:
    """Words for the classification of :func:`classify_branch_point`."""
    return f"{n}:1 resonance" if n else ("symmetry breaking" if symmetry_breaking else "unclassified")
