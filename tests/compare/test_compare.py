"""Exact vs regularized NNM1 at matched energies (nnmstop.compare.matching) and Figs 2-4.

Real datasets at small cost: the exact two-impact family (closed form, coarse step) and
NNM1 stage 1 of the regularized system at H = 30 (well under a second). Every check of
the comparison goes through an independent route: energies from the orbits' time
histories and from the HBM diagnostics, forces from the piecewise law on the exact
orbit and from the HBM series synthesized by the HBM system itself.
"""

import copy
import subprocess
import sys

import numpy as np
import pytest

from fixed_energy import orbit_at_energy
from nnmstop.checks.time_integration import integrate_nonsmooth
from nnmstop.compare import matching as compare
from nnmstop.compare.dataset import comparison_dataset, comparison_energies
from nnmstop.config import ConfigError, load_config, validate_config
from nnmstop.exact.dataset import two_impact_dataset
from nnmstop.exact.family import follow_two_impact_family
from nnmstop.exact.problem import TwoImpactProblem
from nnmstop.figures import exact_vs_regularized as fig
from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.models.two_dof import ModelParameters, piecewise_contact_force, regularized_contact_force, total_energy
from nnmstop.pipeline.run import run_task
from nnmstop.tasks.figures import build_exact_vs_regularized_figure
from nnmstop.tasks.hbm import build_stage

H = 30
PNG_DPI = 60
MARKED = {"a": 0.72, "b": 20.0}


def small_config(eta: float = 0.1, until: dict | None = None) -> dict:
    """Paper physics at H = 30, NNM1 stage 1 only."""
    config = copy.deepcopy(load_config("config/config.yaml"))
    config["hbm"]["harmonics"] = H
    config["hbm"]["points_per_step"] = 2
    config["model"]["eta"] = eta
    config["branches"]["nnm1"]["stages"] = [{"name": "one_impact_per_stop", "until": until or {"impacts_above": 2}}]
    return config


@pytest.fixture(scope="module")
def exact_family():
    return two_impact_dataset(follow_two_impact_family(ModelParameters(), step=0.05))


@pytest.fixture(scope="module")
def stage1():
    return build_stage(small_config(), "nnm1", 1)


@pytest.fixture(scope="module")
def matcher(exact_family, stage1):
    return compare.EnergyMatcher(exact_family, stage1)


@pytest.fixture(scope="module")
def comparison(exact_family, stage1):
    return comparison_dataset(exact_family, stage1, count=6, marked=MARKED, phase_samples=2048)


def _hbm_unknowns(ds, point, system):
    """HBM unknown vector of a comparison point, rebuilt from its stored coefficients."""
    parts = [ds[f"{s}_cos"].values[point, j] for s, count in (("q", 2), ("f", 1), ("z", 1)) for j in range(count)]
    return np.concatenate([p[: system.nc] for p in parts] + [[ds["omega_squared"].values[point]]])


# --------------------------------------------------------------------------- matching


def test_energy_ranges_use_the_monotone_parts(matcher, exact_family, stage1):
    e = exact_family["energy"].values
    arm = matcher.exact_arm
    assert arm.start == int(np.argmin(e)) > 0  # the exact family loses energy after grazing
    assert np.all(np.diff(e[arm]) > 0)
    part = matcher.regularized_part
    assert np.all(np.diff(stage1["energy"].values[part]) > 0)
    assert np.all(stage1["impacts_per_period"].values[part] <= 2)
    assert stage1["impacts_per_period"].values[-1] > 2  # the stage's last orbit is left out
    lo, hi = matcher.energy_range
    assert e[arm][0] < lo < hi < min(e[-1], stage1["energy"].values[part][-1])


def test_energies_really_match(comparison):
    """Exact energy from the time history (conserved), HBM energy from the HBM diagnostics."""
    params = ModelParameters(**{k: comparison.attrs[k] for k in ("alpha", "beta", "delta", "eta")})
    system = compare.system_from_dataset(comparison)
    for i, energy in enumerate(comparison["energy"].values):
        y = [comparison[v].values[i] for v in ("exact_xdot0", "exact_udot0", "exact_tau1", "exact_T1")]
        h = TwoImpactProblem(params).time_history(y, np.linspace(0.0, 4.0 * y[3], 37))
        e_t = total_energy(h.x, h.u, h.xdot, h.udot, params, model="piecewise")
        np.testing.assert_allclose(e_t, energy, rtol=1e-12)
        U = _hbm_unknowns(comparison, i, system)
        assert system.diagnostics(U)["energy"] == pytest.approx(energy, rel=1e-11)
        assert np.linalg.norm(system.residual(U)) <= 1e-11 * np.linalg.norm(U)
    np.testing.assert_allclose(comparison["exact_energy"], comparison["energy"], rtol=1e-13)
    np.testing.assert_allclose(comparison["regularized_energy"], comparison["energy"], rtol=1e-12)


@pytest.mark.numerics
def test_frequencies_agree_with_the_branches(comparison, stage1, matcher):
    """Matched frequencies are those of the orbits of each model at the matched energies.

    Exact side: integrating the non-smooth system (event location at the stops) from the
    matched initial state over one period 1/frequency_exact closes the orbit. Regularized
    side: the HBM orbit solved again at each energy by a separate Newton solve (seeded by
    the stored branch points, tests/fixed_energy.py) has the same frequency to round-off
    of the two solves; no interpolation between stored points.
    """
    params = ModelParameters(**{k: comparison.attrs[k] for k in ("alpha", "beta", "delta", "eta")})
    system = matcher.system
    part = matcher.regularized_part
    seeds = dataset_unknowns(stage1, system)[part]
    for i, energy in enumerate(comparison["energy"].values):
        z0 = [0.0, 0.0, comparison["exact_xdot0"].values[i], comparison["exact_udot0"].values[i]]
        period = 1.0 / float(comparison["frequency_exact"].values[i])
        traj = integrate_nonsmooth(params, z0, [0.0, period])
        np.testing.assert_allclose(traj.states[-1], z0, rtol=0, atol=1e-9)
        U = orbit_at_energy(system, seeds, stage1["energy"].values[part], float(energy))
        assert float(comparison["frequency_regularized"].values[i]) == pytest.approx(system.frequency_hz(U), rel=1e-10)
    np.testing.assert_allclose(comparison["frequency_exact"], 1.0 / (4.0 * comparison["exact_T1"]), rtol=1e-14)
    alike = comparison["counterpart"].values == 0  # differences between like orbits only (test below)
    diff = (comparison["frequency_regularized"] - comparison["frequency_exact"]).values
    np.testing.assert_allclose(comparison["frequency_difference"].values[alike], diff[alike], rtol=1e-12)
    np.testing.assert_allclose(
        comparison["relative_frequency_difference"].values[alike],
        diff[alike] / comparison["frequency_exact"].values[alike],
        rtol=1e-12,
    )


def test_only_like_orbits_are_compared(comparison):
    """Issue 29: each pair's type from an independent synthesis of each orbit (exact closed-form time history,
    HBM series): a pair is compared (its differences finite) exactly where the regularized orbit enters its law's
    contact transition |x| > 1 - sqrt(2 eta/alpha) as often as the exact orbit passes |x| > 1, and neither has
    a harmonic other than the fundamental holding a tenth of the motion; elsewhere the differences are missing
    and counterpart says why. At these parameters the pair just above grazing is no counterpart (the regularized
    orbit does not yet reach the smoothed stop) and point b) is one."""
    params = ModelParameters(**{k: comparison.attrs[k] for k in ("alpha", "beta", "delta", "eta")})
    system = compare.system_from_dataset(comparison)
    n = 4096
    edge = 1.0 - np.sqrt(2.0 * params.eta / params.alpha)
    for i in range(comparison.sizes["point"]):
        y = [comparison[v].values[i] for v in ("exact_xdot0", "exact_udot0", "exact_tau1", "exact_T1")]
        h = TwoImpactProblem(params).time_history(y, 4.0 * y[3] * np.arange(n) / n)
        reg = system.time_history(_hbm_unknowns(comparison, i, system), n)
        entries = [int(np.count_nonzero(a & ~np.roll(a, 1))) for a in (h.x > 1, h.x < -1, reg["x"] > edge,
                                                                      reg["x"] < -edge)]  # fmt: skip
        same_contacts = entries[0] + entries[1] == entries[2] + entries[3]
        status = int(comparison["counterpart"].values[i])
        assert (status == 0) == same_contacts or status == 2
        assert np.isfinite(comparison["max_x_difference"].values[i]) == (status == 0)
        assert comparison["exact_impacts_per_period"].values[i] == 2  # the two-impact family
    (b,) = np.flatnonzero(comparison["marked"].values == 2)
    assert comparison["counterpart"].values[0] == 1 and comparison["counterpart"].values[b] == 0


def test_energy_gradient_matches_finite_differences(matcher):
    system = matcher.system
    U, *_ = matcher.regularized_orbit(3.0)
    op = compare.EnergyOperator(system)
    _, grad = op(U, gradient=True)
    rng = np.random.default_rng(1)
    for _ in range(3):
        d = rng.standard_normal(U.size) * np.abs(U).clip(1e-3)
        h = 1e-6
        fd = (op(U + h * d) - op(U - h * d)) / (2 * h)
        assert grad @ d == pytest.approx(fd, rel=1e-6, abs=1e-9)


# --------------------------------------------------------------------------- orbit differences


def test_force_comparison_uses_the_piecewise_law_on_the_exact_orbit(comparison):
    """Independent synthesis: exact orbit on the aligned phase, HBM force from the HBM system.

    On a grid 16 times finer than the comparison's (no refinement), the largest differences
    must agree with the stored, locally refined, maxima.
    """
    params = ModelParameters(**{k: comparison.attrs[k] for k in ("alpha", "beta", "delta", "eta")})
    system = compare.system_from_dataset(comparison)
    n = 16 * int(comparison.attrs["phase_samples"])
    phase = np.arange(n) / n
    for i in np.flatnonzero(comparison["counterpart"].values == 0):  # the pairs compared
        y = [comparison[v].values[i] for v in ("exact_xdot0", "exact_udot0", "exact_tau1", "exact_T1")]
        h = TwoImpactProblem(params).time_history(y, y[3] + phase * 4.0 * y[3])
        assert h.x[0] == pytest.approx(h.x.max(), rel=1e-12)  # origin at the maximum of x
        reg = system.time_history(_hbm_unknowns(comparison, i, system), n)
        shift = comparison["regularized_origin_shift"].values[i]
        f_reg = np.roll(reg["f"], -int(round(shift * n)))
        x_reg = np.roll(reg["x"], -int(round(shift * n)))
        assert x_reg[0] == pytest.approx(x_reg.max(), rel=1e-12)
        piecewise = piecewise_contact_force(h.x, params.alpha)
        expected = np.abs(f_reg - piecewise).max()
        stored = comparison["max_force_difference"].values[i]
        assert expected * (1 - 1e-12) <= stored <= expected * (1 + 5e-3)  # the peak is a sharp kink
        assert comparison["max_x_difference"].values[i] == pytest.approx(np.abs(x_reg - h.x).max(), rel=1e-6)
        # not the regularized law on the exact orbit: that would give another number
        other = np.abs(f_reg - regularized_contact_force(h.x, params)).max()
        assert abs(other - expected) > 1e-2 * expected


def test_alignment_handles_a_minimum_at_t0(matcher):
    """The half-period-shifted HBM orbit (x minimum at t = 0) gives the same differences."""
    pair = matcher.match(5.0)
    system = matcher.system
    x, u, f, z, lam, _ = system.split(pair.regularized)
    flipped = system.pack(-x, -u, -f, z, lam)  # q(t + T/2) = -q(t): also a solution, x(0) minimal
    assert np.linalg.norm(system.residual(flipped)) <= 1e-11 * np.linalg.norm(flipped)
    a = compare.orbit_differences(pair, system, 1024)
    b = compare.orbit_differences(compare.MatchedOrbits(**{**pair.__dict__, "regularized": flipped}), system, 1024)
    assert (a["regularized_origin_shift"], b["regularized_origin_shift"]) == (0.0, 0.5)
    for key in ("max_x_difference", "max_u_difference", "max_force_difference", "frequency_difference"):
        assert b[key] == pytest.approx(a[key], rel=1e-9, abs=1e-13)


def test_frequency_difference_shrinks_with_eta(exact_family):
    """At a mid-range energy and fixed H, eta = 0.02 is closer to the exact NNM than eta = 0.1."""
    energy = 4.0
    out = {}
    for eta in (0.1, 0.02):
        branch = build_stage(small_config(eta, {"energy_above": 8.0}), "nnm1", 1)
        m = compare.EnergyMatcher(exact_family, branch)
        out[eta] = compare.orbit_differences(m.match(energy), m.system, 1024)
    assert abs(out[0.02]["frequency_difference"]) < 0.5 * abs(out[0.1]["frequency_difference"])
    assert out[0.02]["max_x_difference"] < 0.5 * out[0.1]["max_x_difference"]
    assert out[0.02]["max_force_difference"] < out[0.1]["max_force_difference"]


def test_regularized_orbit_is_a_newton_solution_not_an_interpolation(comparison):
    """The coefficient shift of plain interpolation is recorded and is not negligible."""
    assert np.all(comparison["regularized_residual"].values < 1e-12)
    assert np.all(comparison["exact_residual"].values < 1e-12)
    assert np.any(comparison["interpolation_coefficient_shift"].values > 1e-6)


# --------------------------------------------------------------------------- bad inputs


@pytest.mark.parametrize("energy", [0.5, 0.675, 1.0e3, float("nan"), -1.0, "abc"])
def test_energy_outside_the_common_range_raises(matcher, energy):
    with pytest.raises(ValueError, match=r"energy .* (outside|real number)"):
        matcher.match(energy)


def test_marked_energy_outside_the_range_raises(exact_family, stage1):
    with pytest.raises(ValueError, match="energy 60.0 is outside"):
        comparison_dataset(exact_family, stage1, count=3, marked={"a": 0.72, "b": 60.0})


def test_bad_arguments_raise(exact_family, stage1, matcher):
    with pytest.raises(ValueError, match="end_margin"):
        compare.EnergyMatcher(exact_family, stage1, end_margin=0.7)
    other = exact_family.copy()
    other.attrs = {**exact_family.attrs, "alpha": 20.0}
    with pytest.raises(ValueError, match="alpha differs"):
        compare.EnergyMatcher(other, stage1)
    with pytest.raises(ValueError, match="phase_samples"):
        compare.orbit_differences(matcher.match(2.0), matcher.system, 10)
    with pytest.raises(ValueError, match="number of compared energies"):
        comparison_energies(matcher, 1)


def test_config_section_is_validated():
    config = copy.deepcopy(load_config("config/config.yaml"))
    config["compare"]["points"]["b"] = -1.0
    with pytest.raises(ConfigError, match="compare.points.b"):
        validate_config(config)
    config = copy.deepcopy(load_config("config/config.yaml"))
    config["compare"]["phase_samples"] = 8
    with pytest.raises(ConfigError, match="compare.phase_samples"):
        validate_config(config)


# --------------------------------------------------------------------------- pipeline and figures


def test_task_writes_a_labelled_dataset_and_refuses_stale_inputs(tmp_path, exact_family, stage1):
    import xarray as xr

    config = small_config()
    config["compare"] = {**config["compare"], "energy_count": 3, "phase_samples": 512}
    exact_path, nnm1_path = tmp_path / "exact.nc", tmp_path / "nnm1.nc"
    exact_family.to_netcdf(exact_path)
    stage1.to_netcdf(nnm1_path)
    out = tmp_path / "cmp.nc"
    run_task("compare_nnm1", config, {"exact": str(exact_path), "nnm1": str(nnm1_path)}, {"dataset": str(out)})
    with xr.open_dataset(out) as ds:
        assert ds.sizes["point"] == 5 and ds.sizes["harmonic"] == H + 1
        for name, var in {**ds.coords, **ds.data_vars}.items():
            assert "long_name" in var.attrs and "units" in var.attrs, name
        assert {"alpha", "beta", "delta", "eta", "harmonics", "Conventions"} <= set(ds.attrs)
        # a) at its fraction of the compared range, in log energy (the scene follows the data)
        low, high, r = ds.attrs["energy_range_min"], ds.attrs["energy_range_max"], 0.013
        assert config["compare"]["points"]["a"] == {"energy_fraction": r}
        assert ds.attrs["point_a_energy"] == pytest.approx(low ** (1 - r) * high**r, rel=1e-12)
    stale = copy.deepcopy(config)
    stale["model"]["eta"] = 0.05
    with pytest.raises(ValueError, match=r"eta = 0.1 in the dataset but 0.05 in the configuration \(stale dataset\)"):
        run_task("compare_nnm1", stale, {"exact": str(exact_path), "nnm1": str(nnm1_path)}, {"dataset": str(out)})


def test_figures_are_byte_identical_twice(tmp_path, exact_family, stage1, comparison):
    for run in ("one", "two"):
        d = tmp_path / run
        fig.figure_02(exact_family, stage1, comparison, d / "fig02.pdf", PNG_DPI)
        fig.figure_03(comparison, d / "fig03.pdf", PNG_DPI)
        fig.figure_04(comparison, d / "fig04.pdf", PNG_DPI)
    for name in ("fig02", "fig03", "fig04"):
        for ext in ("pdf", "png"):
            a = (tmp_path / "one" / f"{name}.{ext}").read_bytes()
            assert a == (tmp_path / "two" / f"{name}.{ext}").read_bytes(), f"{name}.{ext}"


def test_figures_refuse_bad_datasets(tmp_path, exact_family, stage1, comparison):
    bad = comparison.copy(deep=True)
    bad["frequency_exact"].values[0] = np.nan
    with pytest.raises(ValueError, match="frequency_exact"):
        fig.figure_02(exact_family, stage1, bad, tmp_path / "f.pdf", PNG_DPI)
    unmarked = comparison.copy(deep=True)
    unmarked["marked"].values[:] = 0
    with pytest.raises(ValueError, match=r"point a\)"):
        fig.figure_03(unmarked, tmp_path / "f.pdf", PNG_DPI)
    with pytest.raises(ValueError, match="missing input 'exact'"):
        build_exact_vs_regularized_figure(
            "fig02", small_config(), {"comparison": "x.nc"}, {"pdf": "a.pdf", "png": "a.png"}
        )


def test_fig02_needs_no_nnm2_and_no_later_nnm1_stage(repo_root):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "snakemake",
            "-n",
            "--forceall",
            "paper_figures/fig02.pdf",
            "paper_figures/fig03.pdf",
            "paper_figures/fig04.pdf",
        ],
        cwd=repo_root,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    text = out.stdout + out.stderr
    assert "results/hbm/stages/nnm1_stage1.nc" in text
    assert "nnm2" not in text
    assert "nnm1_stage2" not in text and "results/hbm/nnm1.nc" not in text


def test_branches_that_share_no_energy_give_a_comparison_that_says_so(exact_family, stage1, tmp_path):
    """A regularized branch that ends below grazing (few harmonics, say) has nothing to compare: the comparison
    holds no point and names the energy ranges; Figs 2-4 are drawn and say why there are no a) and b)."""
    from nnmstop.compare.dataset import empty_comparison_dataset
    from nnmstop.netcdf import check_labelled

    below = stage1.isel(point=stage1["energy"].values < 0.5 * float(exact_family["energy"].min()))
    assert compare.comparison_gap(exact_family, stage1) == ""
    reason = compare.comparison_gap(exact_family, below)
    assert reason.startswith("the energy ranges do not overlap")
    empty = empty_comparison_dataset(below, reason)
    check_labelled(empty)
    assert empty.sizes["point"] == 0 and empty.attrs["alpha"] == stage1.attrs["alpha"]
    from PIL import Image

    for name, args in (("fig02", (exact_family, below, empty)), ("fig03", (empty,)), ("fig04", (empty,))):
        pdf, png = getattr(fig, f"figure_{name[3:]}")(*args, tmp_path / f"{name}.pdf", PNG_DPI)
        assert "do not overlap" in Image.open(png).info["Description"]
