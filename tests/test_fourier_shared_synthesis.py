"""A phase synthesis kept by the caller and shared by several orbits (fourier.fields_at_phases(synthesis=...))."""

import numpy as np
import pytest

from nnmstop import fourier

H = 2
THETA = np.array([-0.4, 0.0, 1.1, 3.0, 5.9])


def test_one_synthesis_serves_two_series_on_the_same_phases():
    at = fourier.PhaseSynthesis(THETA, H)
    omega = 0.8
    # x1 = 1 + cos(theta); x2 = sin(2 theta) - 0.5 cos(2 theta)
    first = {"x": (np.array([1.0, 1.0, 0.0]), np.zeros(3))}
    second = {"x": (np.array([0.0, 0.0, -0.5]), np.array([0.0, 0.0, 1.0]))}
    one = fourier.fields_at_phases(THETA, omega, first, synthesis=at)
    two = fourier.fields_at_phases(THETA, omega, second, synthesis=at)
    np.testing.assert_allclose(one["x"], 1.0 + np.cos(THETA), rtol=0, atol=1e-14)
    np.testing.assert_allclose(one["xdot"], -omega * np.sin(THETA), rtol=0, atol=1e-14)
    np.testing.assert_allclose(two["x"], np.sin(2 * THETA) - 0.5 * np.cos(2 * THETA), rtol=0, atol=1e-14)
    np.testing.assert_allclose(two["xdot"], omega * (2 * np.cos(2 * THETA) + np.sin(2 * THETA)), rtol=0, atol=1e-14)


@pytest.mark.parametrize("phases, harmonics", [(THETA[:3], H), (THETA, H + 1)])
def test_a_synthesis_for_other_phases_or_harmonics_is_refused(phases, harmonics):
    series = {"x": (np.ones(H + 1), np.zeros(H + 1))}
    with pytest.raises(ValueError, match="the synthesis is for"):
        fourier.fields_at_phases(THETA, 1.0, series, synthesis=fourier.PhaseSynthesis(phases, harmonics))
