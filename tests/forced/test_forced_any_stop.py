"""Exact forced responses without the half-period symmetry, for any piecewise-linear stop (issue 30).

Independent references: the closed-form receptance (grazing), event-located DOP853 integration of the
piecewise-linear law (periodicity, switching phases, a finite-difference monodromy, an unstable response
departing at its rate), the phase matrices themselves (a continuous vector field: saltation = identity), the
half-wave reduction and the paper's committed datasets (the full-period solver on the bilateral stop), and the
regularized law by harmonic balance as eta goes to zero.
"""

import json

import numpy as np
import pytest

from nnmstop.checks.forced_integration import integrate_forced_nonsmooth
from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings
from nnmstop.exact.forced import (
    ForcedResponseProblem,
    SymmetricContactProblem,
    follow_contact_family,
    grazing_frequencies,
    grazing_problem,
    structure_contacts,
)
from nnmstop.floquet import match_nearest
from nnmstop.models.contact import Stop
from nnmstop.models.excitation import Damping, Excitation, HarmonicForce
from nnmstop.models.structure import Structure

from .conftest import at_frequency, exact_response_at, oscillator_excitation, regularized_response_at

CONTINUATION = PseudoArclengthSettings(tolerance=1e-12, initial_step=0.01, max_step=0.05)
RANGE = (0.1, 0.35)  # Hz: the chain's first resonance (0.159 Hz) and its second (0.276 Hz)


def chain_excitation(stops, force: float = 0.2, zeta: float = 0.02, dof: int = 0) -> Excitation:
    """A grounded 2-DOF chain of unit masses and springs with ``stops``, damping ratio ``zeta`` on both modes."""
    chain = Structure(np.eye(2), [[2.0, -1.0], [-1.0, 2.0]], list(stops))
    return Excitation(chain, Damping.from_modal_ratios(chain, [zeta, zeta]), HarmonicForce(force, [dof]))


def one_sided(alpha: float = 20.0, eta: float = 0.05, gap: float = 1.0, side: str = "positive", dof: int = 0):
    return Stop(kind="one_sided", dof=dof, side=side, gap=gap, stiffness=alpha, eta=eta)


@pytest.fixture(scope="module")
def one_sided_family():
    """The chain with a one-sided stop on its first mass, forced there (F = 0.2): the family of one contact per
    period from the first grazing orbit, continued to its end (confirmed)."""
    excitation = chain_excitation([one_sided()])
    omega = grazing_frequencies(excitation, 2 * np.pi * RANGE[0], 2 * np.pi * RANGE[1])[0]
    problem, y0, direction = grazing_problem(excitation, omega)
    family = follow_contact_family(problem, y0, direction, CONTINUATION, RANGE, confirm=True)
    return excitation, problem, family


def _mid_flight(problem: ForcedResponseProblem, y):
    """A state in the middle of the free flight of ``[{c}, {}]`` and its phase (no integration starts on a stop)."""
    states, phases = problem.switch_states(y), problem.switch_phases(y)
    theta = 0.5 * (phases[1] + phases[2])
    return problem.phase_list[1].states(states[1], phases[1], y[-1], theta), theta


def _period_map(excitation, omega, z, theta, periods=1, **tolerances):
    t = theta / omega + np.arange(periods + 1) * 2 * np.pi / omega
    return integrate_forced_nonsmooth(excitation, omega, z, t, **tolerances)


# ------------------------------------------------------------------ grazing: closed form


@pytest.mark.parametrize(
    "stops",
    [
        [one_sided()],
        [one_sided(gap=1.0), one_sided(gap=0.6, side="negative")],  # unequal gaps: the nearer side grazes first
        [Stop(kind="relative", dofs=[0, 1], side="negative", gap=0.4, stiffness=10.0, eta=0.05)],
    ],
    ids=["one_sided", "unequal_gaps", "relative_one_sided"],
)
def test_the_non_impacting_response_grazes_where_gap_over_receptance_is_the_force(stops):
    """``F |n . H(Omega) b| = g`` at every located grazing frequency, ``H = (K - Omega^2 M + i Omega C)^-1`` solved
    here directly, for the contact that the response reaches (the largest ``|n . H b| / g``)."""
    excitation = chain_excitation(stops)
    M, K = excitation.structure.dense_matrices()
    C = np.asarray(excitation.damping_matrix)
    b = excitation.force.pattern(2)
    normals = np.array([c.normal(2) for c in structure_contacts(excitation.structure)])
    gaps = np.array([c.gap for c in structure_contacts(excitation.structure)])
    grazing = grazing_frequencies(excitation, 2 * np.pi * RANGE[0], 2 * np.pi * RANGE[1])
    assert len(grazing) >= 2  # the response rises above the nearest gap over a resonance and falls back
    for omega in grazing:
        H = np.linalg.solve(K - omega**2 * M + 1j * omega * C, b)
        reach = np.abs(normals @ H) / gaps
        c = int(np.argmax(reach))
        assert gaps[c] / np.abs(normals[c] @ H) == pytest.approx(excitation.force.amplitude, rel=1e-13)
    below = 0.9 * grazing[0]
    H = np.linalg.solve(K - below**2 * M + 1j * below * C, b)
    assert np.all(excitation.force.amplitude * np.abs(normals @ H) < gaps)


# ------------------------------------------------------------------ the equations


@pytest.mark.parametrize(
    "stop",
    [
        Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1),
        one_sided(dof=1, side="negative", gap=1.3),
        Stop(kind="relative", dofs=[0, 1], gap=0.5, stiffness=7.0, eta=0.1),
        Stop(kind="relative", dofs=[1, 0], side="positive", gap=0.8, stiffness=5.0, eta=0.1),
    ],
    ids=lambda stop: stop.label,
)
def test_the_vector_field_is_continuous_across_every_switch(stop):
    """Saltation = identity: on each switching surface ``n . q = g`` the phase with the contact and the phase
    without it have the same vector field (the contact force vanishes there), for every law kind allowed."""
    excitation = chain_excitation([stop])
    problem = ForcedResponseProblem(excitation, [{0}, set()])
    rng = np.random.default_rng(1)
    for c, contact in enumerate(problem.contacts):
        normal = contact.normal(2)
        inside, outside = problem.phase(()), problem.phase({c})
        for _ in range(3):
            z = rng.standard_normal(4)
            z[:2] += (contact.gap - normal @ z[:2]) * normal / (normal @ normal)  # onto the surface
            # z' = A (z - w) + B F cos(Omega t) b: the forcing is the same in every phase
            with_contact, without = outside.A @ (z - outside.w), inside.A @ (z - inside.w)
            np.testing.assert_allclose(with_contact, without, rtol=0, atol=1e-13 * np.abs(without).max())
            off = z.copy()
            off[:2] += 0.1 * normal  # off the surface they differ: the contact is there
            assert np.abs(outside.A @ (off - outside.w) - inside.A @ (off - inside.w)).max() > 1e-2


@pytest.mark.parametrize("which", ["one_sided", "bilateral_full_period"])
def test_jacobian_matches_finite_differences(which, one_sided_family):
    if which == "one_sided":
        _, problem, family = one_sided_family
        points = family.unknowns[[1, len(family.unknowns) // 2, -2]]
    else:
        excitation = oscillator_excitation(0.05)
        omega = grazing_frequencies(excitation, 2 * np.pi * 0.05, 2 * np.pi * 0.35)[0]
        problem, y0, _ = grazing_problem(excitation, omega, use_symmetry=False)
        assert problem.m == 4 and not problem.half_wave
        points = [y0, y0 + 1e-2 * np.random.default_rng(2).standard_normal(len(y0))]
    for y in points:
        h = 1e-6
        fd = np.array([(problem.residual(y + h * e) - problem.residual(y - h * e)) / (2 * h) for e in np.eye(len(y))]).T
        np.testing.assert_allclose(problem.jacobian(y), fd, atol=1e-7 * np.abs(fd).max())


def test_a_circular_clearance_has_no_exact_response():
    hole = Stop(kind="circular", dofs=[0, 1], gap=1.0, stiffness=10.0, eta=0.1)
    with pytest.raises(ValueError, match=r"exact forced responses need piecewise-linear stops: the circular"):
        grazing_frequencies(chain_excitation([hole]), 0.5, 2.0)


# ------------------------------------------------------------------ the one-sided family against time integration


def test_the_one_sided_family_runs_from_grazing_to_grazing(one_sided_family):
    excitation, problem, family = one_sided_family
    grazing = grazing_frequencies(excitation, 2 * np.pi * RANGE[0], 2 * np.pi * RANGE[1])
    assert problem.describe() == "q0 >= 1 in, q0 >= 1 out" and not problem.half_wave
    assert family.end_margin == "contact_duration" and family.end_check.startswith("end confirmed")
    assert family.unknowns[0, -1] == grazing[0]
    assert abs(family.unknowns[-1, -1] - grazing[1]) <= 1e-9 * grazing[1]
    assert all(problem.assess(y).valid for y in family.unknowns[1:-1])
    # the stop is struck on one side only: the first mass swings further to the free side than into the stop
    amplitude = np.array([problem.amplitudes(y) for y in family.unknowns])
    assert np.all(amplitude[1:-1, 0] > 1.0)


@pytest.mark.numerics
def test_one_sided_orbits_are_periodic_under_event_located_integration(one_sided_family):
    """One period of DOP853 with located switches returns to the start (to the integrator's accuracy, far below
    the contact's scale) and switches where the exact orbit does."""
    excitation, problem, family = one_sided_family
    n = len(family.unknowns)
    for y in family.unknowns[[n // 4, n // 2, 3 * n // 4]]:  # contacts long enough for the events to see them
        z, theta = _mid_flight(problem, y)
        omega = y[-1]
        states, switches = _period_map(excitation, omega, z, theta, rtol=1e-13, atol=1e-14)
        np.testing.assert_allclose(states[-1], z, rtol=0, atol=1e-10)
        assert len(switches) == 2
        exact = np.mod(problem.switch_phases(y)[:2], 2 * np.pi)
        np.testing.assert_allclose(np.sort(np.mod(omega * switches, 2 * np.pi)), np.sort(exact), atol=1e-9)


@pytest.mark.numerics
def test_multipliers_are_those_of_a_finite_difference_monodromy_of_the_integrated_flow(one_sided_family):
    """The product of the phase exponentials (saltation = identity) against central differences of the period
    map of the event-located integration, at the most unstable response and at a stable one."""
    excitation, problem, family = one_sided_family
    largest = np.array([np.abs(problem.multipliers(y)[0]).max() for y in family.unknowns])
    assert largest.max() > 1.5 and largest.min() < 1.0
    for index in (int(np.argmax(largest)), int(np.argmin(largest))):
        y = family.unknowns[index]
        z, theta = _mid_flight(problem, y)
        h = 1e-5
        columns = [
            (
                _period_map(excitation, y[-1], z + h * e, theta)[0][-1]
                - _period_map(excitation, y[-1], z - h * e, theta)[0][-1]
            )
            / (2 * h)
            for e in np.eye(4)
        ]
        finite = np.linalg.eigvals(np.array(columns).T)
        mu = problem.multipliers(y)[0]
        np.testing.assert_allclose(
            mu, match_nearest(mu[None], finite[None])[0], rtol=0, atol=1e-6 * max(1, largest[index])
        )


@pytest.mark.numerics
def test_an_unstable_one_sided_response_departs_at_the_rate_of_its_largest_multiplier(one_sided_family):
    """Between the folds the response is a saddle: a small perturbation grows by |mu|max per period (time
    integration); from a stable response it decays."""
    excitation, problem, family = one_sided_family
    largest = np.array([np.abs(problem.multipliers(y)[0]).max() for y in family.unknowns])
    for index in (int(np.argmax(largest)), int(np.argmin(largest))):
        y = family.unknowns[index]
        z, theta = _mid_flight(problem, y)
        states, _ = _period_map(excitation, y[-1], z + 1e-9 * np.array([1.0, 0.5, -0.3, 0.2]), theta, periods=10)
        distance = np.linalg.norm(states - z, axis=1)
        if largest[index] > 1:
            assert (distance[-1] / distance[-5]) ** 0.25 == pytest.approx(largest[index], rel=0.02)
        else:
            assert distance[-1] < distance[0] and (distance[-1] / distance[-5]) ** 0.25 < 1


# ------------------------------------------------------------------ the paper's bilateral stop without the symmetry


def test_the_full_period_solver_reproduces_the_symmetric_responses_of_the_paper_datasets(repo_root):
    """On the paper's oscillator at F = 0.1 (the pipeline's scene), the family of the general solver (full periods,
    two contact phases, no symmetry assumed): each orbit solves the half-wave equations, its multipliers are the
    squares of the half-period map's, the responses at the committed dataset's frequencies have its amplitudes,
    and the stability changes are the dataset's, same kinds, same frequencies."""
    from nnmstop.forced.responses import ExactSettings, exact_response

    excitation = oscillator_excitation(0.1)
    pieces = exact_response(excitation, (0.05, 0.35), ExactSettings(use_symmetry=False))
    (family,) = [p for p in pieces if p.kind == "one_contact"]
    problem = family.problem
    assert problem.m == 4 and not problem.half_wave and problem.episodes == 2
    symmetric = SymmetricContactProblem(excitation)
    for y in family.unknowns:
        z0, theta0, durations, omega = problem.split(y)
        reduced = np.concatenate([z0, [theta0, durations[0], omega]])
        assert np.abs(symmetric.residual(reduced)).max() < 1e-11
        mu = problem.multipliers(y)[0]
        nu = symmetric.multipliers(reduced)[1]
        np.testing.assert_allclose(mu, match_nearest(mu[None], (nu * nu)[None])[0], atol=1e-8 * np.abs(mu).max())

    reference = json.loads((repo_root / "reference" / "files.json").read_text())["files"]["forced/exact_F0.1.nc"]
    kinds = ("fold", "symmetry_breaking", "period_doubling", "neimark_sacker")
    found = sorted((c.U[-1] / (2 * np.pi), kinds.index(c.kind)) for c in family.changes)
    expected = sorted(zip(reference["values"]["change_frequency"], reference["values"]["change_kind"]))
    assert [k for _, k in found] == [k for _, k in expected]
    np.testing.assert_allclose([f for f, _ in found], [f for f, _ in expected], rtol=1e-8)

    # the dataset's contact points: the general solver at the same frequency (Newton, Omega held) has its amplitude
    curve = np.genfromtxt(repo_root / "reference" / "curves" / "forced__exact_F0.1.csv", delimiter=",", names=True)
    contact = curve[curve["segment"] == 1]
    slope = np.sign(np.diff(contact["frequency"]))
    turns = np.flatnonzero(slope[:-1] * slope[1:] < 0) + 1
    # Omega held: away from the folds (where it is singular) and from the grazing ends (nearly so)
    regular = [i for i in range(5, len(contact) - 5) if np.all(np.abs(turns - i) > 3)]
    contact = contact[regular[::10]]
    assert len(contact) >= 15
    Y = family.unknowns
    for amplitude, frequency in zip(contact["energy"], contact["frequency"]):
        omega = 2 * np.pi * frequency
        start = Y[np.argmin(np.abs(Y[:, -1] - omega) + np.abs(np.array(family.amplitude)[:, 0] - amplitude))]
        y = at_frequency(problem, start, omega)
        assert problem.amplitudes(y)[0] == pytest.approx(amplitude, rel=1e-9)


# ------------------------------------------------------------------ the regularized one-sided law as eta -> 0


def test_the_regularized_one_sided_response_converges_to_the_exact_one_as_eta_goes_to_zero():
    """Past grazing on the upper branch (0.16 Hz, alpha = 3, F = 0.2), the amplitudes of the regularized response
    (harmonic balance) approach the exact ones at first order in eta up to a logarithm (docs/forced.md: the
    one-sided law differs from the piecewise-linear one by eta x / (1 - x) inside the gap, an L1 error
    O(eta log(1/eta))): each threefold decrease of eta divides the error by more than 2."""
    alpha, frequency = 3.0, 0.16
    exact = exact_response_at(chain_excitation([one_sided(alpha=alpha, eta=0.01)]), frequency, RANGE)
    errors = []
    for eta in (alpha / 30, alpha / 90, alpha / 270):
        regularized = regularized_response_at(
            chain_excitation([one_sided(alpha=alpha, eta=eta)]), frequency, (0.14, 0.17)
        )
        errors.append(np.abs(regularized - exact) / exact)
    errors = np.array(errors)
    assert np.all(errors[:-1] / errors[1:] > 2.0), errors
    assert np.all(errors[-1] < 3 * (1 / 270) * np.log(270)), errors  # of the order of (eta/alpha) log(alpha/eta)
