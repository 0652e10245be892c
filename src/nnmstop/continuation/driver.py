"""One continuation loop for every method: :func:`continue_branch` drives a stepper.

A continuation follows the solution curve of ``S(U) = 0`` (``n`` equations, ``n + 1``
unknowns) from a start point along a direction until a stop criterion is met. The loop
is the same for every method: the first tangent, the steps, the points they store, the
stop criterion, the detection of simple branch points (sign changes of ``det [J; t^T]``),
progress messages and error messages naming the step and the energy. What differs is one
step, behind the small :class:`Stepper` interface: the ANM with Padé
(:class:`nnmstop.continuation.anm.ANMStepper`) and Newton pseudo-arclength
(:class:`nnmstop.continuation.pseudo_arclength.PseudoArclengthStepper`).

Each step returns a :class:`StepResult` with a *path* ``a -> U(a)`` over the step, on the
branch all along it, so that branch points (and folds) can be located afterwards whatever
the method (:func:`nnmstop.continuation.branch_points.locate_branch_point`).
Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from nnmstop.continuation.core import (
    Branch,
    ContinuationError,
    ContinuationStats,
    Progress,
    StopCriterion,
    unit_tangent,
)

__all__ = ["Path", "path_border", "StepResult", "Stepper", "as_stepper", "continue_branch"]

logger = logging.getLogger("nnmstop.continuation.driver")


class Path(Protocol):
    """A piece of the branch: ``path(a)`` is a point, ``path(a, derivative=True)`` is ``dU/da``.

    ``a`` runs from 0 (the start of the step) to the step's ``length``. A path may define
    ``border(a)``, the bordering row for the sign of ``det [J(U(a)); b^T]`` (see :func:`path_border`).
    """

    def __call__(self, a: float, derivative: bool = False) -> np.ndarray: ...


def path_border(path: Path, a: float) -> np.ndarray:
    """A bordering row ``b`` at ``U(a)`` with a positive component along the branch's tangent.

    The sign of ``det [J(U(a)); b^T]`` is then that of the branch (it changes at simple branch
    points, not at folds). The path's own ``border(a)`` when it has one (where its derivative
    is ill-conditioned near a branch point), else its unit derivative.
    """
    border = getattr(path, "border", None)
    if border is not None:
        return border(a)
    t = path(a, derivative=True)
    t /= np.linalg.norm(t)
    return t


@dataclass
class StepResult:
    """One continuation step.

    Attributes
    ----------
    U_end, t_end : ndarray
        End point and unit tangent there (oriented along the travel).
    length : float
        Path parameter of the end point (> 0).
    path : Path
        The branch over the step.
    points : iterable of (U, t)
        The points the step stores, in order along the curve, ending with ``(U_end, t_end)``;
        may be lazy (the driver stops iterating at the first point that meets the stop criterion).
    start_sign, end_sign : int or None
        Sign of ``det [J; t^T]`` at the start or at the end of the step, when the stepper
        computed it (any bordering row with a positive component along the tangent gives
        the same sign).
    """

    U_end: np.ndarray
    t_end: np.ndarray
    length: float
    path: Path
    points: Iterable
    start_sign: int | None = None
    end_sign: int | None = None


class Stepper:
    """Interface of a continuation method; subclasses implement :meth:`step` and :meth:`path_through`.

    ``max_steps`` bounds the number of steps of one continuation.
    """

    max_steps: int = 1000

    def new_stats(self) -> ContinuationStats:
        """Counters of one continuation (a subclass may add its own)."""
        return ContinuationStats()

    def start(self, system, U) -> None:
        """Check the start point and reset any state carried from step to step."""

    def step(self, system, U, tangent, stats: ContinuationStats) -> StepResult:
        """One step from ``U`` along the unit ``tangent``; raises ContinuationError or LinAlgError on failure."""
        raise NotImplementedError

    def path_through(
        self, system, U_a, tangent_a, U_b, stats: ContinuationStats, strict: bool = True
    ) -> tuple[Path, float]:
        """The path of this method's step from ``U_a`` (unit tangent ``tangent_a``) that ends at ``U_b``.

        Returns the path and the parameter of ``U_b`` on it; raises ValueError when ``U_b`` is
        not on it, or with ``strict=False`` returns the path up to the step's own end then.
        """
        raise NotImplementedError


def as_stepper(method) -> Stepper:
    """A :class:`Stepper`, or settings with a ``stepper()`` method (``ANMSettings``, ``PseudoArclengthSettings``)."""
    if isinstance(method, Stepper):
        return method
    make = getattr(method, "stepper", None)
    if make is None:
        raise ValueError(f"expected a continuation stepper or its settings, got {method!r}")
    return make()


def _check_start(system, U, direction):
    n = system.n_unknowns
    for name, vec in (("U_start", U), ("direction", direction)):
        if vec.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},), got {vec.shape}")
        if not np.all(np.isfinite(vec)):
            raise ValueError(f"{name} must be finite")
    if not np.linalg.norm(direction) > 0:
        raise ValueError("direction must be a non-zero vector")


def continue_branch(
    system,
    U_start,
    direction,
    stepper: Stepper,
    stop: StopCriterion,
    label: str = "continuation",
    progress_seconds: float = 2.0,
    log: logging.Logger = logger,
) -> Branch:
    """Follow the branch through ``U_start`` along ``direction`` with ``stepper`` until ``stop`` says so.

    Parameters
    ----------
    system : object
        Provides ``n_unknowns``, ``residual``, ``jacobian`` (or ``factorize_bordered``),
        ``diagnostics`` (a dict with ``energy``, ``frequency``, ``impacts_per_period``) and
        what the stepper needs.
    U_start : ndarray
        A point of the branch.
    direction : ndarray
        Rough direction of travel; the tangent is oriented along it.
    stepper : Stepper
        The method (a fresh state is set by ``stepper.start``).
    stop : callable
        ``stop(U, diagnostics) -> str``, checked at every stored point; a non-empty string
        ends the continuation and is recorded as the end reason.
    label : str
        Name in log and error messages.
    progress_seconds : float
        Interval between progress messages.

    Returns
    -------
    Branch
        The start point, then the points of every step; ``branch_points`` the indices of
        the points ending a step across which ``det [J; t^T]`` changed sign.

    Raises
    ------
    ContinuationError
        When a step fails or ``stepper.max_steps`` is exhausted; the message names the step
        and the energy.
    ValueError
        When ``U_start`` or ``direction`` has the wrong shape or is not finite, or the
        stepper refuses the start point.
    """
    U = np.array(U_start, dtype=float)
    direction = np.array(direction, dtype=float)
    _check_start(system, U, direction)
    stepper.start(system, U)
    stats = stepper.new_stats()
    started = time.perf_counter()
    branch = Branch(stats=stats)
    tangent, sign = unit_tangent(system, U, direction, stats)
    diag = system.diagnostics(U)
    branch.add(U, 0, diag)
    progress = Progress(label, progress_seconds, log)

    def failure(step, err):
        stats.wall_time = time.perf_counter() - started
        return ContinuationError(
            f"{label}: step {step} failed at energy {diag['energy']:.6g} (frequency {diag['frequency']:.6g} Hz): {err}"
        )

    def flag_sign(new_sign, step):
        """Record a sign change of det [J; t^T]: a branch point within the step ending at the last point."""
        nonlocal sign
        if new_sign is None:
            return
        if new_sign != sign:
            branch.branch_points.append(len(branch.points) - 1)
            log.info(
                "%s: simple branch point passed near energy %.6g, frequency %.6g Hz (step %d)",
                label,
                diag["energy"],
                diag["frequency"],
                step,
            )
        sign = new_sign

    for step in range(1, stepper.max_steps + 1):
        try:
            result = stepper.step(system, U, tangent, stats)
        except (ContinuationError, np.linalg.LinAlgError) as err:
            raise failure(step, err) from err
        if not (np.all(np.isfinite(result.U_end)) and result.length > 0):
            raise failure(step, "non-finite values")
        stats.steps = step
        flag_sign(result.start_sign, step - 1)  # the sign at U: a change lies within the previous step
        points = iter(result.points)
        while True:
            try:
                U_j, t_j = next(points)
            except StopIteration:
                break
            except (ContinuationError, np.linalg.LinAlgError) as err:
                raise failure(step, err) from err
            diag = system.diagnostics(U_j)
            branch.add(U_j, step, diag)
            reason = stop(U_j, diag)
            if reason:
                flag_sign(result.end_sign, step)
                branch.end_reason = reason
                branch.end_tangent = t_j
                stats.wall_time = time.perf_counter() - started
                progress(step, diag, result.length, force=True)
                return branch
        flag_sign(result.end_sign, step)
        U, tangent = result.U_end, result.t_end
        progress(step, diag, result.length)
    stats.wall_time = time.perf_counter() - started
    raise ContinuationError(
        f"{label}: no stop criterion met after max_steps = {stepper.max_steps} steps "
        f"(last energy {diag['energy']:.6g}, frequency {diag['frequency']:.6g} Hz)"
    )
