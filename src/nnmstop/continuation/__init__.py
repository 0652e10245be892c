"""Continuation of solution curves: the ANM (with Pade) and Newton pseudo-arclength.

Branch points (location, tangents, switching): :mod:`nnmstop.continuation.branch_points`.
Shared numerics for the whole package: :func:`newton_solve` and :func:`bisect_sign_change`
(:mod:`nnmstop.continuation.newton`), :func:`factorize_bordered` (:mod:`nnmstop.continuation.linear`).
"""

from nnmstop.continuation.linear import BorderedFactorization, factorize_bordered
from nnmstop.continuation.newton import Bisection, NewtonResult, bisect_sign_change, newton_solve

__all__ = [
    "BorderedFactorization",
    "factorize_bordered",
    "Bisection",
    "NewtonResult",
    "bisect_sign_change",
    "newton_solve",
]
