"""Branch points and branch switching (nnmstop.hbm.bifurcation, nnmstop.hbm.stages.bifurcated_branch)."""

import copy

import numpy as np
import pytest
import yaml

from nnmstop.config import ConfigError, validate_config
from nnmstop.continuation.anm import ANMSettings, continue_anm
from nnmstop.continuation.core import ContinuationStats, newton_correct, relative_residual
from nnmstop.hbm.bifurcation import (
    bifurcation_tangents,
    locate_branch_point,
    quadratic_form,
    subharmonic_share,
    switch_branch,
)
from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.stages import combine_stages, start_point
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import two_dof_structure
from nnmstop.netcdf import check_labelled
from nnmstop.tasks.hbm import build_bifurcated, build_stage, system_from_config


class Transcritical:
    """``S(x, y, lam) = [x (lam - x), y]``: the curves ``x = 0`` and ``x = lam`` cross at 0.

    Their tangents there, ``(0, 0, 1)`` and ``(1, 0, 1)/sqrt(2)``, are 45 degrees apart:
    a switch along the null vector orthogonal to the incoming tangent would be wrong.
    """

    n_equations, n_unknowns = 2, 3

    def residual(self, U):
        x, y, lam = U
        return np.array([x * (lam - x), y])

    def jacobian(self, U):
        x, y, lam = U
        return np.array([[lam - 2 * x, 0.0, x], [0.0, 1.0, 0.0]])

    def series_cache(self, order):
        return None

    def series_products(self, series, p, cache=None):
        """sum_r Q(U_r, U_{p-r}) for the ANM (Q of x lam - x^2, summed symmetrically)."""
        out = np.zeros(2)
        for r in range(1, p):
            a, b = series[r], series[p - r]
            out[0] += a[0] * b[2] - a[0] * b[0]
        return out


def test_quadratic_form_of_the_toy_system():
    toy = Transcritical()
    a, b = np.array([1.0, 2.0, 3.0]), np.array([-0.5, 1.0, 2.0])
    # quadratic part of S_1: x lam - x^2 -> Q(a, b) = (a_x b_lam + a_lam b_x) / 2 - a_x b_x
    expected = 0.5 * (a[0] * b[2] + a[2] * b[0]) - a[0] * b[0]
    np.testing.assert_allclose(quadratic_form(toy, a, b), [expected, 0.0], atol=1e-14)


def test_locate_and_switch_at_a_transcritical_point():
    toy = Transcritical()
    U_a, U_b = np.array([0.0, 0.0, -0.3]), np.array([0.0, 0.0, 0.5])
    U_star, _ = locate_branch_point(toy, U_a, U_b, tol=1e-12)
    np.testing.assert_allclose(U_star, 0.0, atol=1e-11)
    point = bifurcation_tangents(toy, U_star, U_b - U_a)
    np.testing.assert_allclose(point.incoming, [0.0, 0.0, 1.0], atol=1e-8)
    np.testing.assert_allclose(abs(point.bifurcated @ np.array([1.0, 0.0, 1.0])) / np.sqrt(2), 1.0, atol=1e-8)
    assert point.angle == pytest.approx(45.0, abs=1e-6)
    for step in (0.1, -0.1):
        U1 = switch_branch(toy, point, step)
        assert U1[0] == pytest.approx(U1[2], abs=1e-12)  # on x = lam
        assert abs(U1[0]) > 0.05


def test_no_branch_point_between_regular_points():
    toy = Transcritical()
    with pytest.raises(ValueError, match="no branch point"):
        locate_branch_point(toy, np.array([0.0, 0.0, 0.2]), np.array([0.0, 0.0, 0.5]))


def test_quadratic_form_against_the_jacobian(paper_params):
    """The ANM bilinear form against the analytic Jacobian: J(U + b) a - J(U) a = 2 Q(a, b)."""
    system = HarmonicBalanceSystem(two_dof_structure(paper_params), 8)
    rng = np.random.default_rng(3)
    U, a, b = (rng.normal(size=system.n_unknowns) for _ in range(3))
    lhs = system.jacobian(U + b) @ a - system.jacobian(U) @ a
    np.testing.assert_allclose(2 * quadratic_form(system, a, b), lhs, atol=1e-11 * np.linalg.norm(lhs))


@pytest.fixture(scope="module")
def resonance_config(repo_root):
    """NNM1 through its 3:1 branch point with H = 51 (NNM2 read over three periods then has 17)."""
    config = yaml.safe_load((repo_root / "tests" / "data" / "small_config.yaml").read_text())
    config = copy.deepcopy(config)
    config["hbm"]["harmonics"] = 51
    config["branches"]["nnm1"]["stages"] = [
        {"name": "one_impact_per_stop", "until": {"impacts_above": 2}},
        {"name": "resonance_3to1", "until": {"impacts_at_most": 4}},  # two per stop: past the branch point
    ]
    config["bifurcations"] = {
        "nnm1_3to1": {"parent": "nnm1", "resonance": 3, "energy_range": [3.0, 30.0], "switch_step": 1e-3}
    }
    return validate_config(config)


@pytest.fixture(scope="module")
def bifurcated(resonance_config):
    stage1 = build_stage(resonance_config, "nnm1", 1)
    stage2 = build_stage(resonance_config, "nnm1", 2, stage1)
    nnm1 = combine_stages([stage1, stage2])
    stage2.attrs["previous_stage"] = stage1  # kept for the combination test (never written)
    stage2.attrs["whole_branch"] = nnm1
    return stage2, build_bifurcated(resonance_config, "nnm1_3to1", nnm1)


def test_bifurcated_branch_is_nnm2_read_over_three_periods(resonance_config, bifurcated):
    """The switched branch holds orbits of period T/3 and, as an independent check,
    coincides with NNM2 continued from its own linear mode with H/3 harmonics."""
    stage2, ds = bifurcated
    assert ds.attrs["resonance"] == 3 and ds.attrs["parent_branch"] == "nnm1"
    assert float(ds["subharmonic_share"].max()) < 1e-12
    energy = ds["energy"].values
    assert energy.min() < 3.5 and energy.max() > 28.0
    # the branch point is the tip of the 3:1 tongue of NNM1, where its energy turns back
    e_bp = ds.attrs["branch_point_energy"]
    # (the located fold, not the least stored energy, which lies wherever a step landed)
    folds = stage2["fold_energy"].values
    assert e_bp == pytest.approx(folds[np.argmin(np.abs(folds - e_bp))], rel=1e-3)
    assert int(ds["branch_point"].values[np.argmin(np.abs(energy - e_bp))]) == 1
    # NNM2 with 17 harmonics from its own linear mode: the same algebraic system as the
    # bifurcated branch restricted to the harmonics 3k, with lam read as 9 lam
    nnm2_system = system_from_config(resonance_config, harmonics=17)
    U0, direction = start_point(nnm2_system, 2, 0.05)
    nnm2 = continue_anm(
        nnm2_system, U0, direction, lambda U, d: "end" if d["energy"] > 40.0 else "", ANMSettings(points_per_step=4)
    )
    nnm2_points = np.array(nnm2.points)
    system = system_from_config(resonance_config)
    fixed_lam = np.zeros(nnm2_system.n_unknowns)
    fixed_lam[nnm2_system.i_lam] = 1.0
    for U in dataset_unknowns(ds, system)[::8]:
        x, u, f, z, lam, _ = system.split(U)
        V = nnm2_system.pack(x[::3], u[::3], f[::3], z[::3], 9.0 * lam)
        # the NNM2 orbit of the same frequency, by Newton at fixed lam from the nearest NNM2 point
        guess = nnm2_points[np.argmin(np.abs(nnm2_points[:, nnm2_system.i_lam] - V[-1]))].copy()
        guess[nnm2_system.i_lam] = V[-1]
        W, _ = newton_correct(nnm2_system, guess, fixed_lam, ContinuationStats(), tol=1e-10)
        assert np.linalg.norm(W - V) < 1e-7 * np.linalg.norm(V)


def test_bifurcated_orbits_solve_the_balanced_equations(resonance_config, bifurcated):
    _, ds = bifurcated
    assert float(ds["algebraic_residual"].max()) < 1e-7
    assert ds["energy"].notnull().all() and ds["frequency"].notnull().all()
    system = system_from_config(resonance_config)
    U = dataset_unknowns(ds, system)
    assert max(subharmonic_share(system, u, 3) for u in U[::10]) < 1e-12
    assert max(relative_residual(system, u) for u in U[::10]) < 1e-7


def test_resonance_without_branch_point_gives_an_empty_dataset_that_says_so(resonance_config, bifurcated):
    stage2, _ = bifurcated
    config = copy.deepcopy(resonance_config)
    config["bifurcations"]["nnm1_3to1"]["resonance"] = 5
    ds = build_bifurcated(config, "nnm1_3to1", stage2.attrs["whole_branch"])
    assert ds.sizes["point"] == 0 and ds.attrs["skipped"] == 1
    assert "no branch point of the 5:1 resonance" in ds.attrs["end_reason"]
    assert "3:1 resonance" in ds.attrs["end_reason"]  # names what the branch has instead
    check_labelled(ds)


def test_config_checks_of_bifurcations(resonance_config):
    config = copy.deepcopy(resonance_config)
    config["bifurcations"]["nnm1_3to1"]["stage"] = 7
    with pytest.raises(ConfigError, match="bifurcations.nnm1_3to1.stage"):
        validate_config(config)
    config = copy.deepcopy(resonance_config)
    config["bifurcations"]["nnm1_3to1"]["energy_range"] = [30.0, 3.0]
    with pytest.raises(ConfigError, match="energy_range"):
        validate_config(config)
    config = copy.deepcopy(resonance_config)
    config["figures"]["fig07"]["bifurcated"] = ["nnm1_5to1"]
    with pytest.raises(ConfigError, match="figures.fig07.bifurcated"):
        validate_config(config)


def test_summary_reports_the_branch_point(bifurcated):
    from nnmstop.hbm.dataset import summarize_bifurcated

    stage2, ds = bifurcated
    text = summarize_bifurcated(ds)
    assert "3:1 branch point" in text and f"{ds.attrs['branch_point_energy']:.6g}" in text
    with pytest.raises(ValueError, match="not increasing"):
        summarize_bifurcated(ds, stage2)  # NNM1's energy turns back: no interpolation in E


def test_stage_dataset_records_located_branch_points_and_folds(bifurcated):
    """The 3:1 branch point of NNM1 is located where J is singular, classified as the
    T/3 crossing, and coincides with the tip of the tongue (an energy fold)."""
    stage2, ds = bifurcated
    resonance = stage2["branch_point_resonance"].values
    assert 3 in resonance
    k = int(np.flatnonzero(resonance == 3)[0])
    assert float(stage2["branch_point_singular_ratio"][k]) < 1e-5
    assert float(stage2["branch_point_energy"][k]) == pytest.approx(ds.attrs["branch_point_energy"], rel=1e-9)
    flagged = int(stage2["branch_point_flagged_point"][k])
    assert stage2["branch_point"].values[flagged] == 1
    # folds: refined extremum never above a stored maximum's neighbours' parabola... at least as extreme
    e = stage2["energy"].values
    for i, e_fold in zip(stage2["fold_point"].values, stage2["fold_energy"].values):
        if e[i] < e[i - 1]:  # a minimum
            assert e_fold <= e[i] + 1e-12
        else:
            assert e_fold >= e[i] - 1e-12
    nearest = np.min(np.abs(stage2["fold_energy"].values - stage2["branch_point_energy"].values[k]))
    assert nearest < 1e-3 * stage2["branch_point_energy"].values[k]


def test_combined_stages_keep_the_located_points(bifurcated):
    from nnmstop.hbm.stages import combine_stages

    stage2, _ = bifurcated
    stage1 = stage2.attrs["previous_stage"]
    plain = stage2.copy()
    plain.attrs = {k: v for k, v in stage2.attrs.items() if k not in ("previous_stage", "whole_branch")}
    both = combine_stages([stage1, plain])
    assert (
        both.sizes["located_branch_point"]
        == stage1.sizes["located_branch_point"] + stage2.sizes["located_branch_point"]
    )
    # indices shifted to the combined branch: they still point at flagged steps and energy extrema
    assert np.all(both["branch_point"].values[both["branch_point_flagged_point"].values] == 1)
    assert np.all(both["energy_fold"].values[both["fold_point"].values] == 1)
    assert set(np.round(stage2["fold_energy"].values, 9)) <= set(np.round(both["fold_energy"].values, 9))
