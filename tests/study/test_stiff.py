"""Stiff paths: the exact solver at alpha = 1e6, the regularized force at extreme values,
a sharp-stop continuation against the exact orbits, and the study's guard and end check."""

import dataclasses
from fractions import Fraction

import numpy as np
import pytest
import xarray as xr

from nnmstop.checks.shooting import orbit_initial_state, refine_orbit
from nnmstop.checks.time_integration import integrate_nonsmooth, integrate_regularized
from nnmstop.compare.matching import EnergyMatcher
from nnmstop.config import load_config
from nnmstop.exact.family import follow_two_impact_family
from nnmstop.exact.grazing import assess_orbit
from nnmstop.exact.problem import TwoImpactProblem
from nnmstop.models.two_dof import ModelParameters, piecewise_contact_force, regularized_contact_force, total_energy
from nnmstop.settings import study_settings
from nnmstop.study.error_runtime import case_run
from nnmstop.study.runs import match_energies, run_stage_one, two_impact_arm
from nnmstop.study.stiff_cases import _confirm_end, exact_checks

EPS = np.finfo(float).eps


# --------------------------------------------------------------------------- exact solver, alpha = 1e6


@pytest.fixture(scope="module")
def stiff_family():
    """The first 40 orbits of the exact family for a nearly rigid stop (contact lasts ~1.6e-3)."""
    params = ModelParameters(alpha=1.0e6, beta=1.0, delta=1.0, eta=0.1)
    return params, follow_two_impact_family(params, step=2.0e-3, max_points=40)


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
    assert all(assess_orbit(problem, y).valid for y in family.unknowns[1:])


def test_exact_orbit_is_periodic_by_event_located_integration_for_alpha_1e6(stiff_family):
    params, family = stiff_family
    y = family.unknowns[-1]
    t = np.linspace(0.0, 4.0 * y[3], 17)
    trajectory = integrate_nonsmooth(params, [0.0, 0.0, y[0], y[1]], t, max_step=5e-3)
    exact = TwoImpactProblem(params).time_history(y, t)
    closed = np.column_stack([exact.x, exact.u, exact.xdot, exact.udot])
    assert trajectory.switch_times.size == 4  # enter and leave each stop once
    assert np.abs(trajectory.states[-1] - trajectory.states[0]).max() < 1e-9
    assert np.abs(trajectory.states - closed).max() < 1e-8


def test_a_continuation_step_longer_than_the_contact_is_caught_as_a_false_end():
    """With the default step the alpha = 1e6 family 'ends' two orbits after grazing; the check says so."""
    params = ModelParameters(alpha=1.0e6, beta=1.0, delta=1.0, eta=0.1)
    family = follow_two_impact_family(params, step=0.02, max_points=4000)
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


X_EXTREME = np.concatenate(
    [-np.logspace(300, -300, 121), np.logspace(-300, 300, 121), [0.5, 0.999, 1.0, 1.001, 2.0, 3.0]]
)
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

        def p(v, xf=xf):
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
    from nnmstop.exact.dataset import two_impact_dataset

    params = ModelParameters.from_config(config["model"])
    return two_impact_dataset(
        follow_two_impact_family(params, step=config["exact"]["step"], max_points=config["exact"]["max_points"])
    )


def _shoot_at_energy(params, state, period, energy, rtol=1e-10):
    """Periodic orbit of the regularized equations (7) at ``energy``, by time integration only.

    :func:`nnmstop.checks.shooting.refine_orbit` shoots at fixed ``x(0)`` (start at rest, velocities
    zero at T/2); a secant iteration on ``x(0)`` then brings the energy of the start state
    (at rest: potential energy only, :func:`nnmstop.models.two_dof.total_energy`) to ``energy``.
    ``rtol`` (relative, on the energy) sits above the shooting's own accuracy (velocities to
    1e-11 of their scale, DOP853 at 1e-12), which limits how closely the energy can be hit; the
    frequency then carries a relative error of order ``rtol``, far below the parts asserted here.
    """

    def shoot(x0):
        z = np.array(state, dtype=float)
        z[0] = x0
        z, T = refine_orbit(params, z, period)
        return float(total_energy(z[0], z[1], 0.0, 0.0, params)) - energy, z, T

    a = float(state[0])
    fa, _, _ = shoot(a)
    b = a * (1.0 + 1e-3)
    fb, z, T = shoot(b)
    for _ in range(20):
        a, b, fa = b, b - fb * (b - a) / (fb - fa), fb
        fb, z, T = shoot(b)
        if abs(fb) <= rtol * energy:
            return z, T
    raise AssertionError(f"secant on x(0) did not reach energy {energy} (off by {fb:.1e})")


def test_sharp_stop_continuation_matches_the_exact_orbits_within_the_study_error(config, exact_family_dataset):
    """eta = 1e-3 with H = 100, at E = 3 and 12. The study's frequency error (HBM against exact, as
    ``match_energies`` gives it) is the product of two parts, each checked against an
    independent reference: (a) truncation: the HBM orbit against the periodic orbit of the same
    regularized system found by time integration (shooting) at the same energy; (b) regularization:
    the shot orbit against the exact non-smooth orbit, with the eta scaling and the knee force of
    the model's cubic."""
    energies = [3.0, 12.0]
    run = run_stage_one(case_run(study_settings(config), 100, 1e-3), energy_limit=13.0)
    assert run.converged, run.failure
    matched = match_energies(exact_family_dataset, run.dataset, energies, phase_samples=1024)
    assert matched.complete, matched.failure
    system = matched.system
    alpha = system.params.alpha
    matcher = EnergyMatcher(exact_family_dataset, two_impact_arm(run.dataset, exact_family_dataset))
    phase = np.arange(4096) / 4096
    # (1 + HBM vs exact) = (1 + HBM vs shot) (1 + shot vs exact) at one energy, so the two parts below
    # account for the whole study error; each is checked on its own.
    for energy, U in zip(energies, matched.orbits):
        # (a) truncation part. The indicator is the share of the mean square in the top tenth of the
        # harmonics, so the relative size of the missing tail is about its square root; a first-order
        # error in the orbit cannot shift the frequency by more than that relative amount.
        truncation = system.truncation(U)
        assert truncation < 1e-4, truncation
        state, period = orbit_initial_state(system, U)
        shot, shot_period = _shoot_at_energy(system.params, state, period, energy)
        hbm_vs_shot = shot_period / period - 1.0  # (f_hbm - f_shot) / f_shot
        assert abs(hbm_vs_shot) < np.sqrt(truncation), (energy, hbm_vs_shot, truncation)
        # (b) regularization part: the shot orbit against the exact orbit at the same energy
        y, _, _ = matcher.exact_orbit(energy)
        exact_period = 4.0 * y[3]
        shift, x_difference = {}, {}
        for eta in (1e-2, 1e-3):
            params = dataclasses.replace(system.params, eta=eta)
            z, T = (shot, shot_period) if eta == 1e-3 else _shoot_at_energy(params, shot, shot_period, energy)
            shift[eta] = exact_period / T - 1.0
            # the regularized stop is stiffer everywhere (f >= the piecewise law): higher frequency
            assert shift[eta] > 0.0, (energy, eta, shift[eta])
            # contact force: both orbits start at the turning point x = max. The regularized force
            # exceeds the piecewise law by at most its knee value f(1) = sqrt(eta alpha / 2) (closed form
            # of the cubic at x = 1, up to O(eta)), and the piecewise law is alpha-Lipschitz, so
            # |f_reg(x_reg) - f_pw(x_exact)| <= f(1) + alpha max|x_reg - x_exact|; at the sample where
            # x_reg is nearest the knee the exact force is at most alpha (x_reg - 1 + max dx)^+, which
            # bounds the largest difference from below by the regularized force there less that.
            knee = np.sqrt(eta * alpha / 2.0)
            x_reg = integrate_regularized(params, z, phase * T).states[:, 0]
            exact = TwoImpactProblem(system.params).time_history(y, y[3] + phase * exact_period)
            force_reg = regularized_contact_force(x_reg, params)
            dx = x_difference[eta] = np.abs(x_reg - exact.x).max()
            df = np.abs(force_reg - exact.force).max()
            assert abs(float(regularized_contact_force(np.array([1.0]), params)[0]) - knee) < 2 * eta, knee
            k = int(np.argmin(np.abs(np.abs(x_reg) - 1.0)))
            lower = abs(force_reg[k]) - alpha * (max(abs(x_reg[k]) - 1.0, 0.0) + dx)
            assert lower > 0.0, (energy, eta, lower, knee)  # the bracket around f(1) is not empty below
            assert lower <= df <= knee + 2 * eta + alpha * dx, (energy, eta, lower, df, knee, dx)
        # The frequency shift is a potential excess over the piecewise law: the linear spring eta x in
        # free flight, and in contact (eta/2) log(alpha (|x| - 1) / eta) (the potential of the cubic),
        # so shift = eta (a + b log(1/eta)) with a, b >= 0. Ten times eta then gives a ratio between
        # 10 log(100) / log(1000) = 6.67 (log term alone) and 10 (no log term); the next order, set by
        # the knee width sqrt(eta / alpha) = 0.018 at eta = 1e-2, moves it by a few per cent at most.
        # The largest x difference comes from the same potential excess (the amplitude at fixed energy),
        # so it follows the same law.
        low, high = 10.0 * np.log(100.0) / np.log(1000.0) * 0.95, 10.0 * 1.05
        for name, part in (("frequency", shift), ("x", x_difference)):
            ratio = part[1e-2] / part[1e-3]
            assert low < ratio < high, (energy, name, ratio)


def test_too_few_harmonics_for_a_sharp_stop_is_refused_plainly(config):
    run = run_stage_one(case_run(study_settings(config), 10, 1e-3))
    assert not run.converged and run.dataset is None
    assert "truncation indicator" in run.failure and "H = 10" in run.failure and "energy" in run.failure
    assert "eta = 0.001" in run.failure


def test_stiff_stop_with_the_paper_harmonics_is_refused_plainly(config):
    """alpha = 1e4 with H = 100: every algebraic residual at round-off, yet the contact (~0.03 of a
    period of ~7) is far from resolved; the guard stops at the first orbit that shows it."""
    base = case_run(study_settings(config), 100, 0.1)
    run = run_stage_one(
        dataclasses.replace(
            base,
            params=dataclasses.replace(base.params, alpha=1.0e4),
            continuation=dataclasses.replace(base.continuation, max_steps=60),
        )
    )
    assert not run.converged
    assert "H = 100" in run.failure and "alpha = 10000" in run.failure


def test_stiff_case_dataset_reports_every_attempt(config, tmp_path):
    from nnmstop.netcdf import write_dataset
    from nnmstop.study.stiff_cases import stiff_branch_dataset

    settings = study_settings(config)
    settings = dataclasses.replace(settings, stiff=dataclasses.replace(settings.stiff, harmonics=(10, 20)))
    ds = stiff_branch_dataset(settings, xr.Dataset(), 1.0e4, 1.0, 1.0, 1e-3)
    assert not bool(ds["converged"]) and int(ds["harmonics"]) == -1
    assert "H=10:" in str(ds["attempts"].values) and "H=20:" in str(ds["attempts"].values)
    path = write_dataset(ds, tmp_path / "case.nc", title="t", summary="s", kind="stiff_nnm1")
    with xr.open_dataset(path) as back:
        assert np.isnan(float(back["frequency_error"])) and np.isnan(float(back["runtime"]))
        assert "no number of harmonics tried resolves the branch" in str(back["failure"].values)
