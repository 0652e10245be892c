"""Stability of the exact NNM1 against the regularized NNM1, per impact regime (issue 13, part 3).

Both branches carry a Floquet verdict ``stable`` per orbit: the exact one from
:mod:`nnmstop.exact.stability`, the regularized one from the HBM datasets (whatever
method produced it; an optional ``stability_resolved = 0`` marks an orbit without a
verdict). The regimes are paired as in :func:`nnmstop.compare.exact_branches.compare_with_regularized`
(the one implementation of the pairing). For every compared regularized orbit of a regime,
the exact verdict at the same energy is read on the exact regime (same monotone piece and
nearest frequency as the frequency comparison); an orbit whose energy falls between two
exact orbits of different verdicts sits at an exact stability change and is not counted
either way. Stability changes along each branch are located between consecutive orbits
(no interpolation: the reported energies bracket the change) and the changes of the two
branches in a regime are paired in branch order when they are equally many and go the
same way, to give the shift of each change with the regularization.
Method notes: ``docs/methods/compare.md``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from nnmstop.catalogue import describe
from nnmstop.compare.exact_branches import compare_with_regularized, monotone_pieces

__all__ = [
    "REGIME_COLUMNS",
    "verdicts",
    "stability_changes",
    "exact_verdict_at",
    "compare_stability",
    "stability_comparison_dataset",
    "stability_table",
]

#: Verdict codes along a branch.
UNSTABLE, STABLE, NO_VERDICT = 0, 1, -1

#: Columns of the regime table (long names and units in the variable catalogue, kind ``stability_comparison``).
REGIME_COLUMNS = (
    "impacts_per_period",
    "exact_sequence",
    "n_compared",
    "n_agree",
    "n_both_stable",
    "n_both_unstable",
    "n_exact_stable_only",
    "n_regularized_stable_only",
    "n_no_regularized_verdict",
    "n_at_exact_change",
    "agreement",
    "disagreement_energies",
    "n_exact_changes",
    "n_regularized_changes",
    "exact_change_energies",
    "regularized_change_energies",
)

_INTEGER = tuple(c for c in REGIME_COLUMNS if c == "impacts_per_period" or c.startswith("n_"))


def verdicts(ds: xr.Dataset) -> np.ndarray:
    """Verdict per orbit: 1 stable, 0 unstable, -1 none (``stability_resolved = 0`` if present)."""
    if "stable" not in ds:
        raise ValueError("the dataset lacks the Floquet flag 'stable'")
    out = ds["stable"].values.astype(np.int8)
    if np.any((out != 0) & (out != 1)):
        raise ValueError(f"'stable' must hold 0 or 1, got {sorted(set(out.tolist()))}")
    if "stability_resolved" in ds:
        out = np.where(ds["stability_resolved"].values.astype(bool), out, NO_VERDICT).astype(np.int8)
    return out


def stability_changes(energy, frequency, verdict) -> list:
    """Changes of the verdict along a branch, between consecutive orbits with a verdict.

    Returns
    -------
    list of dict
        ``before``, ``after`` (indices of the bracketing orbits), ``energy_before``,
        ``energy_after``, ``energy`` (their geometric mean), ``frequency`` (mean),
        ``becomes`` (``"stable"`` or ``"unstable"`` in branch order).
    """
    energy, frequency, verdict = (np.asarray(a) for a in (energy, frequency, verdict))
    known = np.flatnonzero(verdict != NO_VERDICT)
    out = []
    for a, b in zip(known, known[1:]):
        if verdict[a] != verdict[b]:
            out.append(
                {
                    "before": int(a),
                    "after": int(b),
                    "energy_before": float(energy[a]),
                    "energy_after": float(energy[b]),
                    "energy": float(np.sqrt(energy[a] * energy[b])),
                    "frequency": float(0.5 * (frequency[a] + frequency[b])),
                    "becomes": "stable" if verdict[b] == STABLE else "unstable",
                }
            )
    return out


def exact_verdict_at(energy, frequency, verdict, e, f) -> int:
    """Exact verdict at energy ``e`` on a regime (``energy``, ``frequency``, ``verdict`` of its orbits).

    Among the pieces of the regime monotone in energy that cover ``e``, the one whose
    frequency (linear in ``ln E``) is nearest to ``f``; the verdict of its two orbits
    bracketing ``e`` if they agree, ``NO_VERDICT`` if they differ (a change lies between
    them) or no piece covers ``e``.
    """
    best = None
    for a, b in monotone_pieces(energy):
        en = energy[a : b + 1]
        order = np.argsort(en)
        en, fr, ve = en[order], frequency[a : b + 1][order], verdict[a : b + 1][order]
        if not en[0] <= e <= en[-1]:
            continue
        k = int(np.clip(np.searchsorted(en, e), 1, en.size - 1))
        f_here = np.interp(np.log(e), np.log(en), fr)
        v = int(ve[k - 1]) if ve[k - 1] == ve[k] else NO_VERDICT
        if best is None or abs(f_here - f) < best[0]:
            best = (abs(f_here - f), v)
    return NO_VERDICT if best is None else best[1]


def _intervals(energy, flags) -> str:
    """``"E1-E2; E3-E4"``: energy ranges of the runs of consecutive True flags."""
    parts, start = [], None
    for k, flag in enumerate(list(flags) + [False]):
        if flag and start is None:
            start = k
        elif not flag and start is not None:
            seg = energy[start:k]
            parts.append(f"{seg.min():.4g}-{seg.max():.4g}" if k - start > 1 else f"{seg[0]:.4g}")
            start = None
    return "; ".join(parts) if parts else "none"


def compare_stability(exact_ds: xr.Dataset, regularized_ds: xr.Dataset) -> tuple:
    """Agreement of the verdicts per paired impact regime, and the stability changes of both.

    Parameters
    ----------
    exact_ds, regularized_ds : xarray.Dataset
        Branches with ``energy``, ``frequency``, ``impacts_per_period`` and ``stable``
        (the regularized one optionally ``stability_resolved``).

    Returns
    -------
    rows : list of dict
        One per paired regime with the keys of :data:`REGIME_COLUMNS`.
    pairs : list of dict
        Stability changes paired between the two branches: ``regime``, ``becomes``,
        ``exact_energy``, ``regularized_energy``, ``exact_frequency``,
        ``regularized_frequency``, ``energy_ratio`` (regularized over exact).
    """
    v_x, v_r = verdicts(exact_ds), verdicts(regularized_ds)
    e_x, f_x = exact_ds["energy"].values, exact_ds["frequency"].values
    e_r, f_r = regularized_ds["energy"].values, regularized_ds["frequency"].values
    rows, pairs = [], []
    for k, row in enumerate(compare_with_regularized(exact_ds, regularized_ds)):
        ax, bx = row["exact_points"]
        ar, br = row["regularized_points"]
        idx = row["points"]["index"]
        reg = v_r[idx]
        ex = np.array([exact_verdict_at(e_x[ax:bx], f_x[ax:bx], v_x[ax:bx], e_r[i], f_r[i]) for i in idx], dtype=int)
        both = (reg != NO_VERDICT) & (ex != NO_VERDICT)
        agree = both & (reg == ex)
        changes_x = stability_changes(e_x[ax:bx], f_x[ax:bx], v_x[ax:bx])
        changes_r = stability_changes(e_r[ar:br], f_r[ar:br], v_r[ar:br])
        n = int(both.sum())
        rows.append(
            {
                "impacts_per_period": row["impacts"],
                "exact_sequence": row["exact_sequence"],
                "n_compared": n,
                "n_agree": int(agree.sum()),
                "n_both_stable": int((agree & (ex == STABLE)).sum()),
                "n_both_unstable": int((agree & (ex == UNSTABLE)).sum()),
                "n_exact_stable_only": int((both & (ex == STABLE) & (reg == UNSTABLE)).sum()),
                "n_regularized_stable_only": int((both & (ex == UNSTABLE) & (reg == STABLE)).sum()),
                "n_no_regularized_verdict": int((reg == NO_VERDICT).sum()),
                "n_at_exact_change": int(((ex == NO_VERDICT) & (reg != NO_VERDICT)).sum()),
                "agreement": float(agree.sum() / n) if n else 1.0,
                "disagreement_energies": _intervals(e_r[idx][both], (reg != ex)[both]),
                "n_exact_changes": len(changes_x),
                "n_regularized_changes": len(changes_r),
                "exact_change_energies": ", ".join(f"{c['energy']:.4g}" for c in changes_x) or "none",
                "regularized_change_energies": ", ".join(f"{c['energy']:.4g}" for c in changes_r) or "none",
            }
        )
        # Changes are paired only when the two branches tell the same story in the regime.
        if len(changes_x) == len(changes_r) and all(a["becomes"] == b["becomes"] for a, b in zip(changes_x, changes_r)):
            for a, b in zip(changes_x, changes_r):
                pairs.append(
                    {
                        "regime": k,
                        "becomes": a["becomes"],
                        "exact_energy": a["energy"],
                        "regularized_energy": b["energy"],
                        "exact_frequency": a["frequency"],
                        "regularized_frequency": b["frequency"],
                        "energy_ratio": b["energy"] / a["energy"],
                    }
                )
    return rows, pairs


def stability_comparison_dataset(exact_ds: xr.Dataset, regularized_ds: xr.Dataset) -> xr.Dataset:
    """The comparison of :func:`compare_stability` as a labelled dataset.

    Dimension ``regime`` (the columns of :data:`REGIME_COLUMNS`) and dimension
    ``paired_change`` (the paired stability changes and their energy shift).
    """
    rows, pairs = compare_stability(exact_ds, regularized_ds)
    if not rows:
        raise ValueError("no impact regime is shared by the exact and regularized branches: nothing to compare")
    data = {}
    for name in REGIME_COLUMNS:
        values = [r[name] for r in rows]
        if isinstance(values[0], str):
            array = np.array(values, dtype=object)
        else:
            array = np.array(values, dtype=np.int32 if name in _INTEGER else float)
        data[name] = ("regime", array)
    change_vars = {
        "change_regime": ("regime", np.int32),
        "change_exact_energy": ("exact_energy", float),
        "change_regularized_energy": ("regularized_energy", float),
        "change_exact_frequency": ("exact_frequency", float),
        "change_regularized_frequency": ("regularized_frequency", float),
        "change_energy_ratio": ("energy_ratio", float),
    }
    for name, (key, dtype) in change_vars.items():
        data[name] = ("paired_change", np.array([p[key] for p in pairs], dtype=dtype))
    data["change_becomes_stable"] = (
        "paired_change",
        np.array([p["becomes"] == "stable" for p in pairs], dtype=np.int8),
    )
    coords = {"regime": np.arange(len(rows), dtype=np.int32), "paired_change": np.arange(len(pairs), dtype=np.int32)}
    ds = xr.Dataset(data, coords=coords)
    total = {k: int(sum(r[k] for r in rows)) for k in ("n_compared", "n_agree")}
    ds.attrs = {
        "compared_orbits": total["n_compared"],
        "agreeing_orbits": total["n_agree"],
        "regularized_stability_method": str(
            regularized_ds["stable"].attrs.get("comment", "as in the regularized dataset")
        ),
        "method": (
            "Regimes paired as in nnmstop.compare.exact_branches.compare_with_regularized; the exact verdict at "
            "each compared "
            "regularized energy from the two bracketing exact orbits of the same monotone piece (nearest frequency); "
            "changes located between consecutive orbits; changes paired in branch order when both branches have "
            "the same number of changes going the same way in the regime (nnmstop.compare.stability)."
        ),
    }
    return describe(ds, "stability_comparison")


def stability_table(ds: xr.Dataset) -> pd.DataFrame:
    """The ``regime`` variables of :func:`stability_comparison_dataset` as a table."""
    missing = [name for name in REGIME_COLUMNS if name not in ds]
    if missing:
        raise ValueError(f"the dataset lacks {missing}: not a stability comparison dataset")
    return ds[list(REGIME_COLUMNS)].to_dataframe()
