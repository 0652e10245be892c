r"""Curves of codimension-one points followed in two parameters, on the project's continuation driver.

A curve starts from a point located on a one-parameter response (a fold, a flip, a Neimark-Sacker point, a
grazing orbit), corrected onto the augmented system :class:`~nnmstop.bifurcation_atlas.augmented.CurveSystem` with the
second parameter held (:func:`correct_on_curve`), and is followed both ways by
:func:`nnmstop.continuation.driver.continue_branch` with the dense pseudo-arclength step (the step of the
exact families: corrected to round-off) and validity events (:class:`CurveEvents`): the formulation's own
assumptions (the exact one-contact response: the contact lasts, free flight remains, no second contact),
the parameter window, and for a Neimark-Sacker curve ``|cos theta| < 1``. The curve ends at the located
event, which is a codimension-two point where the event is one (:mod:`nnmstop.bifurcation_atlas.codim2`). The borders
of the test functions are refreshed every ``segment_points`` points and where the bordered matrix loses
its conditioning: the curve is continued in segments, each starting where the last one stopped.
Method note: ``docs/methods/atlas.md``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from nnmstop.bifurcation_atlas.augmented import CurveSystem, NeimarkSackerTest, StateTest
from nnmstop.bifurcation_atlas.equations import Margins
from nnmstop.continuation.core import ContinuationError
from nnmstop.continuation.dense_arclength import DenseArclengthSettings
from nnmstop.continuation.driver import continue_branch
from nnmstop.continuation.newton import newton_solve, round_off_criterion

__all__ = ["CurveSettings", "CurveEvents", "Curve", "correct_on_curve", "follow_curve", "END_REASONS"]

logger = logging.getLogger("nnmstop.bifurcation_atlas.curves")

#: What each validity margin means when a curve reaches it.
END_REASONS = {
    "contact_duration": "the contact shrinks to zero duration: the curve meets the grazing curve",
    "free_duration": "the contact lasts half a period: no free flight left",
    "leaves_stop": "the stop DOF leaves the stop during the contact: a second contact per period",
    "early_impact": "the stop DOF reaches a stop during the free flight: a second contact per period",
    "other_stops": "a passive stop is reached: a second stop is struck",
    "truncation": "the harmonics no longer resolve the orbit (truncation above max_truncation)",
    "unit_pair": "the pair of multipliers becomes real (cos theta = +-1): a 1:1 or 1:2 resonance",
    "touch_inside": "the second contact's touching phase reaches the end of its phase",
    "closed": "the curve is closed: it comes back to its start",
    "max_points": "the most points of a curve are reached (the curve goes on)",
    "frequency_low": "the frequency leaves the window (low end)",
    "frequency_high": "the frequency leaves the window (high end)",
    "second_low": "the second parameter leaves the window (low end)",
    "second_high": "the second parameter leaves the window (high end)",
}


@dataclass(frozen=True)
class CurveSettings:
    """Continuation of a curve: the dense step (``step``, ``min_step``, ``tolerance``, and the largest move in the
    plane per step: ``max_frequency_step`` Hz, ``max_log_second_step``), the points per segment between border
    refreshes, how far the borders may drift from the null vectors before a refresh
    (:meth:`~nnmstop.bifurcation_atlas.augmented.TestFunction.conditioning`), and the most points of a curve
    (both directions together)."""

    step: float = 0.02
    min_step: float = 1e-9
    tolerance: float = 1e-11
    segment_points: int = 25
    max_condition: float = 1e3
    max_points: int = 2000
    max_frequency_step: float = 2e-4
    max_log_second_step: float = 0.05

    def dense(self) -> DenseArclengthSettings:
        """The dense step; its energy is the second parameter (:meth:`CurveSystem.diagnostics`), so a step moves
        the point by at most ``max_frequency_step`` Hz and ``max_log_second_step`` in log of the second parameter
        (a fine curve in the plane whatever the scale of the unknowns)."""
        return DenseArclengthSettings(
            step=self.step,
            min_step=self.min_step,
            tolerance=self.tolerance,
            max_frequency_step=self.max_frequency_step,
            max_log_energy_step=self.max_log_second_step,
        )


#: Contact duration (phase, radians) below which a curve point is a grazing orbit to round-off. Every grazing orbit
#: is a fold of the one-contact formulation, symmetric or full-period (the frequency is even in the contact duration
#: there), so a fold curve that reaches the grazing curve could follow it on: it ends there instead.
GRAZING_DURATION = 1e-9


class CurveEvents:
    """The validity margins of a curve point (:data:`END_REASONS`): the formulation's, the window's, the test's.

    ``window``: ``((Omega_low, Omega_high), (low, high))`` of the two free parameters; ``skip``: margins of the
    formulation not checked (``contact_duration`` on the grazing curve, where it is zero by construction).
    """

    def __init__(self, system: CurveSystem, window, skip=()):
        self.system, self.window, self.skip = system, window, tuple(skip)

    def margins(self, U) -> dict:
        x, extra, params = self.system.split(U)
        (w_low, w_high), (s_low, s_high) = self.window
        a, b = params[self.system.free[0]], params[self.system.free[1]]
        margins = dict(
            frequency_low=(a - w_low) / w_low,
            frequency_high=(w_high - a) / w_high,
            second_low=(b - s_low) / max(abs(s_low), abs(s_high)),
            second_high=(s_high - b) / max(abs(s_low), abs(s_high)),
        )
        if isinstance(self.system.test, NeimarkSackerTest):
            margins["unit_pair"] = 1.0 - abs(float(extra[0]))
        margins.update(self.system.test.margins(self.system.equations, x, extra, params))
        if min(margins.values()) <= 0:  # outside the window the parameters may not even be admissible (F <= 0)
            return margins
        own = self.system.equations.assess(x, params).margins
        margins.update({k: v for k, v in own.items() if k not in self.skip})
        if "contact_duration" in margins:  # the grazing orbits (delta = 0) are folds of the formulation too
            margins["contact_duration"] -= GRAZING_DURATION
        return margins

    def __call__(self, U) -> Margins:
        return Margins(self.margins(U))

    def describe(self, key) -> str:
        return END_REASONS.get(key, str(key))


@dataclass
class Curve:
    """A followed curve: its kind, the points in order (unknowns of the augmented system), their segments, why
    each end is an end (margin key or reason) and the located end points' checks."""

    kind: str
    system: CurveSystem
    points: np.ndarray
    segment: np.ndarray
    end_keys: tuple
    end_reasons: tuple
    seed_index: int
    notes: list = field(default_factory=list)

    def params(self) -> np.ndarray:
        """``(points, 3)``: ``Omega, F, p`` of every point."""
        return np.array([self.system.split(U)[2] for U in self.points])

    def states(self) -> np.ndarray:
        return np.array([self.system.split(U)[0] for U in self.points])

    def extras(self) -> np.ndarray:
        return np.array([self.system.split(U)[1] for U in self.points]).reshape(len(self.points), -1)


def correct_on_curve(system: CurveSystem, U0, tolerance: float = 1e-11, max_iter: int = 30):
    """Newton on the augmented system with the second free parameter held at its value in ``U0``: the point of
    the curve at that parameter (a located point of a one-parameter response is one, up to its location
    tolerance). Raises ContinuationError when Newton does not converge."""
    U0 = np.asarray(U0, dtype=float)
    held = len(U0) - 1
    value = U0[held]

    def residual(U):
        return np.append(system.residual(U), U[held] - value)

    def jacobian(U):
        row = np.zeros(len(U))
        row[held] = 1.0
        return np.vstack([system.jacobian(U), row])

    result = newton_solve(residual, jacobian, U0, tol=tolerance, max_iter=max_iter, criterion=round_off_criterion())
    relative = np.linalg.norm(system.residual(result.y)) / max(1.0, np.linalg.norm(result.y))
    if not result.converged or not relative <= 1e3 * tolerance:
        raise ContinuationError(
            f"the {system.test.kind} point could not be corrected onto its curve ({result.reason or 'no convergence'}, "
            f"relative residual {relative:.2e})"
        )
    return result.y


class _SegmentStop:
    """The stop criterion of one segment: the curve's budget of points, closed, refresh of the borders."""

    def __init__(self, system, settings: CurveSettings, start, stored: int, budget: int, left: bool):
        self.system, self.settings, self.start = system, settings, start
        self.stored, self.budget, self.left, self.count = stored, budget, left, 0

    def __call__(self, V, diagnostics) -> str:
        self.count += 1
        if self.stored + self.count >= self.budget:
            return "max_points"
        distance = float(np.linalg.norm(np.asarray(V) - self.start))
        self.left = self.left or distance > 10 * self.settings.step
        if self.left and distance <= self.settings.step:
            return "closed"
        if self.count >= self.settings.segment_points:
            return "refresh"
        x, extra, params = self.system.split(V)
        if self.system.test.conditioning(self.system.equations, x, extra, params) > self.settings.max_condition:
            return "refresh"
        return ""


def _one_direction(system, events, U0, direction, settings: CurveSettings, budget: int, label: str):
    """Segments of the curve from ``U0`` along ``direction`` (borders refreshed between them): points, segment
    index per point, end key and reason. A curve that comes back to ``U0`` (within a step, after leaving it by
    ten) is closed: it ends there."""
    points, segments = [], []
    U, d, segment = np.asarray(U0, dtype=float), np.asarray(direction, dtype=float), 0
    start, left = np.asarray(U0, dtype=float), False
    while True:
        x, extra, params = system.split(U)
        system.test.prepare(system.equations, x, extra, params)
        if segment:  # new borders move the test function's own unknowns (not the orbit): back onto the curve
            U = correct_on_curve(system, U, tolerance=settings.tolerance)
        stop = _SegmentStop(system, settings, start, len(points), budget, left)
        branch = continue_branch(
            system, U, d, settings.dense().stepper(), stop, label=label, log=logger, events=events, progress_seconds=30
        )
        left = stop.left
        new = np.array(branch.points[1:] if points else branch.points)
        points += list(new)
        segments += [segment] * len(new)
        if branch.end_event is not None:
            key = branch.end_event.key
            return points, segments, key, events.describe(key)
        if branch.end_reason != "refresh" or len(branch.points) < 2:
            return points, segments, branch.end_reason, END_REASONS.get(branch.end_reason, branch.end_reason)
        U, d = np.asarray(branch.points[-1]), np.asarray(branch.end_tangent)
        segment += 1


def follow_curve(system: CurveSystem, U_seed, window, settings: CurveSettings, skip=(), label: str = "curve") -> Curve:
    """The curve through the corrected point ``U_seed`` in both directions (module docstring)."""
    events = CurveEvents(system, window, skip)
    U_seed = np.asarray(U_seed, dtype=float)
    check = events(U_seed)
    if not check.valid:
        raise ContinuationError(f"{label}: the seed violates {check.violated} ({check.margins})")
    tangent = _seed_tangent(system, U_seed)
    budget = settings.max_points // 2
    p_fwd, s_fwd, k_fwd, r_fwd = _one_direction(system, events, U_seed, tangent, settings, budget, f"{label} (+)")
    if k_fwd == "closed":
        p_bwd, s_bwd, k_bwd, r_bwd = [U_seed], [0], "closed", END_REASONS["closed"]
    else:
        p_bwd, s_bwd, k_bwd, r_bwd = _one_direction(system, events, U_seed, -tangent, settings, budget, f"{label} (-)")
    backward = p_bwd[1:][::-1]
    points = np.array(backward + p_fwd)
    offset = max(s_bwd) + 1 if s_bwd else 0
    segment = np.array([s for s in s_bwd[1:][::-1]] + [offset + s for s in s_fwd])
    return Curve(system.test.kind, system, points, segment, (k_bwd, k_fwd), (r_bwd, r_fwd), len(backward))


def _seed_tangent(system, U):
    from nnmstop.continuation.core import unit_tangent

    x, extra, params = system.split(U)
    system.test.prepare(system.equations, x, extra, params)
    J = system.jacobian(U)
    _, _, Vt = np.linalg.svd(J)
    t = Vt[-1]
    # orient towards growing frequency (the first free parameter)
    index = system.n + system.n_extra
    if t[index] < 0:
        t = -t
    return unit_tangent(system, U, t)[0]


def grazing_test(equations) -> StateTest:
    """The grazing orbits of the exact one-contact responses: zero contact duration (``delta = 0``)."""
    return StateTest(equations.n - 1, 0.0)
