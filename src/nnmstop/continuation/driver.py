"""One continuation loop for every method: :func:`continue_branch` drives a stepper.

A continuation follows the solution curve of ``S(U) = 0`` (``n`` equations, ``n + 1``
unknowns) from a start point along a direction until a stop criterion is met. The loop
is the same for every method: the first tangent, the steps, the points they store, the
stop criterion, the detection of simple branch points (sign changes of ``det [J; t^T]``),
events (conditions that end the continuation where they fail, located on the step's path:
:mod:`nnmstop.continuation.events`), progress messages and error messages naming the step and the
energy. What differs is one step, behind the small :class:`Stepper` interface: the ANM with Padé
(:class:`nnmstop.continuation.anm.ANMStepper`), Newton pseudo-arclength
(:class:`nnmstop.continuation.pseudo_arclength.PseudoArclengthStepper`) and its dense variant
corrected to round-off for the exact orbits
(:class:`nnmstop.continuation.dense_arclength.DenseArclengthStepper`).

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
from nnmstop.continuation.events import Events, locate_event

__all__ = ["Path", "path_border", "StepResult", "Stepper", "as_stepper", "continue_branch", "produced_points"]

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
    points : iterable of (U, t) or (U, t, a)
        The points the step stores, in order along the curve, ending with ``(U_end, t_end)``,
        with their path parameter ``a`` (the end's is ``length``); may be lazy. The driver produces
        them all before storing any (a system with ``diagnostics_many(U_list)`` has their diagnostics
        computed together), then stores them up to the first that meets the stop criterion or fails an
        event; an error raised while producing them fails the step only if the branch reaches it.
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

    def shorten(self, length: float) -> None:
        """Make the next step at most ``length`` long; the driver asks for it when the path of a step
        lost the branch before an event (:attr:`nnmstop.continuation.events.LocatedEvent.trusted`).
        A stepper that cannot shorten its steps raises ContinuationError."""
        raise ContinuationError(f"{type(self).__name__} cannot shorten its steps")

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
    events: Events | None = None,
    event_tol: float = 1e-13,
) -> Branch:
    """Follow the branch through ``U_start`` along ``direction`` with ``stepper`` until ``stop`` says so.

    Parameters
    ----------
    system : object
        Provides ``n_unknowns``, ``residual``, ``jacobian`` (or ``factorize_bordered``),
        ``diagnostics`` (a dict with ``energy``, ``frequency``, ``impacts_per_period``; optionally
        ``diagnostics_many``, the same for a list of points at once) and what the stepper needs.
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
    events : Events, optional
        Conditions checked at every point (:mod:`nnmstop.continuation.events`); at the first point
        where one fails, the change is located on the step's path (to ``event_tol`` of the step),
        the last point where all hold ends the branch (``end_event``) and the condition's
        description is the end reason. Each point's check is kept in ``checks``.
    event_tol : float
        Width of the located event's bracket relative to the step's path length.

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
    run = _Run(system, stepper, stop, label, Progress(label, progress_seconds, log), log, events, event_tol)
    tangent, run.sign = unit_tangent(system, U, direction, run.stats)
    run.store(U, 0, 0.0)
    return run.steps(U, tangent)


def produced_points(points) -> tuple[list, Exception | None]:
    """The points a step produces, in order, and the error that stopped their production (None).

    A step's points are produced before any is stored, so that a system with ``diagnostics_many`` computes
    their diagnostics together; an error is raised only if the branch reaches the point that failed (as when
    they were produced one by one), not when a point before it ends the branch.
    """
    produced = []
    try:
        for item in points:
            produced.append(item)
    except (ContinuationError, np.linalg.LinAlgError) as err:
        return produced, err
    return produced, None


class _Run:
    """The state of one :func:`continue_branch`: the branch so far, the sign of ``det [J; t^T]``, the clock."""

    def __init__(self, system, stepper, stop, label, progress, log, events, event_tol):
        self.system, self.stepper, self.stop, self.label = system, stepper, stop, label
        self.progress, self.log, self.events, self.event_tol = progress, log, events, event_tol
        self.stats = stepper.new_stats()
        self.branch = Branch(stats=self.stats)
        self.started = time.perf_counter()
        self.sign = None
        self.offset = 0.0  # arclength at the start of the current step
        self.diag = None

    def steps(self, U, tangent) -> Branch:
        """Step from ``U`` along ``tangent`` until the branch ends; ContinuationError when ``max_steps`` run out."""
        stepper, stats = self.stepper, self.stats
        for step in range(1, stepper.max_steps + 1):
            try:
                result = stepper.step(self.system, U, tangent, stats)
            except (ContinuationError, np.linalg.LinAlgError) as err:
                raise self.failure(step, err) from err
            if not (np.all(np.isfinite(result.U_end)) and result.length > 0):
                raise self.failure(step, "non-finite values")
            stats.steps = step
            self.flag_sign(result.start_sign, step - 1)  # the sign at U: a change lies within the previous step
            outcome = self.take(result, step)
            if outcome == "ended":
                return self.finish(step, result.length)
            if outcome == "retry":
                continue
            self.flag_sign(result.end_sign, step)
            self.offset += result.length
            U, tangent = result.U_end, result.t_end
            self.progress(step, self.diag, result.length)
        self.finish(stepper.max_steps, 0.0, log_progress=False)
        raise ContinuationError(
            f"{self.label}: no stop criterion met after max_steps = {stepper.max_steps} steps "
            f"(last energy {self.diag['energy']:.6g}, frequency {self.diag['frequency']:.6g} Hz)"
        )

    def store(self, U, step: int, a: float, check=None, diagnostics=None):
        self.diag = self.system.diagnostics(U) if diagnostics is None else diagnostics
        if self.events is not None and check is None:
            check = self.events(U)
        self.branch.add(U, step, self.diag, check=check, arclength=self.offset + a)
        return check

    def failure(self, step, err):
        self.stats.wall_time = time.perf_counter() - self.started
        return ContinuationError(
            f"{self.label}: step {step} failed at energy {self.diag['energy']:.6g} "
            f"(frequency {self.diag['frequency']:.6g} Hz): {err}"
        )

    def flag_sign(self, new_sign, step):
        """Record a sign change of det [J; t^T]: a branch point within the step ending at the last point."""
        if new_sign is None:
            return
        if new_sign != self.sign:
            self.branch.branch_points.append(len(self.branch.points) - 1)
            self.log.info(
                "%s: simple branch point passed near energy %.6g, frequency %.6g Hz (step %d)",
                self.label,
                self.diag["energy"],
                self.diag["frequency"],
                step,
            )
        self.sign = new_sign

    def take(self, result: StepResult, step: int) -> str:
        """Store the step's points until one ends the branch: "ended", "retry" (the step was shortened) or ""."""
        points, failure = produced_points(result.points)
        many = getattr(self.system, "diagnostics_many", None)
        diagnostics = many([item[0] for item in points]) if many is not None and points else [None] * len(points)
        stored_a, start_check = 0.0, self.branch.checks[-1]
        for item, diagnostics_j in zip(points, diagnostics):
            U_j, t_j = item[0], item[1]
            a_j = item[2] if len(item) > 2 else result.length
            check = None if self.events is None else self.events(U_j)
            if check is not None and not check.valid:
                return self._event(result, step, stored_a, self.branch.points[-1], start_check, a_j, check)
            self.store(U_j, step, a_j, check, diagnostics_j)
            stored_a, start_check = a_j, check
            reason = self.stop(U_j, self.diag)
            if reason:
                self.flag_sign(result.end_sign, step)
                self.branch.end_reason, self.branch.end_tangent = reason, t_j
                return "ended"
        if failure is not None:
            raise self.failure(step, failure) from failure
        return ""

    def _event(self, result, step, a_start, U_start, check_start, a_end, check_end) -> str:
        """Locate the event between the last stored point of the step and the first that fails one."""

        def shifted(a, derivative=False):  # the path from the last stored point of the step
            return result.path(a_start + a, derivative)

        try:
            event = locate_event(shifted, self.events, U_start, check_start, a_end - a_start, check_end, self.event_tol)
        except ValueError as err:
            raise self.failure(step, f"locating the event: {err}") from err
        if not event.trusted:
            if a_start > 0:
                raise self.failure(step, "the step's path lost the branch after the step stored points")
            self.log.info(
                "%s step %d: the path of the step lost the branch before the event (slope %.3g); shorter step",
                self.label,
                step,
                event.slope,
            )
            try:
                self.stepper.shorten(0.5 * event.a if event.a > 0 else 0.25 * result.length)
            except ContinuationError as err:
                raise self.failure(step, f"the step's path lost the branch before an event: {err}") from err
            return "retry"
        if event.a > 0:
            self.store(event.U, step, a_start + event.a, event.inside)
        self.branch.end_event = event
        self.branch.end_reason = self.events.describe(event.key)
        return "ended"

    def finish(self, step, length, log_progress=True):
        self.stats.wall_time = time.perf_counter() - self.started
        if log_progress:
            self.progress(step, self.diag, length, force=True)
        return self.branch
