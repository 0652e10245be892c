"""Pseudo-arclength continuation of a family of exact orbits that ends where the orbits stop being admissible.

:func:`continue_family` follows ``residual(y) = 0`` (``m`` equations, ``m + 1`` unknowns) with Newton corrections
to round-off (:func:`round_off_criterion` on :func:`nnmstop.continuation.newton.newton_solve`), checks each orbit
with a caller's ``assess(y)`` and locates, by bisection on the arclength of the last step, the point where the
first validity margin fails. Generic in the problem; the N-DOF one-stop orbits (:mod:`nnmstop.exact.ndof`) use
it. Method notes: docs/methods/exact_ndof.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnmstop.continuation.newton import newton_solve
from nnmstop.exact.grazing import TWO_IMPACT_MARGINS

__all__ = ["round_off_criterion", "FamilyTrace", "continue_family"]


def _converged_to_round_off(dy_norm: float, previous: float, y_norm: float) -> bool:
    """Newton has reached round-off: the update is below 1e-13 relative, or it has stopped shrinking (by at
    least half per iteration) while below 1e-8 relative. The second case is the floor set by the conditioning
    of the quarter-period equations of a model with fast modes (round-off of their velocities at T1)."""
    scale = 1.0 + y_norm
    return dy_norm <= 1e-13 * scale or (dy_norm <= 1e-8 * scale and dy_norm > 0.5 * previous)


def round_off_criterion():
    """A fresh :func:`_converged_to_round_off` test for :func:`~nnmstop.continuation.newton.newton_solve` (it keeps
    the previous update's norm)."""
    previous = [np.inf]

    def converged(y, r, dy) -> bool:
        if dy is None:
            return False
        dy_norm = float(np.linalg.norm(dy))
        done = _converged_to_round_off(dy_norm, previous[0], float(np.linalg.norm(y)))
        previous[0] = dy_norm
        return done

    return converged


def _unit_tangent(jac: np.ndarray, previous: np.ndarray) -> np.ndarray:
    """Null vector of the m x (m + 1) Jacobian, oriented like ``previous``, unit length."""
    rhs = np.zeros(jac.shape[1])
    rhs[-1] = 1.0
    t = np.linalg.solve(np.vstack([jac, previous]), rhs)
    return t / np.linalg.norm(t)


def _correct(residual, jacobian, y_prev, tangent, sigma, max_iter=15):
    """Pseudo-arclength corrector to round-off (:func:`round_off_criterion`); ``(y, residual norm)`` or ``(None, inf)``.

    Refuses a solution farther than half the step from the predictor (a jump to another branch).
    """

    def bordered_residual(y):
        return np.append(residual(y), tangent @ (y - y_prev) - sigma)

    def bordered_jacobian(y):
        return np.vstack([jacobian(y), tangent])

    try:
        result = newton_solve(
            bordered_residual,
            bordered_jacobian,
            y_prev + sigma * tangent,
            tol=0.0,
            max_iter=max_iter,
            criterion=round_off_criterion(),
        )
    except np.linalg.LinAlgError:
        return None, np.inf
    if not result.converged:
        return None, np.inf
    y = result.y
    res = float(np.linalg.norm(residual(y)))
    if np.linalg.norm(y - (y_prev + sigma * tangent)) > 0.5 * abs(sigma) + 1e-12:
        return None, np.inf
    return y, res


@dataclass
class FamilyTrace:
    """Output of :func:`continue_family`: orbits in continuation order and why the family ends."""

    unknowns: np.ndarray
    arclength: np.ndarray
    residual: np.ndarray
    assessments: list
    end_reason: str
    end_margin: str
    end_tangent: np.ndarray


def continue_family(
    residual,
    jacobian,
    assess,
    y0,
    direction,
    step: float,
    max_points: int,
    min_step_ratio: float = 1e-6,
    reasons: dict = TWO_IMPACT_MARGINS,
) -> FamilyTrace:
    """Pseudo-arclength continuation of ``residual(y) = 0`` (m equations, m + 1 unknowns) with validity checks.

    Generic in the problem: ``assess(y)`` returns an object with ``valid`` and ``violated`` (a
    :class:`MarginChecks`). The tangent at ``y0`` is oriented along ``direction``. At the first invalid orbit the
    boundary is located by bisection on the arclength of the last step (to ``1e-13`` of it), the last valid orbit
    is kept and the family ends there, with the reason from ``reasons``. The step is halved when Newton fails and
    restored after a success.
    """
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be a finite number > 0, got {step!r}")
    if int(max_points) != max_points or max_points < 2:
        raise ValueError(f"max_points must be an integer >= 2, got {max_points!r}")
    y = np.asarray(y0, dtype=float)
    res0 = float(np.linalg.norm(residual(y)))
    if res0 > 1e-8:
        raise ValueError(f"the start is not a solution (residual {res0:.3e})")
    tangent = _unit_tangent(jacobian(y), np.asarray(direction, dtype=float))
    ys, arcs, residuals, checks = [y], [0.0], [res0], [assess(y)]
    h, s = float(step), 0.0
    end_reason, end_margin = f"max_points = {max_points} reached (the family is still valid there)", ""
    while len(ys) < max_points:
        y_new, res = _correct(residual, jacobian, y, tangent, h)
        if y_new is None:
            h *= 0.5
            if h < min_step_ratio * step:
                end_reason = f"continuation failed: Newton did not converge for steps down to {h:.3e}"
                break
            continue
        check = assess(y_new)
        if not check.valid:
            lo, hi, y_lo, check_lo, name = 0.0, h, None, None, check.violated[0]
            while hi - lo > 1e-13 * h:
                mid = 0.5 * (lo + hi)
                y_mid, _ = _correct(residual, jacobian, y, tangent, mid)
                if y_mid is None:
                    hi = mid
                    continue
                check_mid = assess(y_mid)
                if check_mid.valid:
                    lo, y_lo, check_lo = mid, y_mid, check_mid
                else:
                    hi, name = mid, check_mid.violated[0]
            if y_lo is not None and lo > 0:
                ys.append(y_lo)
                arcs.append(s + lo)
                residuals.append(float(np.linalg.norm(residual(y_lo))))
                checks.append(check_lo)
            end_reason, end_margin = reasons.get(name, name), name
            break
        tangent = _unit_tangent(jacobian(y_new), tangent)
        y, s = y_new, s + h
        ys.append(y)
        arcs.append(s)
        residuals.append(res)
        checks.append(check)
        h = min(step, 2.0 * h)
    return FamilyTrace(np.array(ys), np.array(arcs), np.array(residuals), checks, end_reason, end_margin, tangent)
