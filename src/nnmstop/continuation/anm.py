r"""Asymptotic Numerical Method (ANM): continuation by high-order power series.

For a quadratic system ``S(U) = L(U) + Q(U, U) = 0`` the branch through a regular
point ``U_0`` is expanded as ``U(a) = sum_{p=0..N} a^p U_p`` in the path parameter
``a = <U - U_0, t>``, with ``t`` the unit tangent at ``U_0``. Identifying powers of
``a`` gives, with ``J = dS/dU(U_0)`` (the same matrix at every order)::

    order 1:  J U_1 = 0,                                   <U_1, t> = 1
    order p:  J U_p = - sum_{r=1}^{p-1} Q(U_r, U_{p-r}),   <U_p, t> = 0

so one LU factorization of the bordered matrix ``[J; t^T]`` serves all orders.
The series is trusted up to the step length (Cochelin's estimate)::

    a_max = (tolerance * ||U_1|| / ||U_N||) ** (1 / (N - 1))

which keeps the last term below ``tolerance``. The end point ``U(a_max)`` becomes
the next start point; the tangent there, ``dU/da(a_max)``, orients the next step.
If the residual at the end of a step exceeds ``newton_threshold`` the end point is
corrected by Newton iterations: chord iterations on the step's own factors first (no
factorization), full Newton only if they fail. With the plain series this does not
happen (step ends sit at ``1e-10`` to a few ``1e-9``); it happens after a geometric
tail was removed (:func:`remove_geometric_tail`) where the singular point is not on
the path being followed (sharp folds of NNM1 near the 3:1 resonance): the cleaned
series then ends at ``1e-5`` to ``5e-4`` and needs about a dozen chord iterations.
Those steps are still longer than the plain series would allow.

With ``ANMSettings.pade`` (the default) each step is taken on the Padé approximant of
its series (:mod:`nnmstop.continuation.pade`: common denominator from a QR of the terms), when that
reaches beyond ``a_max`` at the same tolerance: the step then ends where the
approximants of orders ``N`` and ``N - 1`` stop agreeing to ``tolerance`` relative to
the step, and strictly before the first positive real pole of their denominators.
The end point, the tangent there and the interior points come from the approximant;
the end-residual check and the Newton correction are the same. A geometric tail
(simple bifurcation on the path) is removed from the series first, as without Padé,
so that the step still passes branch points of the followed branch; measured on
NNM1 at ``H = 100``, dropping the tail removal and relying on the approximant's pole
alone lost a branch point and switched branch near the 3:1 resonance.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.linalg.lapack import dgetrs as _getrs

from nnmstop.continuation.pade import pade_pair, pade_step_length
from nnmstop.continuation.core import (
    Branch,
    ContinuationError,
    ContinuationStats,
    Progress,
    StopCriterion,
    bordered_factor,
    determinant_sign,
    newton_correct,
    relative_residual,
    unit_tangent,
)

__all__ = ["ANMSettings", "ANMStep", "TaylorPath", "anm_series", "evaluate_series", "anm_step", "continue_anm"]

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
    """

    order: int = 20
    tolerance: float = 1e-8
    newton_threshold: float = 1e-7
    max_steps: int = 3000
    points_per_step: int = 1
    pade: bool = True

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

    @classmethod
    def from_config(cls, anm_config: dict, **overrides) -> "ANMSettings":
        keys = ("order", "tolerance", "newton_threshold", "max_steps")
        optional = {"pade": anm_config["pade"]} if "pade" in anm_config else {}
        return cls(**{k: anm_config[k] for k in keys}, **optional, **overrides)


def anm_series(system, U0, tangent, order: int, stats: ContinuationStats, lu=None):
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
    lu : tuple, optional
        ``scipy.linalg.lu_factor`` factors of ``[J(U0); tangent^T]`` when the caller
        has them.

    Returns
    -------
    ndarray
        Shape ``(N + 1, n_unknowns)``: row ``p`` is ``U_p``.
    """
    if lu is None:
        lu = bordered_factor(system, U0, tangent, stats)
    n = system.n_unknowns
    series = np.empty((order + 1, n))
    series[0] = U0
    rhs = np.zeros(n)
    rhs[-1] = 1.0
    series[1] = _solve(lu, rhs)
    cache = system.series_cache(order)
    rhs[-1] = 0.0
    for p in range(2, order + 1):
        np.negative(system.series_products(series, p, cache), out=rhs[:-1])
        series[p] = _solve(lu, rhs)
    return series


def _solve(lu, rhs):
    """Solution of ``A x = rhs`` from the ``lu_factor`` factors of ``A``, by LAPACK ``getrs``.

    ``scipy.linalg.lu_solve`` checks both operands for non-finite values at every call;
    the factors were checked once when they were made, and a non-finite right-hand side
    is caught here on the (short) solution instead.
    """
    x, info = _getrs(lu[0], lu[1], rhs)
    if info != 0 or not np.all(np.isfinite(x)):
        raise np.linalg.LinAlgError(f"bordered solve failed (getrs info {info}, or non-finite values)")
    return x


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
    """The power series of a step as a path ``a -> U(a)`` (same call as :class:`nnmstop.continuation.pade.PadeApproximant`)."""

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
    orientation), the LU factors ``lu`` of that matrix, reused by corrections,
    ``path``, the representation ``a -> U(a)`` (``path(a, derivative=True)`` for
    ``dU/da``) the step was taken on: the series, or its Padé approximant, and
    ``a_series``, the step length of the plain series (``a_max`` without Padé).
    """

    series: np.ndarray
    a_max: float
    U_end: np.ndarray
    t_end: np.ndarray
    det_sign: int
    lu: tuple
    path: object
    a_series: float


def anm_step(system, U0, tangent, settings: ANMSettings, stats: ContinuationStats) -> ANMStep:
    """One ANM step from ``U0`` (see :class:`ANMStep`)."""
    lu = bordered_factor(system, U0, tangent, stats)
    series = anm_series(system, U0, tangent, settings.order, stats, lu=lu)
    series, a_b = remove_geometric_tail(series, step_length(series, settings.tolerance))
    if a_b is not None:
        stats.geometric_tails += 1
    a_max = step_length(series, settings.tolerance, last_terms=1 if a_b is None else 4)
    taylor = path = TaylorPath(series)
    a_series = a_max
    if settings.pade:
        path, a_max = _pade_path(series, a_max, settings.tolerance, path, stats)
    try:
        U_end, t_end = _step_end(system, path, a_max, lu, settings, stats)
    except ContinuationError:
        if path is taylor:
            raise
        # the approximant's end could not be corrected: take the plain series' step
        stats.pade_steps -= 1
        path, a_max = taylor, a_series
        U_end, t_end = _step_end(system, path, a_max, lu, settings, stats)
    return ANMStep(series, a_max, U_end, t_end, determinant_sign(lu), lu, path, a_series)


def _step_end(system, path, a_max, lu, settings: ANMSettings, stats: ContinuationStats):
    """End point of a step on ``path`` (Newton-corrected when needed) and the unit tangent there."""
    U_end = path(a_max)
    t_end = path(a_max, derivative=True)
    t_end /= np.linalg.norm(t_end)
    if relative_residual(system, U_end) > settings.newton_threshold:
        # chord iterations with the step's own factors first: usually no new factorization
        U_end, _ = newton_correct(system, U_end, t_end, stats, tol=0.01 * settings.newton_threshold, lu=lu)
        stats.corrected_steps += 1
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


def continue_anm(
    system,
    U_start,
    direction,
    stop: StopCriterion,
    settings: ANMSettings = ANMSettings(),
    label: str = "ANM",
    progress_seconds: float = 2.0,
) -> Branch:
    """Follow the branch through ``U_start`` along ``direction`` until ``stop`` says so.

    Parameters
    ----------
    system : HarmonicBalanceSystem
        Provides ``residual``, ``jacobian``, ``series_products`` and ``diagnostics``.
    U_start : ndarray
        A point of the branch (residual at round-off).
    direction : ndarray
        Rough direction of travel; the tangent is oriented along it.
    stop : callable
        ``stop(U, diagnostics) -> str``; a non-empty string ends the continuation and
        is recorded as the end reason.

    Returns
    -------
    Branch
        The start point, then the end point of every step (and interior points,
        see ``ANMSettings.points_per_step``).

    Raises
    ------
    ContinuationError
        When a step fails or ``max_steps`` is exhausted; the message names the step
        and the energy.
    """
    stats = ContinuationStats()
    started = time.perf_counter()
    branch = Branch(stats=stats)
    U = np.array(U_start, dtype=float)
    tangent = unit_tangent(system, U, np.asarray(direction, dtype=float), stats)
    diag = system.diagnostics(U)
    branch.add(U, 0, diag)
    progress = Progress(label, progress_seconds, logger)
    previous_sign = None
    for step in range(1, settings.max_steps + 1):
        try:
            result = anm_step(system, U, tangent, settings, stats)
            series, a_max, U_end, t_end, det_sign = result[:5]
        except (ContinuationError, np.linalg.LinAlgError) as err:
            raise ContinuationError(
                f"{label}: step {step} failed at energy {diag['energy']:.6g} "
                f"(frequency {diag['frequency']:.6g} Hz): {err}"
            ) from err
        if not (np.all(np.isfinite(U_end)) and a_max > 0):
            raise ContinuationError(
                f"{label}: step {step} produced non-finite values at energy {diag['energy']:.6g}"
            )
        stats.steps = step
        if previous_sign is not None and det_sign != previous_sign:
            # The branch point lies within the previous step: between its start and U.
            branch.branch_points.append(len(branch.points) - 1)
            logger.info("%s: simple branch point passed near energy %.6g, frequency %.6g Hz (step %d)",
                        label, diag["energy"], diag["frequency"], step - 1)
        previous_sign = det_sign
        n_sub = settings.points_per_step
        if n_sub > 1:  # as dense as the plain series would store them
            n_sub *= max(1, int(np.ceil(a_max / result.a_series - 1e-9)))
        # Interior points along the series, then the (possibly corrected) end point; the
        # stop criterion is checked at each, so a stage ends at the first point meeting it.
        for j in range(1, n_sub + 1):
            if j < n_sub:
                a = a_max * j / n_sub
                U_j = result.path(a)
                t_j = result.path(a, derivative=True)
                t_j /= np.linalg.norm(t_j)
                # interior points meet the same accuracy as step ends (chord corrections
                # on the step's factors, no new factorization in general)
                if relative_residual(system, U_j) > settings.newton_threshold:
                    try:
                        U_j, _ = newton_correct(system, U_j, t_j, stats, tol=0.01 * settings.newton_threshold, lu=result.lu)
                    except ContinuationError as err:
                        raise ContinuationError(
                            f"{label}: step {step}, interior point {j}, failed at energy {diag['energy']:.6g}: {err}"
                        ) from err
            else:
                U_j, t_j = U_end, t_end
            diag = system.diagnostics(U_j)
            branch.add(U_j, step, diag)
            reason = stop(U_j, diag)
            if reason:
                branch.end_reason = reason
                branch.end_tangent = t_j
                stats.wall_time = time.perf_counter() - started
                progress(step, diag, a_max, force=True)
                return branch
        U, tangent = U_end, t_end
        progress(step, diag, a_max)
    raise ContinuationError(
        f"{label}: no stop criterion met after max_steps = {settings.max_steps} steps "
        f"(last energy {diag['energy']:.6g}, frequency {diag['frequency']:.6g} Hz)"
    )
