"""Stability from the monodromy matrix (nnmstop.hbm.monodromy) against independent computations.

References: the closed-form Floquet multipliers of the linear limit, Hill's method
(a different discretization of the same linearization), the monodromy of an exact
periodic orbit of (7) integrated by DOP853 (shooting-refined, nnmstop.checks.shooting),
and the symplecticity of the flow of a Hamiltonian linear system. The shooting
refinement (nnmstop.hbm.shooting_refinement) of the orbits whose own error decides the
verdict is checked against the same DOP853 integrator (periodicity and multipliers of
the refined orbit) and against the growth of a perturbation of an orbit it finds
unstable, and against the exact multipliers of the non-smooth model as eta -> 0. Small
H = 40 branches keep the module cheap.
"""

import copy
import dataclasses

import numpy as np
import pytest
import scipy.linalg

from nnmstop.checks.shooting import monodromy, orbit_initial_state, refine_orbit
from nnmstop.config import ConfigError, load_config, validate_config
from nnmstop.exact.family import follow_two_impact_family as follow_family
from nnmstop.exact.problem import TwoImpactProblem
from nnmstop.exact.stability import exact_multipliers
from nnmstop.floquet import symplectic_invariants
from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.monodromy import MonodromySettings, branch_monodromy, orbit_monodromy, variational_step_matrices
from nnmstop.hbm.shooting_refinement import (
    RegularizedDynamics,
    _newton_update,
    refined_stability,
    segment_flow,
    shooting_stability,
)
from nnmstop.hbm.stability import branch_hill, orbit_stability
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.hbm.variational import Linearization
from nnmstop.models.structure import two_dof_parameters, two_dof_structure
from nnmstop.models.two_dof import ModelParameters
from nnmstop.settings import stability_settings


@pytest.fixture(scope="module")
def config(h40_config):
    return h40_config


@pytest.fixture(scope="module")
def system(h40_system):
    return h40_system


@pytest.fixture(scope="module")
def nnm1(h40_nnm1_stages, system):
    """Unknowns of NNM1 stages 1 and 2 (0, 2 then 6 impacts per period, through an energy fold)."""
    return np.concatenate([dataset_unknowns(ds, system) for ds in h40_nnm1_stages])


@pytest.fixture(scope="module")
def verdicts(system, nnm1):
    return branch_monodromy(system, nnm1, MonodromySettings()), branch_hill(system, nnm1)


def test_linear_limit_matches_closed_form():
    """Tiny amplitude: k = eta, so the non-trivial pair is exp(+-i Omega_2 T) with the modes of K + eta."""
    p = ModelParameters()
    system = HarmonicBalanceSystem(two_dof_structure(p), harmonics=16)
    U = system.linear_mode_guess(1, 1e-4)
    K = np.array([[1 + p.beta + p.eta, -p.beta], [-p.beta / p.delta, p.beta / p.delta]])
    w = np.sqrt(np.sort(np.linalg.eigvals(K).real))
    T = 2 * np.pi / w[0]
    r = branch_monodromy(system, U[None])
    assert r.halfwave[0]
    assert abs(r.invariant[0] - 2 * np.cos(w[1] * T)) < 1e-7
    assert r.stable[0] and r.resolved[0]


@pytest.mark.parametrize("step", [0.01, 0.1, 0.6, 3.0])  # the two largest need squarings
def test_magnus_step_matrices_are_the_exponentials_of_their_generators(step):
    """The step matrices (Cayley-Hamilton series, balanced coordinates) against scipy's expm (Pade) of the
    Magnus generator h/2 (A_1 + A_2) + sqrt(3)/12 h**2 [A_2, A_1], A_j = [[0, I], [-M^-1 K_t(t_j), 0]],
    in (q, q') coordinates, for unequal masses and stiffnesses."""
    params = ModelParameters(alpha=30.0, beta=0.7, delta=2.5, eta=0.1)
    system = HarmonicBalanceSystem(two_dof_structure(params), 4)
    linearization = Linearization.of(system)
    rng = np.random.default_rng(3)
    nodes = rng.uniform(params.eta, params.alpha, size=(1, 3, 5, 2))
    matrices = linearization.to_physical(variational_step_matrices(linearization, nodes, step))
    b, d = params.beta, params.delta

    def generator(k):
        stiffness = np.array([[1.0 + b + k, -b], [-b / d, b / d]])
        return np.block([[np.zeros((2, 2)), np.eye(2)], [-stiffness, np.zeros((2, 2))]])

    for k, matrix in zip(nodes.reshape(-1, 2), matrices.reshape(-1, 4, 4)):
        A1, A2 = generator(k[0]), generator(k[1])
        omega = 0.5 * step * (A1 + A2) + np.sqrt(3.0) / 12.0 * step**2 * (A2 @ A1 - A1 @ A2)
        expected = scipy.linalg.expm(omega)
        # round-off of a series summed at norm <= 1/2 (a few ulps), doubled by each squaring (of the balanced
        # generator, whose norm is that of omega at most)
        squarings = max(0, int(np.ceil(np.log2(np.abs(omega).sum(axis=1).max() / 0.5))))
        tolerance = 2.0 ** (squarings + 5) * np.finfo(float).eps * np.abs(expected).max()
        np.testing.assert_allclose(matrix, expected, rtol=0, atol=tolerance)


def test_monodromy_is_symplectic(system, nnm1):
    """The flow of M y'' + (K + k(t) E) y = 0 preserves the symplectic form: M^T J M = J, det M = 1."""
    J = np.block(
        [
            [np.zeros((2, 2)), np.diag([1.0, two_dof_parameters(system.structure).delta])],
            [-np.diag([1.0, two_dof_parameters(system.structure).delta]), np.zeros((2, 2))],
        ]
    )
    for U in nnm1[:: max(1, len(nnm1) // 6)]:
        M = orbit_monodromy(system, U, steps=512)
        scale = np.linalg.norm(M) ** 2
        assert np.abs(M.T @ J @ M - J).max() < 1e-11 * scale
        assert abs(np.linalg.det(M) - 1.0) < 1e-10 * scale


def test_agrees_with_hill_where_both_resolve(verdicts):
    mono, hill = verdicts
    both = mono.resolved & hill.resolved
    assert both.sum() > 0.5 * len(both)
    np.testing.assert_array_equal(mono.stable[both], hill.stable[both])
    # The invariants agree to the errors of the two methods (orbit error for both).
    mu = hill.multipliers[:, 2]
    s_hill = (mu + 1 / mu).real
    bound = mono.settings.resolution_factor * (mono.integration_error + mono.orbit_error + hill.orbit_residual) + 1e-9
    assert np.all(np.abs(mono.invariant - s_hill)[both] <= bound[both])


def test_every_orbit_gets_a_verdict_with_a_reason(verdicts):
    mono, _ = verdicts
    F = mono.settings.resolution_factor
    hbm = ~mono.refined
    limit = F * np.maximum(mono.integration_error, mono.orbit_error)
    assert np.all((mono.margin <= limit)[hbm & ~mono.resolved])
    assert np.all((mono.margin > limit)[hbm & mono.resolved])
    assert np.all(np.isin(mono.reason[hbm & ~mono.resolved], [1, 2]))
    # Refined orbits: the margin against their own (integration and closure) errors.
    refined_limit = np.maximum(F * np.maximum(mono.integration_error, mono.refined_residual), mono.settings.trace_tol)
    assert np.all(np.isin(mono.reason[mono.refined], [3, 4, 5]))
    assert np.all((mono.margin > refined_limit)[mono.reason == 3])
    assert np.all((mono.margin <= refined_limit)[mono.reason == 5])


def test_refinement_replaces_every_orbit_error_verdict(system, nnm1, verdicts):
    """Every orbit whose own error decides the verdict (reason 2 without refinement) is refined."""
    mono, _ = verdicts
    plain = branch_monodromy(system, nnm1, MonodromySettings(refine=False))
    assert np.any(plain.reason == 2)
    np.testing.assert_array_equal(mono.refined, plain.reason == 2)
    assert not np.any(mono.reason == 2)
    np.testing.assert_array_equal(mono.invariant[~mono.refined], plain.invariant[~mono.refined])


@pytest.fixture(scope="module")
def refined(system, nnm1):
    """The orbits left to their own error by the HBM monodromy, refined by shooting."""
    plain = branch_monodromy(system, nnm1, MonodromySettings(refine=False))
    idx = np.flatnonzero(plain.reason == 2)
    s = MonodromySettings()
    r = refined_stability(
        system,
        nnm1[idx],
        s.refine_steps,
        s.refine_max_steps,
        s.refine_tol,
        s.resolution_factor,
        s.refine_max_change,
        floor=s.trace_tol,
    )
    assert np.all(r.converged)
    return r


def test_segment_flows_chain_into_the_whole_flow():
    """The group property of the flow, which multiple shooting rests on: segments integrated one after the
    other, each from the previous one's end, give the end state and fundamental matrix (the product of the
    segments') of one trajectory over the whole grid, from a start in contact with non-zero velocities."""
    params = ModelParameters()
    start = np.array([[1.3, 0.6, 0.4, -0.8]])
    period = np.array([6.0])
    phases = np.linspace(0.0, 0.5 * np.pi, 65)[None]
    dynamics = RegularizedDynamics(two_dof_structure(params))
    whole_end, whole_Q = segment_flow(dynamics, start, period, phases)
    state, Q = start, np.eye(4)
    for m in range(4):
        state, Q_m = segment_flow(dynamics, state, period, phases[:, 16 * m : 16 * (m + 1) + 1])
        Q = Q_m[0] @ Q
    np.testing.assert_allclose(state, whole_end, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(Q, whole_Q[0], rtol=1e-11, atol=1e-11 * np.abs(whole_Q).max())


def test_a_singular_shooting_system_is_flagged_and_the_others_are_solved():
    """Issue 29: one orbit whose condensed Jacobian J (N x (N + 1)) has rank below N used to fail the whole batch
    with numpy's LinAlgError. Its update is now flagged unsolvable; the other orbits get the minimum-norm
    solution of J d = -c (numpy's lstsq, an independent solver)."""
    rng = np.random.default_rng(29)
    N, segments = 2, 3
    Qs = rng.normal(size=(3, segments, 2 * N, 2 * N))
    dp = rng.normal(size=(3, segments, 2 * N))
    mismatch = rng.normal(size=(3, segments, 2 * N))
    Qs[1, -1, :N] = 0.0  # orbit 1: the last segment maps every change onto q = 0 (rank 0)
    dp[1, -1, :N] = 0.0
    update, solvable = _newton_update(Qs, dp, mismatch, N)
    assert solvable.tolist() == [True, False, True]
    for i in (0, 2):
        A, b, c = Qs[i, 0, :, :N], dp[i, 0], mismatch[i, 0]
        for m in range(1, segments):
            A, b, c = Qs[i, m] @ A, Qs[i, m] @ b + dp[i, m], Qs[i, m] @ c + mismatch[i, m]
        J = np.column_stack([A[:N], b[:N]])
        expected = np.linalg.lstsq(J, -c[:N], rcond=None)[0]
        np.testing.assert_allclose(update[i], expected, rtol=1e-10, atol=1e-12)


def test_refined_orbits_match_adaptive_integration(system, refined):
    """DOP853 over a whole period (an independent integrator, no symmetry used) from the refined start:
    the orbit closes, and the multipliers of its monodromy match, within the two integrators' errors."""
    stable = np.abs(refined.invariants.s[:, 0].real) <= 2
    assert stable.any() and (~stable).any()
    picks = [
        int(np.argmax(np.where(stable, np.abs(refined.invariants.s[:, 0].real - 2), -1))),
        int(np.argmax(np.where(~stable, np.abs(refined.invariants.s[:, 0].real - 2), -1))),
    ]
    invariant = refined.invariants.s[:, 0].real
    for i in picks:
        z = np.r_[refined.start[i], 0.0, 0.0]
        coarse = monodromy(two_dof_parameters(system.structure), z, refined.period[i], rtol=1e-12, atol=1e-12)
        fine = monodromy(two_dof_parameters(system.structure), z, refined.period[i], rtol=1e-13, atol=1e-13)
        assert fine.closure < 1e-8
        # Trivial pair at +1 on a periodic orbit: s = tr M - 2 (reference error from its two tolerances).
        s_coarse, s_fine = np.trace(coarse.matrix) - 2.0, np.trace(fine.matrix) - 2.0
        assert abs(invariant[i] - s_fine) <= 2 * refined.integration_error[i] + abs(s_fine - s_coarse) + 1e-10
        assert (abs(s_fine) <= 2) == stable[i]


def test_unstable_refined_orbit_perturbation_grows_like_its_multiplier(system, refined):
    """A small perturbation along the unstable direction, integrated through the nonlinear equations (7)
    period after period (DOP853), grows by the refined orbit's multiplier mu = s/2 + sqrt(s**2/4 - 1).

    The growth is the distance to the unperturbed orbit integrated alike: the refined orbit returns to its
    start only to its own error (a few 1e-8 of its size), a share of the perturbation's size (1e-6) that would
    otherwise bias the rate of a weakly unstable orbit."""
    unstable = np.flatnonzero(np.abs(refined.invariants.s[:, 0].real) > 2)
    i = int(unstable[np.argmax(refined.invariants.s[:, 0].real[unstable])])
    s = refined.invariants.s[:, 0].real[i]
    mu = s / 2 + np.sqrt(s * s / 4 - 1)
    assert mu > 1.05  # growth measurable in a few periods
    z0 = np.r_[refined.start[i], 0.0, 0.0]
    T = refined.period[i]
    ref = monodromy(two_dof_parameters(system.structure), z0, T)
    w, V = np.linalg.eig(ref.matrix)
    v = V[:, np.argmax(np.abs(w))].real
    delta = 1e-6 * np.abs(z0).max()
    z, unperturbed = z0 + delta * v / np.linalg.norm(v), z0
    periods = 6
    for _ in range(periods):
        z = monodromy(two_dof_parameters(system.structure), z, T).final_state
        unperturbed = monodromy(two_dof_parameters(system.structure), unperturbed, T).final_state
    growth = np.linalg.norm(z - unperturbed) / delta
    assert abs(np.log(growth) / periods - np.log(mu)) < 0.02 * np.log(mu) + 1e-3


def test_matches_integrated_monodromy_of_refined_orbits(system, nnm1, verdicts):
    """DOP853 monodromy of an exact periodic orbit of (7) near the HBM orbit (shooting)."""
    mono, _ = verdicts
    energy = np.array([system.diagnostics(U)["energy"] for U in nnm1])
    impacts = np.array([system.diagnostics(U)["impacts_per_period"] for U in nnm1])
    picks = [
        int(np.argmin(energy)),
        int(np.flatnonzero(impacts == 2)[len(np.flatnonzero(impacts == 2)) // 2]),
        int(np.flatnonzero(impacts == 6)[len(np.flatnonzero(impacts == 6)) // 2]),
    ]
    for i in picks:
        z0, T = orbit_initial_state(system, nnm1[i])
        z, T = refine_orbit(two_dof_parameters(system.structure), z0, T)
        ref = monodromy(two_dof_parameters(system.structure), z, T)
        trivial, others, _ = symplectic_invariants(ref.matrix[None])  # delta = 1: symplectic for the standard J
        s_ref, dev_ref = others[0, 0].real, abs(trivial[0] - 2.0)
        assert dev_ref < 1e-6  # exact orbit: trivial pair at +1
        # The HBM orbit differs from the exact one by its error: s moves by about its time residual.
        tol = mono.settings.resolution_factor * (mono.integration_error[i] + mono.orbit_error[i]) + 1e-8
        assert abs(mono.invariant[i] - s_ref) <= tol
        if mono.resolved[i]:
            assert mono.stable[i] == (abs(s_ref) <= 2)


def test_error_estimate_bounds_the_error(system, nnm1):
    coarse = branch_monodromy(system, nnm1[::5], MonodromySettings(steps=128, max_steps=256))
    fine = branch_monodromy(system, nnm1[::5], MonodromySettings(steps=4096, max_steps=8192))
    assert np.all(
        np.abs(coarse.invariant - fine.invariant) <= coarse.integration_error + 10 * fine.integration_error + 1e-12
    )


def test_config_selects_the_method(config, system, nnm1):
    U = nnm1[:3]
    c = copy.deepcopy(config)
    assert "stability_reason" in orbit_stability(system, U, stability_settings(c)).data_vars()
    c["stability"]["method"] = "hill"
    assert "stability_reason" not in orbit_stability(system, U, stability_settings(c)).data_vars()


@pytest.mark.parametrize(
    "key, value",
    [
        ("method", "shooting"),
        ("steps", 100),
        ("max_steps", 64),
        ("trace_tol", -1.0),
        ("resolution_factor", 0.5),
        ("refine", "yes"),
        ("refine_steps", 100),
        ("refine_tol", 0.0),
        ("refine_max_change", 1.0),
    ],
)
def test_bad_stability_config_is_named(key, value):
    c = copy.deepcopy(load_config("config/config.yaml"))
    c["stability"][key] = value
    with pytest.raises(ConfigError, match=f"stability.{key}"):
        validate_config(c)


def test_bad_settings():
    with pytest.raises(ValueError, match="power of two"):
        MonodromySettings(steps=100)
    with pytest.raises(ValueError, match="max_steps"):
        MonodromySettings(steps=512, max_steps=256)
    with pytest.raises(ValueError, match="refine_max_steps"):
        MonodromySettings(refine_steps=256, refine_max_steps=256)
    with pytest.raises(ValueError, match="refine_tol"):
        MonodromySettings(refine_tol=1e-3)


def test_refined_multipliers_tend_to_the_exact_ones_as_eta_vanishes():
    """As eta -> 0 the regularized force tends to the piecewise-linear law: the periodic orbit of (7)
    found by shooting from an exact two-impact orbit (no HBM involved) has a Floquet invariant tending
    to the exact one (product of the phase exponentials, nnmstop.exact_stability), to first order in eta."""
    base = ModelParameters()
    family = follow_family(base, step=0.25, max_points=400)
    y = family.unknowns[int(np.argmin(np.abs(np.asarray(family.energy) - 5.0)))]  # (xdot0, udot0, tau1, T1)
    exact = exact_multipliers(base, "FR", [y[2], y[3] - y[2]])
    period = 4.0 * y[3]
    theta = np.linspace(0.0, 0.5 * np.pi, 2049)
    s = MonodromySettings()
    errors = []
    for eta in (1e-2, 1e-3, 1e-4):
        params = dataclasses.replace(base, eta=eta)
        problem = TwoImpactProblem(params)

        def states_at(phases, problem=problem):  # from the turning point (t = T1), at rest
            at = problem.time_history(y, y[3] + phases * period / (2 * np.pi))
            return np.stack([at.x, at.u, at.xdot, at.udot], axis=-1)

        orbit = problem.time_history(y, y[3] + theta * period / (2 * np.pi))
        r = shooting_stability(
            two_dof_structure(params),
            [period],
            orbit.x[None],
            (orbit.xdot * period / (2 * np.pi))[None],
            states_at,
            s.refine_steps,
            s.refine_max_steps,
            s.refine_tol,
            s.resolution_factor,
            s.refine_max_change,
        )
        assert r.converged[0]
        invariant = r.invariants.s[0, 0].real
        assert (abs(invariant) <= 2) == exact.stable
        errors.append(abs(invariant - exact.trace_invariant))
    # First order: the error falls by about 10 per decade of eta (between orders 0.7 and 1.3).
    assert all(0.05 < later / earlier < 0.2 for earlier, later in zip(errors, errors[1:]))
    assert errors[-1] < 1e-3


def test_orbits_spared_the_step_doubling_keep_their_orbit_error_verdict(system, nnm1):
    """An orbit whose s, anywhere within its integration error, stays within F x its time residual is not
    integrated with more steps: its verdict is the orbit's (reason 2) whatever the steps.

    Constructed case: at the coarsest step count, the orbits whose margin is below (F - 1) times their
    integration error (near the energy fold and the contact changes, 64 steps are coarse there) get a time
    residual between (margin + error) / F and the error, so that only the sparing rule stops their doubling.
    An integration with 16 times the steps must then find reason 2 as well. Refinement off (HBM verdicts).
    """
    settings = MonodromySettings(steps=64, max_steps=4096, refine=False)
    F = settings.resolution_factor
    residual = np.array([system.diagnostics(U)["time_residual"] for U in nnm1])
    first = branch_monodromy(system, nnm1, dataclasses.replace(settings, max_steps=128), time_residual=residual)
    error = first.integration_error
    chosen = (first.margin < (F - 1) * error) & (first.trivial_deviation < error)
    assert chosen.sum() >= 2
    residual[chosen] = 0.5 * ((first.margin[chosen] + error[chosen]) / F + error[chosen])
    coarse = branch_monodromy(system, nnm1, settings, time_residual=residual)
    # without the rule these would be doubled: margin within F x error, error above the orbit's error
    assert np.all(coarse.margin[chosen] <= F * coarse.integration_error[chosen])
    assert np.all(coarse.integration_error[chosen] > coarse.orbit_error[chosen])
    assert np.all(coarse.steps[chosen] == 2 * settings.steps)
    assert np.all(coarse.reason[chosen] == 2)
    fine_settings = dataclasses.replace(settings, steps=1024)
    fine = branch_monodromy(system, nnm1[chosen], fine_settings, time_residual=residual[chosen])
    assert np.all(fine.reason == 2)
