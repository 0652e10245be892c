"""What carries the energy between two orbits of an exact one-stop family, by time integration alone.

Two orbits of a family (a :func:`nnmstop.exact.dataset.one_stop_dataset`, e.g. the tube's
``results/tube/exact_nnm1.nc``), each taken from its stored initial velocities, are integrated over one
period by DOP853 with the contact entries and exits located as events
(:func:`nnmstop.checks.time_integration.integrate_structure_nonsmooth`); nothing of the closed-form
construction is used. Printed: how well each closes after one period and its contact entries, then the
modal content of the difference of the two trajectories (modes of ``(K, M)`` from scipy): the share of
each mode in its mean square and, for the largest, the harmonic of the orbit holding its power and the
ratio of the mode's linear frequency to the orbit's. Usage::

    python -m nnmstop.checks.orbit_difference results/tube/exact_nnm1.nc config/config.yaml --energies 10 40

Method notes: ``docs/methods/tube_resonance.md``.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import xarray as xr
import yaml

from nnmstop.checks.time_integration import integrate_structure_nonsmooth

__all__ = ["IntegratedOrbit", "integrate_orbit", "difference_content", "main"]


@dataclass(frozen=True)
class IntegratedOrbit:
    """One orbit integrated over one period: its energy and frequency, the closure ``max |z(T) - z(0)| / max |z|``,
    the sides of its contact entries, and the displacements at ``samples`` times of the period."""

    energy: float
    frequency: float
    closure: float
    entries: tuple
    q: np.ndarray


def integrate_orbit(structure, ds: xr.Dataset, energy: float, samples: int, rtol: float = 1e-12) -> IntegratedOrbit:
    """The orbit of ``ds`` that first reaches ``energy``, integrated from ``q = 0`` over one period."""
    reached = np.flatnonzero(ds["energy"].values >= energy)
    if reached.size == 0:
        raise ValueError(f"the family never reaches energy {energy!r} (highest {float(ds['energy'].max()):.6g})")
    i = int(reached[0])
    period = 1.0 / float(ds["frequency"].values[i])
    z0 = np.concatenate([np.zeros(structure.n_dofs), ds["initial_velocity"].values[i]])
    t = period * np.arange(samples + 1) / samples
    run = integrate_structure_nonsmooth(structure, z0, t, rtol=rtol, atol=rtol)
    closure = float(np.abs(run.states[-1] - z0).max() / np.abs(run.states).max())
    entries = tuple(int(s) for s in run.switch_sides if s != 0)
    return IntegratedOrbit(
        float(ds["energy"].values[i]), 1.0 / period, closure, entries, run.states[:-1, : structure.n_dofs]
    )


def difference_content(structure, a: IntegratedOrbit, b: IntegratedOrbit):
    """Share of each mode (1-based) in the mean square of ``b.q - a.q``, largest first, and for the largest mode
    the harmonic holding most of its power with that power's share."""
    mass, stiffness = structure.dense_matrices()
    squares, shapes = scipy.linalg.eigh(stiffness, mass)
    modal = (b.q - a.q) @ mass @ shapes
    power = np.abs(np.fft.rfft(modal, axis=0)) ** 2
    power[0] = 0.0
    per_mode = power.sum(axis=0)
    order = np.argsort(per_mode)[::-1]
    k = int(order[0])
    harmonic = int(np.argmax(power[:, k]))
    shares = [(int(m) + 1, float(per_mode[m] / per_mode.sum())) for m in order]
    linear = float(np.sqrt(squares[k]) / (2.0 * np.pi))
    return shares, harmonic, float(power[harmonic, k] / per_mode[k]), linear


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", help="an exact one-stop family dataset (results/tube/exact_nnm1.nc)")
    parser.add_argument("config", help="the configuration that built it (its tube.structure section)")
    parser.add_argument("--energies", nargs=2, type=float, default=[10.0, 40.0])
    parser.add_argument("--samples", type=int, default=4096, help="samples per period (resolve the harmonics)")
    args = parser.parse_args(argv)
    from nnmstop.models.beam import Beam, beam_structure

    config = yaml.safe_load(open(args.config, encoding="utf-8"))
    structure = beam_structure(Beam.from_parameters(config["tube"]["structure"]))
    with xr.open_dataset(args.dataset) as ds:
        runs = [integrate_orbit(structure, ds, e, args.samples) for e in args.energies]
    for run in runs:
        print(
            f"E = {run.energy:.6g}, f = {run.frequency:.10g} Hz: after one period of DOP853 max|z(T) - z(0)|/max|z| "
            f"= {run.closure:.2e}, contact entries {run.entries}"
        )
    shares, harmonic, share, linear = difference_content(structure, *runs)
    top = ", ".join(f"mode {m}: {s:.6f}" for m, s in shares[:3])
    print(f"difference of the two orbits, share of the mean square by mode: {top}")
    mode = shares[0][0]
    print(
        f"mode {mode}: {share:.6f} of its power at harmonic {harmonic} of the orbit; its linear frequency "
        f"{linear:.6g} Hz = {linear / runs[0].frequency:.6f} x the orbit's"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
