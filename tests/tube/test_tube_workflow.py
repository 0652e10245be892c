"""The tube targets end to end on a coarse tube (tests/data/small_tube_config.yaml: 5 elements, H = 12)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import xarray as xr

from nnmstop.netcdf import check_labelled
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]
TUBE_CONFIG = REPO / "tests" / "data" / "small_tube_config.yaml"


def snakemake(workdir: Path, *args: str) -> str:
    return run_snakemake(workdir, TUBE_CONFIG, *args, timeout=900).stdout


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("tube")
    snakemake(workdir, "--cores", "2", "tube")
    return workdir


def test_tube_target_builds_every_dataset_and_figure(built):
    names = {p.name for p in (built / "paper_figures").iterdir()}
    assert names == {
        f"tube_{n}.{e}"
        for n in ("frequency_energy", "shapes", "contact_force", "exact_vs_regularized", "study")
        for e in ("pdf", "png")
    }
    for path in (built / "results" / "tube").rglob("*.nc"):
        with xr.open_dataset(path) as ds:
            check_labelled(ds)  # long_name and units everywhere, no NaN
            assert "ACDD-1.3" in ds.attrs["Conventions"]
    with xr.open_dataset(built / "results" / "tube" / "nnm1_exact_vs_regularized.nc") as ds:
        assert ds.sizes["energy"] >= 2  # the exact family and the regularized NNM1 share an energy range


def test_branch_datasets_carry_the_linear_frequencies_of_their_mode(built):
    """FE (consistent mass) linear frequencies lie above the Euler-Bernoulli ones and converge to them."""
    for branch in ("nnm1", "nnm2"):
        with xr.open_dataset(built / "results" / "tube" / f"{branch}.nc") as ds:
            mode = int(ds.attrs["mode"])
            fe = float(ds.no_contact_frequency.sel(mode=mode))
            eb = float(ds.attrs["euler_bernoulli_frequency"][mode - 1])
            assert fe >= eb
            assert (fe - eb) / eb < 1e-2  # 5 Hermite elements: error ~ h**4 on the eigenvalue
            assert ds.attrs["mode"] == int(branch[-1])
            # the regularized branch starts just above the FE linear frequency (eta stiffens the stop DOF)
            assert fe <= ds.frequency.values[0] < 1.05 * fe


def test_a_tube_figure_alone_plans_only_what_it_needs(tmp_path):
    out = snakemake(tmp_path, "-n", "--forceall", "paper_figures/tube_shapes.pdf")
    assert set(re.findall(r"^(?:local)?rule (\w+):", out, flags=re.MULTILINE)) == {
        "tube_stage",
        "tube_branch",
        "tube_figure",
    }
    assert "results/tube/nnm2.nc" not in out and "exact_nnm1" not in out


def test_tube_datasets_pass_the_cf_and_acdd_checkers(built):
    """A tube dataset of every kind passes cf:1.10 and acdd:1.3 but for the documented exclusions (docs/pipeline.md)."""
    from nnmstop.pipeline.compliance import checker_findings, one_file_per_kind

    for path in one_file_per_kind((built / "results" / "tube").rglob("*.nc")):
        assert checker_findings(path) == [], path


def test_tube_figures_state_their_scales(built, tmp_path, monkeypatch):
    """The shapes' colours have a colour bar of t/T; the exact-vs-regularized plot spans the exact family's
    energies, not the whole branch; NNM1's located points get an enlarged panel when it has any."""
    from nnmstop.figures import structure

    caught = {}
    monkeypatch.setattr(structure, "save_figure", lambda fig, path, dpi: caught.update({path.stem: fig}))
    results = built / "results" / "tube"
    data = {name: xr.open_dataset(results / f"{name}.nc") for name in ("nnm1", "nnm2")}
    data["exact"] = xr.open_dataset(results / "exact_nnm1.nc")
    data["comparison"] = xr.open_dataset(results / "nnm1_exact_vs_regularized.nc")
    spec = {"png_dpi": 40, "shape_samples": 5}
    for name in ("shapes", "exact_vs_regularized", "frequency_energy"):
        structure.draw_structure_figure(name, data, spec, tmp_path / f"{name}.pdf")
    labels = [ax.get_ylabel() for ax in caught["shapes"].axes]
    assert any("t / T" in label for label in labels)  # the colour bar says what the colours are
    low, high = caught["exact_vs_regularized"].axes[0].get_xlim()
    energy = data["exact"].energy.values
    assert low <= energy.min() and energy.max() <= high
    assert high / low < 3.0 * energy.max() / energy.min()  # the window follows the exact family
    marks = sum(data["nnm1"][v].size for v in ("branch_point_energy", "fold_energy", "passed_resonance_energy"))
    assert len(caught["frequency_energy"].axes) == len(data) - 2 + (1 if marks else 0)
