r"""Slices of an atlas: the one-parameter exact response at one value of the second parameter, classified.

A slice is :func:`nnmstop.forced.responses.exact_response` at one force level (or one value of a structural
parameter), as the forced responses compute it. Read on a grid of frequencies, each frequency gets the
responses that exist there (every crossing of the response curve with that frequency), their stability and
whether they impact, and so its region (:data:`REGIONS`):

* ``no_contact``: one stable response, and it does not touch the stop;
* ``impacting``: one stable response, and it impacts;
* ``coexisting``: two or more stable responses (the jump between them, hysteresis);
* ``no_stable_periodic``: every periodic response there is unstable (quasi-periodic or chaotic motion, or a
  periodic response of another period);
* ``not_covered``: between the ends of one-contact families that end on a second contact per period: the
  responses with more contacts per period that connect them are beyond the exact solver (not computed).

The slice also keeps what the curves need: the located stability changes (their state, to seed the curves and
to check them) and the ends of the one-contact families (seeds of the second-contact boundary), and a thinned
set of its response points with their orbits (the explorer shows the orbit where one clicks).
Method note: ``docs/methods/atlas.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnmstop.bifurcation_atlas.equations import ORBIT_HARMONICS, exact_equations
from nnmstop.bifurcation_atlas.flags import END_KINDS, REGIONS
from nnmstop.bifurcation_atlas.parameters import with_parameters
from nnmstop.exact.forced import CONTACT_MARGINS, non_impacting_response
from nnmstop.forced.responses import ExactSettings, exact_response
from nnmstop.forced.stability_changes import KINDS

__all__ = [
    "REGIONS",
    "END_KINDS",
    "Slice",
    "compute_slice",
    "classify",
    "orbit_dofs",
    "piece_equations",
    "keep_points",
    "with_changes",
]

if END_KINDS != tuple(CONTACT_MARGINS):  # the flags of the datasets follow the exact formulation's margins
    raise ImportError(
        f"nnmstop.bifurcation_atlas.flags.END_KINDS {END_KINDS} differ from the contact margins "
        f"{tuple(CONTACT_MARGINS)}"
    )
#: Response points kept per piece for the explorer (with the points around every located change).
KEPT_POINTS = 120


def orbit_dofs(excitation) -> tuple:
    """The two DOFs whose orbits an atlas keeps: the first stop's (first) and the first forced one (x and u)."""
    return int(excitation.structure.stops[0].dofs[0]), int(excitation.force.dofs[0])


def piece_equations(at, piece):
    """The exact formulation (:func:`~nnmstop.bifurcation_atlas.equations.exact_equations`) of a contact family of
    the exact response at ``at``: one contact phase per period (or half period). ValueError for a family with
    more (several contacts grazing at once without the half-wave symmetry: a bilateral stop beside a
    one-sided one), which the atlas does not follow."""
    problem = piece.problem
    if problem.m != 2 or problem.episodes != 1:
        raise ValueError(
            f"the atlas follows responses with one contact phase per period (or half period); the family "
            f"'{problem.describe()}' of this structure has {problem.m} phases (several contacts graze at once "
            "without the half-wave symmetry): not yet"
        )
    return exact_equations(at, contact=problem.switches[0].contact)


@dataclass
class Slice:
    """One slice: the second parameter's value, the response points (frequency Hz, piece, impacting, stable,
    amplitudes of the two kept DOFs, multipliers, orbits), the located changes and the family ends."""

    value: float
    frequency: np.ndarray
    piece: np.ndarray
    impacting: np.ndarray
    stable: np.ndarray
    amplitude: np.ndarray
    multipliers: np.ndarray
    orbit: np.ndarray
    change_kind: np.ndarray
    change_state: np.ndarray
    end_kind: np.ndarray
    end_state: np.ndarray
    all_frequency: list
    all_stable: list
    all_impacting: list
    end_frequency: np.ndarray


def keep_points(n: int, changes) -> np.ndarray:
    """Indices of a piece's points kept for the explorer: evenly spread, the ends and both sides of each change."""
    kept = set(np.linspace(0, n - 1, min(n, KEPT_POINTS)).round().astype(int).tolist())
    for change in changes:
        kept.update(i for i in (change.after_point, change.after_point + 1) if 0 <= i < n)
    return np.array(sorted(kept), dtype=int)


def with_changes(frequencies, stable, changes):
    """A piece's frequencies (Hz) and verdicts with its located stability ``changes`` inserted where they lie: a
    fold's tip (the curve turns back between two stored points) and a change of verdict are then where they are,
    not at the nearer stored point. An inserted point takes the verdict of the point before it."""
    frequency, verdict = list(frequencies), list(stable)
    for change in sorted(changes, key=lambda c: c.after_point, reverse=True):
        k = change.after_point + 1
        frequency.insert(k, float(change.U[-1]) / (2 * np.pi))
        verdict.insert(k, verdict[k - 1])
    return np.array(frequency), np.array(verdict, dtype=bool)


def compute_slice(excitation, plane: str, value: float, frequency_range, settings: ExactSettings) -> Slice:
    """The exact response at the second parameter ``value`` (a force, or the structural parameter ``plane``)."""
    if plane == "force":
        at = excitation.with_amplitude(float(value))
    else:
        at = with_parameters(excitation, excitation.force.amplitude, plane, value)
    pieces = exact_response(at, frequency_range, settings)
    dofs = list(orbit_dofs(at))
    params = (0.0, at.force.amplitude, 0.0)
    kept = {name: [] for name in ("frequency", "piece", "impacting", "stable", "amplitude", "multipliers", "orbit")}
    change_kind, change_state, end_kind, end_state, end_frequency = [], [], [], [], []
    all_frequency, all_stable, all_impacting = [], [], []
    n_state = 2 * at.structure.n_dofs + 3
    for k, piece in enumerate(pieces):
        impacting = piece.kind == "one_contact"
        stable = np.all(np.abs(piece.multipliers) <= 1.0 + 1e-12, axis=1)
        frequency, verdict = with_changes(piece.frequency, stable, piece.changes)
        all_frequency.append(frequency)
        all_stable.append(verdict)
        all_impacting.append(np.full(len(frequency), impacting))
        index = keep_points(len(piece.frequency), piece.changes)
        kept["frequency"].append(piece.frequency[index])
        kept["piece"].append(np.full(len(index), k))
        kept["impacting"].append(np.full(len(index), impacting))
        kept["stable"].append(stable[index])
        kept["amplitude"].append(piece.amplitude[index][:, dofs])
        kept["multipliers"].append(piece.multipliers[index])
        if impacting:
            equations = piece_equations(at, piece)
            orbits = [equations.orbit(y[:-1], (y[-1],) + params[1:])[dofs] for y in piece.unknowns[index]]
        else:
            Q = non_impacting_response(at, 2 * np.pi * piece.frequency[index])[:, dofs]
            orbits = np.zeros((len(index), len(dofs), 2 * ORBIT_HARMONICS + 1))
            orbits[:, :, 1] = Q.real
            orbits[:, :, ORBIT_HARMONICS + 1] = -Q.imag
        kept["orbit"].append(np.asarray(orbits))
        for change in piece.changes:
            change_kind.append(KINDS.index(change.kind))
            change_state.append(change.U)
        reasons = piece.problem.margin_reasons if impacting else CONTACT_MARGINS
        margin = next((key for key, text in reasons.items() if text == piece.end_reason), None)
        if impacting and margin not in (None, "contact_duration"):
            end_kind.append(END_KINDS.index(margin))
            end_state.append(piece.unknowns[-1])
            end_frequency.append(piece.frequency[-1])
    return Slice(
        float(value),
        *(np.concatenate(kept[name]) for name in ("frequency", "piece", "impacting", "stable", "amplitude")),
        np.concatenate(kept["multipliers"]),
        np.concatenate(kept["orbit"]),
        np.array(change_kind, dtype=np.int8),
        np.array(change_state, dtype=float).reshape(-1, n_state),
        np.array(end_kind, dtype=np.int8),
        np.array(end_state, dtype=float).reshape(-1, n_state),
        all_frequency,
        all_stable,
        all_impacting,
        np.array(end_frequency, dtype=float),
    )


def classify(frequencies, stable, impacting, end_frequency, grid) -> dict:
    """Per grid frequency (Hz): the number of responses and of stable ones, and the region (:data:`REGIONS`).

    ``frequencies``, ``stable``, ``impacting``: one array per piece, in the order of its curve. A piece crosses a
    grid frequency between two consecutive points (half-open, so a shared end counts once); the crossing's
    verdict is that of the nearer point. ``end_frequency``: where one-contact families end on a second contact;
    the grid frequencies between the lowest and the highest of them are not covered.
    """
    grid = np.asarray(grid, dtype=float)
    count = np.zeros(len(grid), dtype=np.int32)
    count_stable = np.zeros(len(grid), dtype=np.int32)
    stable_impacting = np.zeros(len(grid), dtype=np.int32)
    for f, s, imp in zip(frequencies, stable, impacting):
        f = np.asarray(f, dtype=float)
        if len(f) < 2:
            continue
        lo, hi = np.minimum(f[:-1], f[1:]), np.maximum(f[:-1], f[1:])
        inside = (lo[None, :] <= grid[:, None]) & (grid[:, None] < hi[None, :])
        nearer_first = np.abs(grid[:, None] - f[None, :-1]) <= np.abs(grid[:, None] - f[None, 1:])
        verdict = np.where(nearer_first, s[None, :-1], s[None, 1:])
        count += inside.sum(axis=1)
        count_stable += (inside & verdict).sum(axis=1)
        stable_impacting += (inside & verdict & imp[None, :-1]).sum(axis=1)
    region = np.where(
        count == 0,
        REGIONS.index("not_covered"),
        np.where(
            count_stable >= 2,
            REGIONS.index("coexisting"),
            np.where(
                count_stable == 1,
                np.where(stable_impacting > 0, REGIONS.index("impacting"), REGIONS.index("no_contact")),
                REGIONS.index("no_stable_periodic"),
            ),
        ),
    )
    ends = np.asarray(end_frequency, dtype=float)
    if ends.size:
        low, high = ends.min(), ends.max()
        step = grid[1] - grid[0] if len(grid) > 1 else 0.0
        uncovered = (grid >= low - 0.5 * step) & (grid <= high + 0.5 * step)
        region = np.where(uncovered, REGIONS.index("not_covered"), region)
    return {
        "responses": count,
        "stable_responses": count_stable,
        "region": region.astype(np.int8),
    }
