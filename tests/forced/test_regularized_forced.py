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

from .conftest import oscillator_excitation

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
