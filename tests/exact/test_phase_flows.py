"""Flows of the linear phases (nnmstop.exact.phases.LinearPhase) against the matrix exponential.

The one-time state, the x velocity used by the extrema search and the stacked transition
matrices are checked against ``scipy.linalg.expm`` of the phase's first-order system (Pade
approximation, an independent computation); the stacked Floquet variables against the
multipliers of each orbit computed on its own.
"""

import numpy as np
import pytest
import scipy.linalg

from nnmstop.exact import stability as es
from nnmstop.exact.phases import phase_of

TIMES = np.array([0.0, 0.07, 0.4, 1.3, 5.0])
Z0 = np.array([1.0, 0.4, 1.7, -0.6])


def _first_order(phase):
    """``A`` and the equilibrium ``z_eq`` of ``z' = A (z - z_eq)``."""
    a = np.zeros((4, 4))
    a[:2, 2:] = np.eye(2)
    a[2:, :2] = -np.linalg.solve(phase.mass, phase.stiffness)
    return a, np.concatenate([np.linalg.solve(phase.stiffness, phase.force), np.zeros(2)])


@pytest.mark.parametrize("kind", ["F", "R", "L"])
def test_states_velocities_and_transitions_are_the_matrix_exponential(paper_params, kind):
    phase = phase_of(paper_params, kind)
    a, z_eq = _first_order(phase)
    exponentials = np.array([scipy.linalg.expm(a * t) for t in TIMES])
    np.testing.assert_allclose(phase.transitions(TIMES), exponentials, rtol=0, atol=1e-12)
    velocity = phase.velocity_function(Z0)
    for t, e in zip(TIMES, exponentials):
        np.testing.assert_allclose(phase.transition(t), e, rtol=0, atol=1e-12)
        expected = z_eq + e @ (Z0 - z_eq)
        np.testing.assert_allclose(phase.state(Z0, float(t)), expected, rtol=0, atol=1e-11)
        assert velocity(float(t)) == pytest.approx(expected[2], abs=1e-11)
    expected_xdot = [(z_eq + e @ (Z0 - z_eq))[2] for e in exponentials]
    np.testing.assert_allclose(phase.velocities(Z0, TIMES), expected_xdot, rtol=0, atol=1e-11)


def test_stacked_floquet_variables_are_those_of_each_orbit(paper_params):
    # enough orbits that a last-bit difference of a stacked operation (numpy's array square
    # against the scalar power did differ on about one orbit in a thousand) shows
    rng = np.random.default_rng(5)
    sequences = list(rng.choice(["FR", "FLF", "FRFL", "FLFR"], size=3000))
    durations = [rng.uniform(0.05, 1.2, len(s)) for s in sequences]
    stacked = es.stability_variables(paper_params, sequences, durations)
    phases = es._phases(paper_params)
    one = [es.exact_multipliers(paper_params, seq, d, phases) for seq, d in zip(sequences, durations)]
    for name, field in [
        ("trace_invariant", "trace_invariant"),
        ("stability_margin", "stability_margin"),
        ("stability_tolerance", "tolerance"),
        ("trivial_multiplier_distance", "trivial_distance"),
    ]:
        np.testing.assert_array_equal(stacked[name][1], [getattr(m, field) for m in one], err_msg=name)
    np.testing.assert_array_equal(stacked["multiplier_real"][1], [m.multiplier.real for m in one])
