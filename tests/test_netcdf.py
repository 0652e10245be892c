"""NetCDF writing (nnmstop.netcdf)."""

import os
import re
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from nnmstop import catalogue
from nnmstop.catalogue import DatasetKind, Variable
from nnmstop.netcdf import cf_variable, check_up_to_date, flag_variable, read_dataset, write_dataset

#: A dataset kind for these tests only (the catalogue's own kinds describe the pipeline's files).
TEST_KIND = DatasetKind(
    "netcdf_test",
    "test datasets",
    (),
    "Datasets of tests/test_netcdf.py.",
    (
        Variable("point", ("point",), "index of the orbit", optional=True),
        Variable("frequency", ("point",), "frequency", units="Hz", optional=True),
        Variable("error", ("case",), "error", missing="where a case failed", optional=True),
    ),
)


@pytest.fixture(autouse=True)
def test_kind(monkeypatch):
    monkeypatch.setitem(catalogue.KINDS, TEST_KIND.name, TEST_KIND)
    required = TEST_KIND.extended("netcdf_required", "t", (), "t", Variable("frequency", ("point",), "f"))
    monkeypatch.setitem(catalogue.KINDS, required.name, required)


WRITE_TWICE_EMPTY = """
import sys
import numpy as np, xarray as xr
from nnmstop import catalogue
from nnmstop.catalogue import DatasetKind, Variable
from nnmstop.netcdf import write_dataset
dims = {"a": "p", "p": "p", "b": "first_empty", "c": "second_empty"}
variables = tuple(Variable(n, (d,), n, optional=True) for n, d in dims.items())
catalogue.KINDS["netcdf_test"] = DatasetKind("netcdf_test", "t", (), "t", variables)
ds = xr.Dataset(
    {"a": ("p", np.arange(3.0), {"long_name": "a", "units": "1"}),
     "b": ("first_empty", np.zeros(0), {"long_name": "b", "units": "1"}),
     "c": ("second_empty", np.zeros(0), {"long_name": "c", "units": "1"})},
    coords={"p": ("p", np.arange(3), {"long_name": "p", "units": "1"})},
)
ds.to_netcdf(sys.argv[1] + ".in.nc")
with xr.open_dataset(sys.argv[1] + ".in.nc") as back:  # zero-length dims come back as unlimited
    write_dataset(back.load(), sys.argv[1], title="t", summary="s", kind="netcdf_test")
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
    ds = xr.Dataset({"error": cf_variable("case", [1e-3, np.nan], "error", fill_value=-9.0e33)})
    assert ds["error"].values[1] == -9.0e33  # nothing non-finite reaches the writer
    write_dataset(ds, tmp_path / "study.nc", title="t", summary="s", kind="netcdf_test")
    back = read_dataset(tmp_path / "study.nc")
    assert back["error"].values[0] == 1e-3 and np.isnan(back["error"].values[1])


def test_write_refuses_a_missing_value_without_its_reason(tmp_path, monkeypatch):
    """A missing value is a value not computed: the variables the catalogue names must say why, there."""
    kind = DatasetKind(
        "netcdf_reason",
        "t",
        (),
        "t",
        (
            Variable("status", ("case",), "why not computed", flags=("computed", "unresolved")),
            Variable("error", ("case", "energy"), "error", missing="where status says why", reason="status"),
        ),
    )
    monkeypatch.setitem(catalogue.KINDS, kind.name, kind)
    status = ("case", np.array([0, 1], dtype=np.int8))
    explained = xr.Dataset({"error": (("case", "energy"), [[1.0, 1.0], [np.nan, np.nan]]), "status": status})
    path = write_dataset(explained, tmp_path / "ok.nc", title="t", summary="s", kind="netcdf_reason")
    back = read_dataset(path)
    assert back["error"].attrs["ancillary_variables"] == "status" and np.isnan(back["error"].values[1]).all()
    lost = xr.Dataset({"error": (("case", "energy"), [[1.0, np.nan], [1.0, 1.0]]), "status": status})
    with pytest.raises(ValueError, match=r"'error' .* missing at \{'case': 0, 'energy': 1\} where \['status'\]"):
        write_dataset(lost, tmp_path / "bad.nc", title="t", summary="s", kind="netcdf_reason")
    assert not (tmp_path / "bad.nc").exists()


def test_flag_variable_holds_cf_flags():
    dims, values, attrs = flag_variable("point", [True, False], "1 where stable", "unstable stable")
    assert values.dtype == np.int8 and values.tolist() == [1, 0]
    assert attrs["flag_values"].tolist() == [0, 1] and attrs["flag_meanings"] == "unstable stable"


def test_write_refuses_nan_and_variables_outside_the_catalogue(tmp_path):
    ds = labelled()
    ds["frequency"].values[1] = np.nan
    with pytest.raises(ValueError, match="'frequency' of a 'netcdf_test' dataset holds 1 NaN"):
        write_dataset(ds, tmp_path / "nan.nc", title="t", summary="s", kind="netcdf_test")
    ds = labelled()
    ds["energy"] = ("point", [1.0, 2.0])
    with pytest.raises(ValueError, match="'energy' is not in the catalogue's dataset kind 'netcdf_test'"):
        write_dataset(ds, tmp_path / "unlisted.nc", title="t", summary="s", kind="netcdf_test")
    ds = labelled().rename_dims(point="orbit")
    with pytest.raises(ValueError, match=r"dimensions \('orbit',\), the catalogue says \('point',\)"):
        write_dataset(ds, tmp_path / "dims.nc", title="t", summary="s", kind="netcdf_test")
    with pytest.raises(ValueError, match="unknown dataset kind 'nowhere'"):
        write_dataset(labelled(), tmp_path / "kind.nc", title="t", summary="s", kind="nowhere")
    ds = xr.Dataset({"error": ("case", [1.0])})
    with pytest.raises(ValueError, match=r"must hold \['frequency'\]"):
        write_dataset(ds, tmp_path / "required.nc", title="t", summary="s", kind="netcdf_required")
    assert not list(tmp_path.iterdir())  # no partial file either


def test_write_takes_the_metadata_from_the_catalogue(tmp_path):
    ds = labelled()
    ds["frequency"].attrs = {"long_name": "something else", "comment": "kept"}
    path = write_dataset(ds, tmp_path / "described.nc", title="t", summary="s", kind="netcdf_test")
    back = read_dataset(path)
    assert back["frequency"].attrs["long_name"] == "frequency" and back["frequency"].attrs["units"] == "Hz"
    assert back["frequency"].attrs["comment"] == "kept" and back.attrs["dataset_kind"] == "netcdf_test"


def test_missing_values_only_where_the_catalogue_allows_them(tmp_path):
    ds = xr.Dataset({"error": ("case", [1e-3, np.nan])})
    path = write_dataset(ds, tmp_path / "missing.nc", title="t", summary="s", kind="netcdf_test")
    back = read_dataset(path)
    assert back["error"].values[0] == 1e-3 and np.isnan(back["error"].values[1])


def test_read_dataset_loads_and_closes_the_file(tmp_path):
    path = write_dataset(labelled(alpha=30.0), tmp_path / "branch.nc", title="t", summary="s", kind="netcdf_test")
    ds = read_dataset(path, required=("frequency",), expected={"alpha": 30.0})
    path.unlink()  # the data were read into memory and the file closed
    assert ds["frequency"].values.tolist() == [0.1, 0.2]


def test_read_dataset_refuses_a_missing_file_or_variable(tmp_path):
    with pytest.raises(ValueError, match="no dataset at"):
        read_dataset(tmp_path / "absent.nc")
    path = write_dataset(labelled(), tmp_path / "branch.nc", title="t", summary="s", kind="netcdf_test")
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


def test_float_coordinate_variables_carry_no_fill_value(tmp_path, monkeypatch):
    """CF forbids missing values in coordinate variables: the IOOS checker finds nothing to say about them."""
    import netCDF4

    from nnmstop.pipeline.compliance import checker_findings

    sweep = DatasetKind(
        "netcdf_sweep",
        "t",
        (),
        "t",
        (
            Variable("energy", ("energy",), "total energy"),
            Variable("frequency", ("energy",), "frequency", units="Hz"),
        ),
    )
    monkeypatch.setitem(catalogue.KINDS, sweep.name, sweep)
    ds = xr.Dataset({"frequency": ("energy", [0.1, 0.2, 0.3])}, coords={"energy": ("energy", [0.5, 1.0, 2.0])})
    path = write_dataset(ds, tmp_path / "study" / "sweep.nc", title="t", summary="s", kind="netcdf_sweep")
    with netCDF4.Dataset(path) as nc:
        assert "_FillValue" not in nc["energy"].ncattrs()
    assert not [f for f in checker_findings(path) if f.startswith("cf:") or "_FillValue" in f]


def altered_copy(path, tmp_path, change):
    """A copy of the dataset at ``path`` changed by ``change(ds)`` and written as xarray would (no checks)."""
    ds = xr.load_dataset(path)
    change(ds)
    copy = tmp_path / "altered.nc"
    ds.to_netcdf(copy)
    return copy


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_read_dataset_refuses_a_non_finite_value_naming_file_and_variable(tmp_path, bad):
    path = write_dataset(labelled(), tmp_path / "branch.nc", title="t", summary="s", kind="netcdf_test")

    def spoil(ds):
        ds["frequency"].values[1] = bad

    copy = altered_copy(path, tmp_path, spoil)
    with pytest.raises(
        ValueError, match=rf"{copy} holds NaN or infinite values .*: frequency \(1 values, first at point 1\)"
    ):
        read_dataset(copy)


def test_read_dataset_refuses_an_empty_truncated_or_foreign_file_naming_it(tmp_path):
    path = write_dataset(labelled(), tmp_path / "branch.nc", title="t", summary="s", kind="netcdf_test")
    empty, truncated, text = tmp_path / "empty.nc", tmp_path / "truncated.nc", tmp_path / "text.nc"
    empty.touch()
    truncated.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    text.write_text("regime,impacts\n0,2\n")
    with pytest.raises(ValueError, match=f"{empty} is empty"):
        read_dataset(empty)
    for broken in (truncated, text):
        with pytest.raises(ValueError, match=f"{broken} cannot be read as NetCDF"):
            read_dataset(broken)


FULL_DISK = """
import sys
from pathlib import Path
import numpy as np, xarray as xr
from nnmstop import catalogue
from nnmstop.catalogue import DatasetKind, Variable
from nnmstop.netcdf import write_dataset
catalogue.KINDS["netcdf_big"] = DatasetKind("netcdf_big", "t", (), "t", (Variable("big", ("point",), "big"),))
folder = Path(sys.argv[1])
ds = xr.Dataset({"big": ("point", np.arange(200_000.0))})
try:
    write_dataset(ds, folder / "big.nc", title="t", summary="s", kind="netcdf_big")
except OSError as error:
    print("REFUSED", error)
print("LEFT", sorted(p.name for p in folder.iterdir()))
"""


def run_in_small_tmpfs(script: str, options: str) -> str:
    """Output of ``script`` run with a fresh tmpfs mounted (``options``) as its first argument, in a
    mount namespace of its own (the machine's mounts stay untouched); skip when the machine forbids it."""
    import shutil

    unshare = shutil.which("unshare")
    if unshare is None:
        pytest.skip("no unshare command: cannot mount a private tmpfs")
    namespace = ["-m"] if os.geteuid() == 0 else ["-r", "-m"]
    command = f'd=$(mktemp -d) && mount -t tmpfs -o {options} tmpfs "$d" && exec "$0" -c "$1" "$d"'
    run = subprocess.run(
        [unshare, *namespace, "sh", "-c", command, sys.executable, script],
        capture_output=True,
        text=True,
        timeout=300,
    )
    if "REFUSED" not in run.stdout and "LEFT" not in run.stdout:
        pytest.skip(f"this machine does not allow a private tmpfs here: {run.stderr.strip()[-300:]}")
    return run.stdout


def test_a_full_disk_is_named_and_leaves_no_temporary_file():
    """A 64 kB tmpfs cannot hold a 1.6 MB dataset: the error says so and nothing is left behind."""
    out = run_in_small_tmpfs(FULL_DISK, "size=64k")
    assert "REFUSED" in out and "No space left on device" in out and "big.nc" in out, out
    assert "the partial file was removed" in out, out
    assert "LEFT []" in out, out


def test_a_read_only_folder_is_named_and_leaves_no_temporary_file():
    out = run_in_small_tmpfs(FULL_DISK, "ro,size=64k")
    assert "REFUSED" in out and re.search("Read-only file system|Permission denied", out) and "big.nc" in out, out
    assert "LEFT []" in out, out
