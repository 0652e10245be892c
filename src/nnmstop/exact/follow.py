"""How every family of exact orbits is followed: the continuation driver, the dense step, validity events.

A family of exact orbits (the one-stop family of any structure, :mod:`nnmstop.exact.ndof`; a phase
sequence of the 2-DOF oscillator, :mod:`nnmstop.exact.family`) is the solution curve of its
quarter-period equations, valid while the assumptions of its construction hold. It is followed by
:func:`nnmstop.continuation.driver.continue_branch` with the dense pseudo-arclength step
(:class:`~nnmstop.continuation.dense_arclength.DenseArclengthStepper`: corrected to round-off) and the
validity margins as events (:class:`ValidityEvents`): at the first orbit where a margin fails, the
driver locates the change on the step's path and the family ends at its last valid orbit.
:func:`continue_exact_family` is that call with the stop criteria of a family (a number of orbits, an
energy); :func:`branch_point_flags` reads the driver's flagged steps as a flag per orbit;
:func:`confirm_family_end` confirms where a family ends by a restart with a smaller step
(:func:`nnmstop.continuation.confirm.confirm_end`).
Method notes: ``docs/methods/exact.md``, ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from nnmstop.continuation.confirm import ContinuationEnd, confirm_end, event_tolerance
from nnmstop.continuation.core import Branch
from nnmstop.continuation.dense_arclength import DenseArclengthSettings
from nnmstop.continuation.driver import continue_branch

__all__ = [
    "ValidityEvents",
    "continue_exact_family",
    "branch_point_flags",
    "residual_norms",
    "RESTART_POINTS",
    "family_end",
    "confirm_family_end",
]

logger = logging.getLogger("nnmstop.exact.follow")

#: Orbits of a restart that confirms an end: it starts two orbits before the end with a ten times smaller
#: step, so some 20 steps cover the last two of the first run; the rest leaves room for shortened steps.
RESTART_POINTS = 170


class ValidityEvents:
    """The validity margins of an exact orbit as continuation events.

    Parameters
    ----------
    assess : callable
        ``assess(y)`` -> the orbit's margins (a :class:`~nnmstop.exact.grazing.MarginChecks`).
    describe : callable
        ``describe(key)`` -> what it means that the margin ``key`` reaches zero.
    """

    def __init__(self, assess: Callable, describe: Callable):
        self.assess, self._describe = assess, describe

    def __call__(self, y):
        return self.assess(y)

    def describe(self, key) -> str:
        return self._describe(key)


def continue_exact_family(
    problem,
    y0,
    direction,
    events: ValidityEvents,
    settings: DenseArclengthSettings,
    *,
    max_points: int,
    energy_max: float = np.inf,
    first_step: float | None = None,
    label: str = "exact family",
) -> Branch:
    """Follow the family of ``problem`` from the orbit ``y0`` along ``direction`` until an event or a stop.

    ``problem`` has ``n_unknowns``, ``residual``, ``jacobian`` and ``diagnostics`` (energy, frequency,
    impacts per period). The branch ends at its first located event (``end_event``: the last valid
    orbit, the violated margin), at ``max_points`` orbits or at the first orbit above ``energy_max``
    (both leave the family valid there); a step that fails raises ContinuationError.
    """
    if int(max_points) != max_points or max_points < 2:
        raise ValueError(f"max_points must be an integer >= 2, got {max_points!r}")
    count = [1]

    def stop(y, diagnostics) -> str:
        count[0] += 1
        if count[0] >= max_points:
            return f"max_points = {max_points} reached (the family is still valid there)"
        if diagnostics["energy"] > energy_max:
            return f"energy above energy_max = {energy_max:g} (the family is still valid there)"
        return ""

    return continue_branch(
        problem,
        y0,
        direction,
        settings.stepper(first_step),
        stop,
        label=label,
        log=logger,
        events=events,
        progress_seconds=10.0,
    )


def branch_point_flags(branch: Branch) -> np.ndarray:
    """True at each orbit that ends a step across which ``det [J; t^T]`` changed sign (a branch point crossed)."""
    flags = np.zeros(len(branch.points), dtype=bool)
    flags[np.asarray(branch.branch_points, dtype=int)] = True
    return flags


def residual_norms(problem, unknowns) -> np.ndarray:
    """Euclidean norm of the quarter-period equations at every orbit."""
    return np.array([np.linalg.norm(problem.residual(y)) for y in unknowns])


def family_end(family) -> ContinuationEnd:
    """The end of a followed family (``unknowns``, ``arclength``, ``energy``, ``end_margin``, ``end_reason``,
    ``step``), at its last valid orbit: a grazing orbit appended after the located boundary is left out."""
    n = len(family.unknowns)
    grazing = getattr(family, "grazing", None)
    if grazing is not None and n > 1 and grazing[-1]:
        n -= 1
    points = np.asarray(family.unknowns[:n], dtype=float)
    return ContinuationEnd(
        points=points,
        arclength=np.asarray(family.arclength[:n], dtype=float),
        event=str(family.end_margin) if family.end_margin else "",
        reason=family.end_reason,
        energy=float(family.energy[n - 1]),
        tolerance=event_tolerance(family.step, points[-1]),
    )


def confirm_family_end(family, restart: Callable, label: str, refine: float = 10.0) -> str:
    """:func:`~nnmstop.continuation.confirm.confirm_end` for a family: ``restart(U, direction, step)`` follows
    the same family from ``U`` with the largest step ``step`` and returns it; raises
    :class:`~nnmstop.continuation.confirm.EndNotConfirmed` when it does not end where ``family`` ends."""
    message = confirm_end(
        family_end(family), lambda U, d, h: family_end(restart(U, d, h)), family.step, refine=refine, label=label
    )
    logger.info("%s: %s", label, message)
    return message
