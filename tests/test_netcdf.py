"""NetCDF writing (nnmstop.netcdf)."""

import os
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from nnmstop.netcdf import cf_variable, check_up_to_date, flag_variable, read_dataset, write_dataset

WRITE_TWICE_EMPTY = """
import sys
import numpy as np, xarray as xr
from nnmstop.netcdf import write_dataset
ds = xr.Dataset(
    {"a": ("p", np.arange(3.0), {"long_name": "a", "units": "1"}),
     "b": ("first_empty", np.zeros(0), {"long_name": "b", "units": "1"}),
     "c": ("second_empty", np.zeros(0), {"long_name": "c", "units": "1"})},
    coords={"p": ("p", np.arange(3), {"long_name": "p", "units": "1"})},
)
ds.to_netcdf(sys.argv[1] + ".in.nc")
with xr.open_dataset(sys.argv[1] + ".in.nc") as back:  # zero-length dims come back as unlimited
    write_dataset(back.load(), sys.argv[1], title="t", summary="s")
"""


def test_zero_length_dimensions_are_written_in_a_fixed_order(tmp_path):
    """Two processes with different string hashing write the same bytes."""
    paths = []
    for seed in ("1", "3", "5"):
        path = tmp_path / f"seed{seed}" / "out.nc"  # same file name: the dataset's id comes from it
        path.parent.mkdir()
        env = {**os.environ, "PYTHONHASHSEED": seed, "SOURCE_DATE_EPOCH": "0"}
        subprocess.run([sys.executable, "-c", WRITE_TWICE_EMPTY, str(path)], check=True, env=env)
        paths.append(path)
    assert len({p.read_bytes() for p in paths}) == 1


def labelled(**attrs) -> xr.Dataset:
    ds = xr.Dataset(
        {"frequency": cf_variable("point", [0.1, 0.2], "frequency", "Hz")},
        coords={"point": cf_variable("point", [0, 1], "index of the orbit", dtype=np.int32)},
    )
    ds.attrs.update(attrs)
    return ds


def test_cf_variable_labels_and_converts():
    dims, values, attrs = cf_variable("point", [1, 2], "count", dtype=np.int32, comment="why")
    assert dims == "point" and values.dtype == np.int32
    assert list(attrs) == ["long_name", "units", "comment"] and attrs["units"] == "1"
    _, text, _ = cf_variable("point", ["FR", "FRF"], "sequence", dtype=None)
    assert text.dtype.kind == "U"


def test_cf_variable_marks_missing_values_so_they_read_back_as_nan(tmp_path):
    error = cf_variable("case", [1e-3, np.nan], "error", fill_value=-9.0e33, ancillary_variables="failure")
    ds = xr.Dataset({"error": error, "failure": cf_variable("case", ["", "diverged"], "why", dtype=None)})
    assert ds["error"].values[1] == -9.0e33  # nothing non-finite reaches the writer
    write_dataset(ds, tmp_path / "study.nc", title="t", summary="s")
    back = read_dataset(tmp_path / "study.nc")
    assert back["error"].values[0] == 1e-3 and np.isnan(back["error"].values[1])


def test_write_refuses_a_fill_value_without_a_reason(tmp_path):
    """A fill value is a value not computed: the dataset must say why, at that very element."""
    status = cf_variable(("case",), np.array([0, 1], dtype=np.int8), "0: computed, 1: unresolved", dtype=None)
    for reason, values, match in (
        (None, [np.nan, 1.0], "names no variable"),
        ("status", [1.0, np.nan], None),  # the unresolved case is filled: explained
        ("status", [np.nan, 1.0], r"at \{'case': 0, 'energy': 0\}"),  # filled where status says computed
    ):
        extra = {"ancillary_variables": reason} if reason else {}
        per_energy = np.array([values, values]).T  # (case, energy)
        error = cf_variable(("case", "energy"), per_energy, "error", fill_value=-9.0e33, **extra)
        ds = xr.Dataset({"error": error, "status": status})
        if match is None:
            write_dataset(ds, tmp_path / "ok.nc", title="t", summary="s")
        else:
            with pytest.raises(ValueError, match=match):
                write_dataset(ds, tmp_path / "bad.nc", title="t", summary="s")


def test_flag_variable_holds_cf_flags():
    dims, values, attrs = flag_variable("point", [True, False], "1 where stable", "unstable stable")
    assert values.dtype == np.int8 and values.tolist() == [1, 0]
    assert attrs["flag_values"].tolist() == [0, 1] and attrs["flag_meanings"] == "unstable stable"


def test_write_refuses_nan_and_unlabelled_variables(tmp_path):
    ds = labelled()
    ds["frequency"].values[1] = np.nan
    with pytest.raises(ValueError, match="'frequency' holds NaN"):
        write_dataset(ds, tmp_path / "nan.nc", title="t", summary="s")
    ds = labelled()
    ds["energy"] = ("point", [1.0, 2.0])
    with pytest.raises(ValueError, match="'energy' lacks the attribute"):
        write_dataset(ds, tmp_path / "unlabelled.nc", title="t", summary="s")
    assert not list(tmp_path.iterdir())  # no partial file either


def test_read_dataset_loads_and_closes_the_file(tmp_path):
    path = write_dataset(labelled(alpha=30.0), tmp_path / "branch.nc", title="t", summary="s")
    ds = read_dataset(path, required=("frequency",), expected={"alpha": 30.0})
    path.unlink()  # the data were read into memory and the file closed
    assert ds["frequency"].values.tolist() == [0.1, 0.2]


def test_read_dataset_refuses_a_missing_file_or_variable(tmp_path):
    with pytest.raises(ValueError, match="no dataset at"):
        read_dataset(tmp_path / "absent.nc")
    path = write_dataset(labelled(), tmp_path / "branch.nc", title="t", summary="s")
    with pytest.raises(ValueError, match=r"lacks the variable\(s\) \['energy'\]"):
        read_dataset(path, required=("frequency", "energy"))


def test_stale_dataset_is_refused_naming_the_setting():
    ds = labelled(alpha=30.0, harmonics=16, sequence="FR")
    check_up_to_date(ds, {"alpha": 30.0 * (1 + 1e-14), "harmonics": 16, "sequence": "FR"})
    with pytest.raises(ValueError, match=r"alpha = 30.0 in the dataset but 300.0 in the configuration"):
        check_up_to_date(ds, {"alpha": 300.0}, source="results/exact/nnm1.nc")
    with pytest.raises(ValueError, match="harmonics"):
        check_up_to_date(ds, {"harmonics": 100})
    with pytest.raises(ValueError, match="does not record 'eta'"):
        check_up_to_date(ds, {"eta": 0.1})
    with pytest.raises(ValueError, match="sequence"):
        check_up_to_date(ds, {"sequence": "FRF"})
