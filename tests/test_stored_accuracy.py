"""The stored orbits against their recomputed residual (nnmstop.stored_accuracy, issue 33.2), on the small build.

Every dataset of the build passes: each orbit satisfies its equations, rebuilt from the file's own attributes,
to the accuracy the file states. One flipped bit of one coefficient (finite, 1e307 or 1e-308), a start
velocity moved by 1e-6, or the structure's parameter changed, and the reader of every task refuses the
file naming it, the variables and the point.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from nnmstop.netcdf import read_dataset
from nnmstop.stored_accuracy import check_orbits, orbit_checks, structure_from_attributes


def _flip_bit(path: Path, variable: str, index: tuple, bit: int) -> float:
    """Flip bit ``bit`` of one stored value of ``variable``, in the file's bytes; the value it becomes."""
    with xr.open_dataset(path) as ds:
        value = float(ds[variable].values[index])
    raw = bytearray(path.read_bytes())
    packed = struct.pack("<d", value)
    assert raw.count(packed) == 1, "the value's bytes are not unique in the file"
    where = raw.find(packed)
    flipped = struct.unpack("<d", (int.from_bytes(packed, "little") ^ (1 << bit)).to_bytes(8, "little"))[0]
    raw[where : where + 8] = struct.pack("<d", flipped)
    path.write_bytes(bytes(raw))
    return flipped


def test_every_dataset_of_the_build_satisfies_its_equations(small_build):
    checked = set()
    for path in sorted((small_build / "results").rglob("*.nc")):
        ds = xr.load_dataset(path)
        for check in orbit_checks(ds):
            assert not len(check.failed), (path, check.measure, check.recomputed[check.worst()])
            checked.add(ds.attrs["dataset_kind"])
    assert {"nnm_branch", "exact_vs_regularized", "two_impact_family", "exact_nnm1"} <= checked, checked


@pytest.mark.parametrize("bit", [62, 52])
def test_one_flipped_bit_of_one_coefficient_is_refused_naming_file_variable_and_point(small_build, tmp_path, bit):
    """Issue 33, reproduction 3: bit 62 of a coefficient below 2 makes it about 1e307, bit 52 halves or
    doubles it; both finite, neither an orbit any more."""
    copy = tmp_path / "nnm1_stage1.nc"
    copy.write_bytes((small_build / "results/hbm/stages/nnm1_stage1.nc").read_bytes())
    point = 7
    flipped = _flip_bit(copy, "q_cos", (point, 0, 1), bit)
    assert np.isfinite(flipped)
    with pytest.raises(ValueError, match=rf"{copy}: q_cos, .* at point {point}, energy .*harmonic balance.*rebuild"):
        read_dataset(copy)


def test_a_moved_start_velocity_of_an_exact_orbit_is_refused(small_build, tmp_path):
    ds = xr.load_dataset(small_build / "results/exact/nnm1_two_impacts.nc")
    ds["xdot0"].values[10] *= 1 + 1e-6
    with pytest.raises(ValueError, match=r"xdot0, udot0.* at point 10, energy"):
        check_orbits(ds, "two_impacts.nc")


def test_another_structure_parameter_is_refused(small_build):
    """The attributes say which equations the orbits solve: alpha 31 instead of 30 and they do not."""
    ds = xr.load_dataset(small_build / "results/hbm/nnm2.nc")
    ds.attrs["alpha"] = 31.0
    with pytest.raises(ValueError, match="nnm2.nc: q_cos.*relative residual of the harmonic balance"):
        check_orbits(ds, "nnm2.nc")


def test_a_dataset_without_its_structure_cannot_be_checked_and_says_why(small_build):
    ds = xr.load_dataset(small_build / "results/hbm/nnm2.nc")
    del ds.attrs["beta"]
    with pytest.raises(ValueError, match=r"cannot be recomputed: it does not record the oscillator's parameters"):
        check_orbits(ds, "nnm2.nc")
    with pytest.raises(ValueError, match="structure kind 'shell'"):
        structure_from_attributes(ds.assign_attrs(structure="shell"))


def test_fig07_refuses_a_stage_with_one_flipped_bit_and_draws_nothing(small_build, tmp_path):
    """Issue 33, reproduction 3: `snakemake paper_figures/fig07.pdf` drew panel a) at x of 1e307 from a stage file
    with bit 62 of one q_cos value flipped, and exited 0. Its task reads through the one reader now."""
    import yaml

    from nnmstop.config import validate_config
    from nnmstop.pipeline.run import find_task

    config = validate_config(yaml.safe_load((Path(__file__).parent / "data" / "small_config.yaml").read_text()))
    stage = tmp_path / "nnm1_stage1.nc"
    stage.write_bytes((small_build / "results/hbm/stages/nnm1_stage1.nc").read_bytes())
    assert abs(_flip_bit(stage, "q_cos", (3, 0, 1), 62)) > 1e300
    outputs = {"pdf": str(tmp_path / "fig07.pdf"), "png": str(tmp_path / "fig07.png")}
    with pytest.raises(ValueError, match=rf"{stage}: q_cos, .* at point 3"):
        find_task("paper_fig07")(config, {"nnm1_stages": [str(stage)]}, outputs)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["nnm1_stage1.nc"]


def test_a_full_period_forced_orbit_is_checked_through_its_switches(tmp_path):
    """A one-sided chain's exact forced response stores its orbits as switches; a moved switch phase is refused."""
    import scipy.sparse

    import nnmstop
    from nnmstop.models.matrices import matrix_structure

    mass, stiffness = tmp_path / "M.npz", tmp_path / "K.npz"
    scipy.sparse.save_npz(mass, scipy.sparse.csr_matrix(np.eye(2)))
    scipy.sparse.save_npz(stiffness, scipy.sparse.csr_matrix([[2.0, -1.0], [-1.0, 2.0]]))
    stop = {"kind": "one_sided", "dof": 0, "side": "positive", "gap": 1.0, "stiffness": 20.0, "eta": 0.05}
    chain = matrix_structure(mass, stiffness, [stop])
    ds = nnmstop.forced_response(chain, [0.02, 0.02], (0.2, [0]), (0.1, 0.35))
    assert "switch_phase" in ds and "contact_unknowns" not in ds
    check_orbits(ds, "the response")  # as computed: every switch orbit solves its equations
    checked = {name for check in orbit_checks(ds) for name in check.variables}
    assert {"switch_state", "switch_phase"} <= checked
    moved = ds.copy(deep=True)
    moved["switch_phase"].values[len(moved["switch_phase"]) // 2] += 1e-3
    with pytest.raises(ValueError, match=r"the response: .*switch_state.*contact equations"):
        check_orbits(moved, "the response")
