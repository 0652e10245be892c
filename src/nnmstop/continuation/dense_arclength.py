r"""Pseudo-arclength steps corrected to round-off, for small dense systems known exactly (the exact orbits).

The families of exact (closed-form) periodic orbits of :mod:`nnmstop.exact` solve a handful of
equations whose residual and Jacobian are exact to round-off: a step of their continuation is
worth a few Newton iterations more to land on the curve to round-off, and the curve's features
(grazing transitions, validity ends) are located on it to a relative ``1e-13`` of a step. The step:

* predictor ``U_k + h t_k``, corrector: Newton in the hyperplane ``<U - U_k, t_k> = h`` iterated
  until the update stops shrinking (:func:`~nnmstop.continuation.corrected_path.newton_in_hyperplane`),
  with a relative residual at most ``tolerance``;
* a corrected point farther than ``h / 2`` from the predictor is refused (the chord turns by at most
  ``atan(1/2)`` from ``t_k``: a larger turn is a jump to another curve, e.g. the spurious family of
  zero-duration phases that crosses an exact family at a grazing orbit), and so is one whose tangent
  turned by more than ``max_angle`` (by default twice the chord's bound, the turn of an arc whose
  chord meets it): with a stiff stop the quarter-period equations have many solution curves within
  a period of the contact mode of each other, and a long step lands on any of them;
* a refused or failed correction halves ``h``; a step whose energy or frequency change exceeds twice
  its limit (``max_log_energy_step``, ``max_frequency_step``) is shortened in proportion, and after
  an accepted step ``h`` grows by at most 2, towards the change limits, never beyond ``step``;
* the tangent at the new point from the bordered factors ``[J(U); t_k^T]``, whose determinant sign is
  the step's end sign (a simple branch point crossed when it changes);
* the step's path is the branch in the parallel hyperplanes ``<U - U_k, t_k> = a``
  (:class:`~nnmstop.continuation.corrected_path.CorrectedPath`), on which the driver locates events and
  branch points.

:class:`DenseArclengthStepper` is this step behind the driver's interface
(:class:`~nnmstop.continuation.driver.Stepper`). Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from nnmstop.continuation.core import (
    ContinuationError,
    ContinuationStats,
    is_integer,
    is_real_number,
    require_on_branch,
)
from nnmstop.continuation.corrected_path import CorrectedPath, newton_in_hyperplane
from nnmstop.continuation.driver import Stepper, StepResult
from nnmstop.continuation.linear import factorize_bordered
from nnmstop.continuation.pseudo_arclength import tangent_angle

__all__ = ["DenseArclengthSettings", "DenseArclengthStats", "DenseArclengthStepper"]

logger = logging.getLogger("nnmstop.continuation.dense_arclength")


@dataclass(frozen=True)
class DenseArclengthSettings:
    """Settings of the dense pseudo-arclength step.

    Parameters
    ----------
    step : float
        Largest step, an arclength in the unknowns (> 0).
    min_step : float
        The continuation fails when a step would have to be shorter (> 0, at most ``step``).
    tolerance : float
        Relative residual ``||S(U)|| / max(||U||, 1)`` a corrected point must reach before Newton
        is run on to round-off (> 0).
    max_iterations : int
        Newton iterations per correction (>= 1).
    max_log_energy_step, max_frequency_step : float
        Largest change of ``ln E`` and of the frequency per step (> 0; ``inf``: no limit), from the
        system's ``diagnostics``.
    max_angle : float
        Largest angle (radians, in ``(0, pi/2)``) between the tangents at the two ends of a step. The
        corrector already refuses a chord that turns by more than ``atan(1/2)`` from ``t_k``; on an arc of
        constant curvature the tangent turns by twice the chord's angle, so a larger turn of the tangent
        (the default ``2 atan(1/2)``) means the corrected point lies on another solution curve than the
        one the step left (the quarter-period equations of a stiff stop have many, close together).
    max_steps : int
        Largest number of steps of one continuation (>= 1).

    Examples
    --------
    >>> DenseArclengthSettings(step=0.05).step
    0.05
    >>> DenseArclengthSettings(step=0.0)
    Traceback (most recent call last):
    ...
    ValueError: step must be a finite number > 0, got 0.0
    """

    step: float = 0.02
    min_step: float = 1e-10
    tolerance: float = 1e-10
    max_iterations: int = 15
    max_log_energy_step: float = math.inf
    max_frequency_step: float = math.inf
    max_angle: float = 2.0 * math.atan(0.5)
    max_steps: int = 20000

    def __post_init__(self):
        for name in ("step", "min_step", "tolerance"):
            value = getattr(self, name)
            if not is_real_number(value) or not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if self.min_step > self.step:
            raise ValueError(f"min_step must be at most step = {self.step!r}, got {self.min_step!r}")
        for name in ("max_log_energy_step", "max_frequency_step"):
            value = getattr(self, name)
            if not is_real_number(value) or not value > 0:
                raise ValueError(f"{name} must be a number > 0 (inf for no limit), got {value!r}")
        if not is_real_number(self.max_angle) or not 0 < self.max_angle < math.pi / 2:
            raise ValueError(f"max_angle must be a number in (0, pi/2) radians, got {self.max_angle!r}")
        for name in ("max_iterations", "max_steps"):
            value = getattr(self, name)
            if not is_integer(value) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")

    def stepper(self, first_step: float | None = None) -> DenseArclengthStepper:
        """The step with these settings, for :func:`nnmstop.continuation.driver.continue_branch`."""
        return DenseArclengthStepper(self, first_step)


@dataclass
class DenseArclengthStats(ContinuationStats):
    """:class:`~nnmstop.continuation.core.ContinuationStats` plus the refused (retried) steps."""

    rejected_steps: int = 0


class DenseArclengthStepper(Stepper):
    """The dense pseudo-arclength step (module docstring); holds the step length from step to step.

    ``first_step`` (at most ``settings.step``) is the length of the first step after :meth:`start`,
    e.g. a small one at the start of a family that enters a grazing transition.
    """

    def __init__(self, settings: DenseArclengthSettings = DenseArclengthSettings(), first_step: float | None = None):
        if first_step is not None and not (math.isfinite(first_step) and first_step > 0):
            raise ValueError(f"first_step must be a finite number > 0, got {first_step!r}")
        self.settings = settings
        self.max_steps = settings.max_steps
        self.first_step = first_step
        self.h = settings.step

    def new_stats(self) -> DenseArclengthStats:
        return DenseArclengthStats()

    def start(self, system, U) -> None:
        require_on_branch(system, U, self.settings.tolerance)
        self.h = min(self.settings.step, self.first_step or self.settings.step)

    def shorten(self, length: float) -> None:
        """The next step is at most ``length`` long (the driver retries a step whose path lost the curve)."""
        self.h = min(self.h, float(length))

    def step(self, system, U, tangent, stats: DenseArclengthStats) -> StepResult:
        settings, h = self.settings, self.h
        before = system.diagnostics(U) if self._limited else None
        while True:
            if h < settings.min_step:
                raise ContinuationError(
                    f"no correction converged for steps down to {h:.3e} < min_step {settings.min_step:.1e}"
                )
            U_new = self.correct(system, U, tangent, h, stats)
            ratio = None if U_new is None else self._change_ratio(before, U_new, system)
            if ratio is not None and ratio <= 2.0:
                factors, t_new = self._tangent(system, U_new, tangent, stats)
                if tangent_angle(tangent, t_new) <= settings.max_angle:
                    break
                ratio = None
            stats.rejected_steps += 1
            h *= 0.5 if ratio is None else 0.9 / ratio
        self.h = min(settings.step, h * min(2.0, 0.9 / max(ratio, 1e-12)))
        stats.corrected_steps += 1
        return StepResult(
            U_end=U_new,
            t_end=t_new,
            length=h,
            path=CorrectedPath(system, U, tangent, U_new, tol=settings.tolerance),
            points=[(U_new, t_new)],
            end_sign=factors.determinant_sign(),
        )

    def correct(self, system, U, tangent, h: float, stats: ContinuationStats | None = None):
        """The corrected point of a step of length ``h`` along the unit ``tangent`` from ``U``, or None when
        Newton fails or lands farther than ``h / 2`` from the predictor."""
        stats = ContinuationStats() if stats is None else stats
        predictor = U + h * tangent
        settings = self.settings
        try:
            result = newton_in_hyperplane(
                system, U, tangent, h, predictor, settings.tolerance, settings.max_iterations, stats
            )
        except (np.linalg.LinAlgError, ValueError):
            return None
        stats.newton_iterations += result.iterations
        if not result.converged or np.linalg.norm(result.y - predictor) > 0.5 * h:
            return None
        return result.y

    @staticmethod
    def _tangent(system, U, border, stats):
        """The factors of ``[J(U); border^T]`` and the unit tangent at ``U`` oriented along ``border``."""
        factors = factorize_bordered(system, U, border, stats, singular_tol=None)
        rhs = np.zeros(len(U))
        rhs[-1] = 1.0
        t = factors.solve(rhs)
        return factors, t / np.linalg.norm(t)

    @property
    def _limited(self) -> bool:
        return math.isfinite(self.settings.max_log_energy_step) or math.isfinite(self.settings.max_frequency_step)

    def _change_ratio(self, before: dict | None, U_new, system) -> float:
        """The larger of the energy and frequency changes over their limits (0 without limits)."""
        settings = self.settings
        if before is None:
            return 0.0
        after = system.diagnostics(U_new)
        ratio = 0.0
        if math.isfinite(settings.max_log_energy_step):
            ratio = abs(math.log(after["energy"] / before["energy"])) / settings.max_log_energy_step
        if math.isfinite(settings.max_frequency_step):
            ratio = max(ratio, abs(after["frequency"] - before["frequency"]) / settings.max_frequency_step)
        return ratio

    def path_through(self, system, U_a, tangent_a, U_b, stats: ContinuationStats, strict: bool = True):
        """The branch in the hyperplanes orthogonal to ``tangent_a`` from ``U_a`` to ``U_b``
        (:class:`~nnmstop.continuation.corrected_path.CorrectedPath`)."""
        path = CorrectedPath(system, U_a, tangent_a, U_b, tol=self.settings.tolerance)
        return path, path.length
