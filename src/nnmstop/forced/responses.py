"""Frequency responses of one excitation: exact (piecewise-linear law) and regularized (harmonic balance).

:func:`exact_response` assembles the exact responses over a frequency range: the non-impacting response
(closed form, on a frequency grid, split at the located grazing frequencies) and, from each grazing
orbit, the family of symmetric one-contact responses (:mod:`nnmstop.exact.forced`), with multipliers and
located stability changes. :func:`regularized_response` continues the harmonic-balance response by the
ANM (:mod:`nnmstop.hbm.forced`) and locates its folds and branch points on the ANM steps. Both return
plain arrays; :mod:`nnmstop.forced.dataset` turns them into datasets.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from nnmstop.continuation.anm import ANMSettings
from nnmstop.continuation.core import ContinuationStats, unit_tangent
from nnmstop.continuation.newton import bisect_sign_change
from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings, PseudoArclengthStepper
from nnmstop.exact.forced import (
    follow_contact_family,
    free_phase,
    grazing_frequencies,
    grazing_problem,
    non_impacting_response,
    structure_contacts,
)
from nnmstop.floquet import match_nearest
from nnmstop.forced.stability_changes import locate_stability_changes, type_by_tangent
from nnmstop.hbm.forced import ForcedHarmonicBalanceSystem, continue_frequency_response
from nnmstop.models.excitation import Excitation

__all__ = [
    "ExactSettings",
    "ExactPiece",
    "exact_response",
    "RegularizedSettings",
    "regularized_response",
    "path_between",
    "locate_folds",
]


@dataclass(frozen=True)
class ExactSettings:
    """Settings of the exact responses: the continuation of the contact families, the grid of the
    non-impacting response (``frequency_samples`` over the range), and ``use_symmetry``: the half-wave
    reduction of the families whose grazing orbit is symmetric (every law odd), else full periods."""

    continuation: PseudoArclengthSettings = field(
        default_factory=lambda: PseudoArclengthSettings(tolerance=1e-12, initial_step=0.01, max_step=0.05)
    )
    frequency_samples: int = 400
    use_symmetry: bool = True


@dataclass
class ExactPiece:
    """One piece of the exact response: ``kind`` ("non_impacting" or "one_contact"), its frequencies (Hz),
    amplitudes ``max |q_j|`` (points, N), multipliers ``mu`` (points, 2N), the unknowns of the contact family
    (empty for the non-impacting piece), the located stability changes, why the piece ends, the multipliers'
    error estimates (points,): their difference from a second computation with :func:`scipy.linalg.expm`, how
    the end was checked (a contact family's end confirmed by a restart, the non-impacting piece's located), and
    the contact family's problem (:class:`~nnmstop.exact.forced.ForcedResponseProblem`; None for the
    non-impacting piece)."""

    kind: str
    frequency: np.ndarray
    amplitude: np.ndarray
    multipliers: np.ndarray
    unknowns: np.ndarray
    changes: list
    end_reason: str
    multiplier_error: np.ndarray
    end_check: str = ""
    problem: object = None


def path_between(system, stepper, points, i: int):
    """The continuation ``stepper``'s path from ``points[i]`` to ``points[i + 1]`` (tangent recomputed there)."""
    stats = ContinuationStats()
    tangent, _ = unit_tangent(system, points[i], points[i + 1] - points[i], stats)
    return stepper.path_through(system, points[i], tangent, points[i + 1], stats, strict=False)


def _non_impacting_pieces(excitation: Excitation, low: float, high: float, samples: int, grazing: list) -> list:
    """The non-impacting response on a grid of ``[low, high]`` Hz, split where a contact coordinate exceeds its
    gap."""
    contacts = structure_contacts(excitation.structure)
    n = excitation.structure.n_dofs
    normals, gaps = np.array([c.normal(n) for c in contacts]), np.array([c.gap for c in contacts])
    problem_phase = free_phase(excitation)
    grid = np.union1d(np.geomspace(low, high, samples), np.array(grazing) / (2 * np.pi))
    response = non_impacting_response(excitation, 2 * np.pi * grid)
    amplitude = np.abs(response)
    inside = np.all(np.abs(response @ normals.T) <= gaps * (1 + 1e-12), axis=1)
    period = 2 * np.pi / (2 * np.pi * grid)
    multipliers = np.exp(np.multiply.outer(period, problem_phase.eigenvalues))
    second = np.linalg.eigvals(scipy.linalg.expm(np.multiply.outer(period, problem_phase.A)))
    errors = np.abs(multipliers - match_nearest(multipliers, second)).max(axis=-1)
    pieces, start = [], None
    for i in range(len(grid) + 1):
        if i < len(grid) and inside[i]:
            start = i if start is None else start
            continue
        if start is not None:
            sl = slice(start, i)
            ends = "frequency range ends" if i == len(grid) else "grazing: the stop DOF reaches the stop"
            pieces.append(
                ExactPiece(
                    "non_impacting",
                    grid[sl],
                    amplitude[sl],
                    multipliers[sl],
                    np.zeros((i - start, 0)),
                    [],
                    ends,
                    errors[sl],
                    "closed form: the linear response on a grid, split at grazing frequencies located to round-off "
                    "(no continuation, nothing to confirm)",
                )
            )
            start = None
    return pieces


def _along_the_curve(pieces: list, rel_tol: float = 1e-8) -> list:
    """``pieces`` in the order of the response curve: from the lowest frequency, each next piece the one that
    starts where the last one ends (a non-impacting piece and a contact family meet at a grazing frequency),
    else the lowest left. Stored so, the pieces make one curve (what the verifier compares)."""
    left = sorted(pieces, key=lambda piece: piece.frequency[0])
    ordered = [left.pop(0)] if left else []
    while left:
        end = ordered[-1].frequency[-1]
        following = [k for k, piece in enumerate(left) if abs(piece.frequency[0] - end) <= rel_tol * end]
        ordered.append(left.pop(following[0] if following else 0))  # by index: pieces hold arrays, no ==
    return ordered


def exact_response(excitation: Excitation, frequency_range, settings: ExactSettings = ExactSettings()) -> list:
    """Pieces of the exact response over ``frequency_range`` (Hz), non-impacting ones and contact families, in
    the order of the curve (each starting where the previous one ends, where they meet).

    Every stop must be piecewise linear (ValueError naming a circular clearance). A contact family starts at each
    grazing frequency not already reached by a family (:func:`~nnmstop.exact.forced.grazing_problem`); its
    multipliers are ``nu`` of the half-period map under the half-wave reduction (``half_period``: a ``nu``
    through -1 is a symmetry breaking), else ``mu`` over the period, where a multiplier through +1 is a fold where
    ``Omega`` turns and elsewhere, on a structure of odd laws, a symmetry breaking
    (:func:`~nnmstop.forced.stability_changes.type_by_tangent`).
    """
    low, high = (float(v) for v in frequency_range)
    grazing = grazing_frequencies(excitation, 2 * np.pi * low, 2 * np.pi * high)
    pieces = _non_impacting_pieces(excitation, low, high, settings.frequency_samples, grazing)
    stepper = PseudoArclengthStepper(settings.continuation)
    reached = []
    for omega in grazing:
        if any(abs(omega - r) <= 1e-8 * omega for r in reached):
            continue
        problem, y0, direction = grazing_problem(excitation, omega, settings.use_symmetry)
        family = follow_contact_family(problem, y0, direction, settings.continuation, (low, high), confirm=True)
        Y = family.unknowns
        reached.append(Y[-1, -1])
        nus = np.array([problem.multipliers(y)[1] for y in Y])
        changes = locate_stability_changes(
            Y,
            nus,
            lambda i, problem=problem: lambda v: problem.multipliers(v)[1],
            lambda i, Y=Y, problem=problem: path_between(problem, stepper, Y, i),
            half_period=problem.half_wave,
        )
        if not problem.half_wave:
            changes = type_by_tangent(changes, problem, Y, excitation.structure.contact.odd)
        amplitude = np.array([problem.amplitudes(y) for y in Y])
        pieces.append(
            ExactPiece(
                "one_contact",
                Y[:, -1] / (2 * np.pi),
                amplitude,
                nus**2 if problem.half_wave else nus,
                Y,
                changes,
                family.end_reason,
                np.array([problem.multiplier_error(y) for y in Y]),
                family.end_check,
                problem,
            )
        )
    return _along_the_curve(pieces)


@dataclass(frozen=True)
class RegularizedSettings:
    """Settings of the regularized (harmonic-balance) response."""

    harmonics: int = 100
    continuation: ANMSettings = field(default_factory=lambda: ANMSettings(points_per_step=2))
    max_truncation: float = 1e-3


def regularized_response(
    excitation: Excitation,
    frequency_range,
    settings: RegularizedSettings = RegularizedSettings(),
    label: str = "forced response",
):
    """The harmonic-balance system and its continued branch over ``frequency_range`` (Hz)."""
    system = ForcedHarmonicBalanceSystem(excitation, settings.harmonics)
    branch = continue_frequency_response(
        system, frequency_range, settings.continuation, settings.max_truncation, label=label
    )
    return system, branch


def locate_folds(system, stepper, points, parameter: int, rel_tol: float = 1e-12) -> list:
    """Points of the curve where ``U[parameter]`` (``Omega``) is extremal: sign changes of its slope along the
    step paths between consecutive ``points``, bisected on the path to ``rel_tol`` of its length."""
    points = np.asarray(points)
    slope = np.sign(np.diff(points[:, parameter]))
    found = []
    for i in np.flatnonzero(slope[:-1] * slope[1:] < 0):
        # the extremum lies within the two steps around point i + 1: take the one where the path's slope flips
        for j in (i, i + 1):
            path, length = path_between(system, stepper, points, int(j))
            ends = [path(a, derivative=True)[parameter] for a in (0.0, length)]
            if ends[0] * ends[1] <= 0:
                located = bisect_sign_change(
                    lambda a, path=path: path(a, derivative=True)[parameter],
                    0.0,
                    length,
                    tol=rel_tol * length,
                    f_a=ends[0],
                    f_b=ends[1],
                )
                found.append((int(j), np.asarray(path(located.midpoint))))
                break
    return found
