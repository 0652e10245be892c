"""Exact orbits over full periods (nnmstop.exact.switching): closed forms, time integration, change of coordinates."""

from __future__ import annotations

import numpy as np
import pytest

from nnmstop import Stop, Structure
from nnmstop.api import exact_family
from nnmstop.checks.time_integration import integrate_structure_piecewise
from nnmstop.exact.switching import SwitchingProblem, follow_switching_family, near_grazing_orbit

CHAIN = np.array([[2.0, -1.0], [-1.0, 1.0]])


def _contact_arc(gap: float, alpha: float, radius):
    """Time beyond a one-sided stop at ``gap`` (stiffness ``alpha``) of x'' + x = 0 entering it on the circle of
    radius ``radius``: the arc of x'' + (1 + alpha) x = alpha gap above x = gap."""
    omega, rest = np.sqrt(1.0 + alpha), alpha * gap / (1.0 + alpha)
    amplitude = np.sqrt((gap - rest) ** 2 + np.maximum(radius**2 - gap**2, 0.0) / omega**2)
    return 2.0 * np.arccos((gap - rest) / amplitude) / omega


def _period(energy, stops):
    """Exact period of the oscillator x'' + x + sum of one-sided contacts = 0 at ``energy``: the free flight on the
    circle of radius R = sqrt(2 E) between the gaps, plus a contact arc at each gap R exceeds."""
    radius = np.sqrt(2.0 * np.asarray(energy))
    free = 2.0 * np.pi
    arcs = 0.0
    for gap, alpha in stops:
        free = free - 2.0 * np.arccos(np.minimum(gap / radius, 1.0))
        arcs = arcs + _contact_arc(gap, alpha, radius)
    return free + arcs


@pytest.mark.numerics
def test_one_dof_one_sided_family_is_the_closed_form_backbone():
    """x'' + x + alpha (x - 1)_+ = 0: T(E) = 2 pi - 2 acos(1/R) + 2 acos((1 - x_e)/B) / Omega, to round-off."""
    structure = Structure(
        np.eye(1), np.eye(1), [Stop(kind="one_sided", dof=0, side="positive", gap=1.0, stiffness=30.0, eta=0.1)]
    )
    family = follow_switching_family(structure, step=0.05, max_points=150)
    assert len(family) == 150 and family.energy.max() > 10.0
    np.testing.assert_allclose(family.period, _period(family.energy, [(1.0, 30.0)]), rtol=1e-13)
    assert np.abs(family.unfolding).max() < 1e-13 and np.all(family.stop_impacts == 1)


@pytest.mark.numerics
def test_unequal_gaps_insert_the_far_side_where_it_is_grazed():
    """Gaps 1 (stiffness 30) and 1.5 (stiffness 20) on one DOF: one impact on the near side until the orbit grazes
    the far one, then one on each; the closed-form period along both segments."""
    stops = [
        Stop(kind="one_sided", dof=0, side="positive", gap=1.0, stiffness=30.0, eta=0.1),
        Stop(kind="one_sided", dof=0, side="negative", gap=1.5, stiffness=20.0, eta=0.1),
    ]
    family = follow_switching_family(Structure(np.eye(1), np.eye(1), stops), step=0.05, max_points=120)
    assert set(family.segment) == {0, 1}
    first = family.energy[family.segment == 1].min()
    assert first == pytest.approx(0.5 * 1.5**2, rel=1e-4)  # the far side grazed at R = 1.5 (next to it)
    np.testing.assert_allclose(family.period, _period(family.energy, [(1.0, 30.0), (1.5, 20.0)]), rtol=1e-12)
    np.testing.assert_array_equal(family.stop_impacts[family.segment == 1], [[1, 1]] * int(np.sum(family.segment)))


@pytest.mark.numerics
def test_two_dof_one_sided_orbits_are_orbits_of_the_piecewise_equations():
    """Orbits of the paper's oscillator with a one-sided stop, integrated by DOP853 with every contact entry and
    exit located as an event: they close after one period and switch at the family's switching times."""
    structure = Structure(
        np.eye(2), CHAIN, [Stop(kind="one_sided", dof=0, side="negative", gap=1.0, stiffness=30.0, eta=0.1)]
    )
    family = follow_switching_family(structure, step=0.05, max_points=80)
    for i in (10, len(family) - 1):
        problem, y = family.problem_of(i), family.unknowns[i]
        z0, period = problem.start_state(y), problem.period(y)
        run = integrate_structure_piecewise(structure, z0, [0.0, 0.5 * period, period])
        assert np.abs(run.states[-1] - z0).max() <= 1e-9 * np.abs(z0).max()
        switches = problem.times(y)[1:-1]
        np.testing.assert_allclose(run.switch_times[: len(switches)], switches, rtol=0, atol=1e-9 * period)
    assert family.x_max[-1, 0] > 1.0 and np.all(family.stop_impacts == 1)


@pytest.mark.numerics
def test_a_relative_stop_is_a_grounded_stop_in_the_relative_coordinate_exactly():
    """The exact orbits of the chain with a stop between its masses, mapped to y = (q1 - q2, q2), solve the
    full-period equations of the structure with the stop on y1, to round-off."""
    T = np.array([[1.0, 1.0], [0.0, 1.0]])
    law = {"gap": 1.0, "stiffness": 30.0, "eta": 0.1}
    relative = Structure(np.eye(2), CHAIN, [Stop(kind="relative", dofs=[0, 1], side="positive", **law)])
    grounded = Structure(T.T @ T, T.T @ CHAIN @ T, [Stop(kind="one_sided", dof=0, side="positive", **law)])
    family = follow_switching_family(relative, step=0.05, max_points=40, mode=1)
    for i in (5, len(family) - 1):
        problem, y = family.problem_of(i), family.unknowns[i]
        other = SwitchingProblem(grounded, problem.sequence)
        z0 = problem.start_state(y)
        mapped = other.unknowns_from_state(
            np.concatenate([np.linalg.solve(T, z0[:2]), np.linalg.solve(T, z0[2:])]), problem.times(y)[1:], y[-1]
        )
        assert np.abs(other.residual(mapped)).max() < 1e-12 * np.abs(mapped).max()
        assert other.energy(mapped) == pytest.approx(problem.energy(y), rel=1e-13)


def test_the_first_orbit_is_next_to_the_grazing_linear_mode():
    structure = Structure(
        np.eye(2), CHAIN, [Stop(kind="one_sided", dof=0, side="positive", gap=2.0, stiffness=30.0, eta=0.1)]
    )
    problem, y, grazing = near_grazing_orbit(structure)
    omega = problem.free.omega[0]
    assert problem.period(grazing) == pytest.approx(2 * np.pi / omega, rel=1e-15)
    assert np.abs(problem.residual(grazing)).max() < 1e-14 * np.abs(grazing).max()  # the linear mode grazes
    assert problem.contact_time(y) == pytest.approx(1e-3 * 2 * np.pi / omega, rel=1e-12)
    assert problem.energy(y) == pytest.approx(problem.energy(grazing), rel=1e-4)


def test_exact_family_of_a_circular_clearance_says_there_is_none():
    structure = Structure(
        np.eye(2), np.diag([1.0, 1.5]), [Stop(kind="circular", dofs=[0, 1], gap=1.0, stiffness=30.0, eta=0.1)]
    )
    with pytest.raises(ValueError, match="not piecewise linear in the Cartesian coordinates"):
        exact_family(structure)


def test_exact_family_api_labels_the_full_period_family():
    structure = Structure(
        np.eye(2), CHAIN, [Stop(kind="one_sided", dof=0, side="positive", gap=1.0, stiffness=30.0, eta=0.1)]
    )
    ds = exact_family(structure, step=0.1, max_points=20)
    assert ds.attrs["segments"] == 1 and ds.sizes["orbit"] == 20
    assert ds.energy.attrs["long_name"] and ds.phase_sequence.values[0] == (
        "free -> one-sided stop (positive side) on q0"
    )
    np.testing.assert_allclose(ds.modal_energy.sum("mode"), ds.energy, rtol=1e-12)
