"""Regularization error of NNM1 in each impact regime, along the whole branch (issue 6).

The exact NNM1 of the non-smooth system (:mod:`nnmstop.exact`) and the
regularized NNM1 (HBM + ANM) cross the same sequence of impact regimes.
:func:`regime_error_dataset` turns the comparison of
:func:`nnmstop.compare.exact_branches.compare_with_regularized` (the one implementation of the
metric) into a labelled dataset:

* dimension ``regime``: one entry per pair of regimes with at least one compared point, in
  branch order: impact count, exact phase sequence(s), energy and frequency ranges of both
  sides, compared and left-out orbits, and the frequency error (regularized minus exact, at
  the regularized energy): largest absolute value and its energy, median, mean, largest
  relative value (:data:`REGIME_VARIABLES`);
* dimension ``point`` (optional): every compared regularized orbit (:data:`POINT_VARIABLES`).

Orbits without an exact partner are counted, never filled with NaN. Method notes (pairing,
interpolation in ``ln E``, where the largest error sits): ``docs/methods/compare.md``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from nnmstop.catalogue import describe
from nnmstop.compare.exact_branches import compare_with_regularized, impact_runs

__all__ = ["REGIME_VARIABLES", "POINT_VARIABLES", "regime_error_dataset", "regime_table"]

_EXACT_ATTRS = ("alpha", "beta", "delta")
_REGULARIZED_ATTRS = ("alpha", "beta", "delta", "eta", "harmonics")

#: Variables along ``regime``: name -> key of a row of ``compare_with_regularized`` (long names and units in the
#: variable catalogue, kind ``regime_errors``).
#: A key ``(name, k)`` takes element ``k`` of a (min, max) range.
REGIME_VARIABLES = {
    "impacts_per_period": "impacts",
    "exact_sequence": "exact_sequence",
    "exact_energy_min": ("exact_energy", 0),
    "exact_energy_max": ("exact_energy", 1),
    "regularized_energy_min": ("regularized_energy", 0),
    "regularized_energy_max": ("regularized_energy", 1),
    "exact_frequency_min": ("exact_frequency", 0),
    "exact_frequency_max": ("exact_frequency", 1),
    "regularized_frequency_min": ("regularized_frequency", 0),
    "regularized_frequency_max": ("regularized_frequency", 1),
    "n_matched": "matched",
    "n_unmatched": "unmatched",
    "max_abs_frequency_error": "max_abs_error",
    "energy_at_max_error": "energy_at_max",
    "median_abs_frequency_error": "median_abs_error",
    "mean_frequency_error": "mean_error",
    "max_rel_frequency_error": "max_rel_error",
}

_INTEGER_VARIABLES = ("impacts_per_period", "n_matched", "n_unmatched")

#: Variables along ``point``: name -> key of ``row["points"]``.
POINT_VARIABLES = {
    "regularized_index": "index",
    "energy": "energy",
    "frequency": "frequency",
    "exact_frequency": "exact_frequency",
    "frequency_error": "error",
    "relative_frequency_error": "rel_error",
}


def _attributes(exact: xr.Dataset, regularized: xr.Dataset) -> dict:
    """Model parameters and harmonics of the inputs, checked for consistency."""
    for name, ds, keys in (("exact", exact, _EXACT_ATTRS), ("regularized", regularized, _REGULARIZED_ATTRS)):
        missing = [k for k in keys if k not in ds.attrs]
        if missing:
            raise ValueError(f"the {name} dataset lacks the global attribute(s) {missing}")
    for key in _EXACT_ATTRS:
        a, b = float(exact.attrs[key]), float(regularized.attrs[key])
        if not np.isclose(a, b, rtol=1e-14, atol=0):
            raise ValueError(f"{key} differs between the exact ({a}) and the regularized ({b}) datasets")
    out = {key: float(exact.attrs[key]) for key in _EXACT_ATTRS}
    out["eta"] = float(regularized.attrs["eta"])
    out["harmonics"] = int(regularized.attrs["harmonics"])
    return out


def _unpaired_runs(regularized: xr.Dataset, rows: list) -> list:
    """Runs of the regularized branch (impacts, start, stop) that no row covers."""
    covered = {row["regularized_points"] for row in rows}
    return [r for r in impact_runs(regularized["impacts_per_period"].values) if (r[1], r[2]) not in covered]


def regime_error_dataset(exact: xr.Dataset, regularized: xr.Dataset, points: bool = True) -> xr.Dataset:
    """Regularization error of the frequency per impact regime, as a labelled dataset.

    Parameters
    ----------
    exact : xarray.Dataset
        Exact NNM1 (``results/exact/nnm1.nc``): variables ``energy``, ``frequency``,
        ``impacts_per_period``, ``phase_sequence``; global attributes ``alpha``,
        ``beta``, ``delta``.
    regularized : xarray.Dataset
        Regularized NNM1 (``results/hbm/nnm1.nc``): variables ``energy``, ``frequency``,
        ``impacts_per_period``; global attributes ``alpha``, ``beta``, ``delta``,
        ``eta``, ``harmonics``.
    points : bool
        Also store the compared orbits along dimension ``point``.

    Returns
    -------
    xarray.Dataset
        Dimension ``regime`` (variables of :data:`REGIME_VARIABLES`) and, if ``points``,
        dimension ``point`` (:data:`POINT_VARIABLES` and ``point_regime``, the index of
        the regime of each orbit). ``long_name`` and ``units`` on every variable, no NaN.
        Global attributes: the model parameters and ``harmonics``, the point counts
        (``regularized_points`` = ``matched_points`` + ``unmatched_points``; the latter
        are the ``n_unmatched`` of the regimes plus ``unpaired_points``, the orbits of
        regularized regimes with no compared orbit, listed in ``unpaired_regimes``) and
        ``method``.

    Raises
    ------
    ValueError
        If a dataset lacks a variable or attribute named above or the two disagree on ``alpha``, ``beta``
        or ``delta``. Where no regularized orbit has an exact partner the dataset has no regime and says so
        (``skipped``, ``end_reason``).

    Examples
    --------
    >>> import xarray as xr  # doctest: +SKIP
    >>> ds = regime_error_dataset(xr.load_dataset("results/exact/nnm1.nc"),
    ...                           xr.load_dataset("results/hbm/nnm1.nc"))  # doctest: +SKIP
    >>> ds[["impacts_per_period", "max_abs_frequency_error"]].to_dataframe()  # doctest: +SKIP
    """
    if "phase_sequence" not in exact:
        raise ValueError("the exact dataset lacks ['phase_sequence'] (it must be an exact multi-impact branch)")
    attrs = _attributes(exact, regularized)
    rows = compare_with_regularized(exact, regularized)
    compared = [row for row in rows if row["matched"] > 0]
    data, coords = _regime_variables(compared)
    point_data, point_coords = _point_variables(compared)
    ds = xr.Dataset({**data, **point_data}, coords={**coords, **point_coords})
    ds.attrs = {**attrs, **_count_attributes(exact, regularized, rows, compared), "method": METHOD}
    ds = describe(ds, "regime_errors")
    if not points:  # the catalogue describes the whole kind; the per-orbit part is left out afterwards
        ds = ds.drop_dims("point")
    if not compared:
        # no regularized orbit in the energy range of an exact regime of its impact count: nothing is compared,
        # and the dataset says so instead of holding NaN metrics
        ds.attrs.update(skipped=1, end_reason="no regularized orbit lies in the energy range of an exact orbit "
                        "with the same number of impacts per period: nothing to compare")  # fmt: skip
    return ds


#: How the regimes are compared (global attribute ``method``).
METHOD = (
    "Both branches are cut into runs of equal impacts per period (runs of a single orbit dropped), "
    "paired in branch order (longest common subsequence of the impact counts). At each regularized "
    "orbit of a paired regime, the exact frequency is interpolated linearly in ln E on the pieces of the "
    "exact regime monotone in energy that cover its energy, keeping the one of nearest frequency "
    "(nnmstop.compare.exact_branches.compare_with_regularized, also: python -m "
    "nnmstop.compare.exact_branches compare)."
)


def _regime_variables(compared: list) -> tuple[dict, dict]:
    data = {}
    for name, key in REGIME_VARIABLES.items():
        values = [row[key[0]][key[1]] if isinstance(key, tuple) else row[key] for row in compared]
        if name == "exact_sequence":
            array = np.array(values, dtype=object) if values else np.array([], dtype=str)
        else:
            array = np.array(values, dtype=np.int32 if name in _INTEGER_VARIABLES else float)
        data[name] = ("regime", array)
    coords = {
        "regime": (
            "regime",
            np.arange(len(compared), dtype=np.int32),
        ),
    }
    return data, coords


def _point_variables(compared: list) -> tuple[dict, dict]:
    data = {}
    for name, key in POINT_VARIABLES.items():
        values = np.concatenate([row["points"][key] for row in compared]) if compared else np.zeros(0)
        data[name] = (
            "point",
            values.astype(np.int32 if name == "regularized_index" else float),
        )
    regime = [np.full(row["matched"], k, dtype=np.int32) for k, row in enumerate(compared)]
    data["point_regime"] = (
        "point",
        np.concatenate(regime) if regime else np.zeros(0, dtype=np.int32),
    )
    n_points = int(data["point_regime"][1].size)
    coords = {
        "point": (
            "point",
            np.arange(n_points, dtype=np.int32),
        )
    }
    return data, coords


def _count_attributes(exact: xr.Dataset, regularized: xr.Dataset, rows: list, compared: list) -> dict:
    """Point counts, and the regularized regimes without a compared orbit (counted and named, not stored)."""
    # A paired regime without any orbit in the exact energy range has no error to report: it is
    # counted and named in the attributes rather than stored with NaN metrics.
    no_overlap = [row for row in rows if row["matched"] == 0]
    unpaired = _unpaired_runs(regularized, rows)
    n_regularized = int(regularized.sizes["point"])
    matched = int(sum(row["matched"] for row in compared))
    unpaired_text = [f"{c} impacts per period (regularized points {a}-{b - 1})" for c, a, b in unpaired]
    unpaired_text += [
        f"{row['impacts']} impacts per period (regularized points {row['regularized_points'][0]}-"
        f"{row['regularized_points'][1] - 1}; outside the energy range of the exact regime)"
        for row in no_overlap
    ]
    return {
        "exact_points": int(exact.sizes["point"]),
        "regularized_points": n_regularized,
        "matched_points": matched,
        "unmatched_points": n_regularized - matched,
        "unpaired_points": int(
            sum(b - a for _, a, b in unpaired)
            + sum(r["regularized_points"][1] - r["regularized_points"][0] for r in no_overlap)
        ),
        "unpaired_regimes": "; ".join(unpaired_text) if unpaired_text else "none",
    }


def regime_table(ds: xr.Dataset) -> pd.DataFrame:
    """The ``regime`` variables of :func:`regime_error_dataset` as a table (one row per regime).

    Parameters
    ----------
    ds : xarray.Dataset

    Returns
    -------
    pandas.DataFrame
        Indexed by ``regime``, columns in the order of :data:`REGIME_VARIABLES`.
    """
    missing = [name for name in REGIME_VARIABLES if name not in ds]
    if missing:
        raise ValueError(f"the dataset lacks {missing}: not a regime error dataset")
    return ds[list(REGIME_VARIABLES)].to_dataframe()
