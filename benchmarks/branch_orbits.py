"""The orbits of built branch datasets, for the stability benchmarks (module ``branch_orbits`` of ``benchmarks/``)."""

from __future__ import annotations

import sys
from pathlib import Path

import xarray as xr

from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.tasks.hbm import system_from_config

__all__ = ["branch_orbits"]


def branch_orbits(datasets, config: dict, stride: int = 1):
    """Yield ``(path, system, U, time_residual)`` for every ``stride``-th orbit of each built dataset.

    A dataset that is not built is skipped with a note on stderr.
    """
    for name in datasets:
        path = Path(name)
        if not path.exists():
            print(f"skipping {name}: not built", file=sys.stderr)
            continue
        with xr.open_dataset(path) as ds:
            system = system_from_config(config, harmonics=int(ds.attrs["harmonics"]))
            U = dataset_unknowns(ds.load(), system)[::stride]
            residual = ds["time_residual"].values[::stride]
        yield path, system, U, residual
