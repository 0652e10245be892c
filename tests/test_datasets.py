"""NetCDF writing (nnmstop.netcdf)."""

import os
import subprocess
import sys

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
