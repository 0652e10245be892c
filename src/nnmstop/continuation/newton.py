"""One dense Newton iteration and one bisection for the whole package.

:func:`newton_solve` iterates ``y <- y - J(y)^{-1} F(y)`` and reports what happened in a
:class:`NewtonResult` instead of raising, so that each caller decides what a failure means
(refuse a step, halve it, raise its own error). The Jacobian callable may return a dense
matrix (solved by ``numpy.linalg.solve``) or any factorization with ``solve(rhs)``, for
example the bordered factors of :func:`nnmstop.continuation.linear.factorize_bordered`
(chord iterations reuse one). The convergence test is on the Newton step (the default,
for iterations run to round-off), on the residual, or a callable of the caller.

:func:`bisect_sign_change` halves a bracket ``[a, b]`` across which a function changes
side (sign of a determinant, valid/invalid orbit) down to a given width.
Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["NewtonResult", "newton_solve", "step_converged", "round_off_criterion", "Bisection", "bisect_sign_change"]


@dataclass(frozen=True)
class NewtonResult:
    """Outcome of :func:`newton_solve`.

    Attributes
    ----------
    y : ndarray
        The last iterate (the solution when ``converged``).
    converged : bool
        The convergence test held (and the polishing update, if asked, was made).
    iterations : int
        Newton updates applied (the polishing update included).
    residual_norm : float
        The residual measure (``norm(y, F(y))``) at ``y``.
    reason : str
        Why the iteration stopped without converging ("" when it converged).
    step : ndarray or None
        The last update (None when no update was made).
    jacobian : object
        What ``jacobian`` returned for the last update (a matrix or a factorization),
        None when no update was made.
    """

    y: np.ndarray
    converged: bool
    iterations: int
    residual_norm: float
    reason: str = ""
    step: np.ndarray | None = None
    jacobian: Any = None


def step_converged(y, dy, tol: float) -> bool:
    """The default test: ``||dy|| <= tol (1 + ||y||)`` after the update ``dy`` to ``y``."""
    return bool(np.linalg.norm(dy) <= tol * (1.0 + np.linalg.norm(y)))


def round_off_criterion():
    """A convergence test for :func:`newton_solve` that runs the iteration to round-off.

    Converged once an update is below ``1e-13`` relative, or once it has stopped shrinking (by at
    least half per iteration) while below ``1e-8`` relative: the floor that the conditioning of the
    equations sets (the quarter-period equations of a model with fast modes, whose velocities at the
    turning point carry the round-off). A fresh test per iteration (it keeps the previous update).
    """
    previous = [np.inf]

    def converged(y, r, dy) -> bool:
        if dy is None:
            return False
        dy_norm = float(np.linalg.norm(dy))
        scale = 1.0 + float(np.linalg.norm(y))
        done = dy_norm <= 1e-13 * scale or (dy_norm <= 1e-8 * scale and dy_norm > 0.5 * previous[0])
        previous[0] = dy_norm
        return done

    return converged


def _euclidean(y, r) -> float:
    return float(np.linalg.norm(r))


def _linear_solve(jacobian, rhs):
    """``J^{-1} rhs`` for a dense matrix or a factorization with ``solve``."""
    if hasattr(jacobian, "solve"):
        return jacobian.solve(rhs)
    return np.linalg.solve(jacobian, rhs)


def _convergence_test(criterion, tol: float, norm: Callable) -> Callable:
    """``test(y, r, dy) -> bool`` of :func:`newton_solve`'s ``criterion``."""
    if criterion == "step":
        return lambda y, r, dy: dy is not None and step_converged(y, dy, tol)
    if criterion == "residual":
        return lambda y, r, dy: norm(y, r) <= tol
    if callable(criterion):
        return criterion
    raise ValueError(f"criterion must be 'step', 'residual' or a callable, got {criterion!r}")


def newton_solve(
    residual: Callable,
    jacobian: Callable | None,
    y0,
    *,
    tol: float,
    max_iter: int,
    criterion: str | Callable = "step",
    polish: bool = False,
    norm: Callable = _euclidean,
    stop_on_growth: bool = False,
) -> NewtonResult:
    """Newton iterations on ``F(y) = 0`` from ``y0``.

    Parameters
    ----------
    residual : callable
        ``F(y)``; with ``jacobian=None`` it returns ``(F(y), J(y))`` (when both come from
        one computation, e.g. a variational integration).
    jacobian : callable or None
        ``J(y)``: a square matrix, or an object whose ``solve(rhs)`` returns ``J^{-1} rhs``
        (a factorization; a constant one gives chord iterations).
    y0 : array_like
        Initial guess (copied).
    tol : float
        Tolerance of the built-in criteria.
    max_iter : int
        Updates allowed before giving up (the polishing update is not counted).
    criterion : {"step", "residual"} or callable
        ``"step"``: converged when :func:`step_converged` holds after an update.
        ``"residual"``: converged when ``norm(y, F(y)) <= tol``, tested on ``y0`` too.
        A callable ``criterion(y, r, dy) -> bool`` is called with ``r = F(y)`` on ``y0``
        (``dy = None``) and after every update.
    polish : bool
        After convergence, make one more update (not tested): the residual then sits at
        round-off when the criterion was on the step.
    norm : callable
        ``norm(y, r)``, the residual measure reported (and used by ``"residual"`` and
        ``stop_on_growth``); Euclidean norm of ``r`` by default.
    stop_on_growth : bool
        Give up (not converged) as soon as the residual measure grows from one iterate
        to the next after the first update: Newton is diverging, do not spend more work.

    Returns
    -------
    NewtonResult
        Never raises for non-convergence or non-finite iterates (``converged`` is False
        and ``reason`` says why); exceptions of ``residual``, ``jacobian`` or the linear
        solve (for example ``numpy.linalg.LinAlgError``) propagate.
    """
    test = _convergence_test(criterion, tol, norm)
    if not (isinstance(max_iter, (int, np.integer)) and max_iter >= 0):
        raise ValueError(f"max_iter must be an integer >= 0, got {max_iter!r}")

    def evaluate(y):
        return residual(y) if jacobian is None else (residual(y), None)

    y = np.array(y0, dtype=float)
    r, J = evaluate(y)
    dy, J_used = None, None
    measure = norm(y, r) if np.all(np.isfinite(r)) else np.inf

    def result(converged, iterations, reason=""):
        return NewtonResult(y, converged, iterations, float(measure), reason, dy, J_used)

    if not np.all(np.isfinite(r)):
        return result(False, 0, "non-finite residual at the initial guess")
    if test(y, r, None):
        return result(True, 0)
    for it in range(1, max_iter + 1):
        J_used = jacobian(y) if jacobian is not None else J
        dy = _linear_solve(J_used, -r)
        y = y + dy
        r, J = evaluate(y)
        if not (np.all(np.isfinite(y)) and np.all(np.isfinite(r))):
            measure = np.inf
            return result(False, it, f"non-finite values after {it} iterations")
        previous, measure = measure, norm(y, r)
        if test(y, r, dy):
            if polish:
                J_used = jacobian(y) if jacobian is not None else J
                dy = _linear_solve(J_used, -r)
                y = y + dy
                r, J = evaluate(y)
                measure = norm(y, r)
                return result(bool(np.all(np.isfinite(y))), it + 1)
            return result(True, it)
        if stop_on_growth and 1 < it < max_iter and measure > previous:
            return result(False, it, f"residual growing ({previous:.2e} -> {measure:.2e})")
    return result(False, max_iter, f"no convergence in {max_iter} iterations (residual {measure:.2e})")


@dataclass(frozen=True)
class Bisection:
    """Outcome of :func:`bisect_sign_change`: the final bracket and the values at its ends.

    ``lo`` is on the side of ``a`` (``value_lo = f(lo)``), ``hi`` on the side of ``b``;
    ``midpoint`` is the located point.
    """

    lo: float
    hi: float
    value_lo: Any
    value_hi: Any

    @property
    def midpoint(self) -> float:
        return 0.5 * (self.lo + self.hi)


def bisect_sign_change(
    f: Callable,
    a: float,
    b: float,
    *,
    tol: float,
    side: Callable = np.sign,
    f_a=None,
    f_b=None,
    max_iter: int = 200,
) -> Bisection:
    """Bisect ``[a, b]`` (either order) until its width is at most ``tol``.

    Parameters
    ----------
    f : callable
        ``f(x)``, any value; ``side(f(x))`` tells on which side of the change ``x`` lies.
    a, b : float
        The bracket; ``side(f(a)) != side(f(b))`` is required.
    tol : float
        Width (absolute, > 0) at which bisection stops.
    side : callable
        Maps a value of ``f`` to a comparable label: the sign by default; e.g.
        ``lambda v: v.valid`` for a function returning an assessment.
    f_a, f_b : optional
        ``f(a)`` and ``f(b)`` when the caller knows them (not evaluated again).
    max_iter : int
        Bound on the halvings (a width of ``2**-200`` of the bracket is below round-off).

    Raises
    ------
    ValueError
        If ``tol`` is not > 0 or ``f`` is on the same side at both ends.
    """
    if not (np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be finite and > 0, got {tol!r}")
    lo, hi = float(a), float(b)
    value_lo = f(lo) if f_a is None else f_a
    value_hi = f(hi) if f_b is None else f_b
    side_lo = side(value_lo)
    if side(value_hi) == side_lo:
        raise ValueError(f"no sign change between {a!r} and {b!r}: f is on the same side ({side_lo!r}) at both")
    for _ in range(max_iter):
        if abs(hi - lo) <= tol:
            break
        mid = 0.5 * (lo + hi)
        value = f(mid)
        if side(value) == side_lo:
            lo, value_lo = mid, value
        else:
            hi, value_hi = mid, value
    return Bisection(lo, hi, value_lo, value_hi)
