r"""Newton predictor-corrector pseudo-arclength continuation (the baseline method).

The same branches as :func:`nnmstop.continuation.anm.continue_anm`, on the same
:class:`~nnmstop.hbm.system.HarmonicBalanceSystem` (``n`` equations ``S(U) = 0``, ``n + 1``
unknowns), by the classical order-one method:

predictor
    ``U_pred = U_k + ds * t_k`` along the unit tangent ``t_k`` at the last point;
corrector
    full Newton iterations on the bordered system::

        [ J(U)  ] dU = - [ S(U) ]
        [ t_k^T ]        [  0   ]

    i.e. on ``S(U) = 0`` in the hyperplane ``<U - U_k, t_k> = ds`` (the
    pseudo-arclength condition, satisfied exactly by the predictor and kept by every
    update). Every iteration evaluates and factorizes the bordered Jacobian anew
    (:func:`nnmstop.continuation.core.bordered_factor`), so a step costs as many
    factorizations as Newton iterations;
tangent
    the new tangent solves ``[J; t_k^T] t = e_{n+1}`` with the LU factors of the
    last corrector iteration, i.e. the Jacobian at the last-but-one iterate: no extra
    factorization when the last Newton update was short (at most
    ``sqrt(tolerance) * max(||U||, 1)``), a fresh factorization at the converged point
    otherwise (typically after a single iteration, when the last-but-one iterate is
    the predictor). The last row makes ``<t, t_k> > 0``, so the orientation carries
    over from step to step, and the sign of ``det [J; t_k^T]`` flags simple branch
    points as in the ANM;
step control
    a step is accepted when the corrector converges within ``max_iterations`` and
    the tangent turns by less than ``max_angle`` (the angle test keeps the
    continuation on its branch at sharp turns and near bifurcation points, where a
    long step could converge onto a crossing branch). After an accepted step the
    length is scaled by ``target_iterations / iterations`` and by
    ``max_angle / (2 * angle)`` (the smaller of the two, within ``[1/2, growth]``,
    capped by ``max_step``); after a rejected step it is halved and the step retried
    from the same point. Below ``min_step`` the continuation gives up with a
    :class:`~nnmstop.continuation.core.ContinuationError` naming the step and the energy.

Accuracy, and what "the same accuracy as the ANM" means here. Both methods return
points whose accuracy is measured by the same number,
:func:`nnmstop.continuation.core.relative_residual` ``||S(U)|| / max(||U||, 1)``. The ANM
controls it through its series tolerance (Cochelin's step length keeps the last
series term below ``tolerance``) and bounds it by construction through its Newton
threshold (a step end above ``newton_threshold = 1e-7`` is corrected). With
``ANMSettings(tolerance=1e-8)`` its step ends on NNM1 and NNM2 at ``H = 100`` have
relative residuals from ``1e-10`` to ``3.5e-9`` (up to ``1.2e-8`` at ``H = 20``). The
corrector here stops as soon as the relative residual is at most ``tolerance``, with
the convergence rule of :func:`~nnmstop.continuation.core.newton_correct`; "same accuracy"
means this ``tolerance`` equals the ANM series tolerance (default ``1e-8`` for both),
so that the largest residuals of the two methods are of the same order (checked by the
tests and printed by ``benchmarks/continuation_benchmark.py``). The baseline is
sensitive to it: at ``1e-7`` (the ANM's guaranteed bound, looser than what the ANM
achieves) it needs about 25-35 % fewer factorizations, and at ``3e-9`` about 25-35 %
more. The HBM truncation error (``diagnostics()['time_residual']``, 1e-3 to 1e-2 at
high energy with ``H = 100``) is identical for both methods and far larger.

Robustness. With the defaults the baseline follows NNM1 at ``H = 100`` through all
its folds to energy 1.5e5, on the same branch as the ANM, and flags the same three
simple branch points (energies near 7.4, 245 and 3.4e3). It is not robust to loose
settings: near energy 4.7e3 the bordered Jacobian of NNM1 is nearly singular (the
tangent computed at one point turns by 0.56 rad with the bordering row), so at
``tolerance=1e-6`` the angle test cannot be met and the continuation stops with a
``ContinuationError``; with ``target_iterations=4`` the longer steps leave the branch
for a neighbouring one between energies 3e2 and 2e3.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.linalg import lu_solve

from nnmstop.continuation.core import (
    Branch,
    ContinuationError,
    ContinuationStats,
    Progress,
    StopCriterion,
    bordered_factor,
    determinant_sign,
    newton_converged,
    relative_of_residual,
    relative_residual,
    unit_tangent,
)

__all__ = ["PseudoArclengthSettings", "PseudoArclengthStats", "corrector", "continue_pseudo_arclength"]

logger = logging.getLogger("nnmstop.continuation.pseudo_arclength")


@dataclass(frozen=True)
class PseudoArclengthSettings:
    """Settings of the Newton pseudo-arclength continuation.

    Step lengths are arclengths in the Euclidean norm of the unknown vector, the same
    measure as the ANM path parameter.

    Parameters
    ----------
    tolerance : float
        Corrector tolerance on the relative residual (> 0); see the module docstring
        for how it matches the ANM accuracy.
    initial_step : float
        First step length (> 0).
    min_step : float
        Smallest step length (> 0) before the continuation gives up.
    max_step : float
        Largest step length (>= initial_step; ``inf`` for no cap).
    max_iterations : int
        Newton iterations allowed per corrector (>= 1); more means failure.
    target_iterations : int
        Iteration count the step control aims at (1 <= target_iterations <= max_iterations).
    growth : float
        Largest growth factor of the step length after one accepted step (> 1).
    max_angle : float
        Largest angle, in radians, between the tangents at both ends of an accepted
        step (0 < max_angle < pi).
    max_steps : int
        Largest number of accepted steps before the continuation gives up (>= 1).

    Examples
    --------
    >>> PseudoArclengthSettings(tolerance=1e-10).tolerance
    1e-10
    >>> PseudoArclengthSettings(min_step=-1.0)
    Traceback (most recent call last):
    ...
    ValueError: min_step must be finite and > 0, got -1.0
    """

    tolerance: float = 1e-8
    initial_step: float = 0.05
    min_step: float = 1e-7
    max_step: float = math.inf
    max_iterations: int = 8
    target_iterations: int = 3
    growth: float = 2.0
    max_angle: float = 0.3
    max_steps: int = 20000

    def __post_init__(self):
        for name in ("tolerance", "initial_step", "min_step"):
            value = getattr(self, name)
            if not _is_real(value) or not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        if not _is_real(self.max_step) or np.isnan(self.max_step) or self.max_step < self.initial_step:
            raise ValueError(
                f"max_step must be >= initial_step = {self.initial_step!r} (inf for no cap), got {self.max_step!r}"
            )
        if self.min_step > self.initial_step:
            raise ValueError(f"min_step must be <= initial_step = {self.initial_step!r}, got {self.min_step!r}")
        for name in ("max_iterations", "max_steps"):
            value = getattr(self, name)
            if not _is_int(value) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if not _is_int(self.target_iterations) or not 1 <= self.target_iterations <= self.max_iterations:
            raise ValueError(
                f"target_iterations must be an integer in [1, max_iterations = {self.max_iterations!r}], "
                f"got {self.target_iterations!r}"
            )
        if not _is_real(self.growth) or not (np.isfinite(self.growth) and self.growth > 1):
            raise ValueError(f"growth must be finite and > 1, got {self.growth!r}")
        if not _is_real(self.max_angle) or not 0 < self.max_angle < np.pi:
            raise ValueError(f"max_angle must be in (0, pi) radians, got {self.max_angle!r}")


def _is_real(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def _is_int(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


@dataclass
class PseudoArclengthStats(ContinuationStats):
    """:class:`~nnmstop.continuation.core.ContinuationStats` plus the rejected (retried) steps.

    ``factorizations`` and ``newton_iterations`` include the work spent on rejected
    steps; ``corrected_steps`` equals ``steps`` (every point is a Newton correction).
    """

    rejected_steps: int = 0


def corrector(system, U_pred, tangent, stats: ContinuationStats, tol: float, max_iterations: int):
    """Full Newton iterations on ``[S(U); <U - U_pred, tangent>] = 0``.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    U_pred : ndarray
        Predicted point; the correction stays in the hyperplane through it
        orthogonal to ``tangent``.
    tangent : ndarray
        Unit tangent at the start of the step.
    stats : ContinuationStats
        Factorizations and Newton iterations are counted there.
    tol : float
        Convergence when ``relative_residual <= tol`` and either the last update is
        below ``1e3 * tol * max(||U||, 1)`` or the residual is below ``1e-3 * tol`` (the
        rule of :func:`~nnmstop.continuation.core.newton_correct`: near a singular Jacobian
        the update can stall above round-off while the residual is already there).
    max_iterations : int
        Iterations allowed.

    Returns
    -------
    U : ndarray or None
        The corrected point, None when the iteration failed (no convergence, growing
        residual, singular or non-finite matrix).
    iterations : int
        Iterations spent.
    lu : tuple or None
        LU factors of the last iteration, i.e. of the bordered Jacobian at the
        last-but-one iterate.
    last_update : float
        Norm of the last Newton update: the distance between ``U`` and the point
        where ``lu`` was evaluated.
    reason : str
        Why it failed ("" on success).
    """
    U = np.array(U_pred, dtype=float)
    rhs = np.zeros(system.n_unknowns)

    def evaluate(V):
        r = system.residual(V)
        return r, relative_of_residual(V, r)

    r, rel = evaluate(U)
    previous = math.inf
    for it in range(1, max_iterations + 1):
        if not np.isfinite(rel):
            return None, it - 1, None, math.inf, "non-finite residual"
        # Newton is diverging when the residual grows after the first update: stop now
        # rather than spend the remaining factorizations.
        if it > 2 and rel > previous:
            return None, it - 1, None, math.inf, f"residual growing ({previous:.2e} -> {rel:.2e})"
        previous = rel
        try:
            lu = bordered_factor(system, U, tangent, stats)
        except (np.linalg.LinAlgError, ValueError) as err:
            return None, it - 1, None, math.inf, f"bordered Jacobian: {err}"
        rhs[:-1] = -r
        rhs[-1] = 0.0
        dU = lu_solve(lu, rhs)
        U += dU
        stats.newton_iterations += 1
        r, rel = evaluate(U)
        if newton_converged(U, r, dU, tol):
            return U, it, lu, float(np.linalg.norm(dU)), ""
    reason = f"no convergence in {max_iterations} iterations (relative residual {rel:.2e})"
    return None, max_iterations, None, math.inf, reason


def _angle(a, b) -> float:
    """Angle between two unit vectors, accurate for small angles."""
    return float(2.0 * np.arctan2(np.linalg.norm(a - b), np.linalg.norm(a + b)))


def continue_pseudo_arclength(
    system,
    U_start,
    direction,
    stop: StopCriterion,
    settings: PseudoArclengthSettings = PseudoArclengthSettings(),
    label: str = "pseudo-arclength",
    progress_seconds: float = 2.0,
) -> Branch:
    """Follow the branch through ``U_start`` along ``direction`` until ``stop`` says so.

    Same interface and same returned object as :func:`nnmstop.continuation.anm.continue_anm`.

    Parameters
    ----------
    system : HarmonicBalanceSystem
        Provides ``residual``, ``jacobian`` and ``diagnostics``.
    U_start : ndarray
        A point of the branch (relative residual at most ``settings.tolerance``).
    direction : ndarray
        Rough direction of travel; the tangent is oriented along it.
    stop : callable
        ``stop(U, diagnostics) -> str``; a non-empty string ends the continuation and
        is recorded as the end reason.
    settings : PseudoArclengthSettings
    label : str
        Name used in log and error messages.
    progress_seconds : float
        Interval between progress log messages.

    Returns
    -------
    Branch
        The start point, then one point per accepted step, each with its diagnostics;
        ``stats`` is a :class:`PseudoArclengthStats`; ``branch_points`` lists the
        indices ``i`` such that the sign of ``det [J; t^T]`` changes between points
        ``i`` and ``i + 1`` (a simple branch point lies between them; the sign does not
        change across a fold, where the tangent keeps its orientation).

    Raises
    ------
    ContinuationError
        When the step length falls below ``min_step`` or ``max_steps`` is exhausted;
        the message names the step and the energy.
    ValueError
        When ``U_start`` or ``direction`` has the wrong length or is not finite, or
        ``U_start`` is not a point of the branch.
    """
    U = np.array(U_start, dtype=float)
    direction = np.array(direction, dtype=float)
    n = system.n_unknowns
    for name, vec in (("U_start", U), ("direction", direction)):
        if vec.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},), got {vec.shape}")
        if not np.all(np.isfinite(vec)):
            raise ValueError(f"{name} must be finite")
    if not np.linalg.norm(direction) > 0:
        raise ValueError("direction must be a non-zero vector")
    start_residual = relative_residual(system, U)
    if start_residual > settings.tolerance:
        raise ValueError(
            f"U_start is not on the branch: relative residual {start_residual:.2e} > tolerance "
            f"{settings.tolerance:.1e} (correct it with newton_correct first)"
        )

    stats = PseudoArclengthStats()
    started = time.perf_counter()
    branch = Branch(stats=stats)
    lu = bordered_factor(system, U, direction / np.linalg.norm(direction), stats)
    tangent = unit_tangent(system, U, direction, stats, lu=lu)
    # det [J; b^T] is linear in b and vanishes for b orthogonal to the tangent, so its
    # sign is the same for every bordering row b with <b, t> > 0: the direction here,
    # the previous tangent at the end of each step.
    sign = determinant_sign(lu)
    diag = system.diagnostics(U)
    branch.add(U, 0, diag)
    progress = Progress(label, progress_seconds, logger)
    ds = settings.initial_step
    rhs_tangent = np.zeros(n)
    rhs_tangent[-1] = 1.0
    for step in range(1, settings.max_steps + 1):
        while True:
            U_new, iterations, lu, last_update, reason = corrector(
                system, U + ds * tangent, tangent, stats, settings.tolerance, settings.max_iterations
            )
            if U_new is not None and last_update > np.sqrt(settings.tolerance) * max(np.linalg.norm(U_new), 1.0):
                # The last factorization is too far from U_new for an accurate tangent
                # (typically after a single iteration): refactorize at U_new.
                try:
                    lu = bordered_factor(system, U_new, tangent, stats)
                except (np.linalg.LinAlgError, ValueError) as err:
                    U_new, reason = None, f"bordered Jacobian at the new point: {err}"
            if U_new is not None:
                t_new = lu_solve(lu, rhs_tangent)
                t_new /= np.linalg.norm(t_new)
                angle = _angle(tangent, t_new)
                if angle <= settings.max_angle:
                    break
                reason = f"tangent turned by {angle:.3g} rad > max_angle {settings.max_angle:.3g}"
            stats.rejected_steps += 1
            logger.debug("%s step %d rejected at ds = %.3g: %s", label, step, ds, reason)
            ds *= 0.5
            if ds < settings.min_step:
                stats.wall_time = time.perf_counter() - started
                raise ContinuationError(
                    f"{label}: step {step} failed at energy {diag['energy']:.6g} "
                    f"(frequency {diag['frequency']:.6g} Hz): step length {ds:.3g} fell below "
                    f"min_step {settings.min_step:.3g} ({reason})"
                )
        logger.debug(
            "%s step %d accepted: ds = %.3g, %d iterations, tangent angle %.3g", label, step, ds, iterations, angle
        )
        U, tangent = U_new, t_new
        stats.steps = step
        stats.corrected_steps = step
        new_sign = determinant_sign(lu)
        if new_sign != sign:
            branch.branch_points.append(len(branch.points) - 1)
            logger.info(
                "%s: simple branch point passed near energy %.6g, frequency %.6g Hz (step %d)",
                label,
                diag["energy"],
                diag["frequency"],
                step,
            )
        sign = new_sign
        diag = system.diagnostics(U)
        branch.add(U, step, diag)
        progress(step, diag, ds)
        reason = stop(U, diag)
        if reason:
            branch.end_reason = reason
            branch.end_tangent = tangent
            stats.wall_time = time.perf_counter() - started
            progress(step, diag, ds, force=True)
            return branch
        factor = settings.target_iterations / max(iterations, 1)
        if angle > 0:
            factor = min(factor, settings.max_angle / (2.0 * angle))
        ds = min(ds * min(max(factor, 0.5), settings.growth), settings.max_step)
    stats.wall_time = time.perf_counter() - started
    raise ContinuationError(
        f"{label}: no stop criterion met after max_steps = {settings.max_steps} steps "
        f"(step {settings.max_steps}, last energy {diag['energy']:.6g}, frequency {diag['frequency']:.6g} Hz)"
    )
