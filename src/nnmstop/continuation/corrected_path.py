"""The branch between two of its points as a path, by Newton in parallel hyperplanes.

A method whose steps have no analytic representation (Newton pseudo-arclength) still has
to give a path ``a -> U(a)`` over a step, on the branch all along it, for branch points
and folds to be located after the continuation (:mod:`nnmstop.continuation.driver`).
:class:`CorrectedPath` is that path, parametrized as the ANM series from the same start:
``a = <U - U_0, t_0>``; ``U(a)`` is the point of the branch in the hyperplane
``<U - U_0, t_0> = a``.

Near a simple branch point that hyperplane meets both crossing curves close to each
other: the point is a nearly double root, determined only to about the square root of
the residual's round-off. There the path is the cubic Hermite interpolant between points
a fixed fraction of the step away on either side, which Newton determines to round-off.
Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import numpy as np

from nnmstop.continuation.core import ContinuationError, relative_of_residual
from nnmstop.continuation.linear import factorize_bordered
from nnmstop.continuation.newton import newton_solve

__all__ = ["CorrectedPath", "newton_in_hyperplane"]


def newton_in_hyperplane(system, U0, t0, a: float, guess, tol: float, max_iter: int, stats=None):
    """Newton on ``S(U) = 0`` in the hyperplane ``<U - U0, t0> = a`` from ``guess``, iterated to round-off.

    Converged once the relative residual is at most ``tol`` and the update has stopped shrinking (or
    is below ``1e-14`` relative): the point is then the hyperplane's solution to round-off. Returns
    the :class:`~nnmstop.continuation.newton.NewtonResult` (its ``jacobian`` the factors of
    ``[J; t0^T]`` of the last update).
    """

    def residual(V):
        return np.append(system.residual(V), np.dot(t0, V - U0) - a)

    last_update = [np.inf]

    def converged(V, r, dU):
        if dU is None:
            return False
        update, previous = float(np.linalg.norm(dU)), last_update[0]
        last_update[0] = update
        if relative_of_residual(V, r[:-1]) > tol:
            return False
        return update <= 1e-14 * (1.0 + np.linalg.norm(V)) or update >= previous

    return newton_solve(
        residual,
        lambda V: factorize_bordered(system, V, t0, stats, singular_tol=None),
        guess,
        tol=tol,
        max_iter=max_iter,
        criterion=converged,
    )


class CorrectedPath:
    """The branch from ``U0`` (unit tangent ``t0``) to ``U1`` as a path ``a -> U(a)``, ``a = <U - U0, t0>``.

    Parameters
    ----------
    system : object
        ``residual`` and ``jacobian`` (or ``factorize_bordered``) of the curve's equations.
    U0, t0, U1 : ndarray
        Start, unit tangent there, end (both points on the branch, ``U1`` ahead along ``t0``).
    tol : float
        Relative residual that a Newton point must reach (it is then iterated to round-off).
    max_iter : int
        Newton iterations per point.
    near_singular : float
        A point whose bordered matrix ``[J; t0^T]`` has a smallest LU pivot below
        ``near_singular`` times the largest is taken from the Hermite interpolant instead.
    span : float
        Half-width of that interpolant, as a fraction of the path length.

    Calls raise ContinuationError when Newton does not converge.
    """

    def __init__(
        self,
        system,
        U0,
        t0,
        U1,
        tol: float = 1e-10,
        max_iter: int = 60,
        near_singular: float = 1e-6,
        span: float = 1e-4,
    ):
        self.system, self.U0, self.t0 = system, np.asarray(U0, float), np.asarray(t0, float)
        U1 = np.asarray(U1, float)
        self.length = float(np.dot(U1 - self.U0, self.t0))
        if not self.length > 0:
            raise ValueError(f"the end point is not ahead of the start along t0 (parameter {self.length:.3g})")
        self.tol, self.max_iter, self.near_singular, self.span = tol, max_iter, near_singular, span
        # points computed so far, by increasing a: the guesses interpolate between neighbours
        self._a, self._U = [0.0, self.length], [self.U0, U1]
        self._interpolated: dict = {}

    def border(self, a: float) -> np.ndarray:
        """``t0``: ``<dU/da, t0> = 1`` all along the path, and ``t0`` needs no solve with the
        bordered matrix, which is singular at a branch point (any border is, there)."""
        return self.t0

    def __call__(self, a: float, derivative: bool = False) -> np.ndarray:
        a = float(a)
        U = self._point(a)
        if a in self._interpolated:
            return self._interpolated[a](a, derivative)
        return self._derivative(U) if derivative else U

    def _derivative(self, U) -> np.ndarray:
        """``dU/da``: ``J dU/da = 0``, ``<t0, dU/da> = 1``."""
        rhs = np.zeros(len(U))
        rhs[-1] = 1.0
        return factorize_bordered(self.system, U, self.t0, singular_tol=None).solve(rhs)

    def _remember(self, a: float, U) -> None:
        k = int(np.searchsorted(self._a, a))
        self._a.insert(k, a)
        self._U.insert(k, U)

    def _point(self, a: float, interpolate: bool = True) -> np.ndarray:
        k = int(np.searchsorted(self._a, a))
        if k < len(self._a) and self._a[k] == a:
            return self._U[k]
        lo, hi = min(max(k - 1, 0), len(self._a) - 2), min(max(k, 1), len(self._a) - 1)
        w = (a - self._a[lo]) / (self._a[hi] - self._a[lo])
        guess = (1.0 - w) * self._U[lo] + w * self._U[hi]
        result = self._newton(a, guess)
        factors = result.jacobian
        singular = getattr(factors, "is_singular", lambda tol: False)(self.near_singular)
        if interpolate and (singular or not result.converged):
            curve = self._hermite(a)
            U = curve(a, False)
            self._interpolated[a] = curve
        elif result.converged:
            U = result.y
        else:
            raise ContinuationError(f"path point at a = {a:.6g} of [0, {self.length:.6g}]: {result.reason}")
        self._remember(a, U)
        return U

    def _newton(self, a: float, guess):
        return newton_in_hyperplane(self.system, self.U0, self.t0, a, guess, self.tol, self.max_iter)

    def _hermite(self, a: float):
        """Cubic Hermite interpolant of the path over ``[a - h, a + h]`` (within the path), ``h = span * length``."""
        h = self.span * self.length
        a_lo, a_hi = max(a - h, 0.0), min(a + h, self.length)
        ends = [self._point(b, interpolate=False) for b in (a_lo, a_hi)]
        slopes = [self._derivative(U) for U in ends]
        width = a_hi - a_lo

        def curve(b: float, derivative: bool = False) -> np.ndarray:
            s = (b - a_lo) / width
            if derivative:
                weights = np.array([6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s])
                weights[[0, 2]] /= width
            else:
                weights = np.array(
                    [
                        2 * s**3 - 3 * s**2 + 1,
                        (s**3 - 2 * s**2 + s) * width,
                        -2 * s**3 + 3 * s**2,
                        (s**3 - s**2) * width,
                    ]
                )
            return weights[0] * ends[0] + weights[1] * slopes[0] + weights[2] * ends[1] + weights[3] * slopes[1]

        return curve
