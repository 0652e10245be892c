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
    system = matcher.system
    rows, orbits = [], []
    synthesis_cache = {}  # the phase grid's synthesis, shared by all the pairs
    for energy in energies:
        pair = matcher.match(energy)
        diff = orbit_differences(pair, system, phase_samples, synthesis_cache)
        rows.append((pair, diff))
        orbits.append(pair.regularized)
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
    n = len(energies)
    one = "1"
    hz = "Hz"

    def col(values, long_name, units=one, dtype=float, **extra):
        return ("point", np.asarray(values, dtype=dtype), {"long_name": long_name, "units": units, **extra})

    def pairs(attr):
        return [getattr(p, attr) for p, _ in rows]

    def diffs(key):
        return [d[key] for _, d in rows]

    y = np.array(pairs("exact"))
    aligned = "over the period, on the phase t/T aligned at the turning point in contact"
    not_used = "(error that interpolation alone would add; not present in this comparison)"
    from_diffs = (
        ("frequency_exact", "frequency 1/T of the exact (non-smooth) orbit", hz),
        ("frequency_regularized", "frequency omega/(2 pi) of the regularized HBM orbit", hz),
        ("frequency_difference", "frequency of the regularized orbit minus frequency of the exact orbit", hz),
        ("relative_frequency_difference", "frequency difference (regularized minus exact) over the exact one", one),
        ("max_x_difference", f"largest |x_regularized - x_exact| {aligned}", one),
        ("max_u_difference", f"largest |u_regularized - u_exact| {aligned}", one),
        ("max_xdot_difference", f"largest |xdot_regularized - xdot_exact| {aligned}", one),
        ("max_udot_difference", f"largest |udot_regularized - udot_exact| {aligned}", one),
        (
            "max_force_difference",
            "largest |f_HBM - f_piecewise(x_exact)|: regularized contact force from its Fourier coefficients vs the "
            f"piecewise-linear law (Eq. 4) evaluated on the exact orbit, {aligned}",
            one,
        ),
        ("x_max_exact", "maximum of x over the exact orbit", one),
        ("u_max_exact", "maximum of |u| over the exact orbit", one),
        ("force_max_exact", "maximum of the piecewise-linear contact force over the exact orbit", one),
        (
            "regularized_origin_shift",
            "shift of the time origin of the HBM cosine series, in periods, that puts its turning point in contact "
            "at t = 0 (0: it is at t = 0; 0.5: at t = T/2)",
            one,
        ),
    )
    from_pairs = (
        ("exact_energy", "total energy of the exact orbit (piecewise model), computed from its unknowns", one),
        ("regularized_energy", "total energy of the regularized HBM orbit (regularized model), period mean", one),
        ("exact_residual", "norm of the quarter-period equations of the exact orbit", one),
        ("regularized_residual", "norm of the HBM residual relative to the norm of the unknowns", one),
        (
            "interpolation_coefficient_shift",
            "largest difference between the matched HBM unknowns and their linear interpolation in energy between "
            f"the neighbouring branch points {not_used}",
            one,
        ),
        (
            "interpolation_frequency_shift",
            "frequency of the linear interpolation between neighbouring branch points minus frequency of the matched "
            f"HBM orbit {not_used}",
            hz,
        ),
    )
    data = {name: col(diffs(name), long_name, units) for name, long_name, units in from_diffs}
    data.update({name: col(pairs(name), long_name, units) for name, long_name, units in from_pairs})
    data["regularized_energy_spread"] = col(
        [system.diagnostics(p.regularized)["energy_spread"] for p, _ in rows],
        "relative variation over the period of the energy of the regularized HBM orbit (HBM truncation)",
    )
    exact_names = (
        ("exact_xdot0", "exact orbit: velocity of x at x = u = 0"),
        ("exact_udot0", "exact orbit: velocity of u at x = u = 0"),
        ("exact_tau1", "exact orbit: free-flight duration tau1 of the quarter period"),
        ("exact_T1", "exact orbit: quarter period T1 (the turning point, t = 0 of the aligned phase)"),
    )
    data.update({name: col(y[:, j], long_name) for j, (name, long_name) in enumerate(exact_names)})
    flags = np.zeros(n, dtype=np.int8)
    labels = list(marks)
    for j, label in enumerate(labels, start=1):
        flags[marks[label]] = j
    data["marked"] = (
        "point",
        flags,
        {
            "long_name": "labelled point of the paper's Figs 2-4 (0: not labelled)",
            "units": one,
            "flag_values": np.arange(len(labels) + 1, dtype=np.int8),
            "flag_meanings": " ".join(["none"] + [f"point_{label}" for label in labels]),
        },
    )
    # the regularized orbits, in the layout of the branch datasets (for nnmstop.figures.common.orbit)
    H = system.H
    orbit_data = orbit_variables(system, np.array(orbits))
    data.update({name: orbit_data[name] for name in ORBIT_COEFFICIENTS})
    coords = {
        "point": ("point", np.arange(n), {"long_name": "index of the compared energy", "units": one}),
        "harmonic": ("harmonic", np.arange(H + 1), {"long_name": "harmonic number k (0 is the mean)", "units": one}),
        "dof": ("dof", np.arange(system.n_dofs), {"long_name": "index of the degree of freedom", "units": one}),
        "dof_label": (
            "dof",
            np.array(system.structure.dof_labels, dtype=str),
            {"long_name": "name of the degree of freedom", "units": one},
        ),
        "stop": ("stop", np.arange(system.n_stops), {"long_name": "index of the stop", "units": one}),
        "energy": col(energies, "matched total energy of the exact and regularized orbits"),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs = {
        **system.structure.attributes,
        "harmonics": H,
        "time_samples": system.M,
        "basis": system.basis,
        "phase_samples": int(phase_samples),
        "end_margin": float(end_margin),
        "energy_range_min": matcher.energy_range[0],
        "energy_range_max": matcher.energy_range[1],
        "exact_arm_first_point": int(matcher.exact_arm.start),
        "regularized_last_point": int(matcher.regularized_part.stop - 1),
        "matching": (
            "Newton's method at fixed energy on both sides: exact closed-form quarter-period equations plus energy; "
            "HBM equations plus mean energy over the period. Exact family: increasing arm from its energy minimum; "
            "regularized branch: leading points with increasing energy and at most two impacts per period."
        ),
        "alignment": (
            "phase t/T of each orbit, origin on the symmetry axis where both velocities vanish and x is maximum "
            "(exact: t = T1; HBM cosine series: t = 0 or T/2)"
        ),
        **{f"point_{label}_energy": float(energies[i]) for label, i in marks.items()},
    }
    return ds


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
