"""The bordered factorization shared by the continuation methods (nnmstop.continuation.linear)."""

from __future__ import annotations

import numpy as np
import pytest

from nnmstop.continuation import factorize_bordered
from nnmstop.continuation.core import ContinuationStats


class MatrixSystem:
    """A 'system' whose Jacobian is a fixed ``n x (n + 1)`` matrix."""

    def __init__(self, J):
        self.J = np.asarray(J, float)

    def jacobian(self, U):
        return self.J


def test_solve_and_determinant_sign_match_numpy():
    rng = np.random.default_rng(12)
    for n in (1, 4, 9):
        J = rng.standard_normal((n, n + 1))
        for _ in range(4):
            t = rng.standard_normal(n + 1)
            A = np.vstack([J, t])
            stats = ContinuationStats()
            factors = factorize_bordered(MatrixSystem(J), np.zeros(n + 1), t, stats)
            assert stats.factorizations == 1
            rhs = rng.standard_normal(n + 1)
            np.testing.assert_allclose(factors.solve(rhs), np.linalg.solve(A, rhs), rtol=1e-10, atol=1e-12)
            assert factors.determinant_sign() == int(np.sign(np.linalg.det(A)))
            # det [J; b^T] is linear in b: the opposite border flips the sign
            assert factorize_bordered(MatrixSystem(J), None, -t).determinant_sign() == -factors.determinant_sign()


def test_singular_bordered_matrix_is_refused_unless_asked():
    J = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    border = np.array([1.0, 0.0, 1e-16])  # nearly orthogonal to the null vector e_3: det = 1e-16
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        factorize_bordered(MatrixSystem(J), None, border)
    factors = factorize_bordered(MatrixSystem(J), None, border, singular_tol=None)
    assert factors.determinant_sign() == 1
    assert factorize_bordered(MatrixSystem(J), None, -border, singular_tol=None).determinant_sign() == -1


def test_a_system_with_its_own_factorization_is_delegated_to():
    calls = []

    class Own(MatrixSystem):
        def factorize_bordered(self, U, tangent):
            calls.append((U, tangent))
            return "own factors"

    stats = ContinuationStats()
    out = factorize_bordered(Own(np.eye(2, 3)), "U", "t", stats)
    assert out == "own factors" and calls == [("U", "t")] and stats.factorizations == 1
