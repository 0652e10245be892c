"""`snakemake study` end to end, through its own rules, at a small size (tests/data/small_study_config.yaml).

The study's datasets are measurements kept apart from the paper's; the suite builds them here so that a job of the
study that fails (as the tube study's did unseen, issue 32) fails the suite. The numbers checked are relations that
hold for any size: the error split, and the independence of the error from the ANM settings on one branch.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("study")
    config = yaml.safe_load((REPO / "tests" / "data" / "small_config.yaml").read_text())
    config.update(yaml.safe_load((REPO / "tests" / "data" / "small_study_config.yaml").read_text()))
    path = workdir / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    run_snakemake(workdir, path, "--cores", "2", "study", timeout=900)
    return workdir, config


def test_every_study_job_builds_and_is_gathered(built):
    workdir, config = built
    study = config["study"]
    figures = {p.name for p in (workdir / "paper_figures").iterdir()}
    assert figures == {f"{name}.{ext}" for name in ("error_vs_runtime", "stiff_cases") for ext in ("pdf", "png")}
    with xr.open_dataset(workdir / "results" / "study" / "error_vs_runtime.nc") as ds:
        sweep = study["error_runtime"]
        assert list(ds["harmonics"].values) == sweep["harmonics"] and list(ds["eta"].values) == sweep["eta"]
        assert list(ds["order"].values) == sweep["anm_orders"]
        assert ds["compared"].values.any(), "no setting of the small study was compared with the exact orbits"
    with xr.open_dataset(workdir / "results" / "study" / "stiff_cases.nc") as ds:
        assert list(ds["alpha"].values) == study["stiff"]["alpha"]
        # the closed-form orbits are periodic to round-off when integrated with located events
        assert np.nanmax(ds["energy_periodicity_error"].values) < 1e-10


def test_the_error_split_and_the_anm_sweep_agree(built):
    workdir, config = built
    study = config["study"]
    with xr.open_dataset(workdir / "results" / "study" / "error_vs_runtime.nc") as ds:
        compared = ds["compared"].values
        total = ds["frequency_error"].values
        truncation = ds["frequency_error_truncation"].values
        regularization = ds["frequency_error_regularization"].values[None, :]
        # |H - exact| <= |H - H_ref| + |H_ref - exact| (triangle inequality of the split, per setting)
        assert np.all(total[compared] <= (truncation + regularization)[compared] * (1 + 1e-9))
        assert np.all(np.abs(total - regularization)[compared] <= truncation[compared] * (1 + 1e-9))
        # the ANM sweep runs the same branch (H = anm_harmonics, model eta) with other orders and tolerances:
        # its orbits are Newton-solved at the study energies, so its error is the harmonic sweep's one
        h = list(ds["harmonics"].values).index(study["error_runtime"]["anm_harmonics"])
        e = list(ds["eta"].values).index(config["model"]["eta"])
        anm = ds["anm_frequency_error"].values[ds["anm_compared"].values]
        assert anm.size and compared[h, e]
        np.testing.assert_allclose(anm, total[h, e], rtol=1e-5)
