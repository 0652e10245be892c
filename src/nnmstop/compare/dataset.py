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

from nnmstop.compare.matching import EnergyMatcher, orbit_differences
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
    }
    return ds


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
_ALIGNED = "over the period, on the phase t/T aligned at the turning point in contact"
_NOT_USED = "(error that interpolation alone would add; not present in this comparison)"
#: Variables of each matched pair's differences: name, long name, units.
DIFFERENCES = (
    ("frequency_exact", "frequency 1/T of the exact (non-smooth) orbit", "Hz"),
    ("frequency_regularized", "frequency omega/(2 pi) of the regularized HBM orbit", "Hz"),
    ("frequency_difference", "frequency of the regularized orbit minus frequency of the exact orbit", "Hz"),
    ("relative_frequency_difference", "frequency difference (regularized minus exact) over the exact one", "1"),
    ("max_x_difference", f"largest |x_regularized - x_exact| {_ALIGNED}", "1"),
    ("max_u_difference", f"largest |u_regularized - u_exact| {_ALIGNED}", "1"),
    ("max_xdot_difference", f"largest |xdot_regularized - xdot_exact| {_ALIGNED}", "1"),
    ("max_udot_difference", f"largest |udot_regularized - udot_exact| {_ALIGNED}", "1"),
    (
        "max_force_difference",
        "largest |f_HBM - f_piecewise(x_exact)|: regularized contact force from its Fourier coefficients vs the "
        f"piecewise-linear law (Eq. 4) evaluated on the exact orbit, {_ALIGNED}",
        "1",
    ),
    ("x_max_exact", "maximum of x over the exact orbit", "1"),
    ("u_max_exact", "maximum of |u| over the exact orbit", "1"),
    ("force_max_exact", "maximum of the piecewise-linear contact force over the exact orbit", "1"),
    (
        "regularized_origin_shift",
        "shift of the time origin of the HBM cosine series, in periods, that puts its turning point in contact "
        "at t = 0 (0: it is at t = 0; 0.5: at t = T/2)",
        "1",
    ),
)
#: Variables of each matched pair itself (attributes of :class:`~nnmstop.compare.matching.MatchedOrbits`).
PAIRS = (
    ("exact_energy", "total energy of the exact orbit (piecewise model), computed from its unknowns", "1"),
    ("regularized_energy", "total energy of the regularized HBM orbit (regularized model), period mean", "1"),
    ("exact_residual", "norm of the quarter-period equations of the exact orbit", "1"),
    ("regularized_residual", "norm of the HBM residual relative to the norm of the unknowns", "1"),
    (
        "interpolation_coefficient_shift",
        "largest difference between the matched HBM unknowns and their linear interpolation in energy between "
        f"the neighbouring branch points {_NOT_USED}",
        "1",
    ),
    (
        "interpolation_frequency_shift",
        "frequency of the linear interpolation between neighbouring branch points minus frequency of the matched "
        f"HBM orbit {_NOT_USED}",
        "Hz",
    ),
)
#: The exact orbit's unknowns, columns of ``MatchedOrbits.exact``.
EXACT_UNKNOWNS = (
    ("exact_xdot0", "exact orbit: velocity of x at x = u = 0"),
    ("exact_udot0", "exact orbit: velocity of u at x = u = 0"),
    ("exact_tau1", "exact orbit: free-flight duration tau1 of the quarter period"),
    ("exact_T1", "exact orbit: quarter period T1 (the turning point, t = 0 of the aligned phase)"),
)


def _matched(matcher: EnergyMatcher, energy: float, phase_samples: int, synthesis_cache: dict):
    """The matched pair at ``energy`` and its differences (the phase grid's synthesis shared by all pairs)."""
    pair = matcher.match(energy)
    diff = orbit_differences(pair, matcher.system, phase_samples, synthesis_cache)
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


def _column(values, long_name: str, units: str = "1") -> tuple:
    return ("point", np.asarray(values, dtype=float), {"long_name": long_name, "units": units})


def _difference_variables(rows, system) -> dict:
    data = {name: _column([d[name] for _, d in rows], text, units) for name, text, units in DIFFERENCES}
    data.update({name: _column([getattr(p, name) for p, _ in rows], text, units) for name, text, units in PAIRS})
    data["regularized_energy_spread"] = _column(
        [system.diagnostics(p.regularized)["energy_spread"] for p, _ in rows],
        "relative variation over the period of the energy of the regularized HBM orbit (HBM truncation)",
    )
    y = np.array([p.exact for p, _ in rows])
    data.update({name: _column(y[:, j], text) for j, (name, text) in enumerate(EXACT_UNKNOWNS)})
    return data


def _marked_variable(n: int, marks: dict) -> tuple:
    flags = np.zeros(n, dtype=np.int8)
    labels = list(marks)
    for j, label in enumerate(labels, start=1):
        flags[marks[label]] = j
    attrs = {
        "long_name": "labelled point of the paper's Figs 2-4 (0: not labelled)",
        "units": "1",
        "flag_values": np.arange(len(labels) + 1, dtype=np.int8),
        "flag_meanings": " ".join(["none"] + [f"point_{label}" for label in labels]),
    }
    return "point", flags, attrs


def _coordinates(system, energies) -> dict:
    one = "1"
    return {
        "point": ("point", np.arange(len(energies)), {"long_name": "index of the compared energy", "units": one}),
        "harmonic": (
            "harmonic",
            np.arange(system.H + 1),
            {"long_name": "harmonic number k (0 is the mean)", "units": one},
        ),
        "dof": ("dof", np.arange(system.n_dofs), {"long_name": "index of the degree of freedom", "units": one}),
        "dof_label": (
            "dof",
            np.array(system.structure.dof_labels, dtype=str),
            {"long_name": "name of the degree of freedom", "units": one},
        ),
        "stop": ("stop", np.arange(system.n_stops), {"long_name": "index of the stop", "units": one}),
        "energy": _column(energies, "matched total energy of the exact and regularized orbits"),
    }


def empty_comparison_dataset(branch: xr.Dataset, reason: str) -> xr.Dataset:
    """The comparison when there is none: no point, the structure of ``branch`` and ``reason`` (``end_reason``).

    The exact family and the regularized NNM1 share no energy where both are compared (their monotone parts
    do not overlap, for example where few harmonics stop the regularized branch before grazing): Figs 2-4 say
    so instead of drawing orbits.
    """
    one = "1"
    empty = np.zeros(0)
    data = {
        "frequency_exact": (
            "point",
            empty,
            {"long_name": "frequency 1/T of the exact (non-smooth) orbit", "units": "Hz"},
        ),
        "frequency_regularized": (
            "point",
            empty,
            {"long_name": "frequency omega/(2 pi) of the regularized HBM orbit", "units": "Hz"},
        ),
        "marked": (
            "point",
            np.zeros(0, dtype=np.int8),
            {
                "long_name": "labelled point of the paper's Figs 2-4 (0: not labelled)",
                "units": one,
                "flag_values": np.arange(1, dtype=np.int8),
                "flag_meanings": "none",
            },
        ),
    }
    coords = {
        "point": ("point", np.arange(0), {"long_name": "index of the compared energy", "units": one}),
        "energy": (
            "point",
            empty,
            {"long_name": "matched total energy of the exact and regularized orbits", "units": one},
        ),
    }
    keep = ("structure", "alpha", "beta", "delta", "eta", "dofs", "stops", "harmonics", "time_samples", "basis")
    attrs = {key: branch.attrs[key] for key in keep if key in branch.attrs}
    return xr.Dataset(data, coords=coords, attrs={**attrs, "skipped": 1, "end_reason": reason})
