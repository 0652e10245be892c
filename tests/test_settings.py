"""nnmstop.settings: the configuration becomes typed settings; variations by dataclasses.replace."""

import copy
import dataclasses

import pytest

from nnmstop.config import load_config
from nnmstop.settings import (
    branch_settings,
    branch_spec,
    compare_settings,
    exact_settings,
    study_settings,
    system_from_config,
)


@pytest.fixture(scope="module")
def config(repo_root):
    return load_config(repo_root / "config" / "config.yaml")


def test_settings_carry_the_configured_values(config):
    system = system_from_config(config, harmonics=12, eta=0.02)
    assert system.H == 12 and system.params.eta == 0.02 and system.params.alpha == config["model"]["alpha"]
    settings = branch_settings(config)
    assert settings.continuation.order == config["anm"]["order"]
    assert settings.continuation.points_per_step == config["hbm"]["points_per_step"]
    assert settings.max_truncation == config["hbm"]["max_truncation"]
    nnm1 = branch_spec(config, "nnm1")
    assert nnm1.mode == 1 and len(nnm1.stages) == len(config["branches"]["nnm1"]["stages"])
    assert exact_settings(config).step == config["exact"]["step"]
    assert compare_settings(config).points == {k: float(v) for k, v in config["compare"]["points"].items()}


def test_study_run_is_the_configured_stage_one_at_the_study_limits(config):
    study = study_settings(config)
    run = study.run
    assert run.max_truncation == config["study"]["max_truncation"]  # the study's limit, not hbm's
    assert run.continuation.points_per_step == config["study"]["points_per_step"]
    assert run.branch.stages[0].until == config["branches"]["nnm1"]["stages"][0]["until"]
    assert run.system().n_unknowns == 4 * (run.harmonics + 1) + 1
    stiffer = dataclasses.replace(run, harmonics=40, params=dataclasses.replace(run.params, alpha=300.0))
    assert stiffer.system().params.alpha == 300.0 and stiffer.system().H == 40
    assert run.params.alpha == config["model"]["alpha"]  # frozen: the base is unchanged


def test_study_reads_only_its_sections(config):
    """What the study's rules pass (workflow/rules/study.smk): no other branch, no figure, no hbm.harmonics."""
    parts = {name: config[name] for name in ("model", "anm", "stability", "exact")}
    parts["hbm"] = {"time_samples": config["hbm"]["time_samples"]}
    parts["branches"] = {"nnm1": config["branches"]["nnm1"]}
    study = {k: v for k, v in config["study"].items() if k not in ("png_dpi", "stiff")}
    settings = study_settings({**parts, "study": study})
    assert settings.stiff is None and settings.sweep().reference_harmonics == 800
    with pytest.raises(ValueError, match="study.stiff"):
        settings.stiff_sweep()


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda c: c["study"]["error_runtime"].update(reference_harmonics=400), "reference_harmonics = 400"),
        (lambda c: c["study"].update(energies=[3.0, 1.0]), r"study.energies.*\[3.0, 1.0\]"),
        (lambda c: c["study"]["stiff"].update(harmonics=[100, 50]), r"study.stiff.harmonics.*\[100, 50\]"),
        (lambda c: c.pop("anm"), "section 'anm'"),
    ],
)
def test_bad_study_settings_name_the_key(config, edit, message):
    bad = copy.deepcopy(config)
    edit(bad)
    with pytest.raises(ValueError, match=message):
        study_settings(bad)
