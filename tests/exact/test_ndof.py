"""Exact one-stop orbits of N-DOF structures: against the 2-DOF exact code, against time integration of the
non-smooth equations, against scipy's matrix exponential; conservation and validation."""

import numpy as np
import pytest
import scipy.linalg

from nnmstop.checks.time_integration import integrate_structure_nonsmooth
from nnmstop.exact.family import follow_two_impact_family as follow_family
from nnmstop.exact.ndof import (
    OneStopProblem,
    PhaseFlow,
    assess_orbit,
    follow_one_stop_family,
    grazing_orbit,
    orbit_at_contact_time,
    orbit_at_energy,
    piecewise_energy,
    time_history,
)
from nnmstop.exact.problem import TwoImpactProblem
from nnmstop.models.beam import Beam, BeamStop, beam_structure
from nnmstop.models.structure import Stop, Structure, two_dof_structure
from nnmstop.models.two_dof import ModelParameters


@pytest.fixture(scope="module")
def small_beam():
    """Cantilever of 6 elements (12 DOFs) with a stop at node 4 (alpha, eta as in the default tube)."""
    stop = BeamStop(gap=2e-4, stiffness=1.0e4, eta=1.0e4 / 300, node=4)
    return beam_structure(Beam(1.0, 500.0, 0.7, 6, "clamped", "free", stops=(stop,)))


def test_phase_flow_is_the_matrix_exponential(small_beam):
    problem = OneStopProblem(small_beam)
    phase = problem.contact
    n = problem.n
    mass, stiffness = small_beam.dense_matrices()
    stiffness = stiffness + problem.stop.stiffness * np.outer(np.eye(n)[problem.dof], np.eye(n)[problem.dof])
    # first-order system augmented with a constant state 1 carrying the force: z' = A z + f
    a = np.zeros((2 * n + 1, 2 * n + 1))
    a[:n, n : 2 * n] = np.eye(n)
    a[n : 2 * n, :n] = -np.linalg.solve(mass, stiffness)
    a[n : 2 * n, -1] = np.linalg.solve(mass, phase.force)
    t = 0.37
    expm = scipy.linalg.expm(a * t)
    np.testing.assert_allclose(phase.transition(t), expm[: 2 * n, : 2 * n], atol=1e-9 * np.abs(expm).max())
    z0 = np.random.default_rng(0).standard_normal(2 * n)
    expected = expm @ np.append(z0, 1.0)
    np.testing.assert_allclose(phase.state(z0, t), expected[:-1], atol=1e-9 * np.abs(expected).max())


def test_grid_sampling_matches_the_trigonometric_form(small_beam):
    # products of exponentials over two memory chunks (12 DOFs: 174,720 samples per chunk) against cosines and
    # sines at the same times
    problem = OneStopProblem(small_beam)
    z0 = np.random.default_rng(1).standard_normal(2 * problem.n)
    t, x, v = problem.contact.component_on_grid(z0, 2.0, 200001, problem.dof)
    np.testing.assert_array_equal(t, np.linspace(0.0, 2.0, 200001))
    x_ref, v_ref = problem.contact.component(z0, t, problem.dof)
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-13 * np.abs(x_ref).max())
    np.testing.assert_allclose(v, v_ref, rtol=0, atol=1e-13 * np.abs(v_ref).max())


def test_two_dof_structure_reproduces_the_two_dof_exact_family(paper_params):
    """Two codes, one family: the N-DOF solver on the 2-DOF structure against nnmstop.exact.family."""
    old = follow_family(paper_params, step=0.05)
    new = follow_one_stop_family(two_dof_structure(paper_params), step=0.05)
    problem = new.problem
    # both families end on the same located boundary (x reaches the opposite stop during free flight)
    assert new.end_margin == old.end_margin == "opposite_stop"
    np.testing.assert_allclose(new.energy[-1], old.energy[-1], rtol=1e-9)
    np.testing.assert_allclose(new.frequency[-1], old.frequency[-1], rtol=1e-9)
    # Along the family: frequencies at matched energies. Each orbit of the 2-DOF family is re-solved by the
    # N-DOF code at its energy (seeded by its velocities), and must be the same orbit.
    old_problem = TwoImpactProblem(paper_params)
    compared = 0
    for y_old, energy, frequency in zip(old.unknowns[::10], old.energy[::10], old.frequency[::10]):
        seed = problem.unknowns_from_velocity(y_old[:2], y_old[2], y_old[3])
        jacobian = np.vstack([problem.jacobian(seed), seed[:-2].tolist() + [0.0, 0.0]])
        if np.linalg.cond(jacobian) > 1e8:  # the energy turns back along the family: not a regular parameter
            continue
        y = orbit_at_energy(problem, energy, seed)
        np.testing.assert_allclose(1.0 / (4.0 * y[-1]), frequency, rtol=1e-9)
        # and the old code's equations hold at the new orbit
        y_as_old = np.concatenate([problem.initial_velocity(y), y[-2:]])
        assert np.linalg.norm(old_problem.residual(y_as_old)) < 1e-12
        compared += 1
    assert compared >= 0.8 * len(old.unknowns[::10])


def test_a_passive_stop_ends_the_family_where_it_is_reached(paper_params):
    """The 2-DOF oscillator with a second stop on u: far away it changes nothing; at gap 2 the family ends where
    max |u| over the orbit reaches 2 (u moves 1.618 times x in the first linear mode, so it starts below 2)."""
    base = two_dof_structure(paper_params)
    alone = follow_one_stop_family(base, step=0.05)

    def with_u_stop(gap):
        stops = base.stops + (Stop(dof=1, gap=gap, stiffness=paper_params.alpha, eta=paper_params.eta),)
        return Structure(base.mass, base.stiffness, stops)

    far = follow_one_stop_family(with_u_stop(1e6), step=0.05)
    assert far.end_margin == alone.end_margin
    np.testing.assert_allclose(far.energy[-1], alone.energy[-1], rtol=1e-12)
    near = follow_one_stop_family(with_u_stop(2.0), step=0.05)
    assert near.end_margin == "other_stops"
    assert near.energy[-1] < alone.energy.max()
    # independent look at the end orbit: u on a fine grid of the exact time history touches 2 without passing it
    problem = near.problem
    y = near.unknowns[-1]
    u = time_history(problem, y, np.linspace(0.0, 4.0 * y[-1], 400001)).q[:, 1]
    assert 0.0 <= 2.0 - np.abs(u).max() < 1e-8


def test_beam_orbit_is_periodic_under_time_integration_with_one_impact_per_stop(small_beam):
    problem = OneStopProblem(small_beam)
    y = orbit_at_contact_time(problem, 0.04)
    check = assess_orbit(problem, y)
    assert check.valid
    period = 4.0 * y[-1]
    z0 = np.concatenate([np.zeros(problem.n), problem.initial_velocity(y)])
    trajectory = integrate_structure_nonsmooth(small_beam, z0, [0.0, period])
    scale = np.abs(z0).max()
    np.testing.assert_allclose(trajectory.states[-1], z0, atol=1e-8 * scale)
    # one impact on each side of the stop per period, at the times of the exact construction
    entries = trajectory.switch_sides != 0
    assert list(trajectory.switch_sides[entries]) == [1, -1]
    np.testing.assert_allclose(trajectory.switch_times[entries], [y[-2], y[-2] + 0.5 * period], rtol=1e-9)


def test_exact_time_history_conserves_the_piecewise_energy(small_beam):
    problem = OneStopProblem(small_beam)
    y = orbit_at_contact_time(problem, 0.04)
    t = np.linspace(0.0, 4.0 * y[-1], 801)
    history = time_history(problem, y, t)
    energy = piecewise_energy(small_beam, history.q, history.qdot)
    np.testing.assert_allclose(energy, problem.energy(y), rtol=1e-10)
    x = history.q[:, problem.dof]
    # the stop degree of freedom enters each side of the stop once per period
    assert np.count_nonzero((x[:-1] < problem.gap) & (x[1:] >= problem.gap)) == 1
    assert np.count_nonzero((x[:-1] > -problem.gap) & (x[1:] <= -problem.gap)) == 1
    np.testing.assert_array_equal(history.force, problem.stop.piecewise_force(x))


def test_beam_family_from_grazing_ends_on_a_located_boundary(small_beam):
    family = follow_one_stop_family(small_beam, step=0.05, max_points=400)
    problem = family.problem
    np.testing.assert_allclose(family.unknowns[0], grazing_orbit(problem))
    assert family.end_margin  # the family ends on a violated assumption, not on max_points
    # the grazing start has contact time and entry velocity 0; every later orbit, the located end included,
    # satisfies all the assumptions strictly
    assert all(a.valid for a in family.assessments[1:])
    assert family.residual.max() < 1e-9
    # the grazing orbit is the first linear mode: frequency 1/(2 pi) in the nondimensional time
    np.testing.assert_allclose(family.frequency[0], 1.0 / (2.0 * np.pi), rtol=1e-12)
    assert np.all(family.contact_time >= 0)
    # Independent look at the located end: on a fine grid of the exact contact phase, the stop degree of
    # freedom comes back to the gap (an interior minimum at g, to the grid's resolution) without crossing it.
    assert family.end_margin == "leaves_stop"
    y = family.unknowns[-1]
    t = np.linspace(y[-2], y[-1], 200001)
    x = problem.quarter_state(y, t)[:, problem.dof]
    interior_minima = x[1:-1][(x[1:-1] < x[:-2]) & (x[1:-1] <= x[2:])]
    assert interior_minima.size and 0.0 <= interior_minima.min() - problem.gap < 1e-7


def test_validation_names_the_value():
    stops = (Stop(0, 1.0, 30.0, 0.1), Stop(1, 1.0, 30.0, 0.1))
    with pytest.raises(ValueError, match=r"stop_index must be an integer in \[0, 2\), got 2"):
        OneStopProblem(Structure(np.eye(2), np.diag([1.0, 2.0]), stops), stop_index=2)
    problem = OneStopProblem(two_dof_structure(ModelParameters()))
    with pytest.raises(ValueError, match=r"mode must be in \[0, 2\), got 5"):
        grazing_orbit(problem, 5)
    with pytest.raises(ValueError, match=r"contact_time must be a finite number >= 0, got -1\.0"):
        orbit_at_contact_time(problem, -1.0)
    with pytest.raises(ValueError, match=r"increment must be a finite number > 0, got 0\.0"):
        orbit_at_contact_time(problem, 0.1, increment=0.0)
    with pytest.raises(ValueError, match=r"unknowns must be \(b_1..b_2, tau1, T1\), shape \(4,\), got \(3,\)"):
        problem.residual(np.zeros(3))
    with pytest.raises(ValueError, match="stiffness of a phase must be positive definite"):
        PhaseFlow(np.eye(2), np.diag([0.0, 1.0]), np.zeros(2))
