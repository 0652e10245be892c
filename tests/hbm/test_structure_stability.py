"""Stability of the orbits of any structure (the one interface, nnmstop.hbm.stability.orbit_stability).

References independent of the methods under test: the closed-form multipliers of a linear structure (an orbit
that never reaches its stop), the monodromy of the same variational equation integrated by scipy's adaptive
DOP853, the equations of motion integrated by DOP853 from a refined orbit (its closure and monodromy), Krein's
theory of colliding pairs, and the 2-DOF oscillator written with its degrees of freedom in the other order.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nnmstop import fourier
from nnmstop.continuation.anm import ANMSettings
from nnmstop.floquet import PairInvariants
from nnmstop.hbm.monodromy import MonodromySettings, branch_monodromy
from nnmstop.hbm.shooting_refinement import RegularizedDynamics, refined_stability, segment_flow
from nnmstop.hbm.stability import StabilitySettings, orbit_stability
from nnmstop.hbm.stages import BranchSettings, BranchSpec, StageSpec, follow_stage, start_point
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.hbm.variational import Linearization, stop_coefficients
from nnmstop.models.beam import Beam, beam_structure, default_tube_parameters
from nnmstop.models.structure import Stop, Structure, two_dof_structure
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force, regularized_contact_stiffness

CHAIN_K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])


EXAMPLE_STOP = Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)


def chain(stops=(EXAMPLE_STOP,)):
    """The 3-DOF example of the plan (a grounded chain), with its stop or others."""
    return Structure(np.eye(3), CHAIN_K, stops)


def small_beam(elements: int = 5):
    """The tube's beam with 5 elements (the plate at 0.6 L on a node; 10 DOF) or 2 (the plate at mid-length; 4 DOF)."""
    parameters = default_tube_parameters()
    parameters["n_elements"] = elements
    if elements == 2:
        del parameters["stops"][0]["position"]
        parameters["stops"][0]["node"] = 1
    return beam_structure(Beam.from_parameters(parameters))


def nnm1_branch(system, amplitude, energy_max, max_truncation, continuation):
    """NNM1 of ``system`` by the one staged continuation (:func:`nnmstop.hbm.stages.follow_stage`), one stage from
    the linear mode at ``amplitude`` to the first orbit above ``energy_max``, the start corrected to the Newton
    threshold."""
    settings = BranchSettings(continuation, max_truncation, start_tolerance=continuation.newton_threshold)
    stage = StageSpec("up", {"energy_above": energy_max})
    return follow_stage(system, settings, BranchSpec("nnm1", 1, amplitude, (stage,), energy_max=energy_max))


@pytest.fixture(scope="module")
def two_stop_branch():
    """NNM1 of the chain with two stops (unequal gaps, on dofs 0 and 2) at H = 24, up to energy 12."""
    structure = chain((Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1), Stop(dof=2, gap=1.6, stiffness=20.0, eta=0.08)))
    system = HarmonicBalanceSystem(structure, 24)
    settings = ANMSettings(order=20, tolerance=1e-8)
    branch = nnm1_branch(system, 0.05, 12.0, 1e-2, settings)
    U = np.array(branch.points)
    residual = np.array([system.diagnostics(u)["time_residual"] for u in U])
    return system, U, residual


# --------------------------------------------------------------------------- linear structure


@pytest.mark.parametrize("structure", [chain(), small_beam()], ids=["3-DOF chain", "beam of 5 elements"])
@pytest.mark.parametrize("method", ["monodromy", "hill"])
def test_an_orbit_that_never_reaches_its_stop_has_the_modal_multipliers(structure, method):
    """Far inside the gap the stop adds its constant stiffness eta (its slope differs by O(x**2), 1e-8 at
    x = 1e-4): the structure is linear, and the other modes' multipliers over the orbit's period T are
    exp(+-i omega_j T), on the unit circle; stable and resolved. (T is the orbit's: it differs from mode 1's
    by O(x**2) too, which the high modes' omega_j T would amplify a hundredfold.)"""
    system = HarmonicBalanceSystem(structure, 8)
    U, _ = start_point(system, 1, 1e-4, tol=1e-12)
    result = orbit_stability(system, U[None], StabilitySettings(method=method))
    omega, _ = system.linear_modes()
    period = 2 * np.pi / np.sqrt(system.split(U)[-2])
    assert period == pytest.approx(2 * np.pi / omega[0], rel=1e-8)
    expected = 2 * np.cos(omega[1:] * period)
    mu = result.multipliers[0]
    assert mu.shape == (2 * system.n_dofs,)
    np.testing.assert_allclose(mu[:2], 1.0, atol=1e-5)
    np.testing.assert_allclose(np.abs(mu), 1.0, atol=1e-9)
    found = np.sort((mu[2::2] + 1 / mu[2::2]).real)
    np.testing.assert_allclose(found, np.sort(expected), atol=1e-7)
    assert result.stable[0] and result.resolved[0]


def test_one_degree_of_freedom_has_only_the_trivial_pair():
    structure = Structure(np.eye(1), np.eye(1), [Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)])
    system = HarmonicBalanceSystem(structure, 16)
    U, _ = start_point(system, 1, 0.9, tol=1e-12)
    result = branch_monodromy(system, U[None])
    assert result.multipliers.shape == (1, 2) and result.stable[0] and result.resolved[0]


@pytest.mark.numerics
@pytest.mark.parametrize("resonance, krein_opposite", [("sum", True), ("difference", False)])
def test_colliding_pairs_count_in_the_margin_only_with_opposite_krein_signs(resonance, krein_opposite):
    """Uncoupled modes (diagonal K), the stop on mode 1's DOF, at rest (omega = 1): the contact stiffness of a
    half-wave symmetric orbit varies at the even harmonics 2m omega only, so the pairs of modes 2 and 3 can
    interact where omega_2 + omega_3 (sum) or omega_3 - omega_2 (difference) is even. Krein: at a sum resonance
    the pairs' signatures are opposite and a coupling can open a quartet (the margin is the distance between
    them); at a difference resonance they are equal and cannot (the margin is the distance to +1)."""
    w2 = 2.3
    w3 = (6.0 - w2 if resonance == "sum" else 2.0 + w2) + 1e-4  # just off the collision
    eta = 0.1
    stiffness = np.diag([1.0 - eta, w2**2, w3**2])  # mode 1 at omega = 1 with the stop's eta
    structure = Structure(np.eye(3), stiffness, [Stop(dof=0, gap=1.0, stiffness=30.0, eta=eta)])
    system = HarmonicBalanceSystem(structure, 8)
    U, _ = start_point(system, 1, 1e-3, tol=1e-12)
    result = branch_monodromy(system, U[None])
    s = np.sort(result.invariants.s[0].real)
    gap = abs(s[1] - s[0])
    assert gap < 1e-2  # the pairs nearly meet
    krein = result.invariants.krein[0]
    assert (krein[0] * krein[1] < 0) == krein_opposite
    to_type_change = np.min(np.abs(s - 2.0))  # half-wave symmetric: a pair changes type only at +1
    expected = min(gap, to_type_change) if krein_opposite else to_type_change
    assert result.margin[0] == pytest.approx(expected, rel=1e-6)


# --------------------------------------------------------------------------- against DOP853


def variational_by_dop853(system, U, span, rtol=1e-11):
    """Transition matrix over ``span`` of phase of z'' + B(t) z = 0 (mass-normalized), by adaptive DOP853.

    B(t) from the HBM stop coordinates synthesized at each time and the contact law's slope
    (models.two_dof.regularized_contact_stiffness, the cubic's root), not from the code under test.
    """
    linearization = Linearization.of(system)
    cos, sin = fourier.to_cos_sin(stop_coefficients(system, U[None])[0], system.H)
    omega = np.sqrt(system.split(U)[-2])
    N = system.n_dofs
    laws = [ModelParameters(alpha=a, eta=e) for a, e in zip(system.alphas, system.etas)]

    def rhs(t, y):
        x = fourier.PhaseSynthesis([omega * t], system.H).values(cos.T, sin.T)[0]
        k = [regularized_contact_stiffness(xi, law) for xi, law in zip(x, laws)]
        B = linearization.stiffness + sum(ki * o for ki, o in zip(k, linearization.stop_outer))
        Y = y.reshape(2 * N, 2 * N)
        return np.concatenate([Y[N:], -B @ Y[:N]]).ravel()

    solution = solve_ivp(rhs, (0, span / omega), np.eye(2 * N).ravel(), method="DOP853", rtol=rtol, atol=rtol)
    return solution.y[:, -1].reshape(2 * N, 2 * N)


def check_against_dop853(system, U, result, i):
    """Every pair's invariant of orbit ``i`` within the two integrations' errors (DOP853 at two tolerances)."""
    span = np.pi if result.halfwave[i] else 2 * np.pi
    fine, coarse = (
        PairInvariants.of(variational_by_dop853(system, U[i], span, rtol)[None], halfwave=bool(result.halfwave[i]))
        for rtol in (1e-11, 1e-9)
    )
    reference_error = np.abs(np.sort(fine.s[0].real) - np.sort(coarse.s[0].real)).max()
    difference = np.abs(np.sort(result.invariants.s[i].real) - np.sort(fine.s[0].real)).max()
    assert difference <= 2 * result.integration_error[i] + 2 * reference_error + 1e-10
    if result.resolved[i]:
        assert result.stable[i] == fine.stable(0.0)[0]


@pytest.mark.numerics
def test_two_stop_chain_matches_dop853(two_stop_branch):
    """Orbits with impacts on both stops (Cayley-Hamilton Magnus steps)."""
    system, U, residual = two_stop_branch
    result = branch_monodromy(system, U, MonodromySettings(refine=False), time_residual=residual)
    impacts = np.array([system.diagnostics(u)["impacts_per_period"] for u in U])
    assert impacts.max() >= 4
    for i in (int(np.argmax(impacts >= 2)), len(U) - 1):
        check_against_dop853(system, U, result, i)


@pytest.mark.numerics
def test_beam_matches_dop853():
    """A beam of 2 elements (4 DOF: commutator-free Magnus steps, closed-form exponentials) past its first
    impacts."""
    system = HarmonicBalanceSystem(small_beam(2), 16)
    branch = nnm1_branch(system, 0.05, 30.0, 1e-2, ANMSettings(order=20, tolerance=1e-8))
    U = np.array(branch.points)
    impacts = np.array([system.diagnostics(u)["impacts_per_period"] for u in U])
    assert impacts.max() >= 2
    result = branch_monodromy(system, U, MonodromySettings(refine=False))
    check_against_dop853(system, U, result, int(np.argmax(impacts >= 2)))


def test_error_estimate_bounds_the_error(two_stop_branch):
    system, U, residual = two_stop_branch
    U, residual = U[::6], residual[::6]
    coarse, fine = (
        branch_monodromy(system, U, MonodromySettings(steps=n, max_steps=2 * n, refine=False), time_residual=residual)
        for n in (64, 2048)
    )
    change = np.array(
        [np.abs(np.sort(a.real) - np.sort(b.real)).max() for a, b in zip(coarse.invariants.s, fine.invariants.s)]
    )
    assert np.all(change <= coarse.integration_error + 10 * fine.integration_error + 1e-12)


# --------------------------------------------------------------------------- refinement


def test_segment_flow_matches_dop853_with_two_stops_and_unequal_masses():
    """The refinement's integrator (branch coordinates of every stop, step maps of the variational equation)
    against DOP853 on the equations of motion with forces from the cubic's root: a chain with unequal masses,
    two stops with different gaps (on dofs 0 and 2), a start in contact."""
    stops = (EXAMPLE_STOP, Stop(dof=2, gap=1.6, stiffness=20.0, eta=0.08))
    mass = np.diag([1.0, 1.5, 0.7])
    structure = Structure(mass, CHAIN_K, stops)
    start = np.array([1.3, -0.4, 2.1, 0.3, 0.8, -1.1])
    period = 6.0
    end, Q = segment_flow(
        RegularizedDynamics(structure), start[None], np.array([period]), np.linspace(0, 0.5 * np.pi, 801)[None]
    )
    M_inv = np.linalg.inv(mass)

    def rhs(t, y):
        q, v, Y = y[:3], y[3:6], y[6:].reshape(6, 6)
        force, K_t = CHAIN_K @ q, CHAIN_K.copy()
        for stop in stops:
            law = ModelParameters(alpha=stop.stiffness, eta=stop.eta)
            force[stop.dof] += stop.gap * regularized_contact_force(q[stop.dof] / stop.gap, law)
            K_t[stop.dof, stop.dof] += regularized_contact_stiffness(q[stop.dof] / stop.gap, law)
        return np.concatenate([v, -M_inv @ force, np.concatenate([Y[3:], -M_inv @ K_t @ Y[:3]]).ravel()])

    sol = solve_ivp(rhs, (0, period / 4), np.r_[start, np.eye(6).ravel()], method="DOP853", rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(end[0], sol.y[:6, -1], atol=1e-10)
    np.testing.assert_allclose(Q[0], sol.y[6:, -1].reshape(6, 6), atol=1e-9 * np.abs(Q).max())


@pytest.mark.numerics
def test_refined_chain_orbit_is_periodic_and_its_monodromy_matches_dop853(two_stop_branch):
    """Shooting refinement of an orbit with impacts on both stops: the refined start, integrated through the
    equations of motion over a whole period by DOP853 (forces from the cubic's root, not the integrator's
    parametrization), closes; its monodromy (variational equation alongside) has the refined invariants."""
    system, U, _ = two_stop_branch
    impacts = np.array([system.diagnostics(u)["impacts_per_period"] for u in U])
    i = int(np.argmax(impacts >= 4))
    s = MonodromySettings()
    r = refined_stability(system, U[[i]], s.refine_steps, s.refine_max_steps, s.refine_tol, 2.0, s.refine_max_change)
    assert r.converged[0] and r.residual[0] <= s.refine_tol
    mass, stiffness = system.structure.dense_matrices()
    M_inv = np.linalg.inv(mass)
    N = system.n_dofs
    laws = [ModelParameters(alpha=a, eta=e) for a, e in zip(system.alphas, system.etas)]

    def rhs(t, y):
        q, v, Y = y[:N], y[N : 2 * N], y[2 * N :].reshape(2 * N, 2 * N)
        force, K_t = stiffness @ q, stiffness.copy()
        for dof, gap, law in zip(system.stop_dofs, system.gaps, laws):
            force[dof] += gap * regularized_contact_force(q[dof] / gap, law)
            K_t[dof, dof] += regularized_contact_stiffness(q[dof] / gap, law)
        return np.concatenate([v, -M_inv @ force, np.concatenate([Y[N:], -M_inv @ K_t @ Y[:N]]).ravel()])

    start = np.concatenate([r.start[0], np.zeros(N), np.eye(2 * N).ravel()])
    sol = solve_ivp(rhs, (0, r.period[0]), start, method="DOP853", rtol=1e-12, atol=1e-12)
    end = sol.y[:, -1]
    assert np.abs(end[:N] - r.start[0]).max() < 1e-7 * np.abs(r.start[0]).max()
    assert np.abs(end[N : 2 * N]).max() < 1e-7 * np.abs(r.start[0]).max() * 2 * np.pi / r.period[0]
    L = Linearization.of(system).mass_factor
    S = np.kron(np.eye(2), L.T)
    monodromy = S @ end[2 * N :].reshape(2 * N, 2 * N) @ np.linalg.inv(S)
    reference = PairInvariants.of(monodromy[None], halfwave=False)
    np.testing.assert_allclose(
        np.sort(r.invariants.s[0].real), np.sort(reference.s[0].real), atol=2 * r.integration_error[0] + 1e-6
    )


# --------------------------------------------------------------------------- nothing special about the paper


def test_the_two_dof_oscillator_in_the_other_order_has_the_same_stability():
    """The paper's oscillator written as a Structure with u first and x (the stop) second, unequal masses
    and stiffnesses: the same invariants, verdicts and reasons as in the paper's order (the paper's structure
    is one instance; nothing checks for it)."""
    params = ModelParameters(alpha=30.0, beta=0.7, delta=2.5, eta=0.1)
    paper = two_dof_structure(params)
    mass, stiffness = paper.dense_matrices()
    swap = [1, 0]
    other = Structure(mass[np.ix_(swap, swap)], stiffness[np.ix_(swap, swap)], [Stop(1, 1.0, params.alpha, params.eta)])
    systems = [HarmonicBalanceSystem(s, 20) for s in (paper, other)]
    branch = nnm1_branch(systems[0], 0.5, 8.0, 1e-2, ANMSettings(order=20, tolerance=1e-8))
    U = np.array(branch.points)[::3]
    V = np.array([systems[1].pack(*(systems[0].split(u)[j] for j in (1, 0, 2, 3)), systems[0].split(u)[4]) for u in U])
    residual = np.array([systems[0].diagnostics(u)["time_residual"] for u in U])
    a, b = (branch_monodromy(s, W, time_residual=residual) for s, W in zip(systems, (U, V)))
    np.testing.assert_array_equal(a.stable, b.stable)
    np.testing.assert_array_equal(a.reason, b.reason)
    np.testing.assert_allclose(a.invariant, b.invariant, atol=1e-9)


def test_orbits_of_a_structure_too_stiff_for_the_refinement_keep_the_orbit_verdict(caplog):
    """The refinement's explicit Runge-Kutta scheme must resolve the stiffest mode (h omega_max <= 0.25) at two
    levels of steps within refine_max_steps; for the 5-element beam (omega_max 425 times the first) it cannot:
    an orbit whose own error decides (a time residual beyond max_orbit_residual, given here) keeps reason 2,
    unrefined, and the log says why."""
    system = HarmonicBalanceSystem(small_beam(), 8)
    U, _ = start_point(system, 1, 1e-3, tol=1e-12)
    with caplog.at_level("WARNING", logger="nnmstop.hbm.monodromy"):
        result = branch_monodromy(system, U[None], MonodromySettings(), time_residual=[0.1])
    assert result.reason[0] == 2 and not result.refined[0] and not result.resolved[0]
    assert "not refined" in caplog.text and "stiffest mode" in caplog.text
