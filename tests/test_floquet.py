"""The multiplier pair from the invariant s = mu + 1/mu (nnmstop.floquet), against closed forms."""

import numpy as np
import pytest

from nnmstop.floquet import multipliers_from_invariant


def test_elliptic_pairs_are_the_rotations_of_their_angle():
    theta = np.linspace(0.0, np.pi, 13)
    mu = multipliers_from_invariant(2.0 * np.cos(theta))
    np.testing.assert_allclose(mu[:, 2], np.exp(1j * theta), atol=1e-15)  # non-negative imaginary part
    np.testing.assert_allclose(mu[:, 3], np.exp(-1j * theta), atol=1e-15)
    np.testing.assert_array_equal(mu[:, :2], 1.0)


@pytest.mark.parametrize("mu_big", [1.0 + 1e-9, 3.0, 1e8, -1.0 - 1e-9, -7.5, -1e12])
def test_hyperbolic_pairs_are_the_real_roots_without_cancellation(mu_big):
    mu = multipliers_from_invariant(mu_big + 1.0 / mu_big)
    assert mu[2].imag == mu[3].imag == 0.0
    assert mu[2].real == pytest.approx(mu_big, rel=1e-12 if abs(mu_big) > 2 else 1e-4)
    assert mu[2].real * mu[3].real == pytest.approx(1.0, rel=1e-15)  # a symplectic pair
    assert abs(mu[2]) >= abs(mu[3])
