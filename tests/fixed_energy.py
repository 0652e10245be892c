"""Orbits at a prescribed energy, found by Newton's method (a test helper).

Tests that pick orbits "at energy E" must not depend on where a continuation happened
to store its points: the stored points only give a starting guess, and Newton's method
on ``S(U) = 0, E(U) = E`` (bordered by the exact energy gradient of
:mod:`nnmstop.compare.matching`) finds the orbit itself, whatever the step sequence.
"""

from __future__ import annotations

import numpy as np

from nnmstop.compare import matching as compare
from nnmstop.continuation.core import relative_residual
from nnmstop.continuation.newton import newton_solve


def orbit_at_energy(system, points, energies, target: float, tol: float = 1e-12, max_iter: int = 30):
    """HBM orbit of energy ``target`` on an arm of a branch where the energy is monotone.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    points : ndarray, shape (n, n_unknowns)
        Stored points of one arm (energy strictly monotone along it), in branch order.
    energies : ndarray, shape (n,)
        Their energies.
    target : float
        The energy sought; must lie within the arm's energies.

    Returns
    -------
    ndarray
        The orbit's unknowns (relative residual and energy error below ``tol``).
    """
    points, energies = np.asarray(points), np.asarray(energies, dtype=float)
    step = np.diff(energies)
    if not (np.all(step > 0) or np.all(step < 0)):
        raise ValueError(f"energy is not monotone along the arm: {energies}")
    order = np.argsort(energies)
    e_sorted, p_sorted = energies[order], points[order]
    if not e_sorted[0] <= target <= e_sorted[-1]:
        raise ValueError(f"energy {target} outside the arm's range [{e_sorted[0]:.6g}, {e_sorted[-1]:.6g}]")
    i = int(np.clip(np.searchsorted(e_sorted, target) - 1, 0, e_sorted.size - 2))
    w = (np.log(target) - np.log(e_sorted[i])) / (np.log(e_sorted[i + 1]) - np.log(e_sorted[i]))
    U = p_sorted[i] + w * (p_sorted[i + 1] - p_sorted[i])
    energy_of = compare.EnergyOperator(system)

    def bordered(U):  # HBM equations and relative energy error, with their Jacobian
        e, grad = energy_of(U, gradient=True)
        return np.append(system.residual(U), (e - target) / target), np.vstack([system.jacobian(U), grad / target])

    def converged(U, r, dU):
        return dU is not None and relative_residual(system, U) <= tol and abs(r[-1]) <= tol

    solved = newton_solve(bordered, None, U, tol=tol, max_iter=max_iter, criterion=converged)
    U = solved.y
    if not solved.converged:
        raise AssertionError(
            f"Newton did not converge at energy {target} (relative residual {relative_residual(system, U):.1e})"
        )
    # the solution must lie on this arm, between the two stored points around it
    lo, hi = p_sorted[i], p_sorted[i + 1]
    if np.abs(U - lo).max() > 2.0 * np.abs(hi - lo).max():
        raise AssertionError(f"Newton left the arm at energy {target}")
    return U
