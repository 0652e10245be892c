"""verify covers the atlas: update_reference records it, verify passes it and names what moves."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

import nnmstop
from nnmstop.bifurcation_atlas.curves import CurveSettings
from nnmstop.netcdf import read_dataset, write_dataset
from nnmstop.pipeline.verify import ATLAS_MANIFEST, file_verdicts, update_reference, verify

#: Coarser steps in the plane than the workflow's: the tests check the curves where they cross values, not
#: their drawing.
FAST = CurveSettings(step=0.05, max_frequency_step=0.002)

pytestmark = pytest.mark.numerics


def _write(ds, results):
    path = results / "atlas" / "oscillator_force.nc"
    write_dataset(ds, path, title="atlas", summary="test atlas", kind="atlas")
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    (results / ATLAS_MANIFEST).write_text(f"{digest}  results/atlas/oscillator_force.nc\n")
    return path


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A small atlas written as the workflow writes it, and a reference recorded from it."""
    root = tmp_path_factory.mktemp("atlas_verify")
    results = root / "results"
    (results / "atlas").mkdir(parents=True)
    ds = nnmstop.atlas(nnmstop.two_dof_structure(), (0.085, 0.16), ["u"], (0.08, 0.12), slices=3,
                       kinds=("grazing", "fold"), frequency_samples=40, seeds=[0.1], checks=[0.08, 0.12],
                       curve=FAST)  # fmt: skip
    path = _write(ds, results)
    reference = update_reference(results, root / "reference", manifests=[ATLAS_MANIFEST])
    return results, reference, path


def test_verify_passes_the_atlas_it_recorded(recorded):
    results, reference, _ = recorded
    verdicts = file_verdicts(verify(results, reference))
    # the build holds the atlas only: its default manifest is missing (a discrepancy of the build as a whole)
    assert verdicts.pop("results/MANIFEST.sha256") == "discrepant"
    assert verdicts == {"results/atlas/oscillator_force.nc": "identical", "results/atlas/MANIFEST.sha256": "identical"}


def test_verify_names_a_moved_located_point_and_a_check_off_its_curve(recorded, tmp_path):
    results, reference, path = recorded
    ds = read_dataset(path).load()
    moved = ds.copy(deep=True)
    moved["check_response_frequency"].values[:] *= 1 + 1e-4  # beyond the located points' tolerance (1e-6)
    moved["check_deviation"].values[0] = 10 * ds.attrs["check_tolerance"]
    other = tmp_path / "results"
    (other / "atlas").mkdir(parents=True)
    moved.attrs.pop("dataset_kind")
    _write(moved, other)
    rows = [r for r in verify(other, reference) if r.verdict == "discrepant"]
    quantities = " ".join(r.quantity for r in rows)
    assert "check_response_frequency" in quantities, quantities
    assert "located points on their curves" in quantities, quantities
    assert ds.sizes["check"] >= 4


def _move_first_boundary(region, cells: int):
    """``region`` with the first class boundary of the first slice that has one moved right by ``cells``."""
    region = region.copy()
    for row in region:
        edges = np.flatnonzero(np.diff(row)) + 1
        if len(edges) and edges[0] + cells < len(row):
            row[edges[0] : edges[0] + cells] = row[edges[0] - 1]
            return region
    raise AssertionError("no slice of the small atlas has a class boundary")


@pytest.mark.parametrize(("cells", "verdict"), [(1, "within tolerance"), (3, "discrepant")])
def test_a_region_boundary_may_move_by_one_grid_cell(recorded, tmp_path, cells, verdict):
    """The regions are read on a frequency grid: a cell next to a boundary changes class with round-off (another
    BLAS kernel), so a boundary may move by one cell; by more it is discrepant. Another class order is discrepant."""
    results, reference, path = recorded
    ds = read_dataset(path).load()
    moved = ds.copy(deep=True)
    moved["region"].values[:] = _move_first_boundary(ds["region"].values, cells)
    other = tmp_path / "results"
    (other / "atlas").mkdir(parents=True)
    _write(moved, other)
    rows = [r for r in verify(other, reference) if r.quantity.startswith("variable region: classes along")]
    assert [r.verdict for r in rows] == [verdict], rows
