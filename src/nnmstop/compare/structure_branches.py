"""Exact against regularized NNM of a structure: frequencies at matched energies.

:func:`first_crossing` reads a branch at an energy where it first reaches it (in branch order, linear
in energy between the two points that bracket it); :func:`compare_at_energies` does so on the exact
and the regularized branch at log-spaced energies of their common range and returns the labelled
comparison dataset.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nnmstop.catalogue import describe

__all__ = ["first_crossing", "compare_at_energies"]


def first_crossing(energy, values, target: float, segment=None, with_error: bool = False):
    """``values`` where the branch first reaches ``target`` energy, or NaN if it never does.

    ``segment`` (optional, per point) splits a branch continued over resonance tongues into its
    curves: two consecutive points of different segments bracket nothing. With ``with_error``, also an
    estimate of the error of the linear interpolation there: the quadratic term through the bracketing
    points and a neighbour on the same curve, ``|v[x0, x1, x2] (E - x0) (E - x1)|`` (NaN where there is none).
    It follows the stored points' spacing, which follows the continuation's steps: two builds whose points
    differ agree to the sum of their estimates.
    """
    energy, values = np.asarray(energy, float), np.asarray(values, float)
    below = energy[:-1] - target
    above = energy[1:] - target
    same = np.ones(len(energy) - 1, bool) if segment is None else np.diff(np.asarray(segment)) == 0
    hits = np.flatnonzero((below * above <= 0) & same)
    if hits.size == 0:
        return (float("nan"), float("nan")) if with_error else float("nan")
    i = hits[0]
    span = energy[i + 1] - energy[i]
    w = 0.0 if span == 0 else (target - energy[i]) / span
    value = float(values[i] + w * (values[i + 1] - values[i]))
    if not with_error:
        return value
    third = i - 1 if i > 0 and same[i - 1] else (i + 2 if i + 2 < len(energy) and same[i + 1] else None)
    error = float("nan")
    if third is not None:
        x = energy[[i, i + 1, third]]
        if len(set(x)) == 3:
            first = [(values[i + 1] - values[i]) / (x[1] - x[0]), (values[third] - values[i + 1]) / (x[2] - x[1])]
            error = abs((first[1] - first[0]) / (x[2] - x[0]) * (target - x[0]) * (target - x[1]))
    return value, error


def compare_at_energies(exact_energy, exact_frequency, energy, frequency, count: int, segment=None) -> xr.Dataset:
    """Frequencies of the exact and the regularized branch at ``count`` log-spaced common energies.

    ``segment``: the regularized branch's segments (:func:`first_crossing`).

    The common range runs from the larger to the smaller of the two branches' lowest and highest
    energies, with 1 % of it (in log energy) kept from both ends. Raises ValueError when the branches
    share no energy. ``exact_*`` is what the regularized branch should be compared with: for the exact
    one-stop family, its backbone (:func:`nnmstop.exact.dataset.one_stop_backbone`), not the internal
    resonance it may enter, whose harmonic is far beyond the regularized branch's.
    """
    if count == 0:  # nothing to compare (a structure without exact orbits): the empty comparison
        empty = np.zeros(0)
        ds = xr.Dataset(
            {
                name: ("energy", empty)
                for name in (
                    "exact_frequency",
                    "regularized_frequency",
                    "relative_difference",
                    "exact_interpolation_error",
                    "regularized_interpolation_error",
                )
            },
            coords={"energy": empty},
        )
        return describe(ds, "one_impact_comparison")
    low = max(np.min(exact_energy), np.min(energy))
    high = min(np.max(exact_energy), np.max(energy))
    if not high > low:
        raise ValueError(
            f"the exact ({np.min(exact_energy):.4g}..{np.max(exact_energy):.4g}) and regularized "
            f"({np.min(energy):.4g}..{np.max(energy):.4g}) branches share no energy range"
        )
    margin = (high / low) ** 0.01
    targets = np.geomspace(low * margin, high / margin, count)
    fe, de = np.array([first_crossing(exact_energy, exact_frequency, e, with_error=True) for e in targets]).T
    fr, dr = np.array([first_crossing(energy, frequency, e, segment, with_error=True) for e in targets]).T
    keep = np.isfinite(fe) & np.isfinite(fr)
    ds = xr.Dataset(
        {
            "exact_frequency": ("energy", fe[keep]),
            "regularized_frequency": ("energy", fr[keep]),
            "relative_difference": ("energy", (fr[keep] - fe[keep]) / fe[keep]),
            # where a branch has no third point on the curve, the estimate of the other branch's bracket is all
            "exact_interpolation_error": ("energy", np.nan_to_num(de[keep], nan=0.0)),
            "regularized_interpolation_error": ("energy", np.nan_to_num(dr[keep], nan=0.0)),
        },
        coords={"energy": targets[keep]},
    )
    return describe(ds, "one_impact_comparison")
