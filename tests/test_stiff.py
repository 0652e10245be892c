"""Stiff paths: the exact solver at alpha = 1e6, the regularized force at extreme values,
a sharp-stop continuation against the exact orbits, and the study's guard and end check."""

from fractions import Fraction

import numpy as np
import pytest
import xarray as xr

from nnmstop.config import load_config
from nnmstop.exact import TwoImpactProblem, assess_orbit, follow_family, time_history
from nnmstop.model import ModelParameters, piecewise_contact_force, regularized_contact_force
from nnmstop.study.runs import case_config, match_energies, run_stage_one
from nnmstop.study.stiff_cases import _confirm_end, exact_checks
from nnmstop.time_integration import integrate_nonsmooth

EPS = np.finfo(float).eps


# --------------------------------------------------------------------------- exact solver, alpha = 1e6


@pytest.fixture(scope="module")
def stiff_family():
    """The first 40 orbits of the exact family for a nearly rigid stop (contact lasts ~1.6e-3)."""
    params = ModelParameters(alpha=1.0e6, beta=1.0, delta=1.0, eta=0.1)
    return params, follow_family(params, step=2.0e-3, max_points=40)


def test_exact_residuals_at_round_off_for_alpha_1e6(stiff_family):
    params, family = stiff_family
    problem = TwoImpactProblem(params)
    # x(tau1) - 1 is O(1); xdot(T1), udot(T1) change at the contact frequency sqrt(alpha) per unit of time,
    # so one ulp of T1 moves them by about sqrt(alpha) * |velocity| * eps.
    scale = np.sqrt(1.0 + params.beta + params.alpha) * np.abs(family.unknowns[:, :2]).max()
    for y in family.unknowns:
        r = problem.residual(y)
        assert abs(r[0]) <= 8 * EPS
        assert np.abs(r[1:]).max() <= 16 * EPS * scale
    contact = family.unknowns[-1, 3] - family.unknowns[-1, 2]
    assert 1e-4 < contact < 1e-2  # a real, short contact phase
    assert all(assess_orbit(y, params, problem).valid for y in family.unknowns[1:])


def test_exact_orbit_is_periodic_by_event_located_integration_for_alpha_1e6(stiff_family):
    params, family = stiff_family
    y = family.unknowns[-1]
    t = np.linspace(0.0, 4.0 * y[3], 17)
    trajectory = integrate_nonsmooth(params, [0.0, 0.0, y[0], y[1]], t, max_step=5e-3)
    exact = time_history(y, params, t)
    closed = np.column_stack([exact.x, exact.u, exact.xdot, exact.udot])
    assert trajectory.switch_times.size == 4  # enter and leave each stop once
    assert np.abs(trajectory.states[-1] - trajectory.states[0]).max() < 1e-9
    assert np.abs(trajectory.states - closed).max() < 1e-8


def test_a_continuation_step_longer_than_the_contact_is_caught_as_a_false_end():
    """With the default step the alpha = 1e6 family 'ends' two orbits after grazing; the check says so."""
    params = ModelParameters(alpha=1.0e6, beta=1.0, delta=1.0, eta=0.1)
    family = follow_family(params, step=0.02, max_points=4000)
    confirmed, note = _confirm_end(params, family)
    assert not confirmed, note
    assert "NOT confirmed" in note and "goes on" in note


def test_exact_checks_confirm_a_genuine_end():
    params = ModelParameters(alpha=300.0, beta=1.0, delta=1.0, eta=0.1)
    family, checks = exact_checks(params, step=0.02, max_points=4000)
    assert checks["end_confirmed"], checks["end_check"]
    assert checks["end_margin"] == "opposite_stop"
    assert checks["relative_residual"] < 100 * EPS
    assert checks["periodicity_error"] < 1e-10 and checks["integration_difference"] < 1e-10


# --------------------------------------------------------------------------- regularized force, extremes


X_EXTREME = np.concatenate([-np.logspace(300, -300, 121), np.logspace(-300, 300, 121), [0.5, 0.999, 1.0, 1.001, 2.0, 3.0]])
PARAMS_EXTREME = [(a, e) for a in (30.0, 1.0e4, 1.0e8) for e in (0.1, 1.0e-3, 1.0e-8)]


@pytest.mark.parametrize("alpha, eta", PARAMS_EXTREME)
def test_regularized_force_at_extreme_x_without_overflow(alpha, eta):
    params = ModelParameters(alpha=alpha, eta=eta)
    with np.errstate(over="raise", invalid="raise", divide="raise"):  # underflow of x**2 at 1e-300 is harmless
        f = regularized_contact_force(X_EXTREME, params)
    piecewise = np.abs(piecewise_contact_force(X_EXTREME, alpha))
    assert np.all(np.isfinite(f))
    assert np.all(np.sign(f) == np.sign(X_EXTREME))
    # never below the piecewise law, never above alpha |x|
    assert np.all(np.abs(f) >= piecewise * (1.0 - 4 * EPS))
    assert np.all(np.abs(f) <= alpha * np.abs(X_EXTREME) * (1.0 + 4 * EPS))
    # from |x| = 2 - eta/alpha on, within eta of the piecewise law (far out it sits eta/2 above it)
    far = np.abs(X_EXTREME) >= 2.0
    assert np.all(np.abs(f[far]) - piecewise[far] <= eta + 4 * EPS * np.abs(f[far]))
    # near the origin it is the linear spring eta x
    small = np.abs(X_EXTREME) <= 1e-6
    np.testing.assert_allclose(f[small] / X_EXTREME[small], eta, rtol=1e-5)


@pytest.mark.parametrize("alpha, eta", PARAMS_EXTREME)
def test_regularized_force_is_the_middle_root_of_the_cubic(alpha, eta):
    """Exact rational arithmetic: p(f - w) > 0 > p(f + w), p = the corrected cubic (positive leading term).

    With three real roots that sign pattern holds only around the middle one, so this checks
    both the branch and that f is within w of it. ``w`` is 1e-6 |f| (+ 32 ulps): at the
    knee (x near 1) the closed form loses digits to the cancellation in ``c - y**2``
    (relative error up to ~7e-8 for alpha = 1e8, eta = 1e-8; ~1e-13 for the paper values).
    Checked wherever the neighbouring roots (about eta/2 away far out) are farther than w.
    """
    params = ModelParameters(alpha=alpha, eta=eta)
    f = regularized_contact_force(X_EXTREME, params)
    a, e = Fraction(alpha), Fraction(eta)
    checked = 0
    for x, root in zip(X_EXTREME, f):
        window = 1e-6 * abs(root) + 32 * np.spacing(abs(root))
        if abs(x) < 1e-150 or 8 * window > eta / 2:
            continue
        xf = Fraction(float(x))

        def p(v):
            v = Fraction(float(v))
            return v * (v - a * (xf - 1)) * (v - a * (xf + 1)) + e * a * a * xf

        assert p(root - window) > 0 > p(root + window), (x, root)
        checked += 1
    assert checked >= 40, checked


# --------------------------------------------------------------------------- sharp stop, continuation


@pytest.fixture(scope="module")
def config(repo_root):
    return load_config(repo_root / "config" / "config.yaml")


@pytest.fixture(scope="module")
def exact_family_dataset(config):
    from nnmstop.exact import family_dataset

    params = ModelParameters.from_config(config["model"])
    return family_dataset(follow_family(params, step=config["exact"]["step"], max_points=config["exact"]["max_points"]))


def test_sharp_stop_continuation_matches_the_exact_orbits_within_the_study_error(config, exact_family_dataset):
    """eta = 1e-3 with H = 100: the study's error_vs_runtime gives, on energies 3..12, a frequency
    error of about 2-3e-5 (regularization part 1.2e-5 + truncation) and an x error below 1e-3."""
    run = run_stage_one(case_config(config, harmonics=100, eta=1e-3), max_truncation=1e-3)
    assert run.converged, run.failure
    assert run.truncation < 1e-4
    matched = match_energies(exact_family_dataset, run.dataset, [3.0, 12.0], phase_samples=1024)
    assert matched.complete, matched.failure
    frequency = np.abs(matched.values["relative_frequency_difference"])
    assert np.all(frequency < 4e-5), frequency
    assert np.all(frequency > 2e-6), frequency  # the regularization part is not zero: not a trivial pass
    assert np.all(matched.values["max_x_difference"] < 1.2e-3), matched.values["max_x_difference"]
    assert np.all(matched.values["max_u_difference"] < 6e-4), matched.values["max_u_difference"]
    # the contact force: dominated by the knee, f(1) = sqrt(eta alpha / 2) = 0.12 above the piecewise law,
    # and by the truncation of its kink (about 1/H of its jump in slope)
    assert np.all(matched.values["max_force_difference"] < 0.8), matched.values["max_force_difference"]


def test_too_few_harmonics_for_a_sharp_stop_is_refused_plainly(config):
    run = run_stage_one(case_config(config, harmonics=10, eta=1e-3), max_truncation=1e-3)
    assert not run.converged and run.dataset is None
    assert "truncation indicator" in run.failure and "H = 10" in run.failure and "energy" in run.failure
    assert "eta = 0.001" in run.failure


def test_stiff_stop_with_the_paper_harmonics_is_refused_plainly(config):
    """alpha = 1e4 with H = 100: every algebraic residual at round-off, yet the contact (~0.03 of a
    period of ~7) is far from resolved; the guard stops at the first orbit that shows it."""
    run = run_stage_one(case_config(config, harmonics=100, alpha=1.0e4, eta=0.1, max_steps=60), max_truncation=1e-3)
    assert not run.converged
    assert "H = 100" in run.failure and "alpha = 10000" in run.failure


def test_stiff_case_dataset_reports_every_attempt(config, tmp_path):
    from nnmstop.datasets import write_dataset
    from nnmstop.study.stiff_cases import stiff_branch_dataset

    cfg = case_config(config)
    cfg["study"]["stiff"]["harmonics"] = [10, 20]
    ds = stiff_branch_dataset(cfg, xr.Dataset(), 1.0e4, 1.0, 1.0, 1e-3)
    assert not bool(ds["converged"]) and int(ds["harmonics"]) == -1
    assert "H=10:" in str(ds["attempts"].values) and "H=20:" in str(ds["attempts"].values)
    path = write_dataset(ds, tmp_path / "case.nc", title="t", summary="s")
    with xr.open_dataset(path) as back:
        assert np.isnan(float(back["frequency_error"])) and np.isnan(float(back["runtime"]))
        assert "no number of harmonics tried resolves the branch" in str(back["failure"].values)
