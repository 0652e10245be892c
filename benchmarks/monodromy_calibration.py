"""Calibration of the orbit-error criterion of the monodromy verdict (docs/methods/monodromy.md).

For every ``--stride``-th orbit of a built branch dataset: the invariant
``s = mu + 1/mu`` of the HBM orbit's monodromy (:func:`nnmstop.hbm.monodromy.branch_monodromy`)
against that of the exact periodic orbit of (7) nearby (shooting,
:func:`nnmstop.checks.shooting.refine_orbit`, DOP853 monodromy); prints the ratio of their
difference to the orbit's ``time_residual`` near the type changes (``|s -+ 2| < 0.05``) and
elsewhere, and the margins (in units of ``time_residual``) of the points whose verdicts differ.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/monodromy_calibration.py results/hbm/nnm1.nc [--stride 10]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import xarray as xr

from nnmstop.checks.shooting import monodromy, orbit_initial_state, refine_orbit
from nnmstop.config import load_config
from nnmstop.floquet import PairInvariants
from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.monodromy import MonodromySettings, branch_monodromy
from nnmstop.hbm.variational import Linearization
from nnmstop.models.structure import two_dof_parameters
from nnmstop.tasks.hbm import system_from_config


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset")
    parser.add_argument("--config", default="config/config.yaml")
    parser.add_argument("--stride", type=int, default=10)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    with xr.open_dataset(args.dataset) as ds:
        system = system_from_config(config, harmonics=int(ds.attrs["harmonics"]))
        U = dataset_unknowns(ds.load(), system)[:: args.stride]
        residual = ds["time_residual"].values[:: args.stride]
    mono = branch_monodromy(
        system, U, MonodromySettings.from_config(config.get("stability", {})), time_residual=residual
    )
    near, far, wrong, failed = [], [], [], 0
    # monodromies of (x, u, x', u') to mass-normalized coordinates, where they are symplectic for the standard J
    normalize = np.kron(np.eye(2), Linearization.of(system).mass_factor.T)
    params = two_dof_parameters(system.structure, "the calibration against the shooting of the 2-DOF oscillator")
    for i, orbit in enumerate(U):
        z0, period = orbit_initial_state(system, orbit)
        try:
            z, period = refine_orbit(params, z0, period)
        except RuntimeError:
            failed += 1
            continue
        matrix = normalize @ monodromy(params, z, period).matrix @ np.linalg.inv(normalize)
        s_exact = float(PairInvariants.of(matrix[None], halfwave=False).s[0, 0].real)
        ratio = abs(mono.invariant[i] - s_exact) / residual[i]
        (near if mono.margin[i] < 0.05 else far).append(ratio)
        if (abs(s_exact) <= 2) != bool(mono.stable[i]):
            wrong.append(mono.margin[i] / residual[i])
    print(f"{len(U)} orbits, shooting failed at {failed}")
    print(
        f"near a type change (margin < 0.05): {len(near)} orbits, largest |s_HBM - s_exact| / time_residual "
        f"{max(near, default=0):.2f}"
    )
    print(f"elsewhere: {len(far)} orbits, largest ratio {max(far, default=0):.2f}")
    print("margins / time_residual where the verdicts differ:", ", ".join(f"{m:.2f}" for m in wrong) or "none")
    return 0


if __name__ == "__main__":
    sys.exit(main())
