"""How a stored periodic orbit returns: integrate it by DOP853 over several periods from its stored state.

The sceptical reader's check of any orbit of a dataset, by a method that shares nothing with the one that
computed it: the orbit's state at ``t = 0`` (a regularized orbit's from its Fourier coefficients; an exact
orbit's from its stored start velocities at ``q = 0``) is integrated over ``periods`` of its stored periods
with :func:`scipy.integrate.solve_ivp` (DOP853, tolerances ``rtol``), the regularized equations of the
structure (:func:`~nnmstop.checks.time_integration.integrate_structure_regularized`) or the non-smooth ones,
region by region (:func:`~nnmstop.checks.time_integration.integrate_nonsmooth`,
:func:`~nnmstop.checks.time_integration.integrate_structure_nonsmooth`). Printed per period ``k``: the return
error ``max |z(kT) - z(0)| / max |z|`` and the relative drift of the energy; then the growth of the return
error per period against the orbit's largest Floquet multiplier where the dataset stores it (an unstable orbit
returns less and less well, by about ``|mu|`` a period, from its error at the start). Usage::

    python -m nnmstop.checks.orbit_return results/hbm/nnm1.nc --energy 20 --periods 10
    python -m nnmstop.checks.orbit_return results/exact/nnm1_two_impacts.nc --point 100
    python -m nnmstop.checks.orbit_return results/hbm/nnm1.nc --energy 5 --config examples/three_dof_chain/config.yaml

The structure comes from the dataset's attributes for the paper's oscillator (alpha, beta, delta, eta), else
from ``--config`` (its ``structure`` section, run from the folder its matrix files are relative to).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np
import xarray as xr

from nnmstop import fourier
from nnmstop.checks.time_integration import (
    integrate_nonsmooth,
    integrate_structure_nonsmooth,
    integrate_structure_regularized,
)
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters

__all__ = ["OrbitReturn", "stored_orbit", "orbit_return", "main"]


@dataclass(frozen=True)
class OrbitReturn:
    """One stored orbit integrated over ``periods`` periods: its index, energy and period as stored, the return
    error and the relative energy drift after each period, and its largest stored Floquet multiplier (NaN if
    none)."""

    point: int
    energy: float
    period: float
    model: str
    return_error: np.ndarray
    energy_drift: np.ndarray
    max_multiplier: float


def _structure(ds: xr.Dataset, config: str | None):
    if all(key in ds.attrs for key in ("alpha", "beta", "delta")):
        eta = float(ds.attrs.get("eta", 0.1))  # the exact datasets carry no eta; the non-smooth law ignores it
        params = {k: float(ds.attrs[k]) for k in ("alpha", "beta", "delta")}
        return two_dof_structure(ModelParameters(**params, eta=eta))
    if config is None:
        raise ValueError("this dataset is not of the paper's oscillator: give --config with its structure section")
    from nnmstop.config import load_config
    from nnmstop.settings import structure_from_config

    return structure_from_config(load_config(config))


def stored_orbit(ds: xr.Dataset, point: int, structure) -> tuple[np.ndarray, float, str]:
    """``(z0, T, model)`` of point ``point``: the state ``(q, qdot)`` at ``t = 0``, the period, and which equations
    (``"regularized"``: an HBM branch; ``"non-smooth"``: an exact family) it is an orbit of."""
    n = structure.n_dofs
    if "q_cos" in ds:  # a regularized branch: its Fourier series at t = 0
        omega = float(np.sqrt(ds["omega_squared"].values[point]))
        pairs = {
            str(label): (ds["q_cos"].values[point, j], ds["q_sin"].values[point, j])
            for j, label in enumerate(ds["dof_label"].values)
        }
        labels = [str(label) for label in ds["dof_label"].values]
        fields = fourier.fields_at_phases([0.0], omega, pairs, velocities=tuple(labels))
        q = np.array([fields[name][0] for name in labels])
        qdot = np.array([fields[f"{name}dot"][0] for name in labels])
        return np.concatenate([q, qdot]), 2 * np.pi / omega, "regularized"
    if "initial_velocity" in ds:  # an exact one-stop family of a structure
        v = ds["initial_velocity"].values[point]
        return np.concatenate([np.zeros(n), v]), 1.0 / float(ds["frequency"].values[point]), "non-smooth"
    if "xdot0" in ds:  # an exact family of the paper's oscillator (any number of impacts)
        z0 = np.array([0.0, 0.0, float(ds["xdot0"].values[point]), float(ds["udot0"].values[point])])
        return z0, float(ds["period"].values[point]), "non-smooth"
    raise ValueError("no orbit in this dataset: expected q_cos (a regularized branch), xdot0 or initial_velocity")


def _energy(structure, states, model: str) -> np.ndarray:
    from nnmstop.models.two_dof import regularized_contact_potential

    mass, stiffness = structure.dense_matrices()
    n = structure.n_dofs
    q, v = states[:, :n], states[:, n:]
    energy = 0.5 * np.einsum("ti,ij,tj->t", v, mass, v) + 0.5 * np.einsum("ti,ij,tj->t", q, stiffness, q)
    for stop in structure.stops:
        x = q[:, stop.dof] / stop.gap
        if model == "regularized":
            law = ModelParameters(alpha=stop.stiffness, eta=stop.eta)
            energy += stop.gap**2 * regularized_contact_potential(x, law)
        else:
            energy += stop.gap**2 * stop.piecewise_potential(x)
    return energy


def orbit_return(ds: xr.Dataset, point: int, periods: int = 10, structure=None, rtol: float = 1e-12) -> OrbitReturn:
    """Integrate point ``point`` of ``ds`` over ``periods`` stored periods (module docstring)."""
    if int(periods) != periods or periods < 1:
        raise ValueError(f"periods must be an integer >= 1, got {periods!r}")
    n_points = ds.sizes.get("point", ds.sizes.get("orbit", 0))
    if not 0 <= point < n_points:
        raise ValueError(f"point must be in [0, {n_points}), got {point!r}")
    z0, period, model = stored_orbit(ds, point, structure)
    t = period * np.arange(periods + 1)
    if model == "regularized":
        run = integrate_structure_regularized(structure, z0, t, rtol=rtol, atol=rtol * 1e-1)
    elif structure.n_dofs == 2 and len(structure.stops) == 1 and structure.attributes.get("structure") == "two_dof":
        params = ModelParameters(**{k: float(structure.attributes[k]) for k in ("alpha", "beta", "delta", "eta")})
        run = integrate_nonsmooth(params, z0, t, rtol=rtol, atol=rtol)
    else:
        struck = int(ds.attrs.get("struck_stop", 0))
        run = integrate_structure_nonsmooth(structure, z0, t, stop_index=struck, rtol=rtol, atol=rtol)
    scale = np.abs(run.states).max()
    error = np.abs(run.states[1:] - z0).max(axis=1) / scale
    energy = _energy(structure, run.states, model)
    multiplier = float(ds["max_multiplier"].values[point]) if "max_multiplier" in ds else np.nan
    if np.isnan(multiplier) and "multiplier_modulus" in ds:
        multiplier = float(ds["multiplier_modulus"].values[point])
    return OrbitReturn(
        point, float(ds["energy"].values[point]), period, model, error, energy[1:] / energy[0] - 1.0, multiplier
    )


def _point(ds: xr.Dataset, point, energy) -> int:
    if point is not None:
        return int(point)
    reached = np.flatnonzero(ds["energy"].values >= energy)
    if reached.size == 0:
        raise ValueError(f"the branch never reaches energy {energy!r} (highest {float(ds['energy'].max()):.6g})")
    return int(reached[0])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", help="a branch or exact family dataset (results/hbm/nnm1.nc, results/exact/...)")
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--point", type=int, help="index of the orbit along the dataset")
    which.add_argument("--energy", type=float, help="the first orbit at or above this energy")
    parser.add_argument("--periods", type=int, default=10)
    parser.add_argument("--rtol", type=float, default=1e-12, help="DOP853 tolerance")
    parser.add_argument("--config", help="the configuration of a structure of one's own (its structure section)")
    args = parser.parse_args(argv)
    with xr.open_dataset(args.dataset) as ds:
        ds = ds.load()
    structure = _structure(ds, args.config)
    result = orbit_return(ds, _point(ds, args.point, args.energy), args.periods, structure, args.rtol)
    print(
        f"{args.dataset} point {result.point}: E = {result.energy:.8g}, T = {result.period:.10g} "
        f"({result.model} equations, DOP853 rtol {args.rtol:g})"
    )
    if "time_residual" in ds:  # an HBM orbit is periodic for the equations to its truncation error, no better
        print(f"  its stored time residual (HBM truncation): {float(ds['time_residual'].values[result.point]):.3e}")
    for k, (error, drift) in enumerate(zip(result.return_error, result.energy_drift), start=1):
        print(f"  after {k:3d} period(s): max|z(kT) - z(0)| / max|z| = {error:.3e}, energy drift {drift:+.2e}")
    growth = (result.return_error[-1] / result.return_error[0]) ** (1.0 / max(len(result.return_error) - 1, 1))
    text = f"  return error grows by {growth:.4g} a period"
    if np.isfinite(result.max_multiplier):
        text += f"; the dataset's largest Floquet multiplier modulus: {result.max_multiplier:.6g}"
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
