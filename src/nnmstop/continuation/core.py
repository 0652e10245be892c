"""Pieces shared by the continuation methods: the branch, the counters, the corrector.

A continuation follows the solution curve of ``S(U) = 0`` (``n`` equations, ``n + 1``
unknowns) from a start point in a given direction. :class:`Branch` holds its points, with
the steps that produced them and the flagged branch points; :class:`ContinuationStats`
its cost counters. :func:`newton_correct` is the Newton corrector in the hyperplane
orthogonal to a tangent (chord iterations on given factors first), with the convergence
rule :func:`newton_converged` that every continuation corrector uses; :func:`unit_tangent`
the tangent and the sign of ``det [J; t^T]`` at a point. Accuracy is measured by
:func:`relative_residual`. Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from nnmstop.continuation.linear import factorize_bordered
from nnmstop.continuation.newton import newton_solve

__all__ = [
    "ContinuationError",
    "UnresolvedBranchError",
    "ContinuationStats",
    "Branch",
    "relative_residual",
    "relative_of_residual",
    "newton_converged",
    "newton_correct",
    "OrthogonalUpdate",
    "unit_tangent",
    "StopCriterion",
    "Progress",
    "is_real_number",
    "is_integer",
    "require_on_branch",
]

logger = logging.getLogger("nnmstop.continuation.core")


class ContinuationError(RuntimeError):
    """A continuation could not go on; the message names the step and the energy."""


class UnresolvedBranchError(ContinuationError):
    """The harmonics do not resolve the orbit: the truncation indicator exceeded its limit."""


@dataclass
class ContinuationStats:
    """Cost counters of one continuation run."""

    steps: int = 0
    factorizations: int = 0
    newton_iterations: int = 0
    corrected_steps: int = 0
    geometric_tails: int = 0
    pade_steps: int = 0
    wall_time: float = 0.0


@dataclass
class Branch:
    """Points of a continued branch, in order along the curve.

    ``points`` are unknown vectors; ``step`` is the index of the continuation step
    that produced each point (interior points of one ANM step share it);
    ``diagnostics`` the dict of ``system.diagnostics`` of each point (None where the
    method did not compute it); ``checks`` the events' check of each point (None without
    events, :mod:`nnmstop.continuation.events`); ``arclength`` the pseudo-arclength of each
    point from the start (the steps' path parameters added up; None where unknown).
    ``end_event`` is the located event that ended the branch (None when something else did);
    ``end_check`` how the end was checked, when something checked it
    (:mod:`nnmstop.continuation.confirm`).
    """

    points: list = field(default_factory=list)
    step: list = field(default_factory=list)
    diagnostics: list = field(default_factory=list)
    stats: ContinuationStats = field(default_factory=ContinuationStats)
    end_reason: str = ""
    end_tangent: np.ndarray | None = None
    # Indices of the points that end a continuation step across which the sign of
    # det [J; t^T] changed: a simple branch point lies within that step.
    branch_points: list = field(default_factory=list)
    checks: list = field(default_factory=list)
    arclength: list = field(default_factory=list)
    end_event: object = None
    end_check: str = ""

    def add(self, U, step, diagnostics=None, check=None, arclength=None):
        self.points.append(np.array(U, dtype=float))
        self.step.append(int(step))
        self.diagnostics.append(diagnostics)
        self.checks.append(check)
        self.arclength.append(arclength)


# A stop criterion gets the new point and its diagnostics dict and returns a reason
# string when the continuation must stop (or "" to go on).
StopCriterion = Callable[[np.ndarray, dict], str]


def relative_residual(system, U) -> float:
    """``||S(U)|| / max(||U||, 1)``: the accuracy measure used by both methods."""
    return relative_of_residual(U, system.residual(U))


def unit_tangent(system, U, direction, stats: ContinuationStats | None = None, *, singular_tol: float | None = 1e-14):
    """Unit tangent of the curve at ``U`` oriented along ``direction``, and the sign of ``det [J; t^T]`` there.

    The tangent solves ``[J(U); d^T] t = e_{n+1}`` with ``d`` the unit ``direction``; the sign
    is that of ``det [J(U); d^T]``, the same as with ``t`` as bordering row (``<d, t> > 0``).
    ``singular_tol`` as in :func:`~nnmstop.continuation.linear.factorize_bordered`.
    """
    direction = np.asarray(direction, dtype=float)
    factors = factorize_bordered(system, U, direction / np.linalg.norm(direction), stats, singular_tol=singular_tol)
    rhs = np.zeros(len(direction))
    rhs[-1] = 1.0
    t = factors.solve(rhs)
    return t / np.linalg.norm(t), factors.determinant_sign()


class OrthogonalUpdate:
    """Newton updates ``J dU = rhs`` with ``<t, dU> = 0``, from the factors of ``[J; t^T]``.

    The Jacobian a corrector in the hyperplane orthogonal to ``t`` hands to
    :func:`~nnmstop.continuation.newton.newton_solve`.
    """

    def __init__(self, factors):
        self.factors = factors

    def solve(self, rhs):
        return self.factors.solve(np.append(rhs, 0.0))


def newton_correct(system, U, tangent, stats: ContinuationStats, tol: float, max_iter: int = 12, factors=None):
    """Newton iterations on ``S(U) = 0`` in the hyperplane orthogonal to ``tangent``.

    Full Newton refactorizes at every iteration. With ``factors``, those of a nearby
    bordered matrix ``[J(U_0); t^T]`` (for example those of the ANM step that produced
    ``U``), chord iterations reuse them first (corrections then stay orthogonal to
    that ``t``) and full Newton takes over only if they do not converge. Converged
    when the relative residual is below ``tol`` and the last update is small
    (:func:`newton_converged`). Returns the corrected point and the number of
    iterations; raises ``ContinuationError`` when it does not converge.
    """
    U = np.array(U, dtype=float)

    def converged(V, r, dU):
        return dU is not None and newton_converged(V, r, dU, tol)

    options = dict(tol=tol, criterion=converged, norm=relative_of_residual)
    if factors is not None:
        chord = OrthogonalUpdate(factors)  # chord iterations are cheap: no factorization
        try:
            result = newton_solve(system.residual, lambda V: chord, U, max_iter=3 * max_iter, **options)
        except np.linalg.LinAlgError:  # diverged: full Newton from U
            result = None
        if result is not None:
            stats.newton_iterations += result.iterations
            if result.converged:
                return result.y, result.iterations
    result = newton_solve(
        system.residual,
        lambda V: OrthogonalUpdate(factorize_bordered(system, V, tangent, stats)),
        U,
        max_iter=max_iter,
        **options,
    )
    stats.newton_iterations += result.iterations
    if result.converged:
        return result.y, result.iterations
    if "non-finite" in result.reason:
        raise ContinuationError(f"Newton correction diverged ({result.reason})")
    raise ContinuationError(
        f"Newton correction did not converge in {max_iter} iterations (relative residual "
        f"{result.residual_norm:.2e} > {tol:.1e})"
    )


def is_real_number(value) -> bool:
    """A Python or numpy real number (not a bool), for the settings' checks."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def is_integer(value) -> bool:
    """A Python or numpy integer (not a bool)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def require_on_branch(system, U, tolerance: float, hint: str = "") -> None:
    """ValueError unless the relative residual at ``U`` is at most ``tolerance`` (a stepper's start check)."""
    residual = relative_residual(system, U)
    if residual > tolerance:
        raise ValueError(
            f"U_start is not on the branch: relative residual {residual:.2e} > tolerance {tolerance:.1e}{hint}"
        )


def relative_of_residual(U, r) -> float:
    """:func:`relative_residual` from a residual ``r = S(U)`` already evaluated (inf where it overflows)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return float(np.linalg.norm(r) / max(np.linalg.norm(U), 1.0))


def newton_converged(U, r, dU, tol: float) -> bool:
    """Convergence test of a Newton corrector, shared by both continuation methods.

    ``r = S(U)`` after the update ``dU``: the relative residual is below ``tol`` and the
    update is small.
    """
    residual = relative_of_residual(U, r)
    small_update = np.linalg.norm(dU) <= 1e3 * tol * max(np.linalg.norm(U), 1.0)
    # Near a singular Jacobian (branch points) the update may stall above round-off
    # while the residual is already at it: accept the residual then.
    return residual <= tol and (small_update or residual <= 1e-3 * tol)


class Progress:
    """Throttled progress messages (energy, frequency, step) for long runs."""

    def __init__(self, label: str, every_seconds: float = 2.0, log=logger):
        self.label = label
        self.every = every_seconds
        self.log = log
        self.start = time.perf_counter()
        self.last = -np.inf

    def __call__(self, step: int, diag: dict, step_length: float, force: bool = False):
        now = time.perf_counter()
        if force or now - self.last >= self.every:
            self.last = now
            self.log.info(
                "%s step %d: energy %.6g, frequency %.6g Hz, step length %.3g, %d impacts/period (%.1f s)",
                self.label,
                step,
                diag["energy"],
                diag["frequency"],
                step_length,
                diag["impacts_per_period"],
                now - self.start,
            )
