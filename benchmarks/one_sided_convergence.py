"""Order of convergence in eta of the regularized one-sided stop to the piecewise-linear one (method note:
docs/methods/one_sided_law.md).

The oscillator ``x'' + x + f(x) = 0`` with a one-sided stop (gap 1, stiffness ``alpha``) has the closed-form
exact period ``T(E)`` (free flight on the circle of radius ``sqrt(2 E)`` below the gap, a contact arc above).
For each ``eta`` the regularized period at the same energy is measured twice, independently: by DOP853 between
two turning points (the law alone, no harmonic balance), and by the HBM NNM (the orbit nearest ``E``). Printed:
the relative period errors and the slopes of log(error) against log(eta), between neighbours and fitted.

Usage::

    python benchmarks/one_sided_convergence.py [--energy 4] [--etas 0.2 0.1 ...] [--harmonics 60] [--output F]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from nnmstop import Stop, Structure, continue_nnm
from nnmstop.models.contact import one_sided_force, one_sided_potential
from timing import emit_report


def exact_period(energy: float, alpha: float) -> float:
    radius = np.sqrt(2.0 * energy)
    omega, rest = np.sqrt(1.0 + alpha), alpha / (1.0 + alpha)
    amplitude = np.sqrt((1.0 - rest) ** 2 + (radius**2 - 1.0) / omega**2)
    return 2.0 * np.pi - 2.0 * np.arccos(1.0 / radius) + 2.0 * np.arccos((1.0 - rest) / amplitude) / omega


def integrated_period(energy: float, alpha: float, eta: float) -> float:
    """Twice the time between two turning points of the regularized oscillator at ``energy`` (DOP853)."""

    def potential(x):
        return 0.5 * x * x + float(one_sided_potential(np.array(x), alpha, eta))

    top = brentq(lambda x: potential(x) - energy, 0.0, 10.0 * np.sqrt(energy) + 2.0, xtol=1e-15, rtol=1e-15)

    def turning(_t, z):
        return z[1]

    turning.terminal, turning.direction = True, 1.0
    run = solve_ivp(
        lambda _t, z: [z[1], -z[0] - float(one_sided_force(np.array(z[0]), alpha, eta))],
        (0.0, 100.0),
        [top, 0.0],
        method="DOP853",
        rtol=1e-13,
        atol=1e-14,
        events=turning,
        first_step=1e-6,
    )
    return 2.0 * float(run.t_events[0][0])


def hbm_error(energy: float, alpha: float, eta: float, harmonics: int) -> tuple[float, float]:
    """Relative period error of the HBM orbit nearest ``energy`` against the exact period at its own energy, and the
    largest truncation indicator of the branch."""
    stop = Stop(kind="one_sided", dof=0, side="positive", gap=1.0, stiffness=alpha, eta=eta)
    ds = continue_nnm(
        Structure(np.eye(1), np.eye(1), [stop]),
        harmonics=harmonics,
        energy_max=1.25 * energy,
        stability=None,
        max_truncation=1e-2,
    )
    i = int(np.argmin(np.abs(ds.energy.values - energy)))
    error = abs(float(ds.frequency[i]) * exact_period(float(ds.energy[i]), alpha) - 1.0)
    return error, float(ds.truncation.max())


def slopes(etas, errors) -> str:
    local = np.diff(np.log(errors)) / np.diff(np.log(etas))
    fitted = np.polyfit(np.log(etas), np.log(errors), 1)[0]
    return f"slopes between neighbours {np.array2string(local, precision=3)}, fitted {fitted:.3f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--alpha", type=float, default=30.0)
    parser.add_argument("--energy", type=float, default=4.0)
    parser.add_argument("--etas", type=float, nargs="+", default=[0.2, 0.1, 0.05, 0.025, 0.0125, 0.003, 0.001])
    parser.add_argument("--hbm-etas", type=float, nargs="+", default=[0.2, 0.1, 0.05, 0.025])
    parser.add_argument("--harmonics", type=int, default=60)
    parser.add_argument("--output", type=Path, default=None, help="also write the report to this file")
    args = parser.parse_args(argv)
    exact = exact_period(args.energy, args.alpha)
    lines = [
        "# Order of convergence in eta of the one-sided stop",
        "",
        f"one-sided stop, alpha = {args.alpha:g}, energy {args.energy:g}: exact period {exact:.15g}",
        "",
    ]
    etas = np.array(sorted(args.etas, reverse=True))
    errors = np.array([abs(integrated_period(args.energy, args.alpha, eta) / exact - 1.0) for eta in etas])
    lines.append("regularized law alone (DOP853 between turning points):")
    lines += [f"  eta = {eta:<8g} relative period error {e:.4e}" for eta, e in zip(etas, errors)]
    lines += ["  " + slopes(etas, errors), ""]
    hbm = np.array(sorted(args.hbm_etas, reverse=True))
    results = [hbm_error(args.energy, args.alpha, eta, args.harmonics) for eta in hbm]
    lines.append(f"HBM NNM, H = {args.harmonics} (orbit nearest the energy):")
    lines += [
        f"  eta = {eta:<8g} relative period error {e:.4e} (truncation {t:.1e})" for eta, (e, t) in zip(hbm, results)
    ]
    lines += ["  " + slopes(hbm, [e for e, _ in results])]
    return emit_report("\n".join(lines), args.output)


if __name__ == "__main__":
    sys.exit(main())
