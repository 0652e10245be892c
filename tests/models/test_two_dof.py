"""Physics of nnmstop.models.two_dof: regularized contact law, potentials, linear limits, parameters."""

import warnings

import numpy as np
import pytest
from scipy.integrate import quad

from nnmstop.models.two_dof import (
    ModelParameters,
    linear_modes,
    piecewise_contact_force,
    piecewise_contact_potential,
    regularized_contact_force,
    regularized_contact_potential,
    regularized_contact_stiffness,
    regularized_force_and_potential,
    total_energy,
)

OTHER_PARAMS = ModelParameters(alpha=5.0, beta=0.3, delta=2.5, eta=0.4)
SAMPLE_X = np.array([-37.0, -4.0, -1.3, -1.0, -0.97, -0.4, -1e-3, 1e-3, 0.25, 0.9, 1.0, 1.02, 1.5, 3.0, 12.0, 250.0])


@pytest.fixture(params=["paper", "other"])
def params(request, paper_params):
    return paper_params if request.param == "paper" else OTHER_PARAMS


# --------------------------------------------------------------------------- the force


def test_force_has_the_sign_of_x(params):
    x = np.concatenate([-np.logspace(-8, 6, 57), np.logspace(-8, 6, 57)])
    f = regularized_contact_force(x, params)
    assert np.all(np.sign(f) == np.sign(x))
    assert regularized_contact_force(0.0, params) == 0.0


def test_force_is_eta_x_near_the_origin(params):
    for x in (1e-9, 1e-6, -1e-6):
        f = regularized_contact_force(x, params)
        assert f / (params.eta * x) == pytest.approx(1.0, rel=10 * abs(x))


def test_force_far_out_is_the_piecewise_law_shifted_by_about_eta_over_2(params):
    """Corrected property (iii): f ~ alpha (x - sgn x), sitting ~eta/2 above for large x > 0."""
    for x in (1e3, 1e5, 1e7):
        f = regularized_contact_force(x, params)
        assert f / (params.alpha * (x - 1.0)) == pytest.approx(1.0, rel=params.eps / x)
        offset = f - params.alpha * (x - 1.0)
        # exact limit alpha (1 - sqrt(1 - eta/alpha)) = eta/2 (1 + eta/(4 alpha) + ...)
        assert offset > 0
        assert offset == pytest.approx(params.eta / 2, rel=params.eps)
        f_neg = regularized_contact_force(-x, params)
        assert f_neg / (params.alpha * (-x + 1.0)) == pytest.approx(1.0, rel=params.eps / x)


def _cubic_roots(x, p):
    """Roots in f of f (f - alpha (x-1)) (f - alpha (x+1)) + eta alpha^2 x, built from the factors."""
    poly = np.polymul(np.polymul([1.0, 0.0], [1.0, -p.alpha * (x - 1.0)]), [1.0, -p.alpha * (x + 1.0)])
    poly[-1] += p.eta * p.alpha**2 * x
    return np.roots(poly)


def test_force_is_the_middle_of_three_real_roots_of_the_corrected_cubic(params):
    for x in SAMPLE_X:
        roots = _cubic_roots(x, params)
        assert np.max(np.abs(roots.imag)) <= 1e-9 * np.max(np.abs(roots)), f"complex roots at x={x}"
        middle = np.sort(roots.real)[1]
        f = regularized_contact_force(x, params)
        assert f == pytest.approx(middle, rel=1e-9, abs=1e-12), f"x={x}"


def test_force_is_odd_and_stiffness_and_potential_even(params):
    x = np.abs(SAMPLE_X)
    np.testing.assert_array_equal(regularized_contact_force(-x, params), -regularized_contact_force(x, params))
    np.testing.assert_array_equal(regularized_contact_stiffness(-x, params), regularized_contact_stiffness(x, params))
    np.testing.assert_array_equal(regularized_contact_potential(-x, params), regularized_contact_potential(x, params))


def test_stiffness_matches_finite_differences(params):
    for x in SAMPLE_X:
        h = 1e-6 * max(1.0, abs(x))
        fd = (regularized_contact_force(x + h, params) - regularized_contact_force(x - h, params)) / (2 * h)
        assert regularized_contact_stiffness(x, params) == pytest.approx(fd, rel=1e-6), f"x={x}"
    assert regularized_contact_stiffness(0.0, params) == pytest.approx(params.eta, rel=1e-14)
    assert regularized_contact_stiffness(1e8, params) == pytest.approx(params.alpha, rel=1e-6)


def test_potential_is_the_integral_of_the_force(params):
    for x in SAMPLE_X:
        points = [s for s in (-1.0, 1.0) if min(0.0, x) < s < max(0.0, x)]
        ref, err = quad(
            lambda s: float(regularized_contact_force(s, params)),
            0.0,
            x,
            points=points or None,
            epsabs=0.0,
            epsrel=1e-13,
            limit=200,
        )
        assert regularized_contact_potential(x, params) == pytest.approx(ref, rel=1e-10, abs=1e-15), f"x={x}"


def test_tiny_and_huge_arguments_are_finite_and_accurate(params):
    mags = np.logspace(-12, 12, 97)
    x = np.concatenate([-mags[::-1], [0.0], mags])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f = regularized_contact_force(x, params)
        k = regularized_contact_stiffness(x, params)
        pot = regularized_contact_potential(x, params)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(k)) and np.all(np.isfinite(pot))
    assert np.all(k > 0) and np.all(pot >= 0)
    big = 1e12
    assert regularized_contact_force(big, params) == pytest.approx(params.alpha * (big - 1), rel=1e-12)
    assert regularized_contact_potential(big, params) == pytest.approx(0.5 * params.alpha * (big - 1) ** 2, rel=1e-10)
    tiny = 1e-12
    assert regularized_contact_force(tiny, params) == pytest.approx(params.eta * tiny, rel=1e-10)
    assert regularized_contact_potential(tiny, params) == pytest.approx(0.5 * params.eta * tiny**2, rel=1e-10)


def test_force_and_potential_in_one_solve_are_the_separate_functions(params):
    # HBM diagnostics take both from one root solve: same values, bit for bit.
    mags = np.logspace(-12, 12, 49)
    x = np.concatenate([SAMPLE_X, -mags, mags, [0.0]])
    f, pot = regularized_force_and_potential(x, params)
    assert np.array_equal(f, regularized_contact_force(x, params))
    assert np.array_equal(pot, regularized_contact_potential(x, params))
    xdot, u = np.linspace(-2.0, 2.0, x.size), np.linspace(1.0, -1.0, x.size)
    assert np.array_equal(
        total_energy(x, u, xdot, -xdot, params, potential=pot), total_energy(x, u, xdot, -xdot, params)
    )


def test_piecewise_law_and_its_potential(paper_params):
    a = paper_params.alpha
    x = np.array([-3.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.5])
    np.testing.assert_allclose(piecewise_contact_force(x, a), [-2 * a, 0, 0, 0, 0, 0, 1.5 * a])
    np.testing.assert_allclose(piecewise_contact_potential(x, a), [2 * a, 0, 0, 0, 0, 0, 0.5 * a * 1.5**2])


def test_total_energy_rejects_unknown_model(paper_params):
    with pytest.raises(ValueError, match="'smooth'"):
        total_energy(0.0, 0.0, 1.0, 1.0, paper_params, model="smooth")


# --------------------------------------------------------------------------- linear limits


def _hand_modes(p, added):
    """Closed form of det(K - w^2 M) = 0 for the 2x2 problem with ``added`` stiffness on x.

    (1 + b + k - w^2)(b - d w^2) - b^2 = 0
    <=> d w^4 - (d (1 + b + k) + b) w^2 + b (1 + k) = 0,
    and the mode shape u/x = (1 + b + k - w^2) / b.
    """
    b, d, k = p.beta, p.delta, added
    big_b = d * (1 + b + k) + b
    disc = np.sqrt(big_b**2 - 4 * d * b * (1 + k))
    w2 = np.array([(big_b - disc) / (2 * d), (big_b + disc) / (2 * d)])
    return np.sqrt(w2), (1 + b + k - w2) / b


@pytest.mark.parametrize("limit", ["no_contact", "regularized", "gap_zero"])
def test_linear_modes_match_the_hand_derived_closed_form(params, limit):
    added = {"no_contact": 0.0, "regularized": params.eta, "gap_zero": params.alpha}[limit]
    omega, shapes = linear_modes(params, limit)
    w_ref, ratio_ref = _hand_modes(params, added)
    np.testing.assert_allclose(omega, w_ref, rtol=1e-13)
    np.testing.assert_allclose(shapes[0], [1.0, 1.0], rtol=1e-14)
    np.testing.assert_allclose(shapes[1], ratio_ref, rtol=1e-12)


def test_no_contact_modes_for_unit_parameters_are_golden_ratio(paper_params):
    """For beta = delta = 1: w^4 - 3 w^2 + 1 = 0, so w = (sqrt 5 -+ 1)/2."""
    omega, _ = linear_modes(paper_params, "no_contact")
    np.testing.assert_allclose(omega, [(np.sqrt(5) - 1) / 2, (np.sqrt(5) + 1) / 2], rtol=1e-14)


def test_linear_modes_reject_unknown_limit(paper_params):
    with pytest.raises(ValueError, match="'gap_one'"):
        linear_modes(paper_params, "gap_one")


# --------------------------------------------------------------------------- parameters


@pytest.mark.parametrize("name", ["alpha", "beta", "delta", "eta"])
@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_parameters_reject_out_of_range_values_naming_them(name, bad):
    kwargs = {"alpha": 30.0, "beta": 1.0, "delta": 1.0, "eta": 0.1, name: bad}
    with pytest.raises(ValueError, match=name):
        ModelParameters(**kwargs)


@pytest.mark.parametrize("name", ["alpha", "beta", "delta", "eta"])
@pytest.mark.parametrize("bad", ["1.0", None, True])
def test_parameters_reject_non_numbers_naming_them(name, bad):
    kwargs = {"alpha": 30.0, "beta": 1.0, "delta": 1.0, "eta": 0.1, name: bad}
    with pytest.raises(TypeError, match=name):
        ModelParameters(**kwargs)


def test_parameters_reject_eta_not_below_alpha():
    with pytest.raises(ValueError, match="eta"):
        ModelParameters(alpha=2.0, beta=1.0, delta=1.0, eta=2.0)
