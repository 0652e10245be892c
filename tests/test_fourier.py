"""Fourier layouts and synthesis (nnmstop.fourier) against closed-form trigonometric polynomials."""

import numpy as np
import pytest

from nnmstop import fourier

H = 4
# p(theta) = 0.5 + 2 cos(theta) - 0.3 sin(theta) + 0.7 cos(3 theta) + 1.1 sin(4 theta)
FULL = np.array([0.5, 2.0, 0.0, 0.7, 0.0, -0.3, 0.0, 0.0, 1.1])


def polynomial(theta):
    return 0.5 + 2 * np.cos(theta) - 0.3 * np.sin(theta) + 0.7 * np.cos(3 * theta) + 1.1 * np.sin(4 * theta)


def polynomial_derivative(theta):
    return -2 * np.sin(theta) - 0.3 * np.cos(theta) - 2.1 * np.sin(3 * theta) + 4.4 * np.cos(4 * theta)


def test_uniform_grid_synthesis_is_the_polynomial():
    m = 32
    theta = 2 * np.pi * np.arange(m) / m
    np.testing.assert_allclose(fourier.to_time(FULL, H, m), polynomial(theta), rtol=0, atol=1e-13)
    np.testing.assert_allclose(fourier.synthesis_matrix(H, m) @ FULL, polynomial(theta), rtol=0, atol=1e-13)


def test_synthesis_at_arbitrary_phases_and_its_derivative():
    theta = np.array([-1.3, 0.0, 0.2, 2.9, 7.5])
    cos, sin = fourier.to_cos_sin(FULL, H)
    at = fourier.PhaseSynthesis(theta, H)
    np.testing.assert_allclose(at.values(cos, sin), polynomial(theta), rtol=0, atol=1e-13)
    np.testing.assert_allclose(at.theta_derivative(cos, sin), polynomial_derivative(theta), rtol=0, atol=1e-13)
    omega = 1.7
    fields = fourier.fields_at_phases(theta, omega, {"x": (cos, sin), "f": (cos, sin)})
    np.testing.assert_allclose(fields["xdot"], omega * polynomial_derivative(theta), rtol=0, atol=1e-12)
    assert "fdot" not in fields


def test_derivative_coefficients_match_the_closed_form():
    m = 64
    theta = 2 * np.pi * np.arange(m) / m
    d = fourier.derivative(FULL, H)
    np.testing.assert_allclose(fourier.to_time(d, H, m), polynomial_derivative(theta), rtol=0, atol=1e-12)
    # second derivative of a cosine series: -k^2 on each coefficient, as two first derivatives
    cosine = FULL[: H + 1]
    twice = fourier.derivative(fourier.derivative(cosine, H), H)[: H + 1]
    np.testing.assert_allclose(cosine * fourier.second_derivative_factors(H, "cosine"), twice, rtol=0, atol=1e-13)


def test_samples_to_coefficients_round_trip():
    m = 2 * H + 1  # the fewest samples that determine H harmonics
    theta = 2 * np.pi * np.arange(m) / m
    np.testing.assert_allclose(fourier.to_coefficients(polynomial(theta), H), FULL, rtol=0, atol=1e-13)
    rng = np.random.default_rng(0)
    c = rng.standard_normal((3, 2 * H + 1))
    np.testing.assert_allclose(fourier.to_coefficients(fourier.to_time(c, H, 17), H), c, rtol=0, atol=1e-13)


def test_product_matrix_is_the_projected_product_of_the_series():
    """The closed-form Galerkin matrix of ``w -> [c w]`` against the product of the two polynomials on a fine
    grid projected back onto the first ``H`` harmonics (exact: the product has ``2H`` harmonics), for a full and
    a cosine-layout ``c``; and the matrix from the samples of ``c`` (Hill's route) is the same."""
    rng = np.random.default_rng(4)
    m = 4 * H + 3  # above the 4H + 1 samples that resolve the product exactly
    for c in (FULL, FULL[: H + 1]):
        matrix = fourier.product_matrix(c, H)
        for w in rng.standard_normal((3, 2 * H + 1)):
            projected = fourier.to_coefficients(fourier.to_time(c, H, m) * fourier.to_time(w, H, m), H)
            np.testing.assert_allclose(matrix @ w, projected, rtol=0, atol=1e-13)
        samples = fourier.to_time(c, H, 8 * H)
        np.testing.assert_allclose(fourier.multiplication_matrix(samples, H), matrix, rtol=0, atol=1e-13)
    with pytest.raises(ValueError, match=r"\|n\| <= 2H = 8"):
        fourier.product_matrix_of_spectrum(np.zeros(5, complex), H)


def test_layout_conversions():
    cos, sin = fourier.to_cos_sin(FULL, H)
    assert sin[0] == 0.0
    np.testing.assert_array_equal(fourier.from_cos_sin(cos, sin), FULL)
    padded = fourier.to_full(FULL[: H + 1], H)
    np.testing.assert_array_equal(padded[H + 1 :], 0.0)
    np.testing.assert_array_equal(padded[: H + 1], FULL[: H + 1])


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: fourier.to_full(np.zeros(6), H), "H\\+1 = 5"),
        (lambda: fourier.to_time(FULL, H, 8), "samples must be >= 2H\\+1 = 9"),
        (lambda: fourier.to_coefficients(np.zeros(8), H), "at least 2H\\+1 = 9"),
        (lambda: fourier.coefficient_count(0), "harmonics must be an integer >= 1"),
        (lambda: fourier.coefficient_count(3, "sine"), "basis must be one of"),
    ],
)
def test_bad_input_is_named(call, message):
    with pytest.raises(ValueError, match=message):
        call()
