r"""The stiffness as a sum of squares, ``K = G^T G``, and the solves that keep its accuracy.

A finite-element stiffness is a sum of element strain energies, ``K = sum_e B_e^T D_e B_e = G^T G`` with
``G`` the element strains weighted by the square roots of their stiffness (the *stiffness root*: for a
beam, the curvature at each end of each element). On a fine beam mesh the condition of ``K`` grows as the
number of elements to the fourth power: forming ``K`` in floating point and factoring it loses that many
digits on the lowest modes (at 5e4 elements, all of them). Through ``G`` a solve loses only the condition of
``G``, the square root of that of ``K``, and an energy ``|G v|^2`` is a sum of squares, with no cancellation:

* :class:`RootSolver` solves ``K x = b`` and the least-squares problems of a static condensation by one sparse
  LU of the augmented system ``[[I, G], [G^T, 0]]`` (its condition is that of ``G``);
* :func:`energy_matrix` is ``(G V)^T (G V)``, the stiffness projected on a basis ``V``.

Method note: ``docs/reduction.md`` (round-off on fine meshes).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

__all__ = ["RootSolver", "check_root", "energy_matrix", "fixed_order_product"]


def check_root(root, stiffness, where: str = "stiffness_root"):
    """``root`` as a CSR matrix whose ``G^T G`` is ``stiffness`` to round-off, else ValueError naming it."""
    root = scipy.sparse.csr_matrix(root, dtype=float)
    n = stiffness.shape[0]
    if root.ndim != 2 or root.shape[1] != n:
        raise ValueError(f"{where} must have the {n} columns of the stiffness (one per DOF), got shape {root.shape}")
    if not np.all(np.isfinite(root.data)):
        raise ValueError(f"{where} has non-finite entries")
    product = (root.T @ root).tocsr()
    difference = abs(product - scipy.sparse.csr_matrix(stiffness)).max()
    scale = abs(scipy.sparse.csr_matrix(stiffness)).max()
    if not difference <= 1e-9 * scale:
        raise ValueError(
            f"{where}: G^T G differs from the stiffness by {difference:.3e} ({difference / scale:.1e} of its largest "
            "entry): it is not the root of this stiffness (a stiffness changed without its root?)"
        )
    return root


def fixed_order_product(a, b) -> np.ndarray:
    """``a^T b`` for tall dense ``a`` and ``b``, summed in one fixed order (a sparse product's loop, not BLAS).

    A BLAS product's summation order moves with its threads and CPU kernel; a projection onto a basis of
    10^5 rows then differs at ``1e-14`` between two machines, and a stored orbit checked against a rebuilt
    reduced structure sees it. This loop gives the same bits everywhere."""
    return np.asarray(scipy.sparse.csr_matrix(np.asarray(a, dtype=float).T) @ np.asarray(b, dtype=float))


def energy_matrix(root, basis) -> np.ndarray:
    """``(G V)^T (G V)``: the stiffness projected on the columns of ``basis``, symmetric by construction."""
    strains = root @ np.asarray(basis, dtype=float)
    return fixed_order_product(strains, strains)


class RootSolver:
    """Solves with ``K = G^T G`` through the augmented system ``[[I, G], [G^T, 0]]`` (one sparse LU).

    ``G`` (``m x n``) must have full column rank: the structure held, no rigid-body mode (else ValueError).

    Examples
    --------
    A chain of three springs to the ground, ``G`` the spring elongations:

    >>> import numpy as np
    >>> G = np.array([[1.0, 0.0, 0.0], [-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]])
    >>> x = RootSolver(G).solve(np.array([0.0, 0.0, 1.0]))
    >>> np.round(x, 12).tolist()
    [1.0, 2.0, 3.0]
    """

    def __init__(self, root):
        root = scipy.sparse.csc_matrix(root, dtype=float)
        self.root = root
        m, n = root.shape
        augmented = scipy.sparse.bmat([[scipy.sparse.identity(m), root], [root.T, None]], format="csc")
        try:
            self._lu = scipy.sparse.linalg.splu(augmented)
        except RuntimeError:
            raise ValueError(
                "the stiffness root G is rank-deficient (K = G^T G singular): the structure is free to move "
                "(hold it: a clamped or pinned end, or more boundary DOFs)"
            ) from None
        self._m, self._n = m, n

    def least_squares(self, offset) -> tuple:
        """``(x, r)``: ``x`` minimizes ``|G x + c|`` for each column ``c`` of ``offset`` (``m`` rows), ``r = G x + c``.

        ``G^T r = 0``, so ``x = -K^-1 G^T c`` and ``r^T r`` is the energy left, computed without cancellation.
        """
        offset = np.asarray(offset, dtype=float)
        rhs = np.concatenate([-offset, np.zeros((self._n,) + offset.shape[1:])])
        y = self._lu.solve(rhs)
        return y[self._m :], -y[: self._m]

    def solve(self, b) -> np.ndarray:
        """``x`` with ``K x = b`` (``b``: ``n`` rows, one or several columns)."""
        b = np.asarray(b, dtype=float)
        rhs = np.concatenate([np.zeros((self._m,) + b.shape[1:]), -b])
        return self._lu.solve(rhs)[self._m :]
