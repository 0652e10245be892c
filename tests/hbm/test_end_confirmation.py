"""Issue 25.3 on the staged HBM path: a stage, or a side of a switched branch, that ends on the truncation guard is
confirmed by a restart with shorter steps, or the job fails saying so; a stage that reaches its own condition or
bound, or a side that leaves its energy range, is located, not confirmed."""

import copy
import dataclasses
import re

import numpy as np
import pytest

from nnmstop.config import load_config
from nnmstop.continuation.anm import ANMSettings, continue_anm
from nnmstop.continuation.confirm import EndNotConfirmed
from nnmstop.hbm import criteria, stages
from nnmstop.hbm.stages import combine_stages
from nnmstop.pipeline.run import run_task
from nnmstop.tasks.hbm import branch_settings, branch_spec, build_bifurcated, build_stage, system_from_config

LIMIT = 1e-4  # H = 24 resolves the stop only to about this near E = 2.6


@pytest.fixture(scope="module")
def unresolved_config():
    """Paper physics, H = 24, one stage up to E = 20 that the truncation guard ends first."""
    config = copy.deepcopy(load_config("config/config.yaml"))
    config["hbm"]["harmonics"] = 24
    config["hbm"]["points_per_step"] = 2
    config["hbm"]["max_truncation"] = LIMIT
    config["branches"]["nnm1"]["stages"] = [{"name": "up", "until": {"energy_above": 20.0}}]
    return config


@pytest.fixture(scope="module")
def unresolved_stage(unresolved_config):
    return build_stage(unresolved_config, "nnm1", 1)


def test_a_truncation_end_is_confirmed_and_the_check_stored(unresolved_stage):
    ds = unresolved_stage
    assert ds.attrs["stage_end"] == "truncation"
    assert ds.attrs["end_check"].startswith("end confirmed: restarted before its end with step")
    assert "unresolved: truncation indicator" in ds.attrs["end_check"]  # the restart ended on the guard too
    assert combine_stages([ds]).attrs["end_check"] == ds.attrs["end_check"]


def _unresolved_energy(reason: str) -> float:
    """Energy of the first unresolved orbit, which the stage names in its end reason and drops."""
    return float(re.search(r"at energy ([-+0-9.eE]+)", reason).group(1))


def test_the_confirmed_end_is_where_a_run_with_short_steps_throughout_ends(unresolved_config, unresolved_stage):
    """A second run of the whole stage with every ANM step capped far below the first run's last steps brackets
    the crossing of the truncation limit (last resolved orbit, first unresolved one) more closely, and the two
    brackets overlap: both runs end on the same crossing."""
    config = unresolved_config
    system, settings = system_from_config(config), branch_settings(config)
    coarse = (float(unresolved_stage["energy"].values[-1]), _unresolved_energy(unresolved_stage.attrs["end_reason"]))
    short = dataclasses.replace(settings.continuation, max_step=0.05)
    fine = stages.follow_stage(system, dataclasses.replace(settings, continuation=short), branch_spec(config, "nnm1"))
    assert fine.ended_by == "truncation"
    assert all(d["truncation"] <= LIMIT for d in fine.diagnostics)
    bracket = (fine.diagnostics[-1]["energy"], _unresolved_energy(fine.end_reason))
    assert max(coarse[0], bracket[0]) < min(coarse[1], bracket[1])
    assert bracket[1] - bracket[0] < 0.5 * (coarse[1] - coarse[0])  # the cap did shorten the steps


def test_a_stage_ending_on_its_own_condition_is_located_not_restarted(unresolved_config):
    config = copy.deepcopy(unresolved_config)
    config["branches"]["nnm1"]["stages"] = [{"name": "low", "until": {"energy_above": 1.0}}]
    ds = build_stage(config, "nnm1", 1)
    assert ds.attrs["stage_end"] == "condition"
    assert ds.attrs["end_check"].startswith("located: condition reached")


def _first_run_loses_the_curve(base, energy: float, mark):
    """A stop criterion (subclass of ``base``) whose first instance declares the orbits above ``energy``
    unresolved, as a step that jumped to another solution curve would find them (``mark(stop)`` records that
    end as a truncation); every later one (the restart's) is the real criterion."""

    class FirstRunLosesTheCurve(base):
        made = 0

        def __post_init__(self):
            super().__post_init__()
            type(self).made += 1
            self.spurious = type(self).made == 1

        def __call__(self, U, d):
            if self.spurious and d["energy"] > energy:
                mark(self)
                return f"unresolved: spurious indicator at energy {d['energy']:.6g}"
            return super().__call__(U, d)

    return FirstRunLosesTheCurve


_FirstRunLosesTheCurve = _first_run_loses_the_curve(
    stages.StageStop, 1.5, lambda stop: setattr(stop, "ended_by", "truncation")
)


def test_a_spurious_end_fails_the_job_naming_the_stage_both_ends_and_the_remedy(
    unresolved_config, monkeypatch, tmp_path
):
    config = copy.deepcopy(unresolved_config)
    config["branches"]["nnm1"]["stages"] = [{"name": "low", "until": {"energy_above": 2.0}}]
    monkeypatch.setattr(stages, "StageStop", _FirstRunLosesTheCurve)
    out = tmp_path / "nnm1_stage1.nc"
    with pytest.raises(EndNotConfirmed) as failure:
        run_task("hbm_stage", config, {}, {"dataset": str(out)}, None, branch="nnm1", stage="1")
    message = str(failure.value)
    assert "nnm1 stage 1 (low)" in message and "end NOT confirmed" in message
    assert "spurious indicator" in message and "energy above 2" in message  # both ends
    assert "anm.tolerance" in message
    assert not out.exists() and not list(tmp_path.iterdir())


def test_capped_anm_steps_stay_on_the_curve_and_bad_caps_are_refused(unresolved_config):
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="max_step"):
            ANMSettings(max_step=bad)
    system, settings = system_from_config(unresolved_config), branch_settings(unresolved_config)
    U0, direction = stages.start_point(system, 1, 0.1)
    capped = dataclasses.replace(settings.continuation, max_step=0.02)
    branch = continue_anm(system, U0, direction, lambda U, d: "done" if d["energy"] > 0.5 else "", capped)
    lengths = stages._step_lengths(branch)
    assert 0 < lengths.max() <= 0.02 * (1 + 1e-12)
    residuals = [np.linalg.norm(system.residual(U)) / max(np.linalg.norm(U), 1) for U in branch.points]
    assert max(residuals) <= settings.continuation.newton_threshold


# ---------------------------------------------------------------------------------------- switched branches

SWITCHED_LIMIT = 1e-4  # H = 51 resolves the 3:1 switched branch only up to about E = 430 at this limit


@pytest.fixture(scope="module")
def switched_config():
    """NNM1 through its 3:1 branch point with H = 51, the switched branch asked for up to E = 3000."""
    config = copy.deepcopy(load_config("tests/data/small_config.yaml"))
    config["hbm"]["harmonics"] = 51
    config["hbm"]["max_truncation"] = SWITCHED_LIMIT
    config["branches"]["nnm1"]["stages"] = [
        {"name": "one_impact_per_stop", "until": {"impacts_above": 2}},
        {"name": "resonance_3to1", "until": {"impacts_at_most": 4}},
    ]
    config["bifurcations"] = {
        "nnm1_3to1": {"parent": "nnm1", "resonance": 3, "energy_range": [3.0, 3000.0], "switch_step": 1e-3}
    }
    return config


@pytest.fixture(scope="module")
def switched_parent(switched_config):
    first = build_stage(switched_config, "nnm1", 1)
    return combine_stages([first, build_stage(switched_config, "nnm1", 2, first)])


@pytest.mark.numerics
def test_a_switched_branch_side_ending_on_truncation_is_confirmed_the_other_located(switched_config, switched_parent):
    ds = build_bifurcated(switched_config, "nnm1_3to1", switched_parent)
    high, low = ds.attrs["end_check"].split("; + side: ")
    # the side ending at the higher energy comes first: it meets the truncation limit, the other the range's end
    assert high.startswith("- side: end confirmed: restarted before its end with step")
    assert "unresolved: truncation indicator" in high  # the restart ended on the guard too
    assert low.startswith("located: energy left [3, 3000]")
    assert float(ds["truncation"].max()) <= SWITCHED_LIMIT  # the unresolved end orbit is dropped
    assert 100.0 < float(ds["energy"].max()) < 3000.0


# the guard that a switched branch's sides run with (its first) ends them above E = 100; the restart's is real
_FirstGuardLosesTheCurve = _first_run_loses_the_curve(
    criteria.TruncationGuard, 100.0, lambda guard: setattr(guard, "unresolved", True)
)


def test_a_spurious_end_of_a_switched_branch_fails_naming_the_side_and_both_ends(
    switched_config, switched_parent, monkeypatch
):
    # the spurious indicator must look like one to the side's check too: the last orbit's truncation above the limit
    real_diagnostics = stages.HarmonicBalanceSystem.diagnostics_many

    def diagnostics_many(self, U, samples=None):  # what diagnostics() and the continuation's steps go through
        out = real_diagnostics(self, U, samples)
        for d in out:
            if d["energy"] > 100.0 and _FirstGuardLosesTheCurve.made == 1:
                d["truncation"] = max(d["truncation"], 2 * SWITCHED_LIMIT)
        return out

    monkeypatch.setattr(stages, "TruncationGuard", _FirstGuardLosesTheCurve)
    monkeypatch.setattr(stages.HarmonicBalanceSystem, "diagnostics_many", diagnostics_many)
    with pytest.raises(EndNotConfirmed) as failure:
        build_bifurcated(switched_config, "nnm1_3to1", switched_parent)
    message = str(failure.value)
    assert (
        "bifurcated from nnm1 at the 3:1 resonance" in message and "side)" in message and "end NOT confirmed" in message
    )
    assert "spurious indicator" in message and "unresolved: truncation indicator" in message  # both ends
    assert "anm.tolerance" in message
