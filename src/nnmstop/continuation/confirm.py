"""Confirm where a continuation ends: a restart from before the end with a smaller step must end at the same place.

A continuation can end for a reason that sounds physical and is not: a step too long for the
curve's turns lands on a neighbouring solution curve whose orbits are not admissible, and the
"end of the family" is then located where the step's path left the curve (the exact two-impact
family at ``alpha = 1e6`` with step 0.02 "ended" after two orbits that way, while it goes on to
``E = 21.3``). :func:`confirm_end` restarts the continuation a few points before its end with a
step ``refine`` times smaller and requires the same end:

* an end on a located event (a validity margin reaching zero): the restart must end on an event
  too, at a point no farther from the first than the two runs' location tolerances allow
  (:func:`event_tolerance`: the event's bracket on the step's path, times the largest slope of a
  trusted path, plus the square root of the round-off, to which a margin that reaches zero
  quadratically is located);
* an end on a stop criterion (an energy or a number of points reached, the curve still valid): the
  restart must not end on an event before the first run's end.

Otherwise :class:`EndNotConfirmed` (a ContinuationError) is raised with both ends in its message,
so that the job fails saying so. The caller provides the restart (it knows how to start its
continuation from a given point with a given step). Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from nnmstop.continuation.core import ContinuationError
from nnmstop.continuation.events import MAX_EVENT_SLOPE

__all__ = ["ContinuationEnd", "EndNotConfirmed", "event_tolerance", "confirm_end"]

logger = logging.getLogger("nnmstop.continuation.confirm")


class EndNotConfirmed(ContinuationError):
    """A restart with a smaller step did not end where the continuation ended."""


@dataclass(frozen=True)
class ContinuationEnd:
    """The end of a continuation as :func:`confirm_end` compares it.

    Attributes
    ----------
    points : ndarray, shape (n, n_unknowns)
        The points in continuation order (the last one is the end).
    arclength : ndarray, shape (n,)
        Pseudo-arclength of each point from the first.
    event : str
        The event that ended it ("" when a stop criterion did).
    reason : str
        Why it ended, in words.
    energy : float
        Energy of the end point (for messages).
    tolerance : float
        How far from the true end the end point may lie, as a distance in the unknowns
        (:func:`event_tolerance` for an event end).
    """

    points: np.ndarray
    arclength: np.ndarray
    event: str
    reason: str
    energy: float
    tolerance: float

    @classmethod
    def of_branch(cls, branch, step: float, event_tol: float = 1e-13) -> ContinuationEnd:
        """The end of a driver :class:`~nnmstop.continuation.core.Branch` whose largest step is ``step``.

        An event end is known to :func:`event_tolerance`; an end on a stop criterion (the first stored
        point that meets it, not located) only to the last step's length. For a staged continuation
        (an HBM stage), ``restart(U, direction, step)`` reruns the stage from ``U`` with its step settings
        scaled by ``step / (the stage's step)`` and returns ``ContinuationEnd.of_branch`` of the result.
        """
        points = np.asarray(branch.points, dtype=float)
        arclength = np.array([np.nan if a is None else a for a in branch.arclength], dtype=float)
        event = branch.end_event
        if event is not None:
            tolerance = event_tolerance(step, points[-1], event_tol)
        else:
            tolerance = float(np.linalg.norm(points[-1] - points[-2])) if len(points) > 1 else 0.0
        diagnostics = branch.diagnostics[-1] or {}
        return cls(
            points=points,
            arclength=arclength,
            event="" if event is None else str(event.key),
            reason=branch.end_reason,
            energy=float(diagnostics.get("energy", np.nan)),
            tolerance=tolerance,
        )


def event_tolerance(step: float, U, event_tol: float = 1e-13) -> float:
    """Distance within which a located event end is known.

    Its bracket on the last step's path (``event_tol`` of a step at most ``step``) times the largest slope
    of a trusted path, plus ``sqrt(eps) max(|U|, 1)``: a margin is computed to round-off, and one that
    reaches zero quadratically along the curve (a tangency; or the neighbours of a phase shrinking to
    zero, which it drags to zero with it) is located only to the square root of that.
    """
    return MAX_EVENT_SLOPE * event_tol * step + np.sqrt(np.finfo(float).eps) * max(float(np.linalg.norm(U)), 1.0)


def confirm_end(
    end: ContinuationEnd,
    restart: Callable[[np.ndarray, np.ndarray, float], ContinuationEnd],
    step: float,
    *,
    refine: float = 10.0,
    back: int = 2,
    label: str = "continuation",
) -> str:
    """Restart ``back`` points before the end with the step ``step / refine``; the restart must end at the same place.

    Parameters
    ----------
    end : ContinuationEnd
    restart : callable
        ``restart(U, direction, step) -> ContinuationEnd``: the same continuation from the point ``U`` along
        ``direction`` with the (largest) step ``step``, run at least past ``end``.
    step : float
        The (largest) step of the first run.
    refine : float
        The restart's step is ``step / refine`` (> 1).
    back : int
        The restart starts this many points before the end (fewer when the run has fewer).
    label : str
        Names the continuation in the messages.

    Returns
    -------
    str
        How the end was confirmed.

    Raises
    ------
    EndNotConfirmed
        If the restart ends elsewhere or on another event.
    """
    if not refine > 1:
        raise ValueError(f"refine must be > 1, got {refine!r}")
    points = np.asarray(end.points, dtype=float)
    if len(points) < 2:
        return "nothing to confirm: the continuation ends at its first point (no point before it to restart from)"
    k = max(0, len(points) - 1 - int(back))
    direction = points[min(k + 1, len(points) - 1)] - points[k]
    fine_step = step / refine
    again = restart(points[k], direction, fine_step)
    here = f"{label}: with step {step:g} it ends at energy {end.energy:.9g} ({end.reason})"
    there = f"restarted before its end with step {fine_step:g} it ends at energy {again.energy:.9g} ({again.reason})"
    if end.event:
        gap = float(np.linalg.norm(again.points[-1] - points[-1]))
        limit = end.tolerance + again.tolerance
        # the position decides, not which margin is named first: where a phase shrinks to zero it drags
        # the margins of its neighbours to zero with it, and either run may name another of them
        if again.event and gap <= limit:
            return f"end confirmed: {there} ({gap:.2g} from the first end, within {limit:.2g})"
        raise EndNotConfirmed(
            f"end NOT confirmed: {here}; {there}, {gap:.3g} from the first end (allowed {limit:.3g}): "
            "the end is not a property of the curve"
        )
    reached = end.arclength[-1] - end.arclength[k]
    if again.event and again.arclength[-1] - again.arclength[0] < reached:
        raise EndNotConfirmed(f"end NOT confirmed: {here}; {there} before the first run's end")
    return f"end confirmed: {there} (no event before the first run's end)"
