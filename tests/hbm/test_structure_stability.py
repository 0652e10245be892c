"""Floquet multipliers of structures with stops against independent computations."""

from __future__ import annotations

import numpy as np
import pytest

from nnmstop.hbm.monodromy import orbit_monodromy
from nnmstop.hbm.stages import start_point
from nnmstop.hbm.structure_stability import orbit_multipliers, structure_stability
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.beam import Beam, beam_structure, default_tube_parameters
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters


def test_two_dof_multipliers_match_the_two_dof_monodromy():
    """The generic 2N Magnus integration against the 4x4 monodromy of the paper's oscillator (another integrator)."""
    system = HarmonicBalanceSystem(two_dof_structure(ModelParameters()), 20)
    U, _ = start_point(system, 1, 0.5, tol=1e-12)
    generic = orbit_multipliers(system, U, 256)
    reference = np.linalg.eigvals(orbit_monodromy(system, U))
    # compare as sets: sort both by angle then modulus; the trivial pair sits at +1 within the Jordan splitting
    key = lambda mu: (round(float(np.angle(mu)), 3), round(float(abs(mu)), 6))  # noqa: E731
    np.testing.assert_allclose(sorted(generic, key=key), sorted(reference, key=key), atol=1e-4)


def test_near_rest_multipliers_are_the_linear_rotations():
    """Near rest a beam orbit of mode 1 has multipliers exp(+-i omega_k T) of the regularized linear modes."""
    parameters = default_tube_parameters()
    parameters["n_elements"] = 5  # the plate at 0.6 L on a node
    structure = beam_structure(Beam.from_parameters(parameters))
    system = HarmonicBalanceSystem(structure, 8)
    U, _ = start_point(system, 1, 1e-3, tol=1e-12)
    stability = structure_stability(system, [U], steps=64)
    omega, _ = system.linear_modes()
    period = 2 * np.pi / np.sqrt(system.split(U)[-2])
    expected = np.exp(1j * np.concatenate([omega, -omega]) * period)
    found = stability.multipliers[0]
    for mu in expected:
        assert np.min(np.abs(found - mu)) < 1e-5
    assert stability.stable[0] and stability.resolved[0]


@pytest.mark.parametrize("bad", [{"steps": 2}, {"tolerance": 0.0}])
def test_bad_settings_are_named(bad):
    system = HarmonicBalanceSystem(two_dof_structure(ModelParameters()), 4)
    U, _ = start_point(system, 1, 0.2, tol=1e-12)
    with pytest.raises(ValueError, match=next(iter(bad))):
        structure_stability(system, [U], **bad)
