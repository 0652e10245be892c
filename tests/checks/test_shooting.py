"""The shooting reference of Floquet multipliers (nnmstop.checks.shooting) against the linear limit.

Near rest the regularized force is ``eta x`` plus terms of third order, so the exact periodic
orbits of (7) tend to the linear modes of the regularized system, whose periods and
multipliers are known in closed form (``linear_modes(params, "regularized")``).
"""

import numpy as np
import pytest

from nnmstop.checks.shooting import monodromy, orbit_initial_state, refine_orbit
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters, linear_modes


def refined_linear_mode(params, mode, amplitude):
    """Shooting from a perturbed linear mode (shape and period off by 1e-3) at ``x(0) = amplitude``."""
    omega, shapes = linear_modes(params, "regularized")
    guess = np.array([amplitude, 1.001 * amplitude * shapes[1, mode], 0.0, 0.0])
    return refine_orbit(params, guess, 1.001 * 2 * np.pi / omega[mode])


@pytest.mark.parametrize("mode", [0, 1])
def test_shooting_finds_the_linear_mode_near_rest(paper_params, mode):
    omega, shapes = linear_modes(paper_params, "regularized")
    small, double = (refined_linear_mode(paper_params, mode, a) for a in (1e-3, 2e-3))
    (z, T), (_, T2) = small, double
    period = 2 * np.pi / omega[mode]
    assert z[1] / z[0] == pytest.approx(shapes[1, mode], rel=1e-6)
    assert T == pytest.approx(period, rel=1e-6)
    # the force's first nonlinear term is cubic: the period moves with the square of the amplitude
    assert (T2 - period) / (T - period) == pytest.approx(4.0, rel=0.05)


@pytest.mark.parametrize("mode", [0, 1])
def test_monodromy_of_a_linear_mode_has_the_modal_multipliers(paper_params, mode):
    omega, _ = linear_modes(paper_params, "regularized")
    z, T = refined_linear_mode(paper_params, mode, 1e-3)
    result = monodromy(paper_params, z, T)
    assert result.closure < 1e-10
    # trace of the variational matrix is zero: det = 1 (Liouville)
    assert np.linalg.det(result.matrix) == pytest.approx(1.0, abs=1e-10)
    mu = result.multipliers
    trivial = np.argsort(np.abs(mu - 1.0))[:2]
    assert np.abs(mu[trivial] - 1.0) == pytest.approx([0.0, 0.0], abs=1e-5)
    pair = np.delete(mu, trivial)
    expected = np.exp(1j * omega[1 - mode] * T)
    assert np.sort(np.angle(pair)) == pytest.approx(np.sort([np.angle(expected), -np.angle(expected)]), abs=1e-6)
    assert np.abs(pair) == pytest.approx([1.0, 1.0], abs=1e-9)


def test_initial_state_of_an_hbm_orbit_at_rest():
    """A cosine-basis orbit starts at rest, at the sum of its cosine coefficients."""
    system = HarmonicBalanceSystem(two_dof_structure(ModelParameters()), harmonics=6)
    U = system.linear_mode_guess(2, 0.3)
    state, period = orbit_initial_state(system, U)
    x, u, _, _, lam, _ = system.split(U)
    assert state == pytest.approx([x.sum(), u.sum(), 0.0, 0.0], abs=1e-15)
    assert period == pytest.approx(2 * np.pi / np.sqrt(lam), rel=1e-15)


def test_bad_arguments(paper_params):
    system = HarmonicBalanceSystem(two_dof_structure(paper_params), harmonics=4)
    with pytest.raises(ValueError, match="state0"):
        monodromy(paper_params, [0.0, 1.0], 1.0)
    with pytest.raises(ValueError, match="period"):
        monodromy(paper_params, [0.1, 0.2, 0.0, 0.0], -1.0)
    with pytest.raises(ValueError, match="params"):
        monodromy({"alpha": 30.0}, [0.1, 0.2, 0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="at rest"):
        refine_orbit(paper_params, [0.1, 0.2, 0.3, 0.0], 6.0)
    with pytest.raises(ValueError, match="omega"):
        orbit_initial_state(system, np.zeros(system.n_unknowns))
