"""The comparison dataset of Section 4.1 (Figs 2-4): exact and regularized NNM1 at matched energies.

:func:`comparison_energies` picks log-spaced energies over the common range of an
:class:`~nnmstop.compare.matching.EnergyMatcher`, with the labelled points a) and b) added;
:func:`comparison_dataset` matches the two models at each of them
(:meth:`~nnmstop.compare.matching.EnergyMatcher.match`), measures their differences
(:func:`~nnmstop.compare.matching.orbit_differences`) and assembles the labelled dataset:
frequencies and their difference, largest differences of the fields over the period, both
orbits (exact unknowns and HBM Fourier coefficients in the layout of the branch datasets,
:func:`nnmstop.fourier.to_cos_sin`) and the labelled points. Reading the inputs and writing the
file: :func:`nnmstop.tasks.compare.build_comparison_dataset`. Method notes:
``docs/methods/compare.md``.
"""

from __future__ import annotations

import logging

import numpy as np
import xarray as xr

from nnmstop.catalogue import describe
from nnmstop.compare.matching import EnergyMatcher, orbit_differences, orbit_types
from nnmstop.hbm.dataset import ORBIT_COEFFICIENTS, orbit_variables

__all__ = ["comparison_energies", "comparison_dataset", "empty_comparison_dataset"]

logger = logging.getLogger("nnmstop.compare.dataset")


def comparison_energies(matcher: EnergyMatcher, count: int, marked: dict | None = None) -> tuple[np.ndarray, dict]:
    """Log-spaced energies over the common range, with the ``marked`` energies added.

    Parameters
    ----------
    matcher : EnergyMatcher
    count : int
        Number of log-spaced energies spanning :attr:`EnergyMatcher.energy_range` (>= 2).
    marked : dict, optional
        Label -> energy (for example ``{"a": 0.72, "b": 20.0}``) or ``{"energy_fraction": r}`` (the energy at
        the fraction ``r`` of the range, in log energy), each inside the range.

    Returns
    -------
    energies : ndarray
        Sorted, unique.
    marks : dict
        Label -> index into ``energies``.
    """
    if int(count) != count or count < 2:
        raise ValueError(f"the number of compared energies must be an integer >= 2, got {count!r}")
    marked = dict(marked or {})
    low, high = matcher.energy_range
    # a point is an energy, or a fraction of the common range in log energy (a scene that follows the data)
    at = {
        label: e
        if not isinstance(e, dict)
        else float(low ** (1.0 - e["energy_fraction"]) * high ** e["energy_fraction"])
        for label, e in marked.items()
    }
    values = {label: matcher.check_energy(e) for label, e in at.items()}
    grid = np.geomspace(*matcher.energy_range, int(count))
    energies = np.unique(np.concatenate([grid, list(values.values())]))
    marks = {label: int(np.flatnonzero(energies == e)[0]) for label, e in values.items()}
    return energies, marks


def comparison_dataset(
    exact: xr.Dataset,
    branch: xr.Dataset,
    count: int = 48,
    marked: dict | None = None,
    phase_samples: int = 4096,
    end_margin: float = 0.01,
) -> xr.Dataset:
    """Compare the exact and regularized NNM1 at matched energies; labelled dataset.

    Parameters
    ----------
    exact : xarray.Dataset
        Exact two-impact family.
    branch : xarray.Dataset
        Regularized NNM1 (stage 1 or more) dataset.
    count : int
        Number of log-spaced energies over the common range.
    marked : dict, optional
        Labelled energies (``{"a": E_a, "b": E_b}``), added to the grid and flagged in the
        variable ``marked`` (1 for the first label, 2 for the second, ...).
    phase_samples : int
        Phases per period on which the orbit differences are maximized.
    end_margin : float
        Relative margin from the ends of the common energy range.

    Returns
    -------
    xarray.Dataset
        Dimensions ``point`` (compared energies, increasing) and ``harmonic``.
    """
    matcher = EnergyMatcher(exact, branch, end_margin)
    energies, marks = comparison_energies(matcher, count, marked)
    cache = {}  # the phase grid's synthesis, shared by all the pairs
    rows = [_matched(matcher, energy, phase_samples, cache) for energy in energies]
    system = matcher.system
    data = _difference_variables(rows, system)
    data.update(_type_variables(rows))
    data["marked"] = _marked_variable(len(energies), marks)
    # the regularized orbits, in the layout of the branch datasets (for nnmstop.figures.common.orbit)
    orbit_data = orbit_variables(system, np.array([pair.regularized for pair, _ in rows]))
    data.update({name: orbit_data[name] for name in ORBIT_COEFFICIENTS})
    ds = xr.Dataset(data, coords=_coordinates(system, energies))
    ds.attrs = {
        **system.structure.attributes,
        "harmonics": system.H,
        "time_samples": system.M,
        "basis": system.basis,
        "phase_samples": int(phase_samples),
        "end_margin": float(end_margin),
        "energy_range_min": matcher.energy_range[0],
        "energy_range_max": matcher.energy_range[1],
        "exact_arm_first_point": int(matcher.exact_arm.start),
        "regularized_last_point": int(matcher.regularized_part.stop - 1),
        "matching": MATCHING,
        "alignment": ALIGNMENT,
        **{f"point_{label}_energy": float(energies[i]) for label, i in marks.items()},
        "counterparts": COUNTERPARTS,
    }
    for label, i in marks.items():
        if rows[i][1]["why"]:
            ds.attrs[f"point_{label}_counterpart"] = rows[i][1]["why"]
    return describe(ds, "exact_vs_regularized")


#: Which orbits are compared (global attribute ``counterparts``).
COUNTERPARTS = (
    "only orbits of one type: the same impacts per period at the stop and the same dominant and tongue harmonics "
    "of the mass-weighted motion (nnmstop.compare.matching.orbit_types); where the regularized orbit at the exact "
    "orbit's energy is of another type (an internal resonance tongue, no contact), it is no counterpart: "
    "counterpart says why and the differences are missing"
)
#: How the orbits are matched and aligned (global attributes of the comparison).
MATCHING = (
    "Newton's method at fixed energy on both sides: exact closed-form quarter-period equations plus energy; "
    "HBM equations plus mean energy over the period. Exact family: increasing arm from its energy minimum; "
    "regularized branch: leading points with increasing energy and at most two impacts per period."
)
ALIGNMENT = (
    "phase t/T of each orbit, origin on the symmetry axis where both velocities vanish in contact with the stop "
    "x = +1 (exact: t = T1; HBM cosine series: t = 0 or T/2)"
)
#: Variables of each matched pair's differences (:func:`~nnmstop.compare.matching.orbit_differences`); long
#: names and units in the variable catalogue (kind ``exact_vs_regularized``).
DIFFERENCES = (
    "frequency_exact",
    "frequency_regularized",
    "frequency_difference",
    "relative_frequency_difference",
    "max_x_difference",
    "max_u_difference",
    "max_xdot_difference",
    "max_udot_difference",
    "max_force_difference",
    "x_max_exact",
    "u_max_exact",
    "force_max_exact",
    "regularized_origin_shift",
)
#: Variables of each matched pair itself (attributes of :class:`~nnmstop.compare.matching.MatchedOrbits`).
PAIRS = (
    "exact_energy",
    "regularized_energy",
    "exact_residual",
    "regularized_residual",
    "interpolation_coefficient_shift",
    "interpolation_frequency_shift",
)
#: The exact orbit's unknowns, columns of ``MatchedOrbits.exact``.
EXACT_UNKNOWNS = ("exact_xdot0", "exact_udot0", "exact_tau1", "exact_T1")


#: The types of each pair (:func:`~nnmstop.compare.matching.orbit_types`), variables of the dataset.
TYPES = (
    "exact_impacts_per_period",
    "regularized_contacts_per_period",
    "exact_dominant_harmonic",
    "regularized_dominant_harmonic",
    "exact_tongue_harmonic",
    "regularized_tongue_harmonic",
)


def _matched(matcher: EnergyMatcher, energy: float, phase_samples: int, synthesis_cache: dict):
    """The matched pair at ``energy``, its types and, between like orbits, its differences (the phase grid's
    synthesis shared by all pairs); between orbits of different types the differences are NaN."""
    pair = matcher.match(energy)
    types = orbit_types(pair, matcher.system)
    if types["counterpart"]:
        logger.info("%s", types["why"])
        frequency_exact = 1.0 / (4.0 * pair.exact[3])
        missing = {name: np.nan for name in DIFFERENCES}
        missing.update(
            frequency_exact=frequency_exact, frequency_regularized=float(matcher.system.frequency_hz(pair.regularized))
        )
        return pair, {**missing, **types}
    diff = {**orbit_differences(pair, matcher.system, phase_samples, synthesis_cache), **types}
    logger.info(
        "E = %.6g: frequency exact %.8f Hz, regularized %.8f Hz (relative difference %+.3e); max |dx| %.3e, "
        "|du| %.3e, |df| %.3e",
        energy,
        diff["frequency_exact"],
        diff["frequency_regularized"],
        diff["relative_frequency_difference"],
        diff["max_x_difference"],
        diff["max_u_difference"],
        diff["max_force_difference"],
    )
    return pair, diff


def _column(values) -> tuple:
    return "point", np.asarray(values, dtype=float)


def _difference_variables(rows, system) -> dict:
    data = {name: _column([d[name] for _, d in rows]) for name in DIFFERENCES}
    data.update({name: _column([getattr(p, name) for p, _ in rows]) for name in PAIRS})
    data["regularized_energy_spread"] = _column([system.diagnostics(p.regularized)["energy_spread"] for p, _ in rows])
    y = np.array([p.exact for p, _ in rows])
    data.update({name: _column(y[:, j]) for j, name in enumerate(EXACT_UNKNOWNS)})
    return data


def _type_variables(rows) -> dict:
    data = {name: ("point", np.array([d[name] for _, d in rows], dtype=np.int32)) for name in TYPES}
    data["counterpart"] = ("point", np.array([d["counterpart"] for _, d in rows], dtype=np.int8))
    return data


def _marked_variable(n: int, marks: dict) -> tuple:
    """1 at the first labelled point, 2 at the second (the catalogue names them point_a, point_b)."""
    flags = np.zeros(n, dtype=np.int8)
    for j, label in enumerate(marks, start=1):
        flags[marks[label]] = j
    return "point", flags


def _coordinates(system, energies) -> dict:
    return {
        "point": np.arange(len(energies)),
        "harmonic": np.arange(system.H + 1),
        "dof": np.arange(system.n_dofs),
        "dof_label": ("dof", np.array(system.structure.dof_labels, dtype=str)),
        "stop": np.arange(system.n_stops),
        "energy": _column(energies),
    }


def empty_comparison_dataset(branch: xr.Dataset, reason: str) -> xr.Dataset:
    """The comparison when there is none: no point, the structure of ``branch`` and ``reason`` (``end_reason``).

    The exact family and the regularized NNM1 share no energy where both are compared (their monotone parts
    do not overlap, for example where few harmonics stop the regularized branch before grazing): Figs 2-4 say
    so instead of drawing orbits. Kind ``no_comparison`` of the variable catalogue.
    """
    empty = np.zeros(0)
    data = {"frequency_exact": ("point", empty), "frequency_regularized": ("point", empty)}
    data["marked"] = ("point", np.zeros(0, dtype=np.int8))
    coords = {"point": np.arange(0), "energy": ("point", empty)}
    keep = ("structure", "alpha", "beta", "delta", "eta", "dofs", "stops", "harmonics", "time_samples", "basis")
    attrs = {key: branch.attrs[key] for key in keep if key in branch.attrs}
    return describe(
        xr.Dataset(data, coords=coords, attrs={**attrs, "skipped": 1, "end_reason": reason}), "no_comparison"
    )
