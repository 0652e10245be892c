"""The bordered matrix ``[J(U); t^T]`` of a continuation, factorized once and reused.

Every continuation method solves with the Jacobian ``J`` of the ``n`` equations in the
``n + 1`` unknowns, bordered by a row ``t^T`` (the unit tangent, or a direction): the
ANM for all orders of its series, the pseudo-arclength corrector for one Newton update,
both for the tangent ``[J; t^T] x = e_{n+1}``. The sign of its determinant changes across
a simple branch point, not across a fold (``docs/methods/continuation.md``).

:func:`factorize_bordered` is the one place where that matrix is factorized: dense LU
(LAPACK ``getrf``/``getrs`` through SciPy) by default, or the system's own
``factorize_bordered(U, tangent)`` when it has one (a sparse or structured solver for
large models), as long as that returns an object with ``solve(rhs)`` and
``determinant_sign()`` (and, optionally, ``is_singular(tol)``, which lets the
pseudo-arclength path recognize a nearly double root near a branch point).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lu_factor
from scipy.linalg.lapack import dgetrs

__all__ = ["BorderedFactorization", "factorize_bordered"]


class BorderedFactorization:
    """Dense LU factors of a bordered matrix (``scipy.linalg.lu_factor`` layout).

    Parameters
    ----------
    lu, pivots : ndarray
        The factors and LAPACK pivot indices of ``lu_factor``.
    """

    def __init__(self, lu, pivots):
        self.lu = lu
        self.pivots = pivots
        magnitudes = np.abs(np.diag(lu))
        #: Smallest over largest ``|U_ii|`` (0 when every pivot is 0), as the sparse factors report it.
        self.pivot_ratio = float(magnitudes.min() / magnitudes.max()) if magnitudes.max() > 0 else 0.0

    @classmethod
    def of_matrix(cls, matrix, overwrite: bool = False) -> BorderedFactorization:
        """Factorize a square matrix (it must be finite); ``overwrite`` factors a Fortran-ordered one in place."""
        return cls(*lu_factor(matrix, overwrite_a=overwrite, check_finite=True))

    def solve(self, rhs) -> np.ndarray:
        """``A^{-1} rhs`` by LAPACK ``getrs``.

        The factors were checked finite when they were made; a non-finite right-hand side
        shows in the (short) solution, which is checked instead of the operands.

        Raises
        ------
        numpy.linalg.LinAlgError
            If LAPACK reports an error or the solution is not finite.
        """
        x, info = dgetrs(self.lu, self.pivots, rhs)
        if info != 0 or not np.all(np.isfinite(x)):
            raise np.linalg.LinAlgError(f"bordered solve failed (getrs info {info}, or non-finite values)")
        return x

    def determinant_sign(self) -> int:
        """Sign of the determinant: row swaps and negative pivots each flip it."""
        swaps = np.count_nonzero(self.pivots != np.arange(len(self.pivots)))
        negative = np.count_nonzero(np.diag(self.lu) < 0)
        return -1 if (swaps + negative) % 2 else 1

    def is_singular(self, tol: float) -> bool:
        """``pivot_ratio`` is at most ``tol`` (singular to working precision for ``tol`` ~ 1e-14)."""
        return self.pivot_ratio <= tol


def factorize_bordered(system, U, tangent, stats=None, *, singular_tol: float | None = 1e-14):
    """Factors of ``[J(U); tangent^T]``.

    Parameters
    ----------
    system : object
        Provides ``jacobian(U)`` (``n x (n + 1)``), or ``factorize_bordered(U, tangent)``,
        which is then used instead of the dense LU.
    U, tangent : ndarray
        The point and the bordering row (length ``n + 1``).
    stats : ContinuationStats, optional
        The factorization is counted in ``stats.factorizations``.
    singular_tol : float or None
        The factors are refused when their ``is_singular(singular_tol)`` holds (dense: the
        smallest pivot is at most ``singular_tol`` times the largest; a system's own factors
        without ``is_singular`` are accepted); None accepts any (for sign evaluations close to
        a branch point).

    Returns
    -------
    object
        With ``solve(rhs)`` and ``determinant_sign()`` (a :class:`BorderedFactorization`
        for the dense path).

    Raises
    ------
    numpy.linalg.LinAlgError
        If the matrix is singular to working precision (``singular_tol``).
    ValueError
        If the matrix holds non-finite values.
    """
    if stats is not None:
        stats.factorizations += 1
    own = getattr(system, "factorize_bordered", None)
    if own is not None:
        factors = own(U, tangent)
    else:
        factors = BorderedFactorization.of_matrix(np.vstack([system.jacobian(U), np.asarray(tangent)[None, :]]))
    # a system's own factors are held to the same test when they offer it
    if singular_tol is not None and getattr(factors, "is_singular", lambda tol: False)(singular_tol):
        raise np.linalg.LinAlgError("bordered Jacobian is singular to working precision")
    return factors
