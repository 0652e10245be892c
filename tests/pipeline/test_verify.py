"""The verifier (nnmstop.pipeline.verify) on a small build: identity, curves, missing files.

A small build (tests/data/small_config.yaml: H = 16, short ranges) of the exact two-impact
family and of NNM1 (four stages) is the reference. Copies of it are altered the way a
build on another CPU would differ (other points on the same curve) or the way a wrong
build would (one frequency moved), and the verifier must tell the two apart.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import xarray as xr
import yaml

from nnmstop.pipeline.verify import file_verdicts, main, update_reference, verify
from nnmstop.tasks.manifest import dataset_manifest
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"
TARGETS = ["results/exact/nnm1_two_impacts.nc", "results/hbm/nnm1.nc"]


def _build(workdir: Path, config: Path) -> Path:
    """Build TARGETS with the workflow and write their manifest; return the results directory."""
    result = run_snakemake(workdir, config, "--cores", "2", *TARGETS, check=False)
    assert result.returncode == 0, result.stderr[-3000:]
    datasets = sorted(str(p.relative_to(workdir)) for p in (workdir / "results").rglob("*.nc"))
    dataset_manifest(
        {}, {"datasets": [str(workdir / d) for d in datasets]}, {"manifest": str(workdir / "results/MANIFEST.sha256")}
    )
    manifest = workdir / "results/MANIFEST.sha256"  # paths relative to the work directory, as the workflow writes them
    manifest.write_text(manifest.read_text().replace(f"{workdir}/", ""))
    return workdir / "results"


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """A small build and the reference made from it."""
    workdir = tmp_path_factory.mktemp("verify_build")
    results = _build(workdir, SMALL_CONFIG)
    return results, update_reference(results, workdir / "reference")


def _copy(results: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(results, tmp_path / "results"))


def test_an_identical_copy_is_identical(reference, tmp_path):
    results, ref = reference
    verdicts = file_verdicts(verify(_copy(results, tmp_path), ref))
    assert set(verdicts.values()) == {"identical"} and len(verdicts) == 6  # exact family, NNM1 and its 4 stages
    assert main([str(results), "--reference", str(ref)]) == 0


def test_a_frequency_moved_by_1e5_is_a_discrepancy(reference, tmp_path):
    """One stored NNM1 frequency, halfway along the branch, moved by 1e-5 relative."""
    results, ref = reference
    copy = _copy(results, tmp_path)
    path = copy / "hbm/nnm1.nc"
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    i = ds.sizes["point"] // 2
    frequency = ds["frequency"].values.copy()
    frequency[i] *= 1 + 1e-5
    ds["frequency"].values = frequency
    path.unlink()
    ds.to_netcdf(path)
    rows = verify(copy, ref)
    assert file_verdicts(rows)["results/hbm/nnm1.nc"] == "discrepant"
    assert file_verdicts(rows)["results/hbm/stages/nnm1_stage1.nc"] == "identical"
    assert main([str(copy), "--reference", str(ref)]) == 1


def test_a_missing_file_fails(reference, tmp_path):
    results, ref = reference
    copy = _copy(results, tmp_path)
    (copy / "hbm/stages/nnm1_stage2.nc").unlink()
    rows = verify(copy, ref)
    assert [r.build for r in rows if r.verdict == "discrepant"] == ["missing"]
    assert main([str(copy), "--reference", str(ref)]) == 1


def test_other_points_on_the_same_curve_pass(reference, tmp_path):
    """A build storing 3 points per ANM step instead of 4 (other points, same curves)
    is within tolerance; its files are not identical."""
    results, ref = reference
    config = yaml.safe_load(SMALL_CONFIG.read_text())
    config["hbm"]["points_per_step"] = 3
    resampled_config = tmp_path / "config.yaml"
    resampled_config.write_text(yaml.safe_dump(config))
    rows = verify(_build(tmp_path / "build", resampled_config), ref)
    verdicts = file_verdicts(rows)
    assert verdicts["results/hbm/nnm1.nc"] == "within tolerance"
    assert set(verdicts.values()) <= {"identical", "within tolerance"}, [r for r in rows if r.verdict == "discrepant"]
    with xr.open_dataset(results / "hbm/nnm1.nc") as a, xr.open_dataset(tmp_path / "build/results/hbm/nnm1.nc") as b:
        assert a.sizes["point"] != b.sizes["point"]


def test_bad_directories_are_named(reference, tmp_path):
    results, ref = reference
    with pytest.raises(ValueError, match="does not exist"):
        verify(tmp_path / "nowhere", ref)
    with pytest.raises(ValueError, match="update-reference"):
        verify(results, tmp_path / "no_reference")
    assert main([str(tmp_path / "nowhere"), "--reference", str(ref)]) == 2
