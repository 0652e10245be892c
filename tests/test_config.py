"""Configuration validation: the shipped file, each kind of bad value, and the workflow refusing it."""

import copy
import re
import subprocess
import sys

import pytest
import yaml

from nnmstop.config import ConfigError, load_config, validate_config


@pytest.fixture(scope="module")
def shipped(repo_root):
    return load_config(repo_root / "config" / "config.yaml")


def _with(config, dotted, value):
    """Deep copy of ``config`` with ``dotted`` set to ``value`` (or deleted if value is ...)."""
    out = copy.deepcopy(config)
    *parents, leaf = dotted.split(".")
    node = out
    for key in parents:
        node = node[key]
    if value is ...:
        del node[leaf]
    else:
        node[leaf] = value
    return out


def test_shipped_config_validates(shipped):
    assert validate_config(shipped) is shipped
    assert shipped["model"]["eta"] < shipped["model"]["alpha"]


@pytest.mark.parametrize("key", ["model.alpha", "model.beta", "model.delta", "model.eta"])
@pytest.mark.parametrize("bad", [0.0, -1.0])
def test_non_positive_model_parameters_are_rejected(shipped, key, bad):
    with pytest.raises(ConfigError, match=f"'{key}'"):
        validate_config(_with(shipped, key, bad))


@pytest.mark.parametrize("eta", [30.0, 45.0])
def test_eta_not_below_alpha_is_rejected(shipped, eta):
    with pytest.raises(ConfigError, match="'model.eta'.*alpha"):
        validate_config(_with(shipped, "model.eta", eta))


@pytest.mark.parametrize(
    "key, bad",
    [
        ("model.alpha", "thirty"),
        ("model.beta", [1.0]),
        ("exact.step", "0.02"),
        ("exact.max_points", 40.5),
        ("exact.max_points", None),
        ("model", [30.0, 1.0, 1.0, 0.1]),
    ],
)
def test_wrong_types_are_rejected(shipped, key, bad):
    with pytest.raises(ConfigError, match=f"'{key}'"):
        validate_config(_with(shipped, key, bad))


@pytest.mark.parametrize("key", ["model.gamma", "exact.tolerance", "plots"])
def test_unknown_keys_are_rejected(shipped, key):
    with pytest.raises(ConfigError, match=f"'{key}'"):
        validate_config(_with(shipped, key, 1.0))


@pytest.mark.parametrize("key", ["model.alpha", "model.eta", "exact.step", "exact.max_points", "exact"])
def test_missing_keys_are_rejected(shipped, key):
    with pytest.raises(ConfigError, match=f"'{key}'"):
        validate_config(_with(shipped, key, ...))


@pytest.mark.parametrize("key, bad", [("exact.step", 0.0), ("exact.step", 1.5), ("exact.max_points", 3)])
def test_out_of_range_continuation_settings_are_rejected(shipped, key, bad):
    with pytest.raises(ConfigError, match=f"'{key}'"):
        validate_config(_with(shipped, key, bad))


def test_missing_file_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "nope.yaml")


def dry_run(repo_root, override):
    """``snakemake -n`` of the repository with ``override`` as configfile: the process and its whole output."""
    proc = subprocess.run(
        [sys.executable, "-m", "snakemake", "-n", "--configfile", str(override)],
        cwd=repo_root,
        capture_output=True,
        text=True,
        timeout=120,
    )
    return proc, proc.stdout + proc.stderr


def test_workflow_refuses_a_negative_alpha(repo_root, tmp_path):
    override = tmp_path / "bad.yaml"
    override.write_text(yaml.safe_dump({"model": {"alpha": -1.0}}))
    proc, output = dry_run(repo_root, override)
    assert proc.returncode != 0, output
    assert "model.alpha" in output and "-1.0" in output, output


@pytest.mark.parametrize(
    "key",
    ["model.alpha", "model.eta", "exact.step", "anm.tolerance", "compare.points.a", "execution.worker_idle_seconds"],
)
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), float("-inf")])
def test_non_finite_numbers_are_rejected_at_their_key(shipped, key, bad):
    """NaN passes JSON Schema's bounds (every comparison is false) and `eta >= alpha`; each is named here."""
    with pytest.raises(ConfigError, match=rf"config key '{re.escape(key)}': {bad} is not a finite number"):
        validate_config(_with(shipped, key, bad))


def test_a_non_finite_number_in_a_list_is_named_with_its_index(shipped):
    config = copy.deepcopy(shipped)
    config["figures"]["fig06"]["labels"][1]["energy"] = float("nan")
    with pytest.raises(ConfigError, match=r"'figures\.fig06\.labels\[1\]\.energy': nan is not a finite number"):
        validate_config(config)


def test_the_idle_time_of_the_worker_is_bounded(shipped):
    with pytest.raises(ConfigError, match="'execution.worker_idle_seconds': 100000.0 is greater than the maximum"):
        validate_config(_with(shipped, "execution.worker_idle_seconds", 1e5))


@pytest.mark.parametrize("section", ["model", "exact", "hbm", "anm", "branches", "compare", "figures"])
def test_every_section_of_the_default_target_is_required(shipped, section):
    with pytest.raises(ConfigError, match=f"config key '{section}': '{section}' is a required property"):
        validate_config(_with(shipped, section, ...))


@pytest.mark.parametrize("left, right, modes", [("free", "free", 2), ("pinned", "free", 1), ("free", "pinned", 1)])
def test_a_beam_with_rigid_body_modes_is_refused_at_validation(shipped, left, right, modes):
    config = _with(_with(shipped, "tube.structure.left", left), "tube.structure.right", right)
    with pytest.raises(ConfigError, match=f"'tube.structure': a beam {left} .* has {modes} rigid-body mode"):
        validate_config(config)


def test_workflow_names_a_nan_at_its_key(repo_root, tmp_path):
    """`.nan` in YAML reaches Snakemake's configuration as a float: refused before any job, at its key."""
    override = tmp_path / "nan.yaml"
    override.write_text("model:\n  eta: .nan\n")
    proc, output = dry_run(repo_root, override)
    assert proc.returncode != 0, output
    assert "config key 'model.eta': nan is not a finite number" in output, output[-2000:]
