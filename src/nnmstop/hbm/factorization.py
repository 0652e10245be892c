"""LU factors of the bordered Jacobian ``[J(U); t^T]``, dense or sparse, behind one interface.

A continuation step factors the bordered matrix once and back-substitutes many times
(about twenty right-hand sides per ANM series), and branch-point detection reads the sign
of its determinant. The dense factors (LAPACK's partial-pivoting LU of the full matrix, for
small systems such as the paper's oscillator) are
:class:`nnmstop.continuation.linear.BorderedFactorization`; :class:`SparseBorderedLU` here is
SuperLU on the sparse matrix, reordered by the caller so that elimination follows the structure
of the harmonic-balance Jacobian (see docs/methods/hbm_structure.md). Both offer ``solve``,
``determinant_sign``, ``pivot_ratio`` (smallest over largest ``|U_ii|``) and ``is_singular(tol)``,
the test of near-singularity the continuation applies.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

__all__ = ["SparseBorderedLU", "CondensedBorderedLU", "StopCoupling", "Channel", "permutation_parity"]


def permutation_parity(perm) -> int:
    """Parity (0 even, 1 odd) of a permutation given as an array of the images of ``0 .. n-1``."""
    perm = np.asarray(perm)
    seen = np.zeros(len(perm), dtype=bool)
    cycles = 0
    for start in range(len(perm)):
        if seen[start]:
            continue
        cycles += 1
        j = start
        while not seen[j]:
            seen[j] = True
            j = perm[j]
    return (len(perm) - cycles) % 2


def _finite_or_error(x, what: str):
    if not np.all(np.isfinite(x)):
        raise np.linalg.LinAlgError(f"bordered solve failed: non-finite values in the {what}")
    return x


class SparseBorderedLU:
    """Sparse LU of ``[J; t^T]`` for a sparse ``J`` (one row fewer than columns) and a dense ``t``.

    The dense bordering row is kept out of the sparse factors: SuperLU factors
    ``A = [J; e_k^T]`` with ``k`` the largest component of ``t`` (a local parametrization,
    nonsingular wherever the bordered matrix is), and ``[J; t^T] = A + e_n w^T`` with
    ``w = t - e_k`` is solved by the Sherman-Morrison formula. In ``A`` every row is sparse, so
    threshold pivoting never promotes a dense row into the elimination and the fill stays where
    the order puts it.

    Parameters
    ----------
    jacobian : scipy.sparse matrix
        ``J``, shape ``(n - 1, n)``.
    tangent : ndarray
        ``t``, length ``n``.
    order : ndarray of int
        Elimination order, applied to rows and columns of ``A`` alike (so the determinant keeps
        its sign); SuperLU keeps it (``permc_spec="NATURAL"``) and pivots on rows by threshold.
    pivot_threshold : float
        SuperLU's ``diag_pivot_thresh``: the diagonal entry is kept as pivot when it is at
        least this fraction of the largest one of its column, which preserves the order.
    column_ordering : str
        SuperLU's ``permc_spec`` applied after ``order``; "NATURAL" keeps ``order`` (the
        benchmark compares "COLAMD").
    """

    def __init__(self, jacobian, tangent, order, pivot_threshold: float = 0.1, column_ordering: str = "NATURAL"):
        order = np.asarray(order)
        tangent = np.asarray(tangent, dtype=float)
        n = len(tangent)
        if jacobian.shape != (n - 1, n) or sorted(order.tolist()) != list(range(n)):
            raise ValueError(f"need J of shape ({n - 1}, {n}) and an order of 0..{n - 1}, got J {jacobian.shape}")
        _finite_or_error(tangent, "tangent")
        k = int(np.argmax(np.abs(tangent)))
        coo = sp.coo_matrix(jacobian)
        _finite_or_error(coo.data, "Jacobian")
        # A = [J; e_k^T] with rows and columns renumbered by the order, assembled directly
        position = np.empty(n, dtype=np.int64)
        position[order] = np.arange(n)
        rows = position[np.append(coo.row, n - 1)]
        cols = position[np.append(coo.col, k)]
        square = sp.csc_matrix((np.append(coo.data, 1.0), (rows, cols)), shape=(n, n))
        self.order = order
        self.lu = splu(square, permc_spec=column_ordering, diag_pivot_thresh=pivot_threshold)
        self._w = tangent.copy()
        self._w[k] -= 1.0
        e_last = np.zeros(n)
        e_last[-1] = 1.0
        self._v = self._solve_square(e_last)
        self._denominator = 1.0 + self._w @ self._v
        diagonal = np.abs(self.lu.U.diagonal())
        ratio = diagonal.min() / diagonal.max() if diagonal.max() > 0 else 0.0
        border = abs(self._denominator) / max(1.0, np.linalg.norm(self._w) * np.linalg.norm(self._v))
        self.pivot_ratio = float(min(ratio, border))

    def _solve_square(self, rhs):
        x = np.empty_like(rhs)
        x[self.order] = self.lu.solve(np.ascontiguousarray(rhs[self.order]))
        return x

    def solve(self, rhs):
        """Solution of ``[J; t^T] x = rhs`` (one right-hand side, or one per column of a 2-D array)."""
        y = self._solve_square(np.asarray(rhs, dtype=float))
        correction = (self._w @ y) / self._denominator
        x = y - (np.multiply.outer(self._v, correction) if y.ndim == 2 else self._v * correction)
        return _finite_or_error(x, "solution")

    def determinant_sign(self) -> int:
        """Sign of ``det [J; t^T] = det A (1 + w^T A^-1 e_n)``; ``det A`` from ``Pr A Pc = L U`` (unit ``L``)."""
        negative = np.count_nonzero(self.lu.U.diagonal() < 0) + (self._denominator < 0)
        parity = negative + permutation_parity(self.lu.perm_r) + permutation_parity(self.lu.perm_c)
        return -1 if parity % 2 else 1

    def is_singular(self, tol: float) -> bool:
        """``pivot_ratio`` is at most ``tol`` (singular to working precision for ``tol`` ~ 1e-14)."""
        return self.pivot_ratio <= tol


class Channel(NamedTuple):
    """One component of a stop in :class:`StopCoupling`: its force rows and how its ``g`` enters the ``z`` rows.

    ``f``: slice of the component's force coefficients (rows and columns; the same in the condensed ordering);
    ``Mf``: the multiplication matrix of its force (the ``(f, z)`` block is ``c Mf``); ``Mg``: of its
    ``g = f / alpha - x`` when ``z = sum g**2`` (None: the identity, ``z = g``); ``q_terms``: ``(slice, factor)``
    of every DOF its coordinate reads, ``factor`` including the sign and ``2 / gap`` (or ``1 / gap``);
    ``f_factor``: ``-2 / alpha`` (or ``-1 / alpha``). The ``z`` rows hold ``Mg`` (or the identity) times these
    factors in ``(q, f)``.
    """

    f: slice
    Mf: np.ndarray
    Mg: np.ndarray | None
    q_terms: tuple
    f_factor: float

    def g_part(self, x) -> np.ndarray:
        """The factors applied to the ``q`` and ``f`` parts of ``x``: ``sum factor x[q] + f_factor x[f]``."""
        (q, factor), rest = self.q_terms[0], self.q_terms[1:]
        out = factor * x[q]
        for q, factor in rest:
            out = out + factor * x[q]
        return out + self.f_factor * x[self.f]


class StopCoupling(NamedTuple):
    """One stop's dense Jacobian blocks, and how its ``z`` unknowns enter :class:`CondensedBorderedLU`.

    ``z``: slice of its ``z`` coefficients (rows and columns); ``Mz``: the multiplication matrix of ``z``;
    ``coefficient``: ``c`` of its force equations ``f - eta x + c f z = 0`` (-1 for the paper's stop);
    ``channels``: one :class:`Channel` per component. Each force row block holds ``I + c Mz`` in its ``f`` and
    ``c Mf`` in ``z``; the ``z`` rows hold ``C = sum_channels Mg [factors]`` in ``(q, f)`` and the identity in ``z``.
    """

    z: slice
    Mz: np.ndarray
    coefficient: float
    channels: tuple

    def z_from(self, x) -> np.ndarray:
        """``C x``: the ``z`` rows' product with the ``q`` and ``f`` parts of ``x``."""
        out = None
        for channel in self.channels:
            part = channel.g_part(x)
            part = part if channel.Mg is None else channel.Mg @ part
            out = part if out is None else out + part
        return out


class CondensedBorderedLU:
    """LU of a harmonic-balance ``[J; t^T]`` with the ``z`` unknowns condensed out.

    The rows of every stop's ``z`` equation (``z = sum (f_c / alpha - x_c)^2``, or ``z = f / alpha - x`` for a
    one-sided law) have the identity as their block in ``z``: ``z = r_z - C v`` solves them for any other
    unknowns ``v``, so the matrix is the block ``[[A, B], [C, I]]`` (rows and columns of ``z`` moved last,
    which keeps the determinant's sign: both move past the same number of rows and columns) and
    ``det = det(S)`` with the Schur complement ``S = A - B C``, factored here by LAPACK with partial pivoting:
    exact for every law. ``B`` is nonzero in the force rows (``c M_f``) and in the bordering row; ``C`` is
    ``M_g`` (or the identity) times a combination of the stop's DOFs' and its forces' coefficients.
    Built by :meth:`nnmstop.hbm.system.HarmonicBalanceSystem.factorize_bordered`.

    Parameters
    ----------
    factors : BorderedFactorization
        LU of ``S`` (rows: the kept equations, then the bordering row).
    condensed : slice
        The ``z`` unknowns (and their rows), one block in the full ordering; the others keep their order.
    couplings : list of StopCoupling
        One per stop (:class:`StopCoupling`).
    tangent : ndarray
        The bordering row.
    """

    def __init__(self, factors, condensed: slice, couplings, tangent):
        self.factors = factors
        self.condensed = condensed
        self.couplings = couplings
        self.tangent = tangent
        self.pivot_ratio = factors.pivot_ratio

    def solve(self, rhs) -> np.ndarray:
        """Solution of ``[J; t^T] x = rhs`` (one right-hand side, or one per column of a 2-D array)."""
        rhs = np.asarray(rhs, dtype=float)
        start, stop_ = self.condensed.start, self.condensed.stop
        reduced = np.concatenate([rhs[:start], rhs[stop_:]])
        for stop in self.couplings:
            r_z = rhs[stop.z]
            for channel in stop.channels:
                reduced[channel.f] -= stop.coefficient * (channel.Mf @ r_z)
            reduced[-1] -= self.tangent[stop.z] @ r_z
        v = self.factors.solve(reduced)
        x = np.empty_like(rhs)
        x[:start], x[stop_:] = v[:start], v[start:]
        for stop in self.couplings:
            x[stop.z] = rhs[stop.z] - stop.z_from(x)
        return _finite_or_error(x, "solution")

    def determinant_sign(self) -> int:
        """Sign of ``det [J; t^T] = det S``."""
        return self.factors.determinant_sign()

    def is_singular(self, tol: float) -> bool:
        """``pivot_ratio`` (of the factors of ``S``) is at most ``tol``."""
        return self.pivot_ratio <= tol
