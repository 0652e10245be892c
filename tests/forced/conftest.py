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
