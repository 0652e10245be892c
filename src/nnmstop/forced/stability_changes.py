"""Stability changes along a forced-response curve: detected, located on the curve and typed.

Floquet multipliers ``mu`` of a periodic response of period ``T``; for responses with the half-period
symmetry ``q(t + T/2) = -q(t)``, multipliers ``nu`` of the half-period map, ``mu = nu**2``. A change of the
number of multipliers outside the unit circle between two points of the curve is located by bisection
on the continuation path between them (the path of the step, on the curve all along) and typed by the
multiplier that crosses the circle there:

* ``fold``: a real multiplier through +1 (``nu`` through +1 on the symmetric responses): the curve turns
  back in ``Omega`` (a saddle-node of periodic responses, where the response jumps);
* ``symmetry_breaking``: ``nu`` through -1 (``mu`` through +1 without a fold): responses without the
  half-period symmetry branch off;
* ``period_doubling``: ``mu`` through -1 (``nu`` through ``+-i``): a response of period ``2T`` branches off;
* ``neimark_sacker``: a complex pair through the unit circle elsewhere: a quasi-periodic response.

Per point, :func:`regimes` says what is known of the response where the periodic one is unstable, so
that no periodic response is claimed where there is none. Method notes: docs/forced.md.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.optimize

from nnmstop.continuation.core import unit_tangent
from nnmstop.continuation.newton import bisect_sign_change

__all__ = [
    "KINDS",
    "REGIMES",
    "StabilityChange",
    "unstable_count",
    "crossing_kind",
    "locate_stability_changes",
    "type_branch_points",
    "type_by_tangent",
    "regimes",
]

#: Kinds of located stability changes (dataset flag values 1..4).
KINDS = ("fold", "symmetry_breaking", "period_doubling", "neimark_sacker")
#: Regime of each point (dataset flag values 0..4).
REGIMES = ("stable_periodic", "unstable_jump", "symmetry_broken", "period_doubled", "quasi_periodic")
# A multiplier this close to the real axis (relative to its modulus) counts as real.
_REAL = 1e-7


def unstable_count(multipliers, tol: float = 1e-12) -> int:
    """Number of multipliers outside the unit circle (beyond ``1 + tol``)."""
    return int(np.count_nonzero(np.abs(multipliers) > 1.0 + tol))


def crossing_kind(multipliers, half_period: bool) -> str:
    """Kind (:data:`KINDS`) of the multiplier nearest to the unit circle, at a located change."""
    m = np.asarray(multipliers)
    crossing = m[np.argmin(np.abs(np.abs(m) - 1.0))]
    real = abs(crossing.imag) <= _REAL * abs(crossing)
    if half_period:
        if real:
            return "fold" if crossing.real > 0 else "symmetry_breaking"
        return "period_doubling" if abs(crossing.real) <= 1e-3 * abs(crossing) else "neimark_sacker"
    if real:
        return "fold" if crossing.real > 0 else "period_doubling"
    return "neimark_sacker"


@dataclass(frozen=True)
class StabilityChange:
    """A located stability change: the point of the curve, its index bracket and its kind."""

    U: np.ndarray
    after_point: int
    kind: str
    multipliers: np.ndarray


def locate_stability_changes(
    points, multipliers, multipliers_at, path_between, half_period: bool, rel_tol: float = 1e-10
) -> list:
    """Locate every change of :func:`unstable_count` between consecutive ``points``.

    Where the count goes from ``n`` to more (or back), the ``n + 1``-th largest modulus crosses 1: a continuous
    function of the path parameter, whose root Brent's method finds to ``rel_tol`` of the step in a few
    evaluations. (Should the moduli recomputed at the ends not bracket it, the count itself is bisected.)

    Parameters
    ----------
    points : ndarray (n, m)
        The curve's points, in order.
    multipliers : ndarray (n, k)
        Multipliers of each point (``nu`` when ``half_period``).
    multipliers_at : callable
        ``(i) -> (U -> multipliers)``: the multipliers at any point of the curve between ``points[i]`` and
        ``points[i + 1]`` (at one fixed precision along that step).
    path_between : callable
        ``(i) -> (path, length)``: the curve from ``points[i]`` to ``points[i + 1]`` as ``a -> U(a)``.
    half_period : bool
        The multipliers are those of the half-period map.
    """
    counts = [unstable_count(m) for m in multipliers]
    changes = []
    for i in np.flatnonzero(np.diff(counts) != 0):
        path, length = path_between(int(i))
        multipliers_of = multipliers_at(int(i))
        a = _crossing(path, length, multipliers_of, min(counts[i], counts[i + 1]), rel_tol)
        U = path(a)
        at = np.asarray(multipliers_of(U))
        changes.append(StabilityChange(np.asarray(U), int(i), crossing_kind(at, half_period), at))
    return changes


def _crossing(path, length: float, multipliers_of, n: int, rel_tol: float) -> float:
    """Path parameter where the ``n + 1``-th largest multiplier modulus is 1 (Brent), else where the count changes."""

    def excess(a):
        moduli = np.sort(np.abs(np.asarray(multipliers_of(path(a)))))[::-1]
        return moduli[n] - 1.0

    ends = excess(0.0), excess(length)
    if ends[0] * ends[1] < 0:
        return scipy.optimize.brentq(excess, 0.0, length, xtol=rel_tol * length, rtol=4 * np.finfo(float).eps)
    found = bisect_sign_change(
        lambda a: unstable_count(multipliers_of(path(a))), 0.0, length, tol=rel_tol * length, side=lambda c: c
    )
    return found.midpoint


def type_branch_points(changes, branch_points, reach: int = 2) -> list:
    """``changes`` with each fold (a multiplier ``mu`` through +1) that lies within ``reach`` steps after a simple
    branch point flagged by the continuation (a sign change of ``det [J; t^T]``, which a fold does not make)
    typed ``symmetry_breaking``: where the full-period equations hold the symmetric responses and those without
    the symmetry, these branch off there."""
    flagged = set(branch_points)
    typed = []
    for change in changes:
        near = {change.after_point + k for k in range(reach + 1)}
        if change.kind == "fold" and near & flagged:
            change = replace(change, kind="symmetry_breaking")
        typed.append(change)
    return typed


def type_by_tangent(changes, system, points, symmetric: bool, tolerance: float = 1e-4) -> list:
    """``changes`` with each fold (a multiplier ``mu`` through +1) where the curve's unit tangent at the located
    point has an ``Omega`` component (the last unknown of ``system``) above ``tolerance`` typed
    ``symmetry_breaking`` when ``symmetric`` (every law odd: the responses without the half-wave symmetry branch
    off there, a simple branch point); at a fold of the curve the tangent has no ``Omega`` component. The test of
    the full-period exact responses, whose continuation may see a sign change of ``det [J; t^T]`` next to a grazing
    orbit where several contacts graze at once (a singular point of their equations, not a branch)."""
    typed = []
    for change in changes:
        if change.kind == "fold" and symmetric:
            i = change.after_point
            tangent, _ = unit_tangent(system, change.U, points[i + 1] - points[i])
            if abs(tangent[-1]) > tolerance:
                change = replace(change, kind="symmetry_breaking")
        typed.append(change)
    return typed


def regimes(multipliers, half_period: bool, tol: float = 1e-12) -> np.ndarray:
    """Index in :data:`REGIMES` of each point from its multipliers (rows).

    Stable: ``stable_periodic``. Unstable through a real multiplier > 1 only (between folds): ``unstable_jump``
    (the response jumps to another one). A ``nu`` < -1 only: ``symmetry_broken`` (a periodic response without
    the half-period symmetry). A multiplier ``mu`` < -1: ``period_doubled``; a complex pair outside:
    ``quasi_periodic``. Where several apply the last of these wins.
    """
    out = np.zeros(len(multipliers), dtype=np.int8)
    for i, m in enumerate(np.asarray(multipliers)):
        outside = m[np.abs(m) > 1.0 + tol]
        if not outside.size:
            continue
        real = np.abs(outside.imag) <= _REAL * np.abs(outside)
        mu = outside**2 if half_period else outside
        if np.any(~real & (np.abs(mu.imag) > _REAL * np.abs(mu))):
            out[i] = REGIMES.index("quasi_periodic")
        elif np.any(mu.real < 0):
            out[i] = REGIMES.index("period_doubled")
        elif half_period and np.any(real & (outside.real < 0)):
            out[i] = REGIMES.index("symmetry_broken")
        else:
            out[i] = REGIMES.index("unstable_jump")
    return out
