"""Exact orbits of a stored exact NNM1 rebuilt in closed form, for the explorer.

The exact datasets store each orbit's start velocities ``(xdot0, udot0)``, its phase sequence and
its period, not the duration of each linear phase. :func:`orbit_unknowns` recovers the durations by
locating the switchings on the closed-form phase flows (:class:`nnmstop.exact.phases.LinearPhase`),
then solves the orbit's quarter-period equations (:class:`nnmstop.exact.problem.SequenceProblem`) to
round-off with ``xdot0`` held; :func:`orbit_coefficients` turns the orbit into the Fourier
coefficients the explorer synthesizes, taken at the phase of the turning point (a cosine series).
"""

from __future__ import annotations

import numpy as np
import scipy.optimize

from nnmstop.exact.phases import interior_extrema
from nnmstop.exact.problem import SequenceProblem, newton
from nnmstop.fourier import to_coefficients

__all__ = ["orbit_unknowns", "orbit_coefficients"]


def _first_crossing(phase, z0, window: float, level: float) -> float:
    """First time in ``(0, window]`` where x of the phase from ``z0`` reaches ``level``.

    x is monotone between its interior extrema, so each piece between them holds at most one
    crossing, bracketed for Brent's method. A grazing orbit touches the level at an extremum or at
    the window's end without crossing it: the first such touch within ``1e-9`` is taken, and a phase
    that starts on the level and never comes back to it lasts zero time (the new phase at a grazing).
    """
    times, _ = interior_extrema(phase, z0, window)
    knots = np.concatenate([[0.0], times, [window]])
    gap = phase.state(z0, knots)[:, 0] - level
    starts_on_level = abs(gap[0]) < 1e-9
    if starts_on_level:  # the phase starts on the level and leaves it until x turns back
        knots, gap = knots[1:], gap[1:]
    for a, b, ga, gb in zip(knots[:-1], knots[1:], gap[:-1], gap[1:]):
        if a > 0 and ga == 0.0:
            return float(a)
        if ga * gb < 0:
            return scipy.optimize.brentq(lambda t: phase.state(z0, float(t))[0] - level, a, b, xtol=1e-15)
    touching = np.flatnonzero((np.abs(gap) < 1e-9) & (knots > 0))
    if touching.size:
        return float(knots[touching[0]])
    if starts_on_level:  # a phase of zero duration, at a grazing transition
        return 0.0
    raise ValueError(f"x never reaches {level:+g} within {window:.6g} of the phase start {z0}")


def orbit_unknowns(problem: SequenceProblem, xdot0: float, udot0: float, quarter: float) -> np.ndarray:
    """Unknowns ``(xdot0, udot0, d_1..d_n)`` of the stored orbit, solved to round-off.

    Parameters
    ----------
    problem
        The orbit's phase sequence (``SequenceProblem(params, sequence)``, phase durations as unknowns).
    xdot0, udot0, quarter
        The stored start velocities and quarter period ``T1 = period / 4``.

    Raises
    ------
    ValueError
        If a switching is not found or the quarter-period equations do not converge.
    """
    if problem.switch_times:
        raise ValueError(f"{problem!r} takes switching times; give a SequenceProblem with phase durations")
    z = np.array([0.0, 0.0, xdot0, udot0])
    durations, elapsed = [], 0.0
    for phase, level in zip(problem.phases, problem.levels):
        d = _first_crossing(phase, z, quarter - elapsed, level)
        durations.append(d)
        elapsed += d
        z = phase.state(z, d)
    durations.append(quarter - elapsed)
    seed = np.array([xdot0, udot0, *durations])

    def fun(v):  # xdot0 held: the other unknowns make the system square
        return problem.residual(np.concatenate([[xdot0], v]))

    def jac(v):
        return problem.jacobian(np.concatenate([[xdot0], v]))[:, 1:]

    tolerance = 1e-9 * (1.0 + np.linalg.norm(seed))
    if np.linalg.norm(problem.residual(seed)) <= 1e-3 * tolerance:  # closed already (a grazing orbit's J is singular)
        return seed
    solution, _ = newton(fun, jac, seed[1:])
    y = np.concatenate([[xdot0], solution])
    if np.linalg.norm(problem.residual(y)) > tolerance:
        raise ValueError(f"the exact orbit {problem.sequence} with xdot0 = {xdot0!r} does not close (Newton failed)")
    return y


def orbit_coefficients(problem: SequenceProblem, y, harmonics: int) -> dict:
    """Cosine coefficients (harmonics ``0..H``) of x and u of the exact orbit ``y``, time from the turning point.

    The orbit is sampled at ``8 H`` instants from ``T1`` (where both velocities vanish, so x and u are
    even in time about it and their series hold cosines only) and projected on the first ``H``
    harmonics (:func:`nnmstop.fourier.to_coefficients`). Returns ``{"x": cos, "u": cos}`` and
    ``"sine_share"``: the largest sine coefficient over the largest cosine coefficient (round-off).
    """
    quarter = problem.quarter(y)
    samples = 8 * int(harmonics)
    t = quarter + 4.0 * quarter * np.arange(samples) / samples
    history = problem.time_history(y, t)
    out, sine = {}, 0.0
    for name in ("x", "u"):
        full = to_coefficients(getattr(history, name), harmonics)
        out[name] = full[: harmonics + 1]
        sine = max(sine, np.abs(full[harmonics + 1 :]).max() / np.abs(out[name]).max())
    out["sine_share"] = sine
    return out
