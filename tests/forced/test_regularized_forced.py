"""Regularized forced responses (harmonic balance + ANM) against independent references.

The closed-form linear response at small amplitude; DOP853 integration of the regularized law (the HBM
orbit is periodic within its truncation error); the backbone's prediction of the peak (error falling at
least linearly with the damping, phase resonance at the peak).
"""

import numpy as np
import pytest

from nnmstop.checks.forced_integration import integrate_forced_regularized
from nnmstop.continuation.anm import ANMSettings
from nnmstop.forced.backbone import locate_peak, nnm_backbone, predicted_peaks
from nnmstop.hbm.forced import (
    ForcedHarmonicBalanceSystem,
    continue_frequency_response,
    phase_lags,
    response_amplitudes,
)
from nnmstop.models.excitation import linear_response

from .conftest import exact_response_at, oscillator_excitation, regularized_response_at

SETTINGS = ANMSettings(points_per_step=1)


def test_small_force_gives_the_linear_response_with_the_contact_stiffness_eta():
    """Far inside the gap the regularized law is f = eta x (1 + O(x**2)): the response is the linear one of
    K + eta e_x e_x^T to O(x**2)."""
    excitation = oscillator_excitation(1e-4)
    system = ForcedHarmonicBalanceSystem(excitation, harmonics=3)
    branch = continue_frequency_response(system, (0.05, 0.35), SETTINGS, max_truncation=0.5)
    U = np.asarray(branch.points)
    omega = U[:, system.i_omega]
    extra = np.diag([excitation.structure.stops[0].eta, 0.0])
    expected = np.abs(linear_response(excitation, omega, extra))
    amplitude = response_amplitudes(system, U)
    assert branch.end_reason.startswith("frequency above")
    # rtol: the O(x**2) of the law (x < 0.02); atol: the continuation's accuracy, a residual of 1e-7 relative to
    # |U| ~ 5 (Omega**2 and Omega are unknowns), where an amplitude is small (antiresonance of x)
    np.testing.assert_allclose(amplitude, expected, rtol=1e-4, atol=1e-8)


@pytest.mark.numerics
def test_condensed_factors_of_the_damped_system_match_numpy_on_the_full_bordered_matrix():
    """The forced system's bordered Jacobian (damping couples each cosine to its sine, Omega closes it) factored
    with z condensed out: solutions and determinant sign as numpy's on the whole matrix, at a point in contact."""
    system = ForcedHarmonicBalanceSystem(oscillator_excitation(0.1), harmonics=12)
    rng = np.random.default_rng(7)
    U = system.linear_guess(2 * np.pi * 0.14) * 3.0 + 0.1 * rng.standard_normal(system.n_unknowns)
    assert np.abs(system.to_time(system.split(U)[0])).max() > 1.2  # x beyond the stop: the product blocks matter
    tangent = rng.standard_normal(system.n_unknowns)
    bordered = np.vstack([system.jacobian(U), tangent])
    rhs = rng.standard_normal((system.n_unknowns, 2))
    factors = system.factorize_bordered(U, tangent)
    expected = np.linalg.solve(bordered, rhs)
    tolerance = 1e-10 * np.abs(expected).max()
    np.testing.assert_allclose(factors.solve(rhs), expected, rtol=0, atol=tolerance)
    np.testing.assert_allclose(factors.solve(rhs[:, 1]), expected[:, 1], rtol=0, atol=tolerance)
    assert factors.determinant_sign() == np.linalg.slogdet(bordered)[0]
    assert system.factorize_bordered(U, -tangent).determinant_sign() == -factors.determinant_sign()


def test_hbm_response_is_periodic_under_time_integration_within_its_truncation_error():
    excitation = oscillator_excitation(0.05, alpha=3.0, eta=0.3)
    defects = {}
    for H in (6, 12):
        system = ForcedHarmonicBalanceSystem(excitation, harmonics=H)
        branch = continue_frequency_response(system, (0.09, 0.16), SETTINGS, max_truncation=0.5)
        U = np.asarray(branch.points)
        amplitude = response_amplitudes(system, U)[:, 0]
        U = U[np.argmin(np.abs(amplitude - 1.5))]  # an orbit deep in contact
        omega = U[system.i_omega]
        h = system.time_history(U, 64)
        z0 = np.concatenate([h["q"][:, 0], h["qdot"][:, 0]])
        end = integrate_forced_regularized(excitation, omega, z0, [0.0, 2 * np.pi / omega], rtol=1e-10, atol=1e-11)[-1]
        defects[H] = np.abs(end - z0).max() / np.abs(z0).max()
    assert defects[12] < 1e-3
    assert defects[12] < 0.2 * defects[6]  # the defect is the truncation error: it falls with H


def _peak_and_prediction(zeta: float):
    excitation = oscillator_excitation(0.05 * zeta / 0.01, zeta=zeta, alpha=3.0, eta=0.3)
    force = excitation.force.amplitude
    backbone_system, backbone = nnm_backbone(excitation, 1, 12, SETTINGS, 0.5, 2 * force)
    ((frequency, amplitude, _),) = predicted_peaks(backbone_system, excitation, backbone, SETTINGS, [force])
    system = ForcedHarmonicBalanceSystem(excitation, harmonics=12)
    branch = continue_frequency_response(system, (0.09, 0.16), SETTINGS, max_truncation=0.5)
    peak = locate_peak(system, branch, SETTINGS, dof=0)
    lag = np.degrees(phase_lags(system, peak[None])[0])
    peak_amplitude = response_amplitudes(system, peak[None])[0]
    return frequency, amplitude, peak[system.i_omega] / (2 * np.pi), peak_amplitude, lag


@pytest.mark.numerics
def test_backbone_predicts_the_peak_with_an_error_falling_with_the_damping():
    """F proportional to the damping keeps the peak on the same backbone orbit; the energy balance's error in
    the peak's frequency and amplitude falls at least linearly with the damping, and the forced DOF's lag
    behind the force at the peak is 90 degrees within 40 zeta radians (first order in the damping)."""
    errors = []
    for zeta in (0.02, 0.01, 0.005):
        f_pred, a_pred, f_peak, a_peak, lag = _peak_and_prediction(zeta)
        errors.append((abs(f_peak - f_pred) / f_pred, abs(a_peak[0] - a_pred[0]) / a_pred[0]))
        assert abs(lag[1] - 90.0) <= np.degrees(40 * zeta)
    errors = np.array(errors)
    assert np.all(errors[1:] <= 0.55 * errors[:-1]), errors


@pytest.mark.numerics
def test_regularized_response_converges_to_the_exact_one_at_first_order_in_eta():
    """On the upper branch past grazing (0.115 Hz, F = 0.05, alpha = 3), the regularized law differs from the
    piecewise-linear one by O(eta): the amplitudes converge to the exact response at first order."""
    exact = exact_response_at(oscillator_excitation(0.05, alpha=3.0, eta=0.1), 0.115, (0.05, 0.35))
    errors = np.array(
        [
            np.abs(
                regularized_response_at(oscillator_excitation(0.05, alpha=3.0, eta=eta), 0.115, (0.09, 0.16)) - exact
            )
            / exact
            for eta in (0.1, 0.05, 0.025)
        ]
    )
    orders = np.log2(errors[:-1] / errors[1:])
    assert np.all(orders > 0.8), (errors, orders)
    assert errors[-1, 0] < 0.04


@pytest.mark.numerics
def test_time_integration_leaves_an_unstable_hbm_response_at_its_largest_multiplier():
    """From the most unstable regularized response (between the folds) a perturbation grows by the largest
    Floquet multiplier of the damped variational equation per period; from a stable one it decays."""
    from nnmstop.hbm.forced import forced_multipliers

    excitation = oscillator_excitation(0.05, alpha=3.0, eta=0.3)
    system = ForcedHarmonicBalanceSystem(excitation, harmonics=16)
    U = np.asarray(continue_frequency_response(system, (0.09, 0.16), SETTINGS, max_truncation=1e-3).points)
    largest = np.abs(forced_multipliers(system, U)[0]).max(axis=1)
    for index in (int(np.argmax(largest)), int(np.argmin(largest))):
        omega = U[index, system.i_omega]
        history = system.time_history(U[index], 64)
        z0 = np.concatenate([history["q"][:, 0], history["qdot"][:, 0]])
        t = np.arange(17) * 2 * np.pi / omega
        states = integrate_forced_regularized(
            excitation, omega, z0 + 1e-7 * np.array([1.0, 0.5, -0.3, 0.2]), t, rtol=1e-11, atol=1e-12
        )
        distance = np.linalg.norm(states - z0, axis=1)
        if largest[index] > 1:
            assert (distance[-1] / distance[-9]) ** 0.125 == pytest.approx(largest[index], rel=0.03)
        else:
            assert distance[-1] < distance[0]


@pytest.fixture(scope="module")
def soft_stop_response():
    """The regularized response of the soft-stop oscillator (alpha = 3, eta = 0.3) at H = 16 over its NNM1 peak."""
    excitation = oscillator_excitation(0.05, alpha=3.0, eta=0.3)
    system = ForcedHarmonicBalanceSystem(excitation, harmonics=16)
    branch = continue_frequency_response(system, (0.09, 0.16), SETTINGS, max_truncation=1e-3)
    return system, branch


def test_stop_coordinates_at_the_magnus_nodes_are_the_fourier_series(soft_stop_response):
    """The FFT of the folded coefficients equals the series summed term by term at the Gauss nodes, also with fewer
    steps than harmonics (folding)."""
    from nnmstop.floquet import gauss_nodes
    from nnmstop.hbm.forced import stop_coordinates_at_nodes

    system, branch = soft_stop_response
    U = np.asarray(branch.points)[::5]
    Q = U[:, : system.n_dofs * system.nc].reshape(len(U), system.n_dofs, system.nc)[:, 0]
    k = np.arange(1, system.H + 1)
    for steps in (8, 64):
        theta = U[:, system.i_omega, None, None] * gauss_nodes(2 * np.pi / U[:, system.i_omega], steps)
        kt = theta[..., None] * k
        series = Q[:, None, None, 0] + np.sum(
            Q[:, None, None, 1 : system.H + 1] * np.cos(kt) + Q[:, None, None, system.H + 1 :] * np.sin(kt), axis=-1
        )
        np.testing.assert_allclose(stop_coordinates_at_nodes(system, U, steps)[0], series, atol=1e-13)


@pytest.mark.numerics
def test_resolved_verdicts_hold_with_many_more_steps(soft_stop_response):
    """Every verdict said resolved (margin beyond twice the error estimates) is the verdict of the multipliers with
    16 times the steps; the stability changes lie between points of opposite verdicts."""
    from nnmstop.forced.regularized import ForcedStabilitySettings, regularized_stability
    from nnmstop.hbm.forced import ForcedLinearization

    system, branch = soft_stop_response
    stability, changes = regularized_stability(system, branch, SETTINGS, ForcedStabilitySettings(16, 64, 2.0))
    U = np.asarray(branch.points)
    reference = ForcedLinearization(system).multipliers(U, 1024)
    stable = np.abs(stability.multipliers).max(axis=1) <= 1
    assert np.array_equal(stable[stability.resolved], (np.abs(reference).max(axis=1) <= 1)[stability.resolved])
    assert stability.resolved.mean() > 0.9
    assert [c.kind for c in changes] == ["fold", "fold"]
    for change in changes:
        assert stable[change.after_point] != stable[change.after_point + 1]


def _neimark_sacker_frequencies(changes, frequency_of) -> list:
    return sorted(frequency_of(c) for c in changes if c.kind == "neimark_sacker")


@pytest.mark.numerics
def test_neimark_sacker_points_of_the_hbm_converge_to_the_exact_ones_as_eta_goes_to_zero():
    """The exact symmetric one-contact response at F = 0.1 loses stability through a Neimark-Sacker point just
    past grazing and regains it through another; the regularized response (H = 100) has both, located by its
    monodromy, and they approach the exact ones as eta goes to zero, at the first order of the law's error (the
    convergence test of the amplitudes above): the distance falls at least twice when eta falls 3 times, and is
    below 2 eta."""
    from nnmstop.forced.regularized import ForcedStabilitySettings, regularized_stability
    from nnmstop.forced.responses import exact_response

    window = (0.088, 0.11)
    pieces = exact_response(oscillator_excitation(0.1), window)
    exact = _neimark_sacker_frequencies([c for p in pieces for c in p.changes], lambda c: c.U[-1] / (2 * np.pi))
    assert len(exact) == 2
    distances = []
    for eta in (0.03, 0.01):
        system = ForcedHarmonicBalanceSystem(oscillator_excitation(0.1, eta=eta), harmonics=100)
        branch = continue_frequency_response(system, window, SETTINGS, max_truncation=1e-2)
        _, changes = regularized_stability(system, branch, SETTINGS, ForcedStabilitySettings(32, 1024, 2.0))
        found = _neimark_sacker_frequencies(changes, lambda c, s=system: s.frequency_hz(c.U))
        assert len(found) == 2, found
        distances.append(np.abs(np.array(found) - exact) / np.array(exact))
    assert np.all(distances[1] <= 0.5 * distances[0]), distances
    # first order: the relative distance is of the order of eta itself
    assert np.all(distances[0] < 2 * 0.03) and np.all(distances[1] < 2 * 0.01), distances
