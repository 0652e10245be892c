"""Stability from the monodromy matrix (nnmstop.hbm.monodromy) against independent computations.

References: the closed-form Floquet multipliers of the linear limit, Hill's method
(a different discretization of the same linearization), the monodromy of an exact
periodic orbit of (7) integrated by DOP853 (shooting-refined, nnmstop.checks.shooting),
and the symplecticity of the flow of a Hamiltonian linear system. Small H = 40
branches keep the module cheap.
"""

import copy

import numpy as np
import pytest

from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.stability import branch_hill, orbit_stability
from nnmstop.tasks.hbm import build_stage, stability_settings, system_from_config
from nnmstop.config import ConfigError, load_config, validate_config
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.two_dof import ModelParameters
from nnmstop.hbm.monodromy import MonodromySettings, branch_monodromy, orbit_monodromy, trace_invariants
from nnmstop.checks.shooting import monodromy, orbit_initial_state, refine_orbit
from nnmstop.models.structure import two_dof_structure

H_BRANCH = 40


@pytest.fixture(scope="module")
def config():
    """Paper physics, H = 40; NNM1 from no impact up to the first orbit with four impacts per period."""
    c = copy.deepcopy(load_config("config/config.yaml"))
    c["hbm"]["harmonics"] = H_BRANCH
    c["hbm"]["points_per_step"] = 1
    c["branches"]["nnm1"]["stages"] = [
        {"name": "one_impact_per_stop", "until": {"impacts_above": 2}},
        {"name": "three_impacts_per_stop", "until": {"impacts_at_most": 4}},
    ]
    return c


@pytest.fixture(scope="module")
def system(config):
    return system_from_config(config)


@pytest.fixture(scope="module")
def nnm1(config, system):
    """Unknowns of NNM1 stages 1 and 2 (0, 2 then 6 impacts per period, through an energy fold)."""
    first = build_stage(config, "nnm1", 1)
    second = build_stage(config, "nnm1", 2, first)
    return np.concatenate([dataset_unknowns(first, system), dataset_unknowns(second, system)])


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


def test_monodromy_is_symplectic(system, nnm1):
    """The flow of M y'' + (K + k(t) E) y = 0 preserves the symplectic form: M^T J M = J, det M = 1."""
    J = np.block([[np.zeros((2, 2)), np.diag([1.0, system.params.delta])], [-np.diag([1.0, system.params.delta]), np.zeros((2, 2))]])
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
    unresolved = ~mono.resolved
    limit = F * np.maximum(mono.integration_error, mono.orbit_error)
    assert np.all((mono.margin <= limit)[unresolved])
    assert np.all((mono.margin > limit)[mono.resolved])
    assert np.all(np.isin(mono.reason[unresolved], [1, 2]))


def test_matches_integrated_monodromy_of_refined_orbits(system, nnm1, verdicts):
    """DOP853 monodromy of an exact periodic orbit of (7) near the HBM orbit (shooting)."""
    mono, _ = verdicts
    energy = np.array([system.diagnostics(U)["energy"] for U in nnm1])
    impacts = np.array([system.diagnostics(U)["impacts_per_period"] for U in nnm1])
    picks = [int(np.argmin(energy)), int(np.flatnonzero(impacts == 2)[len(np.flatnonzero(impacts == 2)) // 2]),
             int(np.flatnonzero(impacts == 6)[len(np.flatnonzero(impacts == 6)) // 2])]
    for i in picks:
        z0, T = orbit_initial_state(system, nnm1[i])
        z, T = refine_orbit(system.params, z0, T)
        ref = monodromy(system.params, z, T)
        s_ref, dev_ref = trace_invariants(ref.matrix)
        assert dev_ref < 1e-6  # exact orbit: trivial pair at +1
        # The HBM orbit differs from the exact one by its error: s moves by about its time residual.
        tol = mono.settings.resolution_factor * (mono.integration_error[i] + mono.orbit_error[i]) + 1e-8
        assert abs(mono.invariant[i] - s_ref) <= tol
        if mono.resolved[i]:
            assert mono.stable[i] == (abs(s_ref) <= 2)


def test_error_estimate_bounds_the_error(system, nnm1):
    coarse = branch_monodromy(system, nnm1[::5], MonodromySettings(steps=128, max_steps=256))
    fine = branch_monodromy(system, nnm1[::5], MonodromySettings(steps=4096, max_steps=8192))
    assert np.all(np.abs(coarse.invariant - fine.invariant) <= coarse.integration_error + 10 * fine.integration_error + 1e-12)


def test_config_selects_the_method(config, system, nnm1):
    U = nnm1[:3]
    c = copy.deepcopy(config)
    assert "stability_reason" in orbit_stability(system, U, stability_settings(c)).data_vars()
    c["stability"]["method"] = "hill"
    assert "stability_reason" not in orbit_stability(system, U, stability_settings(c)).data_vars()


@pytest.mark.parametrize(
    "key, value",
    [("method", "shooting"), ("steps", 100), ("max_steps", 64), ("trace_tol", -1.0), ("resolution_factor", 0.5)],
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
