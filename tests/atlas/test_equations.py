"""The periodic-orbit equations the atlas augments: their Jacobians and map derivatives against differences."""

import numpy as np
import pytest
from tests.atlas.conftest import central_differences, located, oscillator, partial_difference

from nnmstop.bifurcation_atlas.equations import ExactSymmetricEquations, HarmonicBalanceEquations, fourier_orbit


@pytest.mark.parametrize("parameter", [None, "gap", "stiffness", "damping_ratio"])
def test_exact_jacobian_in_state_and_parameters_matches_differences(response_at, parameter):
    """[G_x | G_Omega, G_F, G_p] of the exact formulation (analytic in x and Omega, exactly affine in F) against
    central differences of the residual, at the located fold of the response at F = 0.1."""
    equations = ExactSymmetricEquations(oscillator(0.1), parameter)
    (y, omega), *_ = located(response_at(0.1), "fold")
    params = np.array([omega, 0.1, equations.p0])
    J = equations.jacobian(y[:-1], params)
    n = equations.n
    numeric = central_differences(lambda v: equations.residual(v[:n], v[n:]), np.concatenate([y[:-1], params]))
    columns = slice(0, n + 3) if parameter else slice(0, n + 2)  # without a parameter its column is zero
    np.testing.assert_allclose(J[:, columns], numeric[:, columns], atol=2e-7 * np.abs(J).max())
    assert np.all(np.abs(equations.residual(y[:-1], params)) < 1e-12)


def test_residual_is_affine_in_the_force():
    """G(x; F) from the two reference problems equals the problem built at that force, to round-off."""
    from nnmstop.exact.forced import SymmetricContactProblem

    equations = ExactSymmetricEquations(oscillator(0.1))
    rng = np.random.default_rng(3)
    y = np.concatenate([rng.normal(size=4), [0.3, 0.4, 0.62]])
    for force in (0.013, 0.2, 0.7):
        direct = SymmetricContactProblem(oscillator(force)).residual(y)
        np.testing.assert_allclose(equations.residual(y[:-1], (y[-1], force, 0.0)), direct, atol=1e-13)


def test_half_period_map_derivatives_match_differences(response_at):
    """dN/ddelta and dN/dOmega (analytic, from d exp(A t)/dt = A exp(A t)) and dN/dp (differences) of the
    half-period map at a located Neimark-Sacker point."""
    equations = ExactSymmetricEquations(oscillator(0.1), "stiffness")
    (y, omega), *_ = located(response_at(0.1), "neimark_sacker")
    x, params = y[:-1], np.array([omega, 0.1, 30.0])
    indices, d_state, d_params = equations.monodromy_derivatives(x, params)
    assert indices.tolist() == [equations.n - 1]
    numeric = central_differences(lambda v: equations.monodromy(np.r_[x[:-1], v[0]], v[1:]), np.r_[x[-1], params])
    np.testing.assert_allclose(d_state[0], numeric[..., 0], atol=1e-7)
    for k in range(3):
        np.testing.assert_allclose(d_params[k], numeric[..., 1 + k], atol=1e-6)


def test_harmonic_balance_jacobian_and_monodromy_derivatives_match_differences():
    """The harmonic-balance equations (soft stop, H = 8): parameter columns of the Jacobian and the monodromy's
    derivatives along the stop coordinates' coefficients and Omega against central differences."""
    from nnmstop.hbm.forced import ForcedHarmonicBalanceSystem, forced_start_point

    excitation = oscillator(0.05, alpha=3.0, eta=0.3)
    equations = HarmonicBalanceEquations(excitation, 8, "gap", steps=64)
    U, _ = forced_start_point(ForcedHarmonicBalanceSystem(excitation, 8), 0.09)
    x, params = U[:-1], np.array([U[-1], 0.05, 1.0])
    J = equations.jacobian(x, params)
    n = equations.n
    numeric = central_differences(lambda p: equations.residual(x, p), params)
    np.testing.assert_allclose(J[:, n:], numeric, atol=1e-6 * np.abs(J).max())
    indices, d_state, d_params = equations.monodromy_derivatives(x, params)
    for j in (0, 1, len(indices) - 1):
        expected = partial_difference(lambda v: equations.monodromy(v, params), x, indices[j])
        np.testing.assert_allclose(d_state[j], expected, atol=1e-6)
    # the map does not depend on the other unknowns (the damped variational equation sees the stop coordinates)
    other = np.setdiff1d(np.arange(n), indices)[5]
    moved = x.copy()
    moved[other] += 1e-3
    assert np.abs(equations.monodromy(moved, params) - equations.monodromy(x, params)).max() == 0.0


def test_fourier_orbit_recovers_a_series_from_any_phase_origin():
    """fourier_orbit of samples starting at any phase gives the coefficients in the force's phase."""
    theta0 = 0.7
    theta = theta0 + 2 * np.pi * np.arange(64) / 64
    q = 0.3 + 1.2 * np.cos(theta) - 0.4 * np.sin(theta) + 0.05 * np.sin(3 * theta)
    coefficients = fourier_orbit(theta, q[None], 4)[0]
    expected = np.zeros(9)
    expected[[0, 1, 5, 7]] = [0.3, 1.2, -0.4, 0.05]
    np.testing.assert_allclose(coefficients, expected, atol=1e-14)


def test_harmonic_balance_map_derivatives_cover_both_dofs_of_a_relative_stop():
    """A relative stop reads q0 - q1: the monodromy of the regularized response depends on the coefficients of both
    DOFs (its derivatives along those of q1 match differences) and on none of the free DOF q2's."""
    from nnmstop.hbm.forced import ForcedHarmonicBalanceSystem, forced_start_point
    from nnmstop.models.contact import Stop
    from nnmstop.models.excitation import Damping, Excitation, HarmonicForce
    from nnmstop.models.structure import Structure

    stop = Stop(kind="relative", dofs=[0, 1], gap=0.5, stiffness=3.0, eta=0.3)
    chain = Structure(np.eye(3), [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]], [stop])
    excitation = Excitation(chain, Damping.from_modal_ratios(chain, [0.02, 0.02]), HarmonicForce(0.05, [2]))
    equations = HarmonicBalanceEquations(excitation, 8, steps=64)
    U, _ = forced_start_point(ForcedHarmonicBalanceSystem(excitation, 8), 0.3)
    x, params = U[:-1], np.array([U[-1], 0.05, 0.0])
    indices, d_state, _ = equations.monodromy_derivatives(x, params)
    nc = equations.system(params).nc
    assert sorted(set(indices // nc)) == [0, 1]
    for j in (nc + 1, nc + 2):  # coefficients of q1
        expected = partial_difference(lambda v: equations.monodromy(v, params), x, indices[j])
        assert np.abs(expected).max() > 1e-3  # the map does depend on q1
        np.testing.assert_allclose(d_state[j], expected, atol=1e-6)
    moved = x.copy()
    moved[2 * nc + 1] += 1e-3
    assert np.abs(equations.monodromy(moved, params) - equations.monodromy(x, params)).max() == 0.0


def test_docstring_examples_run():
    import doctest

    from nnmstop.bifurcation_atlas import equations

    result = doctest.testmod(equations, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0
