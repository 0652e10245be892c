"""Stops of other kinds through the default target, from the configuration alone (structure: kind: matrices).

The paper's oscillator as matrices, once with unequal gaps (two one-sided stops on x) and once in a circular
clearance with an orthotropic second direction: tiny numerics, every dataset labelled and every figure drawn;
the exact family is the full-period one with an impact on each side (unequal gaps), or holds no orbit and says
why (the circular clearance, not piecewise linear).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import xarray as xr
import yaml

from nnmstop.netcdf import check_labelled
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "three_dof_chain"

STOPS = {
    "unequal_gaps": [
        {"kind": "one_sided", "dof": 0, "side": "positive", "gap": 1.0, "stiffness": 30.0, "eta": 0.1},
        {"kind": "one_sided", "dof": 0, "side": "negative", "gap": 1.3, "stiffness": 30.0, "eta": 0.1},
    ],
    "circular": [{"kind": "circular", "dofs": [0, 1], "gap": 1.0, "stiffness": 30.0, "eta": 0.1}],
}
STIFFNESS = {"unequal_gaps": [[2.0, -1.0], [-1.0, 1.0]], "circular": [[1.0, 0.0], [0.0, 1.7]]}


@pytest.fixture(scope="module", params=sorted(STOPS))
def built(request, tmp_path_factory):
    name = request.param
    workdir = tmp_path_factory.mktemp(name)
    scipy.io.mmwrite(workdir / "mass.mtx", np.eye(2))
    scipy.io.mmwrite(workdir / "stiffness.mtx", np.array(STIFFNESS[name]))
    config = yaml.safe_load((EXAMPLE / "config.yaml").read_text())
    config["structure"]["matrices"].update(dof_labels=["x", "u"], stops=STOPS[name])
    config["forced"]["force"]["dofs"] = ["u"]  # the example forces its chain's free end, x3
    config["hbm"].update(harmonics=24, max_truncation=1e-2, points_per_step=1)
    config["branches"]["nnm1"]["stages"] = [
        {"name": "near_rest", "until": {"energy_above": 0.3}},
        {"name": "beyond", "until": {"energy_above": 4.0}},
    ]
    config["branches"]["nnm2"]["stages"][0]["until"] = {"energy_above": 4.0}
    config["stability"]["steps"] = 64
    config["exact"]["step"] = 0.1
    config["figures"] = {"png_dpi": 50, "fig05": {"legend": "upper left"}}
    (workdir / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    run_snakemake(workdir, workdir / "config.yaml", "--cores", "2", timeout=900)
    return name, workdir


def test_every_dataset_is_labelled_and_every_figure_drawn(built):
    name, workdir = built
    figures = {p.name for p in (workdir / "paper_figures").iterdir()}
    expected = ("fig05", *(f"structure_{n}" for n in ("frequency_energy", "exact_vs_regularized", "contact_force")))
    assert figures == {f"{stem}.{ext}" for stem in expected for ext in ("pdf", "png")}
    for path in (workdir / "results").rglob("*.nc"):
        with xr.open_dataset(path) as ds:
            check_labelled(ds)
    with xr.open_dataset(workdir / "results" / "hbm" / "nnm1.nc") as ds:
        assert list(ds.stop_kind.values) == [s["kind"] for s in STOPS[name]]
        assert int(ds.impacts_per_period[-1]) >= 1


def test_the_exact_family_is_the_full_period_one_or_says_why_there_is_none(built):
    name, workdir = built
    with xr.open_dataset(workdir / "results" / "exact" / "nnm1_one_impact.nc") as exact:
        assert exact.attrs["dataset_kind"] == "switching_family"
        if name == "circular":
            assert exact.sizes["orbit"] == 0 and "not piecewise linear" in exact.attrs["end_reason"]
        else:
            assert exact.sizes["orbit"] > 10 and int(exact.stop_impacts.values[-1].sum()) == 2
    with xr.open_dataset(workdir / "results" / "compare" / "nnm1_one_impact.nc") as comparison:
        if name == "circular":
            assert comparison.sizes.get("energy", 0) == 0
            assert "no exact orbits" in comparison.attrs["end_reason"]
        else:
            # energies where the regularized orbit is not like the exact one have no counterpart (NaN); near
            # grazing the regularized law's slope eta at rest (0.1, against the chain's stiffness of order 1)
            # moves the frequency by several per cent, and the difference falls as the stop's alpha takes over
            energy = comparison.energy.values
            difference = np.abs(comparison.relative_difference.values)
            finite = np.isfinite(difference)
            assert finite.sum() >= 4
            energy, difference = energy[finite], difference[finite]
            assert np.all(np.diff(difference[np.argsort(energy)]) < 0) and difference.min() < 1e-2


def test_a_bad_stop_in_the_configuration_is_refused_by_key(tmp_path):
    from nnmstop.config import ConfigError, validate_config

    shutil.copy(EXAMPLE / "mass.mtx", tmp_path / "mass.mtx")
    shutil.copy(EXAMPLE / "stiffness.mtx", tmp_path / "stiffness.mtx")
    config = yaml.safe_load((EXAMPLE / "config.yaml").read_text())
    config["structure"]["matrices"].update(mass=str(tmp_path / "mass.mtx"), stiffness=str(tmp_path / "stiffness.mtx"))
    for stop, key in (
        ({"kind": "circular", "dofs": [0, 1], "side": "positive"}, "'side' is not allowed for a circular stop"),
        ({"kind": "circular", "dof": 0}, "'dof' is not allowed for a circular stop"),
        ({"kind": "relative", "dofs": [2, 2]}, "relative stop dofs must be two distinct"),
        ({"kind": "one_sided", "dof": 0}, "needs the key 'side'"),
    ):
        config["structure"]["matrices"]["stops"] = [{**stop, "gap": 1.0, "stiffness": 30.0, "eta": 0.1}]
        with pytest.raises(ConfigError, match=rf"config key 'structure.matrices': .*{key}"):
            validate_config(config)
