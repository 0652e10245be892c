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

__all__ = ["first_crossing", "compare_at_energies", "like_exact_family"]


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


def compare_at_energies(
    exact_energy, exact_frequency, energy, frequency, count: int, segment=None, comparable=None
) -> xr.Dataset:
    """Frequencies of the exact and the regularized branch at ``count`` log-spaced common energies.

    ``segment``: the regularized branch's segments (:func:`first_crossing`). ``comparable`` (optional, per
    regularized point): whether the orbit is of the exact family's type (:func:`like_exact_family`); where the
    regularized branch first reaches an energy between two points not both comparable, it has no counterpart
    there: ``no_counterpart`` is 1 and the difference missing. Each frequency carries the estimate of its linear
    interpolation's error (``*_interpolation_error``, :func:`first_crossing`).

    The common range runs from the larger to the smaller of the two branches' lowest and highest
    energies, with 1 % of it (in log energy) kept from both ends. Where the branches share no energy (one of them
    has no orbit, or their ranges do not meet) the dataset holds none and says why (attributes ``skipped`` and
    ``end_reason``). ``exact_*`` is what the regularized branch should be compared with: for the exact one-stop
    family, its backbone (:func:`nnmstop.exact.dataset.one_stop_backbone`), not the internal resonance it may
    enter, whose harmonic is far beyond the regularized branch's.
    """
    if len(exact_energy) == 0 or len(energy) == 0:
        reason = f"the {'exact' if len(exact_energy) == 0 else 'regularized'} branch has no orbit"
    else:
        low, high = max(np.min(exact_energy), np.min(energy)), min(np.max(exact_energy), np.max(energy))
        reason = "" if high > low else (
            f"the exact ({np.min(exact_energy):.4g}..{np.max(exact_energy):.4g}) and regularized "
            f"({np.min(energy):.4g}..{np.max(energy):.4g}) branches share no energy range"
        )  # fmt: skip
    if reason:  # nothing to compare: a dataset with no energy that says why (the figures say it too)
        empty = {name: ("energy", np.zeros(0)) for name in _FREQUENCY_VARIABLES}
        empty.update(no_counterpart=("energy", np.zeros(0, np.int8)))
        ds = xr.Dataset(empty, coords={"energy": np.zeros(0)}, attrs={"skipped": 1, "end_reason": reason})
        return describe(ds, "one_impact_comparison")
    margin = (high / low) ** 0.01
    targets = np.geomspace(low * margin, high / margin, count)
    fe, de = np.array([first_crossing(exact_energy, exact_frequency, e, with_error=True) for e in targets]).T
    fr, dr = np.array([first_crossing(energy, frequency, e, segment, with_error=True) for e in targets]).T
    like = np.ones(targets.size, dtype=bool)
    if comparable is not None:  # both points bracketing the first crossing comparable (the minimum of 0/1 flags)
        like = np.array([first_crossing(energy, np.asarray(comparable, float), e, segment) == 1 for e in targets])
    keep = np.isfinite(fe) & np.isfinite(fr)
    difference = np.where(like, (fr - fe) / fe, np.nan)
    ds = xr.Dataset(
        {
            "exact_frequency": ("energy", fe[keep]),
            "regularized_frequency": ("energy", fr[keep]),
            "relative_difference": ("energy", difference[keep]),
            "no_counterpart": ("energy", (~like[keep]).astype(np.int8)),
            # where a branch has no third point on the curve, the estimate of the other branch's bracket is all
            "exact_interpolation_error": ("energy", np.nan_to_num(de[keep], nan=0.0)),
            "regularized_interpolation_error": ("energy", np.nan_to_num(dr[keep], nan=0.0)),
        },
        coords={"energy": targets[keep]},
    )
    return describe(ds, "one_impact_comparison")


#: The frequency variables of a comparison (and the relative difference and interpolation errors).
_FREQUENCY_VARIABLES = (
    "exact_frequency",
    "regularized_frequency",
    "relative_difference",
    "exact_interpolation_error",
    "regularized_interpolation_error",
)


def like_exact_family(nnm1: xr.Dataset, struck_stop: int) -> np.ndarray:
    """Per point of a regularized NNM1, whether its orbit is of the type of the exact one-stop family's
    backbone: NNM1 at its own frequency (:mod:`nnmstop.hbm.identity`, ``orbit_kind`` 0, ``dominant_mode`` 1), and
    no stop struck but ``struck_stop`` (``stop_impacts``). All true where the dataset holds no identity."""
    like = np.ones(nnm1.sizes["point"], dtype=bool)
    if "orbit_kind" in nnm1:
        like &= (nnm1["orbit_kind"].values == 0) & (nnm1["dominant_mode"].values == 1)
    if "stop_impacts" in nnm1 and nnm1.sizes.get("stop", 1) > 1:
        others = np.delete(nnm1["stop_impacts"].values, struck_stop, axis=1)
        like &= np.all(others == 0, axis=1)
    return like
