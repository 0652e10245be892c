"""Floquet multipliers of the exact orbits (nnmstop.exact.stability) against independent references.

References: the closed-form multipliers of the linear grazing orbit, constructed symplectic
matrices with a known spectrum, the monodromy of the flow of the event-located DOP853
integrator (nnmstop.checks.time_integration, finite differences of the flow over one period) and
the growth of small perturbations integrated through the non-smooth equations.
"""

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp
from test_multi_impact import SEEDS, _refine

from nnmstop.checks.time_integration import integrate_nonsmooth
from nnmstop.exact import stability as es
from nnmstop.exact.dataset import two_impact_dataset
from nnmstop.exact.family import follow_two_impact_family
from nnmstop.exact.problem import SequenceProblem, first_grazing_orbit
from nnmstop.models.two_dof import linear_modes, mass_matrix, stiffness_matrix


@pytest.fixture(scope="module")
def orbits(paper_params):
    out = {}
    for seq in ("FLF", "FL", "FRFR", "FR"):
        problem = SequenceProblem(paper_params, seq)
        out[seq] = (problem, _refine(problem, SEEDS[seq]))
    return out


def _flow(params, z0, period):
    traj = integrate_nonsmooth(params, z0, [0.0, period], rtol=1e-13, atol=1e-14)
    return traj.states[-1]


def _integrated_monodromy(params, z0, period, h=1e-6):
    """Central differences of the event-located flow over one period (columns = perturbed states)."""
    cols = []
    for k in range(4):
        dz = np.zeros(4)
        dz[k] = h
        cols.append((_flow(params, z0 + dz, period) - _flow(params, z0 - dz, period)) / (2 * h))
    return np.column_stack(cols)


def _random_symplectic(rng):
    """exp(J S) with S symmetric is symplectic for the canonical form J."""
    j = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.eye(2), np.zeros((2, 2))]])
    s = rng.normal(size=(4, 4))
    return scipy.linalg.expm(0.3 * j @ (s + s.T)), j


@pytest.mark.parametrize("lam", [np.exp(0.7j), np.exp(3.0j), 3.5, -2.0, 1.0 + 1e-3])
def test_constructed_symplectic_spectrum_is_recovered(lam):
    rng = np.random.default_rng(3)
    p, j = _random_symplectic(rng)
    # canonical block form: Jordan pair at +1 on (q1, p1), the pair lam, 1/lam on (q2, p2)
    core = np.eye(4)
    core[0, 2] = 0.8  # q1 += 0.8 p1: the Jordan block
    if np.iscomplexobj(lam) and abs(np.imag(lam)) > 0:
        th = np.angle(lam)
        core[np.ix_([1, 3], [1, 3])] = [[np.cos(th), np.sin(th)], [-np.sin(th), np.cos(th)]]
    else:
        core[1, 1], core[3, 3] = lam, 1.0 / lam
    assert np.allclose(core.T @ j @ core, j)
    m = p @ core @ np.linalg.inv(p)
    r = es.multipliers_from_monodromy(m)
    expected = lam if abs(lam) >= 1 else 1 / lam
    assert abs(r.multiplier - (expected if np.imag(expected) >= 0 else np.conj(expected))) < 1e-10
    assert r.stable == bool(abs(abs(lam) - 1.0) < 1e-12)
    assert r.invariant_mismatch < 1e-10
    assert r.trivial_distance < 1e-6  # the Jordan pair: eigenvalues accurate to sqrt(eps) only


def test_grazing_orbit_has_the_multipliers_of_the_linear_mode(paper_params):
    """The grazing orbit is the first linear mode: the other mode turns by omega2 T in one period."""
    y = first_grazing_orbit(paper_params)
    r = es.exact_multipliers(paper_params, "FR", [y[2], y[3] - y[2]])
    omega, _ = linear_modes(paper_params, "no_contact")
    expected = 2.0 * np.cos(2.0 * np.pi * omega[1] / omega[0])
    assert abs(r.trace_invariant - expected) < 1e-12
    assert r.stable and abs(abs(r.multiplier) - 1.0) < 1e-15


@pytest.mark.parametrize("seq", ["FLF", "FL", "FRFR", "FR"])
def test_monodromy_is_symplectic_with_a_jordan_pair_at_one(paper_params, orbits, seq):
    problem, y = orbits[seq]
    m = es.monodromy(paper_params, seq, y[2:])
    mass = mass_matrix(paper_params)
    form = np.block([[np.zeros((2, 2)), mass], [-mass, np.zeros((2, 2))]])
    assert np.abs(m.T @ form @ m - form).max() < 1e-9 * max(1.0, np.linalg.norm(m)) ** 2
    # the orbit's own velocity is an eigenvector of eigenvalue 1 (time shift)
    z0 = problem.switch_states(y)[0]
    v = problem.phases[0].field(z0)
    assert np.linalg.norm(m @ v - v) < 1e-10 * np.linalg.norm(v) * np.linalg.norm(m)


@pytest.mark.parametrize("seq", ["FLF", "FL", "FRFR", "FR"])
def test_multipliers_match_the_event_located_integrator(paper_params, orbits, seq):
    problem, y = orbits[seq]
    z0 = problem.switch_states(y)[0]
    period = 4.0 * problem.quarter(y)
    m_int = _integrated_monodromy(paper_params, z0, period)
    r = es.exact_multipliers(paper_params, seq, y[2:])
    s_int = np.trace(m_int) - 2.0
    # finite differences (h = 1e-6) of a flow integrated to ~1e-12: about 1e-6 relative
    assert abs(s_int - r.trace_invariant) < 1e-5 * max(1.0, abs(r.trace_invariant))
    assert abs(r.stability_margin) > 1e-3  # so that the verdicts can be compared
    assert (2.0 - abs(s_int) >= 0) == r.stable


def _deviation_after_periods(params, z_orbit, dz, period, n):
    times = period * np.arange(n + 1)
    ref = integrate_nonsmooth(params, z_orbit, times, rtol=1e-13, atol=1e-15).states
    pert = integrate_nonsmooth(params, z_orbit + dz, times, rtol=1e-13, atol=1e-15).states
    return np.linalg.norm(pert - ref, axis=1)


def test_perturbation_of_an_unstable_orbit_grows_like_its_multiplier(paper_params, orbits):
    problem, y = orbits["FRFR"]
    r = es.exact_multipliers(paper_params, "FRFR", y[2:])
    assert not r.stable and abs(r.multiplier) > 2.0
    m = es.monodromy(paper_params, "FRFR", y[2:])
    w, v = np.linalg.eig(m)
    dz = 1e-8 * np.real(v[:, np.argmax(np.abs(w))])
    z0 = problem.switch_states(y)[0]
    dev = _deviation_after_periods(paper_params, z0, dz, 4.0 * problem.quarter(y), 4)
    growth = dev[1:] / dev[:-1]
    assert np.allclose(growth, abs(r.multiplier), rtol=1e-3)


def test_perturbation_of_a_stable_orbit_stays_bounded(paper_params, orbits):
    problem, y = orbits["FLF"]
    r = es.exact_multipliers(paper_params, "FLF", y[2:])
    assert r.stable and r.stability_margin > 0.1
    m = es.monodromy(paper_params, "FLF", y[2:])
    w, v = np.linalg.eig(m)
    k = np.argmax(np.abs(w - 1.0))  # a member of the elliptic pair
    dz = 1e-8 * np.real(v[:, k]) / np.linalg.norm(np.real(v[:, k]))
    z0 = problem.switch_states(y)[0]
    dev = _deviation_after_periods(paper_params, z0, dz, 4.0 * problem.quarter(y), 8)
    # rotation in the elliptic plane: the norm oscillates within the eigenvector's conditioning
    assert dev.max() < 20.0 * dev[0]
    # the same perturbation under the unstable FRFR orbit would have grown 2.29**8 ~ 760 times


def test_bad_inputs_are_rejected(paper_params):
    with pytest.raises(ValueError, match="durations"):
        es.exact_multipliers(paper_params, "FR", [0.1, -0.2])
    with pytest.raises(ValueError, match="one duration per phase"):
        es.exact_multipliers(paper_params, "FRF", [0.1, 0.2])
    with pytest.raises(ValueError, match="F, R, L"):
        es.exact_multipliers(paper_params, "FX", [0.1, 0.2])
    with pytest.raises(ValueError, match="4 x 4"):
        es.multipliers_from_monodromy(np.eye(3))


def test_two_impact_family_changes_stability_at_its_energy_extrema(paper_params):
    """On the energy surface, a fold of the family in energy is a saddle-node of the Poincare map:
    the non-trivial pair passes +1 there and nowhere else on this stretch of the family."""
    from nnmstop.catalogue import describe

    family = follow_two_impact_family(paper_params, step=0.02, max_points=40)
    ds = describe(two_impact_dataset(family), "two_impact_family")  # labelled as write_dataset writes it
    for name in (
        "stable",
        "multiplier_real",
        "multiplier_imag",
        "multiplier_modulus",
        "stability_margin",
        "stability_tolerance",
        "trivial_multiplier_distance",
        "trace_invariant",
    ):
        assert {"long_name", "units"} <= set(ds[name].attrs), name
    energy, stable = ds["energy"].values, ds["stable"].values
    extrema = np.flatnonzero(np.diff(np.sign(np.diff(energy)))) + 1
    changes = np.flatnonzero(np.diff(stable)) + 1
    assert extrema.size == 2 and changes.size == 2  # the maximum just after grazing, then the minimum
    for k, c in zip(extrema, changes):
        assert abs(k - c) <= 1
    # the pair leaves the unit circle through +1 (s crosses 2), not through -1
    s = ds["trace_invariant"].values
    for c in changes:
        assert s[c - 1] > 0 and s[c] > 0 and max(s[c - 1], s[c]) > 2.0
    assert np.all(ds["stability_tolerance"].values < 1e-11)


def _variational_monodromy(params, z0, period):
    """Variational equation dPhi/dt = A(t) Phi integrated by DOP853 between the stop crossings that the
    event-located integrator finds along the orbit; Phi is carried unchanged across each crossing."""
    traj = integrate_nonsmooth(params, z0, [0.0, period], rtol=1e-13, atol=1e-14)
    edges = np.concatenate([[0.0], traj.switch_times[traj.switch_times < period], [period]])
    mids = 0.5 * (edges[1:] + edges[:-1])
    x_mid = integrate_nonsmooth(params, z0, np.concatenate([[0.0], mids]), rtol=1e-13, atol=1e-14).states[1:, 0]
    minv = np.linalg.inv(mass_matrix(params))
    phi = np.eye(4)
    for (a, b), x in zip(zip(edges[:-1], edges[1:]), x_mid):
        k = stiffness_matrix(params, params.alpha if abs(x) > 1.0 else 0.0)
        a_r = np.block([[np.zeros((2, 2)), np.eye(2)], [-minv @ k, np.zeros((2, 2))]])
        sol = solve_ivp(
            lambda _t, y, a_r=a_r: (a_r @ y.reshape(4, 4)).ravel(),
            (a, b),
            phi.ravel(),
            method="DOP853",
            rtol=1e-13,
            atol=1e-14,
        )
        phi = sol.y[:, -1].reshape(4, 4)
    return phi, traj.switch_times.size


@pytest.mark.parametrize("seq", ["FLF", "FRFR"])
def test_multipliers_match_the_variational_equation_through_the_event_located_integrator(paper_params, orbits, seq):
    problem, y = orbits[seq]
    z0 = problem.switch_states(y)[0]
    period = 4.0 * problem.quarter(y)
    m_var, crossings = _variational_monodromy(paper_params, z0, period)
    assert crossings == 2 * problem.impacts_per_period  # every excursion beyond a stop enters and leaves once
    r = es.exact_multipliers(paper_params, seq, y[2:])
    assert abs(np.trace(m_var) - 2.0 - r.trace_invariant) < 1e-8 * max(1.0, np.linalg.norm(m_var))
