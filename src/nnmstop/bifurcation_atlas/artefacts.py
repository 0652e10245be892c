r"""Regularization artefacts of the atlas, measured: what the regularized law moves, and how the exact law's
stability departs from the non-impacting response near grazing.

* :func:`fold_distances`: the same fold point (the jump-down fold of NNM1's resonance) of the exact and of the
  regularized responses at a few forces, for decreasing ``eta``. The regularized law differs from the
  piecewise-linear one by ``O(eta)`` away from the kink (the admissible root of the cubic sits ``eta/2``
  above ``alpha (x - 1)``, NOTES.md), so the fold moves by ``O(eta)``: the expected order is 1, measured as the
  slope of ``log(distance)`` against ``log(eta)``.
* :func:`multiplier_departure`: along the exact one-contact family from a grazing orbit, the distance of the
  half-period map's multipliers from those of the non-impacting response at the same frequency, against the
  penetration ``max |q_c| - gap``. The contact lasts ``delta ~ sqrt(penetration)`` (the stop coordinate's
  maximum is parabolic) and the half-period map changes by ``exp(A_R t) - exp(A_F t) = O(t)`` over it, while
  the saltation matrices are the identity (the force is continuous at the stop): a square-root law, exponent
  1/2, measured over at least two decades of penetration (:func:`power_law_exponent`).

Method note: ``docs/methods/atlas.md``; the measured numbers: ``benchmarks/atlas_artefacts.py``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["power_law_exponent", "multiplier_departure", "fold_distances"]


def power_law_exponent(x, y) -> float:
    """Least-squares slope of ``log y`` against ``log x``."""
    return float(np.polyfit(np.log(np.asarray(x, dtype=float)), np.log(np.asarray(y, dtype=float)), 1)[0])


def multiplier_departure(excitation, omega_grazing: float, durations):
    """Penetrations and multiplier departures along the exact one-contact family from the grazing orbit at
    ``omega_grazing`` (rad per unit time): at each contact duration ``delta`` (phase) of ``durations``, the
    orbit of the family (Newton on the symmetric formulation with ``delta`` held), its penetration
    ``max |q_c| - gap`` and ``max_k |nu_k - nu0_k|`` with ``nu0`` the half-period multipliers of the
    non-impacting response at the same frequency (matched nearest). Returns ``(penetration, departure)``."""
    from nnmstop.continuation.newton import newton_solve, round_off_criterion
    from nnmstop.exact.forced import SymmetricContactProblem
    from nnmstop.floquet import match_nearest

    problem = SymmetricContactProblem(excitation)
    y = problem.grazing_start(omega_grazing)
    held = problem.n_unknowns - 2
    penetration, departure = [], []
    for delta in sorted(float(d) for d in durations):
        y = y.copy()
        y[held] = delta

        def residual(v, delta=delta):
            return np.append(problem.residual(v), v[held] - delta)

        def jacobian(v):
            row = np.zeros(len(v))
            row[held] = 1.0
            return np.vstack([problem.jacobian(v), row])

        result = newton_solve(residual, jacobian, y, tol=1e-14, max_iter=40, criterion=round_off_criterion())
        if not result.converged:
            raise RuntimeError(f"the family's orbit of contact duration {delta:g} did not converge ({result.reason})")
        y = result.y
        omega = float(y[-1])
        nu = problem.multipliers(y)[1]
        nu0 = np.linalg.eigvals(-problem.phases["F"].exponential(np.pi / omega))
        penetration.append(problem.amplitudes(y)[problem.stop.dof] - problem.stop.gap)
        departure.append(float(np.abs(nu - match_nearest(nu[None], nu0[None])[0]).max()))
    return np.array(penetration), np.array(departure)


def fold_distances(excitation, etas, forces, harmonics: int, anm, max_truncation: float, frequency_window):
    """Relative distance between the regularized and the exact jump-down fold of NNM1 at each force, per ``eta``.

    The exact fold: the highest-frequency fold the exact response locates in ``frequency_window`` (Hz); the
    regularized one: the Omega-extremum on the harmonic-balance response's ANM steps nearest to it
    (:func:`nnmstop.forced.responses.locate_folds`). Returns ``(exact Hz (forces,), regularized Hz (etas,
    forces), distance (etas, forces))``.
    """
    from nnmstop.continuation.anm import ANMStepper
    from nnmstop.forced.responses import RegularizedSettings, exact_response, locate_folds, regularized_response

    exact = []
    for force in forces:
        pieces = exact_response(excitation.with_amplitude(force), frequency_window)
        folds = [c.U[-1] / (2 * np.pi) for p in pieces for c in p.changes if c.kind == "fold"]
        if not folds:
            raise ValueError(f"the exact response at F = {force:g} has no fold in {frequency_window} Hz")
        exact.append(max(folds))
    exact = np.array(exact)
    regularized = np.zeros((len(etas), len(forces)))
    for i, eta in enumerate(etas):
        structure = excitation.structure
        stops = tuple(dataclasses.replace(s, eta=float(eta)) for s in structure.stops)
        softer = dataclasses.replace(excitation, structure=dataclasses.replace(structure, stops=stops))
        for j, force in enumerate(forces):
            settings = RegularizedSettings(int(harmonics), anm, float(max_truncation))
            system, branch = regularized_response(softer.with_amplitude(force), frequency_window, settings)
            found = [
                system.frequency_hz(U) for _, U in locate_folds(system, ANMStepper(anm), branch.points, system.i_omega)
            ]
            if not found:
                raise ValueError(f"the regularized response (eta = {eta:g}, F = {force:g}) has no fold")
            regularized[i, j] = min(found, key=lambda f: abs(f - exact[j]))
    return exact, regularized, np.abs(regularized - exact) / exact
