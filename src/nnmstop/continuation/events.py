"""Events of a continuation: conditions that end it, located on the path of the step where they fail.

An *event set* is what a continuation checks at every point besides its equations: the validity
margins of the exact orbits (a phase keeps its sign of duration, the stop coordinate stays inside
the gap in free flight, ...), each a number that is > 0 while its condition holds. It is a callable
``events(U) -> check`` whose result has ``valid`` (every condition holds) and ``violated`` (the
keys of the failing conditions, most violated first), with ``events.describe(key)`` the words for
a condition that fails (:class:`Events`). The driver (:func:`nnmstop.continuation.driver.continue_branch`)
calls :func:`locate_event` at the first point of a step where a condition fails: the change is
bisected on the step's own path ``a -> U(a)`` (the same path on which branch points are located), so
the continuation ends at the last point where every condition holds, to a fraction of the step.

A located change is only an event where the path is the branch: a path that has lost the branch
(past a turn of the branch with respect to the step's direction, Newton in a hyperplane lands on
another solution or fails) changes from valid to invalid without any condition reaching zero on
the branch. :attr:`LocatedEvent.trusted` tells the two apart by the slope of the path at the
located point and by the distance to the point found just beyond; the driver shortens the step and
tries again where it is not.
Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from nnmstop.continuation.core import ContinuationError
from nnmstop.continuation.newton import bisect_sign_change

__all__ = ["Events", "LocatedEvent", "locate_event", "MAX_EVENT_SLOPE"]

#: Largest ``|dU/da|`` of the step's path at a trusted event: the branch there turns by at most 60
#: degrees from the step's direction ``t_k`` (``|dU/da| = 1 / cos`` of that angle for a path with
#: ``<dU/da, t_k> = 1``). Where the branch turns back with respect to ``t_k`` the slope grows without bound.
MAX_EVENT_SLOPE = 2.0


class Events(Protocol):
    """The conditions checked at every point of a continuation (see the module docstring)."""

    def __call__(self, U) -> Any: ...

    def describe(self, key) -> str: ...


@dataclass
class LocatedEvent:
    """Where a condition first fails along a step's path.

    Attributes
    ----------
    key : object
        The condition that fails (the first of ``violated`` at the nearest point beyond).
    a : float
        Path parameter of the last point where every condition holds.
    U : ndarray
        That point.
    inside : object
        Its check (``events(U)``).
    outside : object
        The check of the nearest point beyond, where ``key`` fails.
    slope : float
        ``|dU/da|`` of the path at ``a``.
    width : float
        Width of the final bracket in ``a``.
    jump : float
        Distance from ``U`` to the nearest point found beyond (``inf`` where the path failed there).
    """

    key: Any
    a: float
    U: np.ndarray
    inside: Any
    outside: Any
    slope: float
    width: float = 0.0
    jump: float = 0.0

    @property
    def trusted(self) -> bool:
        """The path is the branch at the located point: its slope is at most :data:`MAX_EVENT_SLOPE`, and the
        point found beyond is as close as that slope allows over the bracket (plus ``sqrt(eps) max(|U|, 1)``
        for the round-off of the two corrected points); a path that switched to another curve jumps."""
        allowed = MAX_EVENT_SLOPE * self.width + np.sqrt(np.finfo(float).eps) * max(float(np.linalg.norm(self.U)), 1.0)
        return bool(self.slope <= MAX_EVENT_SLOPE and self.jump <= allowed)


def locate_event(path, events, U_start, check_start, a_end: float, check_end, tol: float) -> LocatedEvent:
    """Bisect the change from valid to invalid on ``path`` over ``[0, a_end]``.

    Parameters
    ----------
    path : Path
        The step's path (``path(a)``; a ContinuationError where it cannot be computed counts as
        beyond the change: the path does not go on there).
    events : Events
    U_start, check_start : ndarray, object
        ``path(0)`` and its check; the bisection counts it as inside even where a margin is zero there
        (a family that starts on the boundary of its validity, at a grazing orbit).
    a_end, check_end : float, object
        Parameter of the first point found invalid, and its check.
    tol : float
        Width of the final bracket, relative to ``a_end``.
    """
    outside = [check_end]

    def evaluate(a):
        try:
            U = path(a)
        except (ContinuationError, np.linalg.LinAlgError):
            return None
        check = events(U)
        if not check.valid:
            outside[0] = check
        return U, check

    def side(value):
        return value is not None and (value[1] is None or bool(value[1].valid))

    bracket = bisect_sign_change(
        evaluate, 0.0, a_end, tol=tol * a_end, side=side, f_a=(U_start, None), f_b=(None, check_end)
    )
    U, inside = bracket.value_lo
    inside = check_start if inside is None else inside
    beyond = bracket.value_hi[0] if bracket.value_hi is not None else None
    jump = np.inf if beyond is None else float(np.linalg.norm(beyond - U))
    return LocatedEvent(
        outside[0].violated[0],
        bracket.lo,
        U,
        inside,
        outside[0],
        _slope(path, bracket.lo),
        width=bracket.hi - bracket.lo,
        jump=jump,
    )


def _slope(path, a: float) -> float:
    try:
        return float(np.linalg.norm(path(a, derivative=True)))
    except (ContinuationError, np.linalg.LinAlgError):
        return np.inf
