"""Fixtures of the forced-response tests: the paper's oscillator with light Rayleigh damping."""

import numpy as np
import pytest

from nnmstop.models.excitation import Damping, Excitation, HarmonicForce
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters


def oscillator_excitation(force: float, zeta: float = 0.01, alpha: float = 30.0, eta: float = 0.1) -> Excitation:
    """The paper's oscillator, damping ratio ``zeta`` on both linear modes, force on u."""
    structure = two_dof_structure(ModelParameters(alpha=alpha, eta=eta))
    return Excitation(structure, Damping.from_modal_ratios(structure, [zeta, zeta]), HarmonicForce(force, [1]))


@pytest.fixture(scope="session")
def contact_family():
    """The exact symmetric one-contact family at F = 0.05 (Rayleigh damping 0.01), continued once."""
    from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings
    from nnmstop.exact.forced import SymmetricContactProblem, follow_contact_family, grazing_frequencies

    excitation = oscillator_excitation(0.05)
    problem = SymmetricContactProblem(excitation)
    grazing = grazing_frequencies(excitation, 2 * np.pi * 0.05, 2 * np.pi * 0.35)
    direction = np.zeros(problem.n_unknowns)
    direction[-2] = 1.0
    settings = PseudoArclengthSettings(tolerance=1e-12, initial_step=0.01, max_step=0.05)
    family = follow_contact_family(problem, problem.grazing_start(grazing[0]), direction, settings, (0.05, 0.35))
    return excitation, problem, grazing, family


def at_frequency(problem, y, omega: float):
    """The orbit of ``problem`` at the angular frequency ``omega`` next to ``y``: Newton with Omega held."""
    from nnmstop.continuation.newton import newton_solve

    result = newton_solve(
        lambda v: np.append(problem.residual(v), v[-1] - omega),
        lambda v: np.vstack([problem.jacobian(v), np.eye(len(v))[-1]]),
        y,
        tol=1e-13,
        max_iter=30,
    )
    assert result.converged, result.reason
    return result.y


def exact_response_at(excitation, frequency: float, frequency_range):
    """``max |q|`` of the exact response at ``frequency`` (Hz): the first crossing of the family from the first
    grazing orbit in ``frequency_range``, then Newton with Omega held (round-off)."""
    from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings
    from nnmstop.exact.forced import follow_contact_family, grazing_frequencies, grazing_problem

    low, high = frequency_range
    start = grazing_frequencies(excitation, 2 * np.pi * low, 2 * np.pi * high)[0]
    problem, y0, direction = grazing_problem(excitation, start)
    settings = PseudoArclengthSettings(tolerance=1e-12, initial_step=0.02, max_step=0.1)
    Y = follow_contact_family(problem, y0, direction, settings, frequency_range).unknowns
    i = np.flatnonzero(np.diff(np.sign(Y[:, -1] / (2 * np.pi) - frequency)))[0]
    return problem.amplitudes(at_frequency(problem, Y[i], 2 * np.pi * frequency))


def regularized_response_at(excitation, frequency: float, window, harmonics: int = 24):
    """``max |q|`` of the regularized response at ``frequency`` (Hz): the first crossing of the ANM continuation over
    ``window``, located on the ANM step (bisection of Omega along the series, no interpolation)."""
    from nnmstop.continuation.anm import ANMSettings, ANMStepper
    from nnmstop.continuation.newton import bisect_sign_change
    from nnmstop.forced.responses import path_between
    from nnmstop.hbm.forced import ForcedHarmonicBalanceSystem, continue_frequency_response, response_amplitudes

    settings = ANMSettings(points_per_step=1)
    system = ForcedHarmonicBalanceSystem(excitation, harmonics)
    U = np.asarray(continue_frequency_response(system, window, settings, max_truncation=1e-3).points)
    omega = 2 * np.pi * frequency
    j = np.flatnonzero(np.diff(np.sign(U[:, system.i_omega] - omega)))[0]
    path, length = path_between(system, ANMStepper(settings), U, j)
    found = bisect_sign_change(lambda a: path(a)[system.i_omega] - omega, 0.0, length, tol=1e-12 * length)
    return response_amplitudes(system, path(found.midpoint)[None])[0]
