"""The atlas in the workflow: a large atlas plans without computing; bad atlas configurations are refused."""

from __future__ import annotations

import copy
import re
from pathlib import Path

import pytest
import yaml

from nnmstop.config import ConfigError, validate_config
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"


def small_config() -> dict:
    return yaml.safe_load(SMALL_CONFIG.read_text())


def test_a_dry_run_of_a_200_slice_atlas_plans_every_job_without_computing(tmp_path):
    """200 slices of the small configuration's oscillator map: one atlas_slice job each, one job per curve kind,
    planned in a dry run that writes no result."""
    config = small_config()
    config["atlas"]["maps"]["oscillator_force"]["slices"] = {"from": 0.001, "to": 0.2, "count": 200}
    config["atlas"]["maps"]["oscillator_force"]["range"] = [0.0005, 0.21]
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    out = run_snakemake(tmp_path, path, "-n", "--forceall", "atlas", timeout=300).stdout
    counts = dict(re.findall(r"^(atlas_\w+)\s+(\d+)$", out, flags=re.MULTILINE))
    kinds = len(config["atlas"]["maps"]["oscillator_force"]["kinds"])
    assert int(counts["atlas_slice"]) == 200, counts
    assert int(counts["atlas_curves"]) == kinds, counts
    assert not (tmp_path / "results").exists()


def test_the_slurm_profile_plans_the_atlas_jobs(tmp_path):
    """A dry run with the SLURM profile plans the atlas' slices and curves (no cluster needed)."""
    out = run_snakemake(tmp_path, SMALL_CONFIG, "-n", "--forceall", "--profile", str(REPO / "profiles" / "slurm"),
                        "atlas", timeout=300).stdout  # fmt: skip
    assert "atlas_slice" in out and "atlas_curves" in out


@pytest.mark.parametrize(
    "edit, key",
    [
        (lambda a: a["maps"]["oscillator_force"].update(seeds=[0.0123]), "seeds"),
        (lambda a: a["maps"]["oscillator_force"].update(kinds=["cusp"]), "kinds"),
        (lambda a: a["maps"]["oscillator_force"].update(plane="mass"), "plane"),
        (lambda a: a["maps"]["oscillator_force"].update(force_dofs=["w"]), "force dof"),
        (lambda a: a["maps"]["oscillator_force"].update(kinds=["regularized_fold"]), "regularized"),
        (lambda a: a["maps"]["oscillator_force"].update(range=[0.5, 0.1]), "range"),
    ],
)
def test_a_bad_atlas_configuration_is_refused_naming_the_key(edit, key):
    config = copy.deepcopy(small_config())
    edit(config["atlas"])
    with pytest.raises(ConfigError, match=key):
        validate_config(config)


def test_an_atlas_of_a_structure_of_ones_own_from_its_configuration(tmp_path):
    """Issue 29: the atlas target for `structure: kind: matrices` from the configuration alone (the 3-DOF example,
    its map `structure: structure`, forced as its forced scene says). Its grazing curve is the closed form
    F_g(Omega) = gap / max_t |x1(t)| of the chain's linear response at unit force, computed here independently."""
    import numpy as np
    import xarray as xr

    from nnmstop.exact.forced import non_impacting_response
    from nnmstop.forced.scenes import forced_scenes

    example = REPO / "examples" / "three_dof_chain"
    config = yaml.safe_load((example / "config.yaml").read_text())
    for name in ("mass", "stiffness"):
        config["structure"]["matrices"][name] = str(example / f"{name}.mtx")
    spec = config["atlas"]["maps"]["chain_force"]
    spec.update(slices={"from": 0.02, "to": 0.04, "count": 2}, seeds=[0.04], checks=[0.02], kinds=["grazing"])
    config["atlas"]["frequency_samples"] = 20
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    run_snakemake(tmp_path, path, "--cores", "2", "atlas", timeout=600)
    assert (tmp_path / "paper_figures" / "atlas_chain_force.png").is_file()
    with xr.open_dataset(tmp_path / "results" / "atlas" / "chain_force.nc") as ds:
        assert ds.sizes["point"] > 10
        omega, force = 2 * np.pi * ds["frequency"].values, ds["second"].values
    unit = forced_scenes({**config, "forced": {**config["forced"], "force": {"dofs": ["x3"], "amplitudes": [1.0]}}},
                         "structure")[0].excitation  # fmt: skip
    assert unit.structure.n_dofs == 3
    np.testing.assert_allclose(force, 1.0 / np.abs(non_impacting_response(unit, omega)[:, 0]), rtol=1e-9)
