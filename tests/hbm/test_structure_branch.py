"""NNM1 of a finite-element tube by the generic engine, checked in the time domain."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nnmstop.continuation.anm import ANMSettings
from nnmstop.hbm.structure_branch import continue_structure_nnm
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.beam import Beam, beam_structure, default_tube_parameters
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force


@pytest.fixture(scope="module")
def tube_branch():
    """A 5-element tube (plate at 0.6 L, 3 x the static stiffness there), NNM1 up to several impacts per stop."""
    parameters = default_tube_parameters()
    parameters["n_elements"] = 5
    stiffness = 3.0 * 3.0 * parameters["bending_stiffness"] / 0.6**3
    parameters["stops"][0].update(stiffness=stiffness, eta=stiffness / 300.0)
    structure = beam_structure(Beam.from_parameters(parameters))
    system = HarmonicBalanceSystem(structure, 40)
    branch = continue_structure_nnm(system, 1, 0.1, 20.0, 1e-3, ANMSettings(max_steps=400), "tube nnm1")
    return structure, system, branch


def _period_defect(structure, system, U):
    """|y(T) - y(0)| / |y(0)| of the regularized FE model integrated from the HBM orbit's state at t = 0."""
    stop = structure.stops[0]
    law = ModelParameters(alpha=stop.stiffness, eta=stop.eta)
    mass, stiffness = structure.dense_matrices()
    mass_inverse = np.linalg.inv(mass)
    N = structure.n_dofs

    def rhs(t, y):
        force = stiffness @ y[:N]
        force[stop.dof] += stop.gap * regularized_contact_force(y[stop.dof] / stop.gap, law)
        return np.concatenate([y[N:], -mass_inverse @ force])

    history = system.time_history(U, 256)
    y0 = np.concatenate([history["q"][:, 0], history["qdot"][:, 0]])
    period = 256 * history["t"][1]
    end = solve_ivp(rhs, (0.0, period), y0, method="DOP853", rtol=1e-11, atol=1e-12).y[:, -1]
    return np.linalg.norm(end - y0) / np.linalg.norm(y0)


def test_hbm_orbits_of_the_tube_are_periodic_in_time(tube_branch):
    """Along the branch, including orbits with several impacts per stop, the HBM orbit closes under DOP853.

    The HBM orbit satisfies the equations of motion up to its time residual r (relative to the largest
    restoring force at the stop); the state after one period then misses the start by a quantity of the order
    of r: the bound pi r (and an integrator floor of 1e-8) follows the engine's own periodicity test.
    """
    structure, system, branch = tube_branch
    # one orbit of each impact count along the branch, the most energetic of each (hardest to close)
    chosen = {}
    for U, diagnostics in zip(branch.points, branch.diagnostics):
        if diagnostics is not None:
            chosen[diagnostics["impacts_per_period"]] = (U, diagnostics)
    checked_impacts = []
    for U, diagnostics in chosen.values():
        defect = _period_defect(structure, system, U)
        assert defect < np.pi * diagnostics["time_residual"] + 1e-8, (diagnostics["energy"], defect)
        checked_impacts.append(diagnostics["impacts_per_period"])
    assert max(checked_impacts) >= 4  # several impacts per stop were checked, not only the one-impact regime
    assert 2 in checked_impacts
