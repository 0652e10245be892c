"""Staged continuation of the regularized NNMs and their datasets."""

import copy

import numpy as np
import pytest
import xarray as xr

from nnmstop.catalogue import describe
from nnmstop.config import load_config
from nnmstop.continuation.core import ContinuationError, ContinuationStats, newton_correct
from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.stages import combine_stages
from nnmstop.models.two_dof import ModelParameters, linear_modes
from nnmstop.netcdf import check_labelled, read_dataset, write_dataset
from nnmstop.pipeline.run import run_task
from nnmstop.tasks.hbm import build_stage, system_from_config


@pytest.fixture(scope="module")
def small_config():
    """Paper physics, few harmonics, NNM1 in two stages up to the first energy fold."""
    config = copy.deepcopy(load_config("config/config.yaml"))
    config["hbm"]["harmonics"] = 24
    config["hbm"]["points_per_step"] = 2
    config["branches"]["nnm1"]["stages"] = [
        {"name": "no_impact", "until": {"impacts_above": 0}},
        {"name": "one_impact_per_stop", "until": {"energy_above": 20.0}},
    ]
    return config


@pytest.fixture(scope="module")
def nnm1_stages(small_config):
    first = build_stage(small_config, "nnm1", 1)
    second = build_stage(small_config, "nnm1", 2, first)
    return first, second


def test_nnm2_approaches_gap_zero_mode_from_below(small_config):
    ds = build_stage(small_config, "nnm2", 1)
    params = ModelParameters.from_config(small_config["model"])
    limit = linear_modes(params, "gap_zero")[0][1] / (2 * np.pi)
    start = linear_modes(params, "regularized")[0][1] / (2 * np.pi)
    freq = ds["frequency"].values
    assert freq[0] == pytest.approx(start, rel=1e-4)  # linear limit at low energy
    assert 0.98 * limit <= freq[-1] < limit
    # hardening all the way: frequency grows with energy along NNM2
    order = np.argsort(ds["energy"].values)
    assert np.all(np.diff(freq[order]) > -1e-9)
    check_labelled(describe(ds, "nnm_branch"))  # long names and units come from the catalogue when written


def test_stage_ends_where_its_criterion_is_first_met(nnm1_stages):
    first, second = nnm1_stages
    assert first["impacts_per_period"].values[-1] > 0
    assert np.all(first["impacts_per_period"].values[:-1] == 0)
    assert second["energy"].values[-1] > 20.0
    assert np.all(second["energy"].values[:-1] <= 20.0)
    assert "impacts" in first.attrs["end_reason"] and "energy" in second.attrs["end_reason"]


def test_stages_join_continuously(small_config, nnm1_stages):
    """Stage 2 starts exactly where stage 1 ends; the combined branch has every point once."""
    first, second = nnm1_stages
    xr.testing.assert_allclose(
        first.isel(point=-1).drop_vars(["point", "step", "stage"]),
        second.isel(point=0).drop_vars(["point", "step", "stage"]),
    )
    both = combine_stages([first, second])
    assert both.sizes["point"] == first.sizes["point"] + second.sizes["point"] - 1
    np.testing.assert_array_equal(both["point"].values, np.arange(both.sizes["point"]))


def test_staged_branch_matches_a_single_run(small_config, nnm1_stages):
    """Two stages trace the same curve as one continuation run with the last criterion."""
    single_config = copy.deepcopy(small_config)
    single_config["branches"]["nnm1"]["stages"] = [small_config["branches"]["nnm1"]["stages"][1]]
    single = build_stage(single_config, "nnm1", 1)
    staged = combine_stages(list(nnm1_stages))
    # energy grows monotonically up to E = 20 on NNM1 here: compare frequency at matched energies
    for ds in (single, staged):
        assert np.all(np.diff(ds["energy"].values) > 0)
    # every staged orbit is the orbit of the single run at its frequency: Newton at fixed
    # omega^2 from the single run's nearest point lands on it (no interpolation error)
    system = system_from_config(small_config)
    single_points = dataset_unknowns(single, system)
    fixed_lam = np.zeros(system.n_unknowns)
    fixed_lam[system.i_lam] = 1.0
    staged_points = dataset_unknowns(staged, system)
    for V in staged_points[:: max(1, len(staged_points) // 25)]:
        guess = single_points[np.argmin(np.abs(single_points[:, system.i_lam] - V[system.i_lam]))].copy()
        guess[system.i_lam] = V[system.i_lam]
        W, _ = newton_correct(system, guess, fixed_lam, ContinuationStats(), tol=1e-10)
        assert np.linalg.norm(W - V) < 1e-6 * np.linalg.norm(V)


def test_dataset_round_trip_gives_solutions(small_config, nnm1_stages):
    """Unknowns rebuilt from the stored coefficients solve the HBM system."""
    system = system_from_config(small_config)
    ds = nnm1_stages[1]
    U = dataset_unknowns(ds, system)
    residuals = [np.linalg.norm(system.residual(u)) / max(np.linalg.norm(u), 1) for u in U]
    assert max(residuals) < 10 * small_config["anm"]["newton_threshold"]
    np.testing.assert_allclose(ds["algebraic_residual"].values, residuals, rtol=1e-6, atol=1e-15)
    assert np.all(np.abs(ds["unfolding"].values) == 0.0)  # cosine basis: no unfolding term


def test_failed_stage_names_step_and_energy_and_leaves_no_dataset(small_config, tmp_path):
    config = copy.deepcopy(small_config)
    config["anm"]["max_steps"] = 2
    out = tmp_path / "nnm1_stage1.nc"
    with pytest.raises(ContinuationError, match=r"energy"):
        run_task("hbm_stage", config, {}, {"dataset": str(out)}, None, branch="nnm1", stage="1")
    assert not out.exists()
    assert not list(tmp_path.iterdir())


def test_stage_number_out_of_range_is_rejected(small_config):
    with pytest.raises(ValueError, match="stage must be in 1..2"):
        build_stage(small_config, "nnm1", 3)


@pytest.fixture(scope="module")
def bounded_stages(small_config):
    """A stage whose condition (more than 40 impacts per period) never comes below its energy bound 3."""
    config = copy.deepcopy(small_config)
    config["branches"]["nnm1"]["stages"] = [
        {"name": "never", "until": {"impacts_above": 40}, "energy_max": 3.0},
        {"name": "after", "until": {"energy_above": 20.0}},
    ]
    first = build_stage(config, "nnm1", 1)
    return config, first, build_stage(config, "nnm1", 2, first)


def test_a_stage_whose_condition_never_comes_ends_at_its_bound_and_the_next_is_skipped(bounded_stages, tmp_path):
    config, first, second = bounded_stages
    energy = first["energy"].values
    assert energy[-1] > 3.0 and np.all(energy[:-1] <= 3.0)  # ended at the first point above the bound
    assert first.attrs["stage_condition_met"] == 0
    assert (
        "bound 3" in first.attrs["end_reason"] and first.attrs["stage_condition"] == "more than 40 impacts per period"
    )
    # the stage after it holds no orbit and says why, naming the stage and its condition
    assert second.sizes["point"] == 0 and second.attrs["skipped"] == 1
    assert "stage 1 (never) ended without its condition (more than 40 impacts per period)" in second.attrs["end_reason"]
    check_labelled(second)
    path = write_dataset(second, tmp_path / "skipped.nc", title="t", summary="s", kind="skipped_branch")
    with xr.open_dataset(path) as back:
        assert back.sizes["point"] == 0 and "skipped" in back.attrs["end_reason"]
    both = combine_stages([first, second])
    assert both.sizes["point"] == first.sizes["point"]
    assert list(both.attrs["skipped_stages"]) == [2] and "never" in both.attrs["skip_reason"]


def test_a_skipped_stage_skips_the_stages_after_it(bounded_stages):
    config, _, second = bounded_stages
    config = copy.deepcopy(config)
    config["branches"]["nnm1"]["stages"].append({"name": "third", "until": {"energy_above": 40.0}})
    third = build_stage(config, "nnm1", 3, second)
    assert third.sizes["point"] == 0 and third.attrs["end_reason"] == second.attrs["end_reason"]


def test_unresolved_orbits_end_the_stage_with_the_reason(small_config):
    """Past the truncation limit the stage ends at its last resolved orbit (the unresolved one dropped)."""
    config = copy.deepcopy(small_config)
    config["hbm"]["max_truncation"] = 1e-4  # H = 24 resolves the stop only to about this at E = 20
    config["branches"]["nnm1"]["stages"] = [{"name": "up", "until": {"energy_above": 20.0}}]
    ds = build_stage(config, "nnm1", 1)
    assert ds.attrs["stage_condition_met"] == 0 and ds.attrs["end_reason"].startswith("unresolved: truncation")
    assert float(ds["truncation"].max()) <= 1e-4 < 20.0  # every stored orbit resolved
    assert ds["energy"].values[-1] < 20.0


def test_a_corrupted_start_orbit_is_named_with_its_file(small_config, nnm1_stages, tmp_path):
    first, _ = nnm1_stages
    path = write_dataset(first, tmp_path / "nnm1_stage1.nc", title="t", summary="s", kind="nnm_branch")
    corrupted = read_dataset(path)
    corrupted["q_cos"].values[-1, 0, 3] *= 1.0 + 1e-3  # one harmonic of the last orbit off
    with pytest.raises(ValueError, match=r"nnm1_stage1\.nc.*not a point of the branch"):
        build_stage(small_config, "nnm1", 2, corrupted)
    other = read_dataset(path)
    other.attrs["branch"] = "nnm2"
    with pytest.raises(ValueError, match=r"nnm1_stage1\.nc.*branch 'nnm2'"):
        build_stage(small_config, "nnm1", 2, other)
