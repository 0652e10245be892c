"""The exact two-impact NNM1 family against independent references.

References: hand-derived linear modes, the matrix exponential of the first-order system,
finite differences, and the event-driven time integration of Eqs. (3)-(4)
(:mod:`nnmstop.checks.time_integration`, DOP853 with located stop crossings).
"""

import numpy as np
import pytest
import scipy.linalg
import xarray as xr

from nnmstop.checks.time_integration import integrate_nonsmooth, integrate_regularized
from nnmstop.exact.dataset import two_impact_dataset
from nnmstop.exact.family import follow_two_impact_family
from nnmstop.exact.grazing import TWO_IMPACT_MARGINS, assess_orbit
from nnmstop.exact.phases import LinearPhase
from nnmstop.exact.problem import TwoImpactProblem, first_grazing_orbit, high_energy_orbit
from nnmstop.models.two_dof import ModelParameters, linear_modes, mass_matrix, stiffness_matrix, total_energy
from nnmstop.tasks.exact import build_two_impact_dataset

OTHER_PARAMS = ModelParameters(alpha=5.0, beta=0.3, delta=2.5, eta=0.4)


@pytest.fixture(scope="module")
def family(paper_params):
    return follow_two_impact_family(paper_params, step=0.02, max_points=4000)


@pytest.fixture(scope="module")
def other_family():
    return follow_two_impact_family(OTHER_PARAMS, step=0.02, max_points=4000)


def _z0(y):
    return np.array([0.0, 0.0, y[0], y[1]])


def _interior_indices(n, count=6):
    """Indices spread over the family, away from the grazing start and the end point.

    Right after grazing the penetration into the stops is tiny (below 1e-6 for the first
    points), which no event-driven integrator resolves reliably.
    """
    return np.unique(np.linspace(max(1, n // 20), n - 2, count).round().astype(int))


# --------------------------------------------------------------------------- closed-form flows


@pytest.mark.parametrize("phase_name", ["free_flight", "contact"])
def test_linear_phase_matches_the_matrix_exponential(paper_params, phase_name):
    phase = getattr(LinearPhase, phase_name)(paper_params)
    m, k = mass_matrix(paper_params), stiffness_matrix(paper_params, 0.0 if phase_name == "free_flight" else 30.0)
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(m, k), np.zeros((2, 2))]])
    z_eq = np.concatenate([np.linalg.solve(k, phase.force), np.zeros(2)])
    z0 = np.array([1.0, -0.3, 2.0, 0.7])
    for t in (0.0, 0.37, 2.9, 41.0):
        expected = z_eq + scipy.linalg.expm(a * t) @ (z0 - z_eq)
        np.testing.assert_allclose(phase.state(z0, t), expected, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(phase.transition(t), scipy.linalg.expm(a * t), rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(phase.field(z0), a @ (z0 - z_eq), rtol=1e-14, atol=1e-14)


def test_analytic_jacobian_matches_finite_differences(paper_params, family):
    problem = TwoImpactProblem(paper_params)
    for y in (family.unknowns[40], first_grazing_orbit(paper_params) + [0.03, -0.05, -0.2, 0.1]):
        h = 1e-6
        fd = np.column_stack([(problem.residual(y + h * e) - problem.residual(y - h * e)) / (2 * h) for e in np.eye(4)])
        np.testing.assert_allclose(problem.jacobian(y), fd, rtol=1e-7, atol=1e-8)


# --------------------------------------------------------------------------- linear limit, residuals


def test_grazing_orbit_is_the_first_linear_mode_with_unit_amplitude(paper_params, family):
    omega, _ = linear_modes(paper_params, "no_contact")
    y = first_grazing_orbit(paper_params)
    np.testing.assert_array_equal(family.unknowns[0], y)
    assert family.frequency[0] == pytest.approx(omega[0] / (2 * np.pi), rel=1e-14)
    assert np.linalg.norm(TwoImpactProblem(paper_params).residual(y)) < 1e-15
    hist = TwoImpactProblem(paper_params).time_history(y, np.linspace(0.0, 4 * y[3], 4001))
    assert hist.x.max() == pytest.approx(1.0, abs=1e-12)
    assert hist.x.min() == pytest.approx(-1.0, abs=1e-12)
    assert np.all(hist.force == 0.0)
    # continuity: contact duration and frequency shift vanish together at the start
    contact = family.unknowns[1:6, 3] - family.unknowns[1:6, 2]
    shift = family.frequency[1:6] - family.frequency[0]
    assert np.all(contact > 0) and np.all(np.diff(contact) > 0)
    assert np.all(shift > 0) and np.all(np.diff(shift) > 0) and shift[0] < 1e-3


@pytest.mark.parametrize("which", ["paper", "other"])
def test_residuals_are_at_round_off(which, family, other_family):
    fam = family if which == "paper" else other_family
    assert fam.residual.max() < 1e-13
    problem = TwoImpactProblem(fam.params)
    recomputed = [np.linalg.norm(problem.residual(y)) for y in fam.unknowns]
    np.testing.assert_allclose(recomputed, fam.residual, atol=1e-16)


# --------------------------------------------------------------------------- orbits


def test_energy_is_conserved_along_the_full_period(paper_params, family):
    for k in _interior_indices(len(family)):
        y = family.unknowns[k]
        hist = TwoImpactProblem(paper_params).time_history(y, np.linspace(0.0, 4 * y[3], 2001))
        energy = total_energy(hist.x, hist.u, hist.xdot, hist.udot, paper_params, model="piecewise")
        np.testing.assert_allclose(energy, family.energy[k], rtol=1e-13)


@pytest.mark.parametrize("which", ["paper", "other"])
def test_orbits_are_periodic_for_the_event_driven_integrator(which, family, other_family):
    fam = family if which == "paper" else other_family
    picks = list(_interior_indices(len(fam), 5))
    if which == "paper":
        picks.append(int(np.argmin(fam.energy)))  # the orbit of least energy (energy is not monotone)
    for k in picks:
        y = fam.unknowns[k]
        period = 4 * y[3]
        traj = integrate_nonsmooth(fam.params, _z0(y), [0.0, period])
        np.testing.assert_allclose(traj.states[-1], _z0(y), rtol=0, atol=1e-9, err_msg=f"orbit {k}")
        # one impact on each stop: enter and leave each stop once per period
        assert len(traj.switch_times) == 4, f"orbit {k}: {traj.switch_times}"


def test_time_history_matches_integration_over_the_period(paper_params, family):
    for k in _interior_indices(len(family), 3):
        y = family.unknowns[k]
        t = np.linspace(0.0, 4 * y[3], 41)
        traj = integrate_nonsmooth(paper_params, _z0(y), t)
        hist = TwoImpactProblem(paper_params).time_history(y, t)
        np.testing.assert_allclose(np.column_stack([hist.x, hist.u, hist.xdot, hist.udot]), traj.states, atol=1e-9)
        # impacts at x = 1 occur at tau1 and 2 T1 - tau1 (mirror symmetry about T1)
        np.testing.assert_allclose(traj.switch_times[:2], [y[2], 2 * y[3] - y[2]], atol=1e-9)


def _integrated(params, y, times):
    """States of the event-driven integration from the orbit's initial state at the given times."""
    times = np.asarray(times, dtype=float)
    order = np.argsort(times)
    states = integrate_nonsmooth(params, _z0(y), np.concatenate([[0.0], times[order]])).states[1:]
    out = np.empty_like(states)
    out[order] = states
    return out


def test_section_3_1_symmetries_hold_for_integrated_orbits(paper_params, family):
    """x(T1 + s) = x(T1 - s), u likewise (velocities reversed), and q(t + T/2) = -q(t)."""
    for k in _interior_indices(len(family), 3):
        y = family.unknowns[k]
        quarter, period = y[3], 4 * y[3]
        s = np.linspace(0.0, quarter, 9)
        before, after = _integrated(paper_params, y, quarter - s), _integrated(paper_params, y, quarter + s)
        np.testing.assert_allclose(after[:, :2], before[:, :2], atol=1e-9)
        np.testing.assert_allclose(after[:, 2:], -before[:, 2:], atol=1e-9)
        first, shifted = _integrated(paper_params, y, s), _integrated(paper_params, y, s + period / 2)
        np.testing.assert_allclose(shifted, -first, atol=1e-9)


def test_time_history_force_and_symmetries(paper_params, family):
    y = family.unknowns[300]
    quarter, period = y[3], 4 * y[3]
    t = np.linspace(-period, 2 * period, 3001)
    hist = TwoImpactProblem(paper_params).time_history(y, t)
    shifted = TwoImpactProblem(paper_params).time_history(y, t + period / 2)
    np.testing.assert_allclose(shifted.x, -hist.x, atol=1e-13)
    np.testing.assert_allclose(shifted.udot, -hist.udot, atol=1e-13)
    mirrored = TwoImpactProblem(paper_params).time_history(y, 2 * quarter - t)
    np.testing.assert_allclose(mirrored.u, hist.u, atol=1e-13)
    np.testing.assert_allclose(mirrored.xdot, -hist.xdot, atol=1e-13)
    contact = np.abs(hist.x) > 1
    np.testing.assert_allclose(hist.force[contact], 30.0 * (hist.x - np.sign(hist.x))[contact], rtol=1e-14)
    assert np.all(hist.force[~contact] == 0)
    # contact fraction of the period equals (T1 - tau1) / T1
    assert contact.mean() == pytest.approx((y[3] - y[2]) / y[3], abs=2e-3)


# --------------------------------------------------------------------------- the end of the family


def _orbit_past(params, y_end, tangent, sigma):
    """Solve the quarter-period equations at arclength ``sigma`` from ``y_end`` along ``tangent``."""
    problem = TwoImpactProblem(params)
    y = y_end + sigma * tangent
    for _ in range(20):
        f = np.append(problem.residual(y), tangent @ (y - y_end) - sigma)
        y = y + np.linalg.solve(np.vstack([problem.jacobian(y), tangent]), -f)
    assert np.linalg.norm(problem.residual(y)) < 1e-12
    return y


@pytest.mark.parametrize("which", ["paper", "other"])
def test_family_ends_where_the_recorded_assumption_fails(which, family, other_family):
    fam = family if which == "paper" else other_family
    name = fam.end_margin
    assert fam.end_reason == TWO_IMPACT_MARGINS[name]
    last = fam.assessments[-1]
    assert last.valid and 0 < last.margins[name] < 1e-9
    problem = TwoImpactProblem(fam.params)
    null = scipy.linalg.null_space(problem.jacobian(fam.unknowns[-1]))[:, 0]
    tangent = null if null @ (fam.unknowns[-1] - fam.unknowns[-2]) > 0 else -null
    for sigma in (1e-6, 1e-4):
        past = assess_orbit(TwoImpactProblem(fam.params), _orbit_past(fam.params, fam.unknowns[-1], tangent, sigma))
        before = assess_orbit(TwoImpactProblem(fam.params), _orbit_past(fam.params, fam.unknowns[-1], tangent, -sigma))
        assert past.margins[name] < 0 and name in past.violated
        assert before.valid and before.margins[name] > 0


def test_paper_family_ends_on_the_opposite_stop_as_the_integrator_confirms(paper_params, family):
    """The secondary free-flight oscillation of x grows until x strikes x = -1."""
    assert family.end_margin == "opposite_stop"
    y_prev = family.unknowns[-2]
    assert y_prev[0] < 0  # x starts each quarter by moving away from the stop it will hit
    problem = TwoImpactProblem(paper_params)
    null = scipy.linalg.null_space(problem.jacobian(family.unknowns[-1]))[:, 0]
    tangent = null if null @ (family.unknowns[-1] - y_prev) > 0 else -null
    y_past = _orbit_past(paper_params, family.unknowns[-1], tangent, 1e-3)
    # the algebraic solution past the end is not an orbit: x crosses -1 during the "free flight"
    traj = integrate_nonsmooth(paper_params, _z0(y_past), [0.0, y_past[2]])
    early = traj.switch_times[traj.switch_times < 0.9 * y_past[2]]
    assert early.size == 2, traj.switch_times  # enters and leaves the stop x = -1 well before tau1
    dip = integrate_nonsmooth(paper_params, _z0(y_past), [0.0, early.mean()]).states[-1]
    assert dip[0] < -1.0
    y = family.unknowns[-1]
    hist = TwoImpactProblem(paper_params).time_history(y, np.linspace(0, y[2], 20001))
    assert hist.x.min() == pytest.approx(-1.0, abs=1e-9)


def test_energy_is_not_monotone_along_the_paper_family(family):
    """Leaving the grazing orbit, the energy first decreases, then increases."""
    k_min = int(np.argmin(family.energy))
    assert 0 < k_min < len(family) - 1
    assert family.energy[k_min] < family.energy[0] < family.energy[-1]


def test_max_points_stops_the_continuation(paper_params):
    fam = follow_two_impact_family(paper_params, step=0.02, max_points=25)
    assert len(fam) == 25 and fam.end_margin == "" and "max_points" in fam.end_reason
    assert all(a.valid for a in fam.assessments[1:])


# --------------------------------------------------------------------------- high energy


def test_frequency_rises_towards_the_gap_zero_mode(paper_params, family):
    f_gap0 = linear_modes(paper_params, "gap_zero")[0][0] / (2 * np.pi)
    f_free = linear_modes(paper_params, "no_contact")[0][0] / (2 * np.pi)
    assert np.all(family.frequency < f_gap0)
    assert np.all(np.diff(family.frequency) > 0)
    # the family covers most of the way from the linear to the gap-0 frequency
    assert (f_gap0 - family.frequency[-1]) < 0.01 * (f_gap0 - f_free)


def test_high_energy_orbits_tend_to_the_gap_zero_mode(paper_params):
    f_gap0 = linear_modes(paper_params, "gap_zero")[0][0] / (2 * np.pi)
    problem = TwoImpactProblem(paper_params)
    gaps = []
    for x_max in (10.0, 100.0, 1000.0):
        y = high_energy_orbit(paper_params, x_max)
        check = assess_orbit(problem, y)
        assert check.valid and check.x_max == pytest.approx(x_max, rel=1e-12)
        assert np.linalg.norm(problem.residual(y)) < 1e-14 * np.linalg.norm(y)
        gaps.append(f_gap0 - 1 / (4 * y[3]))
    assert all(g > 0 for g in gaps)
    # the frequency defect decays like 1 / x_max
    assert gaps[0] / gaps[1] == pytest.approx(10, rel=0.25)
    assert gaps[1] / gaps[2] == pytest.approx(10, rel=0.05)


# --------------------------------------------------------------------------- regularized cross-check


def test_regularized_orbit_approaches_the_exact_orbit_as_eta_shrinks(paper_params, family):
    y = family.unknowns[150]
    t = np.linspace(0.0, 4 * y[3], 11)
    errors = []
    for eta in (1e-2, 1e-3):
        params = ModelParameters(paper_params.alpha, paper_params.beta, paper_params.delta, eta)
        traj = integrate_regularized(params, _z0(y), t)
        energy = total_energy(*traj.states.T, params, model="regularized")
        np.testing.assert_allclose(energy, energy[0], rtol=1e-10)
        errors.append(np.abs(traj.states[-1] - _z0(y)).max())
    assert errors[1] < errors[0] / 5


# --------------------------------------------------------------------------- datasets and inputs


def test_dataset_is_labelled_and_consistent(paper_params, family, tmp_path):
    from nnmstop.catalogue import describe

    ds = describe(two_impact_dataset(family), "two_impact_family")  # what write_dataset writes
    for name in [
        "energy",
        "frequency",
        "period",
        "x_max",
        "u_at_x_max",
        "xdot0",
        "udot0",
        "free_flight_time",
        "contact_time",
        "residual",
    ]:
        assert name in ds.data_vars and ds[name].dims == ("point",)
    for var in {**ds.coords, **ds.data_vars}.values():
        assert var.attrs["units"] and var.attrs["long_name"]
    assert "Hz" in ds.frequency.attrs["units"]
    assert ds.attrs["end_reason"] == family.end_reason
    assert (ds.attrs["alpha"], ds.attrs["beta"], ds.attrs["delta"]) == (30.0, 1.0, 1.0)
    np.testing.assert_allclose(ds.frequency * ds.period, 1.0, rtol=1e-15)
    np.testing.assert_allclose(ds.contact_time + ds.free_flight_time, ds.period / 4, rtol=1e-15)
    assert float(ds.residual.max()) < 1e-13


def test_build_dataset_writes_netcdf(tmp_path):
    config = {
        "model": {"alpha": 30.0, "beta": 1.0, "delta": 1.0, "eta": 0.1},
        "exact": {"step": 0.05, "max_points": 30},
    }
    path = build_two_impact_dataset(config, tmp_path / "out" / "family.nc")
    with xr.open_dataset(path) as ds:
        assert ds.sizes["point"] == 30
        assert "max_points" in ds.attrs["end_reason"]
        assert ds.attrs["Conventions"].startswith("CF")


def test_bad_inputs_are_rejected_naming_the_value(paper_params):
    with pytest.raises(ValueError, match="step"):
        follow_two_impact_family(paper_params, step=-0.1)
    with pytest.raises(ValueError, match="max_points"):
        follow_two_impact_family(paper_params, max_points=1)
    with pytest.raises(ValueError, match="x_max"):
        high_energy_orbit(paper_params, 0.5)
    with pytest.raises(ValueError, match="shape"):
        TwoImpactProblem(paper_params).time_history([1.0, 2.0, 3.0], [0.0])
    with pytest.raises(ValueError, match="residual"):
        follow_two_impact_family(paper_params, start=[1.0, 1.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="model"):
        build_two_impact_dataset({"exact": {"step": 0.1, "max_points": 10}}, "unused.nc")
