"""The exact NNM1 against the regularized one: frequency at matched energy per impact regime.

Both branches are cut into impact regimes (:func:`impact_runs`: maximal runs of points
with the same number of impacts per period), the regimes are paired in branch order and
the exact frequency is interpolated at each regularized energy on the pieces of the exact
regime that are monotone in energy (:func:`monotone_pieces`).
:func:`compare_with_regularized` is the one implementation of this metric, behind
:mod:`nnmstop.compare.regimes` and ``python -m nnmstop.compare.exact_branches compare
EXACT.nc REGULARIZED.nc``.
"""

from __future__ import annotations

import argparse
import difflib

import numpy as np
import xarray as xr

__all__ = ["impact_runs", "monotone_pieces", "compare_with_regularized", "format_comparison", "main"]


def impact_runs(impacts) -> list:
    """Maximal runs of equal impact counts (the impact regimes of a branch): list of ``(count, start, stop)``."""
    impacts = np.asarray(impacts)
    edges = np.flatnonzero(np.diff(impacts)) + 1
    starts = np.concatenate([[0], edges])
    stops = np.concatenate([edges, [impacts.size]])
    return [(int(impacts[a]), int(a), int(b)) for a, b in zip(starts, stops)]


def monotone_pieces(energy) -> list:
    """Index ranges ``[a, b]`` (inclusive) on which ``energy`` is monotone."""
    d = np.sign(np.diff(energy))
    pieces, a = [], 0
    for i in range(1, d.size):
        if d[i] != d[i - 1] and d[i] != 0:
            pieces.append((a, i))
            a = i
    pieces.append((a, energy.size - 1))
    return [(a, b) for a, b in pieces if b > a]


def _check_branch_variables(name: str, ds: xr.Dataset) -> None:
    """Refuse a branch dataset that cannot be compared (missing variables, bad energies)."""
    missing = [v for v in ("energy", "frequency", "impacts_per_period") if v not in ds]
    if missing:
        raise ValueError(f"the {name} dataset lacks {missing}")
    for v in ("energy", "frequency"):
        values = np.asarray(ds[v].values, dtype=float)
        if not np.all(np.isfinite(values) & (values > 0)):
            raise ValueError(f"the {name} dataset's {v!r} must be finite and > 0 everywhere (it is matched in ln E)")


def _exact_frequency_at(ex, fx, er, fr) -> np.ndarray:
    """Exact frequency at each regularized energy of a regime (NaN where none covers it).

    Interpolated linearly in ``ln E`` on every piece of the exact regime that is monotone
    in energy and covers ``E``; of several candidates (energy folds), the one nearest to
    the regularized frequency is kept.
    """
    pieces = []
    for a, b in monotone_pieces(ex):
        order = np.argsort(ex[a : b + 1])
        energy = ex[a : b + 1][order]
        pieces.append((energy[0], energy[-1], np.log(energy), fx[a : b + 1][order]))
    out = np.full(er.size, np.nan)
    for k, (e, f) in enumerate(zip(er, fr)):
        cands = [np.interp(np.log(e), le, fp) for lo, hi, le, fp in pieces if lo <= e <= hi]
        if cands:
            out[k] = min(cands, key=lambda c: abs(c - f))
    return out


def compare_with_regularized(exact_ds: xr.Dataset, regularized_ds: xr.Dataset) -> list:
    """Frequency of the regularized NNM1 against the exact one at matched energy, per impact regime.

    Both branches are cut into *regimes*, maximal runs of points with the same number of
    impacts per period, and the regimes are paired in branch order (longest common
    subsequence of the impact counts; the single grazing orbit at the start of the exact
    branch and the linear regime of the regularized one have no partner). For each
    regularized point of a regime whose energy lies within the energy range of its exact
    partner, the exact frequency is interpolated (linearly in ``ln E``) on every piece of
    the exact regime that is monotone in energy and covers that energy; the piece of
    nearest frequency is kept (the regimes are not monotone in energy). Regularized points
    outside every such piece have no partner: they are counted (``unmatched``), not compared.

    Parameters
    ----------
    exact_ds : xarray.Dataset
        Exact branch (:func:`nnmstop.tasks.exact.build_multi_impact_dataset`): ``energy``, ``frequency``,
        ``impacts_per_period`` along ``point``, and ``phase_sequence`` if available.
    regularized_ds : xarray.Dataset
        Regularized branch (``results/hbm/nnm1.nc``): ``energy``, ``frequency``,
        ``impacts_per_period``.

    Returns
    -------
    list of dict
        One per paired regime: ``impacts``, ``exact_sequence``, ``exact_energy`` and
        ``regularized_energy`` (ranges), ``matched`` (number of regularized points
        compared), ``max_abs_error`` (Hz) and the regularized energy where it occurs
        (``energy_at_max``), ``median_abs_error``, ``mean_error`` (regularized minus exact,
        Hz), ``max_rel_error``; the exact and regularized energy and frequency ranges.
        The metrics are NaN for a regime with no matched point. The per-point data behind
        them: ``exact_points`` and ``regularized_points`` (index ranges ``(start, stop)``
        of the regime in each dataset), ``unmatched`` (regularized points of the regime
        not compared) and ``points``, a dict of arrays over the matched points:
        ``index`` (point of the regularized dataset), ``energy``, ``frequency``,
        ``exact_frequency``, ``error`` (regularized minus exact, Hz), ``rel_error``
        (``error`` over the exact frequency).

    Raises
    ------
    ValueError
        If a dataset lacks one of the variables above, or holds an energy or frequency
        that is not finite and positive.
    """
    for name, ds in (("exact", exact_ds), ("regularized", regularized_ds)):
        _check_branch_variables(name, ds)
    e_x, f_x = exact_ds["energy"].values, exact_ds["frequency"].values
    e_r, f_r = regularized_ds["energy"].values, regularized_ds["frequency"].values
    runs_x = [r for r in impact_runs(exact_ds["impacts_per_period"].values) if r[2] - r[1] > 1]
    runs_r = [r for r in impact_runs(regularized_ds["impacts_per_period"].values) if r[2] - r[1] > 1]
    seq_x = exact_ds["phase_sequence"].values if "phase_sequence" in exact_ds else None
    matcher = difflib.SequenceMatcher(a=[r[0] for r in runs_x], b=[r[0] for r in runs_r], autojunk=False)
    rows = []
    for block in matcher.get_matching_blocks():
        for i in range(block.size):
            cx, ax, bx = runs_x[block.a + i]
            _, ar, br = runs_r[block.b + i]
            sequence = "/".join(dict.fromkeys(seq_x[ax:bx])) if seq_x is not None else ""
            rows.append(_regime_row(cx, sequence, (ax, bx, e_x[ax:bx], f_x[ax:bx]), (ar, br, e_r[ar:br], f_r[ar:br])))
    return rows


def _regime_row(impacts: int, sequence: str, exact: tuple, regularized: tuple) -> dict:
    """The comparison of one paired regime (the row of :func:`compare_with_regularized`)."""
    ax, bx, ex, fx = exact
    ar, br, er, fr = regularized
    f_exact = _exact_frequency_at(ex, fx, er, fr)
    keep = np.isfinite(f_exact)
    err = fr[keep] - f_exact[keep]
    rel = err / f_exact[keep]
    n = int(keep.sum())
    worst = int(np.argmax(np.abs(err))) if n else 0
    return {
        "impacts": impacts,
        "exact_sequence": sequence,
        "exact_energy": (float(ex.min()), float(ex.max())),
        "regularized_energy": (float(er.min()), float(er.max())),
        "exact_frequency": (float(fx.min()), float(fx.max())),
        "regularized_frequency": (float(fr.min()), float(fr.max())),
        "matched": n,
        "max_abs_error": float(np.abs(err).max()) if n else np.nan,
        "energy_at_max": float(er[keep][worst]) if n else np.nan,
        "median_abs_error": float(np.median(np.abs(err))) if n else np.nan,
        "mean_error": float(err.mean()) if n else np.nan,
        "max_rel_error": float(np.abs(rel).max()) if n else np.nan,
        "exact_points": (ax, bx),
        "regularized_points": (ar, br),
        "unmatched": int(er.size - n),
        "points": {
            "index": np.arange(ar, br)[keep],
            "energy": er[keep],
            "frequency": fr[keep],
            "exact_frequency": f_exact[keep],
            "error": err,
            "rel_error": rel,
        },
    }


def format_comparison(rows: list) -> str:
    """The rows of :func:`compare_with_regularized` as a plain-text table."""
    head = (
        f"{'impacts':>7} {'exact':>7} {'exact energy':>17} {'regularized energy':>19} {'n':>4} "
        f"{'max|df| Hz':>10} {'at E':>8} {'median|df|':>10} {'mean df':>9} {'max|df|/f':>9}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['impacts']:>7d} {r['exact_sequence']:>7} {r['exact_energy'][0]:>8.4g}-{r['exact_energy'][1]:<8.4g} "
            f"{r['regularized_energy'][0]:>9.4g}-{r['regularized_energy'][1]:<9.4g} {r['matched']:>4d} "
            f"{r['max_abs_error']:>10.2e} {r['energy_at_max']:>8.4g} {r['median_abs_error']:>10.2e} "
            f"{r['mean_error']:>9.1e} {r['max_rel_error']:>9.2e}"
        )
    lines.append("df = regularized - exact frequency at the regularized energy (Hz of the nondimensional time)")
    return "\n".join(lines)


def main(argv=None) -> None:
    """Command line: ``python -m nnmstop.compare.exact_branches compare EXACT.nc REGULARIZED.nc``."""
    parser = argparse.ArgumentParser(
        prog="python -m nnmstop.compare.exact_branches", description=__doc__.splitlines()[0]
    )
    sub = parser.add_subparsers(dest="command", required=True)
    cmp_ = sub.add_parser("compare", help="regularization error of the frequency per impact regime")
    cmp_.add_argument("exact", help="exact branch, e.g. results/exact/nnm1.nc")
    cmp_.add_argument("regularized", help="regularized branch, e.g. results/hbm/nnm1.nc")
    args = parser.parse_args(argv)
    with xr.open_dataset(args.exact) as ex, xr.open_dataset(args.regularized) as reg:
        rows = compare_with_regularized(ex.load(), reg.load())
    print(format_comparison(rows))


if __name__ == "__main__":
    main()
