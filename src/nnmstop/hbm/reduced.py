"""Orbits of a reduced structure against the full model: recovery, truncation of the basis, and the error.

A structure reduced by :func:`nnmstop.models.reduction.craig_bampton` runs through the one engine
(:class:`~nnmstop.hbm.system.HarmonicBalanceSystem`) like any other; these functions relate its orbits to
those of the full model it came from, for the convergence study (``benchmarks/reduction_convergence.py``),
the tests and the a-posteriori check of docs/reduction.md:

* :func:`full_unknowns`: the unknown vector of the full model's system from a reduced orbit (the DOF
  harmonics through the recovery matrix; stop forces, ``z`` and ``omega**2`` as they are);
* :func:`fewer_modes`: a reduced orbit restricted to the first ``m`` modal coordinates, the start of Newton
  on the structure reduced with ``m`` modes;
* :func:`orbit_at_amplitude`: the orbit of a system whose first stop has a given fundamental cosine amplitude
  ``x_c^1`` (Newton from a guess with that amplitude held), the common abscissa on which a reduced and the
  full branch are compared;
* :func:`orbit_difference`: relative difference of frequency and of the contact DOFs' harmonics.
"""

from __future__ import annotations

import numpy as np

from nnmstop.continuation.core import ContinuationError, ContinuationStats, OrthogonalUpdate, relative_of_residual
from nnmstop.continuation.linear import factorize_bordered
from nnmstop.continuation.newton import newton_solve, round_off_criterion

__all__ = ["full_unknowns", "fewer_modes", "orbit_at_amplitude", "orbit_difference", "contact_harmonics"]


def _blocks(system, U):
    N, s, nc = system.n_dofs, system.n_stops, system.nc
    U = np.asarray(U, dtype=float)
    return U[: N * nc].reshape(N, nc), U[N * nc : (N + 2 * s) * nc], U[(N + 2 * s) * nc :]


def full_unknowns(reduced_system, full_system, U) -> np.ndarray:
    """The full model's unknown vector of the reduced orbit ``U`` (``q_full = T q`` harmonic by harmonic)."""
    reduction = reduced_system.structure.reduction
    if reduction is None:
        raise ValueError("full_unknowns needs a system of a reduced structure (craig_bampton)")
    if reduced_system.nc != full_system.nc or reduced_system.n_stops != full_system.n_stops:
        raise ValueError("the reduced and the full system must have the same harmonics, basis and stops")
    Q, stops, tail = _blocks(reduced_system, U)
    return np.concatenate([(reduction.recovery @ Q).ravel(), stops, tail])


def fewer_modes(system, U, n_modes: int) -> np.ndarray:
    """Reduced orbit ``U`` restricted to the boundary DOFs and its first ``n_modes`` modal coordinates."""
    reduction = system.structure.reduction
    boundary = len(reduction.boundary)
    if not 0 <= n_modes <= reduction.kept_modes:
        raise ValueError(f"n_modes must lie in [0, {reduction.kept_modes}], got {n_modes!r}")
    Q, stops, tail = _blocks(system, U)
    return np.concatenate([Q[: boundary + n_modes].ravel(), stops, tail])


def orbit_at_amplitude(system, U_guess, amplitude: float, max_iter: int = 30) -> np.ndarray:
    """The orbit of ``system`` near ``U_guess`` whose first stop has the fundamental cosine amplitude ``amplitude``.

    ``amplitude`` is ``x_c^1`` in the stop's own coordinate (over its gap); Newton holds it fixed and runs to
    round-off (:func:`~nnmstop.continuation.newton.round_off_criterion`: on the update, since the residual of a
    fine mesh has a floor of about ``1e-8`` relative set by the conditioning of ``K``).

    Raises
    ------
    ContinuationError
        When Newton does not converge.
    """
    U = np.array(U_guess, dtype=float)
    index = system.slices["x"].start + 1
    U[index] = amplitude * system.gaps[0]
    direction = np.zeros(system.n_unknowns)
    direction[index] = 1.0
    stats = ContinuationStats()
    result = newton_solve(
        system.residual,
        lambda V: OrthogonalUpdate(factorize_bordered(system, V, direction, stats)),
        U,
        tol=0.0,
        max_iter=max_iter,
        criterion=round_off_criterion(),
        norm=relative_of_residual,
    )
    if not result.converged:
        raise ContinuationError(
            f"Newton at amplitude {amplitude!r} did not converge ({result.reason}; relative residual "
            f"{result.residual_norm:.2e})"
        )
    return result.y


def contact_harmonics(system, U) -> np.ndarray:
    """Fourier coefficients of the stop DOFs over their gaps, (stops, coefficients)."""
    Q, _, _ = _blocks(system, U)
    return Q[system.stop_dofs] / system.gaps[:, None]


def orbit_difference(system_a, U_a, system_b, U_b) -> dict:
    """Relative difference of two orbits of the same stops: ``frequency`` and ``harmonics`` (contact DOFs).

    ``harmonics`` is ``max |X_a - X_b| / max |X_b|`` over the stops' coordinates and every coefficient.
    """
    f_a, f_b = float(system_a.frequency_hz(U_a)), float(system_b.frequency_hz(U_b))
    x_a, x_b = contact_harmonics(system_a, U_a), contact_harmonics(system_b, U_b)
    return {
        "frequency": abs(f_a - f_b) / abs(f_b),
        "harmonics": float(np.max(np.abs(x_a - x_b)) / np.max(np.abs(x_b))),
    }
