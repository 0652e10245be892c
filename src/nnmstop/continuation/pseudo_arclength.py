r"""Newton predictor-corrector pseudo-arclength continuation (the baseline method).

The same branches as the ANM, on the same system, by the classical order-one method: a
tangent predictor ``U_k + ds t_k``, a full-Newton corrector in the hyperplane
``<U - U_k, t_k> = ds`` (one factorization of ``[J; t_k^T]`` per iteration, :func:`corrector`),
the new tangent from the last factors, and a step length controlled by the Newton
iteration count and the turn of the tangent (rejected steps are halved and retried).
Accuracy is the relative residual ``||S(U)|| / max(||U||, 1)``, as for the ANM: the
corrector tolerance plays the role of the ANM series tolerance.

:class:`PseudoArclengthStepper` is the step behind the driver's interface
(:mod:`nnmstop.continuation.driver`); its path over a step, for branch-point location, is
a :class:`~nnmstop.continuation.corrected_path.CorrectedPath`.
:func:`continue_pseudo_arclength` runs the driver with it.
Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from nnmstop.continuation.core import (
    Branch,
    ContinuationError,
    ContinuationStats,
    OrthogonalUpdate,
    StopCriterion,
    is_integer,
    is_real_number,
    newton_converged,
    relative_of_residual,
    require_on_branch,
)
from nnmstop.continuation.corrected_path import CorrectedPath
from nnmstop.continuation.driver import Stepper, StepResult, continue_branch
from nnmstop.continuation.linear import factorize_bordered
from nnmstop.continuation.newton import newton_solve

__all__ = [
    "PseudoArclengthSettings",
    "PseudoArclengthStats",
    "PseudoArclengthStepper",
    "corrector",
    "continue_pseudo_arclength",
]

logger = logging.getLogger("nnmstop.continuation.pseudo_arclength")


@dataclass(frozen=True)
class PseudoArclengthSettings:
    """Settings of the Newton pseudo-arclength continuation.

    Step lengths are arclengths in the Euclidean norm of the unknown vector, the same
    measure as the ANM path parameter.

    Parameters
    ----------
    tolerance : float
        Corrector tolerance on the relative residual (> 0); equal to the ANM series
        tolerance for the same accuracy (``docs/methods/continuation.md``).
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
            if not is_real_number(value) or not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        if not is_real_number(self.max_step) or np.isnan(self.max_step) or self.max_step < self.initial_step:
            raise ValueError(
                f"max_step must be >= initial_step = {self.initial_step!r} (inf for no cap), got {self.max_step!r}"
            )
        if self.min_step > self.initial_step:
            raise ValueError(f"min_step must be <= initial_step = {self.initial_step!r}, got {self.min_step!r}")
        for name in ("max_iterations", "max_steps"):
            value = getattr(self, name)
            if not is_integer(value) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if not is_integer(self.target_iterations) or not 1 <= self.target_iterations <= self.max_iterations:
            raise ValueError(
                f"target_iterations must be an integer in [1, max_iterations = {self.max_iterations!r}], "
                f"got {self.target_iterations!r}"
            )
        if not is_real_number(self.growth) or not (np.isfinite(self.growth) and self.growth > 1):
            raise ValueError(f"growth must be finite and > 1, got {self.growth!r}")
        if not is_real_number(self.max_angle) or not 0 < self.max_angle < np.pi:
            raise ValueError(f"max_angle must be in (0, pi) radians, got {self.max_angle!r}")

    def stepper(self) -> PseudoArclengthStepper:
        """The pseudo-arclength step with these settings, for :func:`nnmstop.continuation.driver.continue_branch`."""
        return PseudoArclengthStepper(self)


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
        rule of :func:`~nnmstop.continuation.core.newton_converged`: near a singular Jacobian
        the update can stall above round-off while the residual is already there).
    max_iterations : int
        Iterations allowed; the iteration also stops when the residual grows after the
        second update (Newton diverging).

    Returns
    -------
    U : ndarray or None
        The corrected point, None when the iteration failed (no convergence, growing
        residual, singular or non-finite matrix).
    iterations : int
        Iterations spent.
    factors : object or None
        Factors of the bordered Jacobian of the last iteration, i.e. at the
        last-but-one iterate.
    last_update : float
        Norm of the last Newton update: the distance between ``U`` and the point
        where ``factors`` was evaluated.
    reason : str
        Why it failed ("" on success).
    """
    factorizations = [0]

    def jacobian(V):
        factorizations[0] += 1
        return OrthogonalUpdate(factorize_bordered(system, V, tangent, stats))

    def converged(V, r, dU):
        return dU is not None and newton_converged(V, r, dU, tol)

    try:
        result = newton_solve(
            system.residual,
            jacobian,
            U_pred,
            tol=tol,
            max_iter=max_iterations,
            criterion=converged,
            norm=relative_of_residual,
            stop_on_growth=True,
        )
    except (np.linalg.LinAlgError, ValueError) as err:
        done = factorizations[0] - 1  # the updates made before the failing one
        stats.newton_iterations += done
        return None, done, None, math.inf, f"bordered Jacobian: {err}"
    stats.newton_iterations += result.iterations
    if not result.converged:
        return None, result.iterations, None, math.inf, result.reason
    return result.y, result.iterations, result.jacobian.factors, float(np.linalg.norm(result.step)), ""


def tangent_angle(a, b) -> float:
    """Angle between two unit vectors, accurate for small angles."""
    return float(2.0 * np.arctan2(np.linalg.norm(a - b), np.linalg.norm(a + b)))


class PseudoArclengthStepper(Stepper):
    """The predictor-corrector step with step-length control (``docs/methods/continuation.md``).

    Holds the step length from one step to the next (reset by :meth:`start`).
    """

    def __init__(self, settings: PseudoArclengthSettings = PseudoArclengthSettings()):
        self.settings = settings
        self.max_steps = settings.max_steps
        self.ds = settings.initial_step

    def new_stats(self) -> PseudoArclengthStats:
        return PseudoArclengthStats()

    def start(self, system, U) -> None:
        require_on_branch(system, U, self.settings.tolerance, " (correct it with newton_correct first)")
        self.ds = self.settings.initial_step

    def step(self, system, U, tangent, stats: PseudoArclengthStats) -> StepResult:
        settings, ds = self.settings, self.ds
        rhs_tangent = np.zeros(len(U))
        rhs_tangent[-1] = 1.0
        while True:
            U_new, iterations, factors, last_update, reason = corrector(
                system, U + ds * tangent, tangent, stats, settings.tolerance, settings.max_iterations
            )
            if U_new is not None and last_update > np.sqrt(settings.tolerance) * max(np.linalg.norm(U_new), 1.0):
                # The last factorization is too far from U_new for an accurate tangent
                # (typically after a single iteration): refactorize at U_new.
                try:
                    factors = factorize_bordered(system, U_new, tangent, stats)
                except (np.linalg.LinAlgError, ValueError) as err:
                    U_new, reason = None, f"bordered Jacobian at the new point: {err}"
            if U_new is not None:
                t_new = factors.solve(rhs_tangent)
                t_new /= np.linalg.norm(t_new)
                angle = tangent_angle(tangent, t_new)
                if angle <= settings.max_angle:
                    break
                reason = f"tangent turned by {angle:.3g} rad > max_angle {settings.max_angle:.3g}"
            stats.rejected_steps += 1
            logger.debug("step %d rejected at ds = %.3g: %s", stats.steps + 1, ds, reason)
            ds *= 0.5
            if ds < settings.min_step:
                raise ContinuationError(f"step length {ds:.3g} fell below min_step {settings.min_step:.3g} ({reason})")
        logger.debug(
            "step %d accepted: ds = %.3g, %d iterations, tangent angle %.3g", stats.steps + 1, ds, iterations, angle
        )
        stats.corrected_steps += 1
        factor = settings.target_iterations / max(iterations, 1)
        if angle > 0:
            factor = min(factor, settings.max_angle / (2.0 * angle))
        self.ds = min(ds * min(max(factor, 0.5), settings.growth), settings.max_step)
        return StepResult(
            U_end=U_new,
            t_end=t_new,
            length=ds,
            path=CorrectedPath(system, U, tangent, U_new),
            points=[(U_new, t_new)],
            # [J(U_new); tangent^T]: tangent has a positive component along t_new
            end_sign=factors.determinant_sign(),
        )

    def path_through(self, system, U_a, tangent_a, U_b, stats: ContinuationStats, strict: bool = True):
        """The corrected path from ``U_a`` through ``U_b`` (:class:`CorrectedPath`; it ends at ``U_b``)."""
        path = CorrectedPath(system, U_a, tangent_a, U_b)
        return path, path.length


def continue_pseudo_arclength(
    system,
    U_start,
    direction,
    stop: StopCriterion,
    settings: PseudoArclengthSettings = PseudoArclengthSettings(),
    label: str = "pseudo-arclength",
    progress_seconds: float = 2.0,
) -> Branch:
    """Follow the branch through ``U_start`` along ``direction`` by pseudo-arclength until ``stop`` says so.

    :func:`nnmstop.continuation.driver.continue_branch` with a :class:`PseudoArclengthStepper`:
    the start point, then one point per accepted step; ``stats`` is a
    :class:`PseudoArclengthStats`. ``U_start`` must be on the branch (relative residual at
    most ``settings.tolerance``, else ValueError).
    """
    return continue_branch(
        system, U_start, direction, PseudoArclengthStepper(settings), stop, label, progress_seconds, logger
    )
