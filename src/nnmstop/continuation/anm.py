r"""Asymptotic Numerical Method (ANM): continuation by high-order power series.

For a quadratic system ``S(U) = L(U) + Q(U, U) = 0`` the branch through ``U_0`` is the
series ``U(a) = sum_p a^p U_p`` in ``a = <U - U_0, t>``; every order solves with the same
bordered matrix ``[J(U_0); t^T]``, factorized once per step (:func:`anm_series`). Cochelin's
estimate of the validity range gives the step length; a geometric tail (a simple
bifurcation on the path) is removed first (:func:`remove_geometric_tail`) so that steps
pass branch points on the followed branch; with ``ANMSettings.pade`` the step goes on
along the Padé approximant of the series (:mod:`nnmstop.continuation.pade`). Step ends
above the Newton threshold are corrected, by chord iterations on the step's factors first.

:class:`ANMStepper` puts one step (:func:`anm_step`) behind the interface of the
continuation driver (:mod:`nnmstop.continuation.driver`); :func:`continue_anm` runs the
driver with it. Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from nnmstop.continuation.core import (
    Branch,
    ContinuationError,
    ContinuationStats,
    StopCriterion,
    newton_correct,
    relative_residual,
)
from nnmstop.continuation.driver import Stepper, StepResult, continue_branch, produced_points
from nnmstop.continuation.linear import factorize_bordered
from nnmstop.continuation.pade import pade_pair, pade_step_length

__all__ = [
    "ANMSettings",
    "ANMStep",
    "ANMStepper",
    "TaylorPath",
    "anm_series",
    "evaluate_series",
    "step_length",
    "anm_step",
    "continue_anm",
]

logger = logging.getLogger("nnmstop.continuation.anm")


@dataclass(frozen=True)
class ANMSettings:
    """Settings of the ANM continuation.

    Parameters
    ----------
    order : int
        Series order ``N`` (>= 2).
    tolerance : float
        Accuracy target of the step-length estimate (> 0).
    newton_threshold : float
        Relative residual beyond which a step end is corrected by Newton.
    max_steps : int
        Largest number of steps before the continuation gives up.
    points_per_step : int
        Points stored per step (the end point included), for smooth curves; >= 1.
        1 stores the step ends only. Above 1, the count is per length of the plain
        series' step (Cochelin's estimate): a step on the Padé approximant that
        reaches ``k`` times further stores ``ceil(k)`` times as many points, so that
        the stored curves are as dense as with the plain series.
    pade : bool
        Represent each step by the Padé approximant of its series
        (:mod:`nnmstop.continuation.pade`) wherever that reaches further than the series at the
        same tolerance (the plain series' step is taken instead when the
        approximant's end cannot be corrected by Newton), the default; False
        keeps the plain power series.
    max_step : float
        Largest step length (path parameter ``a``): a step whose estimate reaches further stops there,
        on the same path. No cap (inf) by default; a restart that confirms where a continuation ends
        (:mod:`nnmstop.continuation.confirm`) takes a fraction of the steps it ended with.
    """

    order: int = 20
    tolerance: float = 1e-8
    newton_threshold: float = 1e-7
    max_steps: int = 3000
    points_per_step: int = 1
    pade: bool = True
    max_step: float = np.inf

    def __post_init__(self):
        if not (isinstance(self.order, (int, np.integer)) and self.order >= 2):
            raise ValueError(f"order must be an integer >= 2, got {self.order!r}")
        for name in ("tolerance", "newton_threshold"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        if self.max_steps < 1:
            raise ValueError(f"max_steps must be >= 1, got {self.max_steps!r}")
        if self.points_per_step < 1:
            raise ValueError(f"points_per_step must be >= 1, got {self.points_per_step!r}")
        if not isinstance(self.pade, (bool, np.bool_)):
            raise ValueError(f"pade must be true or false, got {self.pade!r}")
        if not self.max_step > 0:
            raise ValueError(f"max_step must be > 0 (inf: no cap), got {self.max_step!r}")

    def stepper(self) -> ANMStepper:
        """The ANM step with these settings, for :func:`nnmstop.continuation.driver.continue_branch`."""
        return ANMStepper(self)

    @classmethod
    def from_config(cls, anm_config: dict, **overrides) -> ANMSettings:
        keys = ("order", "tolerance", "newton_threshold", "max_steps")
        optional = {"pade": anm_config["pade"]} if "pade" in anm_config else {}
        return cls(**{k: anm_config[k] for k in keys}, **optional, **overrides)


def anm_series(system, U0, tangent, order: int, stats: ContinuationStats, factors=None):
    """Taylor coefficients ``U_0, ..., U_N`` of the branch at ``U0`` (one factorization).

    Parameters
    ----------
    system : HarmonicBalanceSystem
        Provides ``series_cache`` and ``series_products``.
    U0 : ndarray
        Start point of the series (a point of the branch).
    tangent : ndarray
        Unit tangent at ``U0``: the bordering row, which defines the path parameter.
    order : int
        Series order ``N``.
    stats : ContinuationStats
        The factorization is counted there when this function makes it.
    factors : optional
        Factors of ``[J(U0); tangent^T]``
        (:func:`~nnmstop.continuation.linear.factorize_bordered`) when the caller has them.

    Returns
    -------
    ndarray
        Shape ``(N + 1, n_unknowns)``: row ``p`` is ``U_p``.
    """
    if factors is None:
        factors = factorize_bordered(system, U0, tangent, stats)
    n = system.n_unknowns
    series = np.empty((order + 1, n))
    series[0] = U0
    rhs = np.zeros(n)
    rhs[-1] = 1.0
    series[1] = factors.solve(rhs)
    cache = system.series_cache(order)
    rhs[-1] = 0.0
    for p in range(2, order + 1):
        np.negative(system.series_products(series, p, cache), out=rhs[:-1])
        series[p] = factors.solve(rhs)
    return series


def evaluate_series(series, a, derivative: bool = False):
    """``U(a)`` (or ``dU/da``) by Horner's rule."""
    if derivative:
        out = np.zeros_like(series[0])
        for p in range(len(series) - 1, 0, -1):
            out = out * a + p * series[p]
        return out
    out = np.zeros_like(series[0])
    for term in reversed(series):
        out = out * a + term
    return out


def step_length(series, tolerance: float, last_terms: int = 1) -> float:
    """Cochelin's estimate of the validity range of the series.

    With ``last_terms > 1`` the smallest estimate over the last few orders is taken
    (used after a geometric tail was removed, which zeroes the very last term).
    """
    n = len(series) - 1
    u1 = np.linalg.norm(series[1])
    estimates = [
        (tolerance * u1 / max(np.linalg.norm(series[q]), 1e-300)) ** (1.0 / (q - 1))
        for q in range(max(2, n - last_terms + 1), n + 1)
    ]
    return float(min(estimates))


def remove_geometric_tail(series, a_max: float, alignment: float = 1e-6, reach: float = 3.0):
    """Split off a geometric progression from the last series terms (simple bifurcation).

    Near a simple bifurcation point the terms of the series become collinear and grow
    (or decay) geometrically, ``U_p ~ w / a_b**p``: the bifurcation at ``a = a_b``
    limits the radius of convergence and steps shrink towards it without passing.
    Following Cochelin & Medale (2013), when the last three terms are aligned to within
    ``alignment`` and the singular point is within ``reach`` step lengths ``a_max``
    (so that it is what limits the step), the geometric part is subtracted from every
    term ``p >= 1``; the remaining series describes the branch being followed beyond
    ``a_b``.

    Returns
    -------
    series : ndarray
        Cleaned series (a new array, same layout) or the input when no progression
        was found.
    a_b : float or None
        Signed path parameter of the singular point, None when none was found.
    """
    n = len(series) - 1
    if n < 4:
        return series, None
    last, prev, prev2 = series[n], series[n - 1], series[n - 2]
    norms = [np.linalg.norm(v) for v in (last, prev, prev2)]
    if min(norms) == 0.0:
        return series, None
    cos1 = np.dot(last, prev) / (norms[0] * norms[1])
    cos2 = np.dot(prev, prev2) / (norms[1] * norms[2])
    if abs(cos1) < 1 - alignment or abs(cos2) < 1 - alignment or np.sign(cos1) != np.sign(cos2):
        return series, None
    a_b = np.dot(prev, prev) / np.dot(last, prev)
    if abs(a_b) > reach * a_max:
        return series, None
    cleaned = np.array(series, dtype=float)
    cleaned[1:] -= np.outer(a_b ** np.arange(n - 1, -1, -1), last)
    return cleaned, float(a_b)


class TaylorPath:
    """The power series of a step as a path ``a -> U(a)`` (called like a Padé approximant)."""

    def __init__(self, series):
        self.series = series

    def __call__(self, a: float, derivative: bool = False):
        return evaluate_series(self.series, a, derivative=derivative)


class ANMStep(NamedTuple):
    """Result of one ANM step.

    ``series`` (cleaned of a geometric tail if one was found), the step length
    ``a_max``, the end point ``U_end`` (Newton-corrected if needed), the unit tangent
    ``t_end`` there, the sign ``det_sign`` of ``det [J(U0); tangent^T]`` (it changes
    across a simple branch point, not across a fold, when the tangent keeps its
    orientation), the ``factors`` of that matrix, reused by corrections,
    ``path``, the representation ``a -> U(a)`` (``path(a, derivative=True)`` for
    ``dU/da``) the step was taken on: the series, or its Padé approximant, and
    ``a_series``, the step length of the plain series (``a_max`` without Padé).
    """

    series: np.ndarray
    a_max: float
    U_end: np.ndarray
    t_end: np.ndarray
    det_sign: int
    factors: object
    path: object
    a_series: float


def anm_step(system, U0, tangent, settings: ANMSettings, stats: ContinuationStats) -> ANMStep:
    """One ANM step from ``U0`` (see :class:`ANMStep`)."""
    factors = factorize_bordered(system, U0, tangent, stats)
    series = anm_series(system, U0, tangent, settings.order, stats, factors=factors)
    series, a_b = remove_geometric_tail(series, step_length(series, settings.tolerance))
    if a_b is not None:
        stats.geometric_tails += 1
    a_max = min(step_length(series, settings.tolerance, last_terms=1 if a_b is None else 4), settings.max_step)
    taylor = path = TaylorPath(series)
    a_series = a_max
    if settings.pade and a_max < settings.max_step:
        path, a_max = _pade_path(series, a_max, settings.tolerance, path, stats)
        a_max = min(a_max, settings.max_step)
    try:
        U_end, t_end = _step_end(system, path, a_max, factors, settings, stats)
    except ContinuationError:
        if path is taylor:
            raise
        # the approximant's end could not be corrected: take the plain series' step
        return plain_series_step(
            system, ANMStep(series, a_max, None, None, 0, factors, path, a_series), settings, stats
        )
    return ANMStep(series, a_max, U_end, t_end, factors.determinant_sign(), factors, path, a_series)


def plain_series_step(system, step: ANMStep, settings: ANMSettings, stats: ContinuationStats) -> ANMStep:
    """``step`` taken on its plain power series instead of the Padé approximant (same series and factors).

    The approximant reaches further than the series at the same estimated accuracy, but where it passes
    near one of its own poles (close to a singular point of the branch, an internal resonance) a point
    of it may lie off the branch beyond what Newton can correct; the series' step is then taken.
    """
    stats.pade_steps -= 1
    path = TaylorPath(step.series)
    U_end, t_end = _step_end(system, path, step.a_series, step.factors, settings, stats)
    return step._replace(
        a_max=step.a_series, U_end=U_end, t_end=t_end, path=path, det_sign=step.factors.determinant_sign()
    )


def _on_threshold(system, U, t, factors, settings: ANMSettings, stats: ContinuationStats):
    """``U`` corrected by Newton when its residual exceeds the threshold (chord iterations on ``factors`` first)."""
    if relative_residual(system, U) <= settings.newton_threshold:
        return U, False
    U, _ = newton_correct(system, U, t, stats, tol=0.01 * settings.newton_threshold, factors=factors)
    return U, True


def _step_end(system, path, a_max, factors, settings: ANMSettings, stats: ContinuationStats):
    """End point of a step on ``path`` (Newton-corrected when needed) and the unit tangent there."""
    U_end = path(a_max)
    t_end = path(a_max, derivative=True)
    t_end /= np.linalg.norm(t_end)
    U_end, corrected = _on_threshold(system, U_end, t_end, factors, settings, stats)
    stats.corrected_steps += corrected
    return U_end, t_end


def _pade_path(series, a_max: float, tolerance: float, taylor, stats: ContinuationStats):
    """The Padé approximant of ``series`` and its step length, when it reaches beyond ``a_max``."""
    pair = pade_pair(series, a_max)
    if pair is None:
        return taylor, a_max
    a_pade = pade_step_length(pair[0], pair[1], tolerance, a_max)
    if a_pade <= a_max:
        return taylor, a_max
    stats.pade_steps += 1
    return pair[0], a_pade


def _replayed(points, failure):
    """The points already produced, then the error that stopped their production (raised only if reached)."""
    yield from points
    if failure is not None:
        raise failure


class ANMStepper(Stepper):
    """The ANM step (:func:`anm_step`) behind the continuation driver's interface."""

    def __init__(self, settings: ANMSettings = ANMSettings()):
        self.settings = settings
        self.max_steps = settings.max_steps

    def step(self, system, U, tangent, stats: ContinuationStats) -> StepResult:
        result = anm_step(system, U, tangent, self.settings, stats)
        points, failure = produced_points(self._points(system, result, stats))
        if failure is not None and not isinstance(result.path, TaylorPath):
            # a point of the approximant could not be corrected (as for its end in anm_step): the series' step
            result = plain_series_step(system, result, self.settings, stats)
            points, failure = produced_points(self._points(system, result, stats))
        return StepResult(
            U_end=result.U_end,
            t_end=result.t_end,
            length=result.a_max,
            path=result.path,
            points=_replayed(points, failure),
            start_sign=result.det_sign,
        )

    def _points(self, system, result: ANMStep, stats: ContinuationStats):
        """Interior points along the step's path, then its (possibly corrected) end point.

        With ``points_per_step > 1``, as many per length of the plain series' step (so that
        the curves are as dense as with the plain series); interior points meet the same
        accuracy as step ends (chord corrections on the step's factors).
        """
        n_sub = self.settings.points_per_step
        if n_sub > 1:
            n_sub *= max(1, int(np.ceil(result.a_max / result.a_series - 1e-9)))
        for j in range(1, n_sub):
            a = result.a_max * j / n_sub
            U_j = result.path(a)
            t_j = result.path(a, derivative=True)
            t_j /= np.linalg.norm(t_j)
            try:
                U_j, _ = _on_threshold(system, U_j, t_j, result.factors, self.settings, stats)
            except ContinuationError as err:
                raise ContinuationError(f"interior point {j}: {err}") from err
            yield U_j, t_j, a
        yield result.U_end, result.t_end, result.a_max

    def path_through(self, system, U_a, tangent_a, U_b, stats: ContinuationStats, strict: bool = True):
        """The ANM step from ``U_a`` recomputed; ``U_b``'s parameter is that of the nearest point of its path.

        The path is the series (or its Padé approximant, as the continuation used it), the branch
        to the series' accuracy all along the step, geometric tail removed so that it runs through
        a branch point on the branch being followed. With ``strict=False``, a ``U_b`` off the path
        (a step end that Newton moved, e.g. onto the other curve past a branch point) gives the path
        up to its own end instead of a ValueError.
        """
        step = anm_step(system, U_a, tangent_a, self.settings, stats)
        path, a_max = step.path, step.a_max
        chord = U_b - U_a
        # a Padé approximant's parameter is not the projection on tangent_a: refine it as the
        # parameter of the point of the path nearest to U_b
        a_end = min(max(float(np.dot(chord, tangent_a)), 0.0), a_max)
        for _ in range(30):
            d = path(a_end, derivative=True)
            update = -float(np.dot(path(a_end) - U_b, d) / np.dot(d, d))
            a_end = min(max(a_end + update, 0.0), 1.001 * a_max)
            if abs(update) <= 1e-14 * max(a_end, 1e-300):
                break
        gap = np.linalg.norm(path(a_end) - U_b)
        if not (a_end > 0 and gap <= 1e-3 * np.linalg.norm(chord)):
            if not strict:
                logger.info("U_b is %.3g off the recomputed ANM step: its own end (a = %.6g) is taken", gap, a_max)
                return path, a_max
            raise ValueError(
                f"U_b is not on the ANM step from U_a (distance {gap:.3g} to it, chord {np.linalg.norm(chord):.3g}): "
                "pass the two ends of one continuation step"
            )
        return path, a_end


def continue_anm(
    system,
    U_start,
    direction,
    stop: StopCriterion,
    settings: ANMSettings = ANMSettings(),
    label: str = "ANM",
    progress_seconds: float = 2.0,
) -> Branch:
    """Follow the branch through ``U_start`` along ``direction`` by the ANM until ``stop`` says so.

    :func:`nnmstop.continuation.driver.continue_branch` with an :class:`ANMStepper`: the
    start point, then the end point of every step (and interior points, see
    ``ANMSettings.points_per_step``). ``system`` also provides ``series_products``.
    """
    return continue_branch(system, U_start, direction, ANMStepper(settings), stop, label, progress_seconds, logger)
