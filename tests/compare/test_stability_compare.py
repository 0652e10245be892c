"""The exact-vs-regularized stability table (nnmstop.compare.stability) on constructed branches.

Every expected count and energy below follows by hand from the constructed verdicts.
"""

import numpy as np
import pytest
import xarray as xr

from nnmstop.compare import stability as sc
from nnmstop.figures.stability import stability_figure


def _branch(energy, frequency, impacts, stable, resolved=None, sequence=None):
    n = len(energy)
    data = {
        "energy": ("point", np.asarray(energy, float)),
        "frequency": ("point", np.asarray(frequency, float)),
        "impacts_per_period": ("point", np.asarray(impacts, np.int32)),
        "stable": ("point", np.asarray(stable, np.int8)),
    }
    if resolved is not None:
        data["stability_resolved"] = ("point", np.asarray(resolved, np.int8))
    if sequence is not None:
        data["phase_sequence"] = ("point", np.array([sequence] * n, dtype=object))
    return xr.Dataset(data, attrs={"eta": 0.1})


def _monotone_case(reg_threshold):
    # exact: energies 1.0, 1.5, ..., 10.0, stable up to 5.0 (the change lies between 5.0 and 5.5)
    e_x = np.arange(1.0, 10.01, 0.5)
    exact = _branch(e_x, 0.1 + 0.001 * e_x, np.full(e_x.size, 2), e_x <= 5.0, sequence="FR")
    # regularized: energies 1.25, 2.25, ..., 9.25, stable below reg_threshold
    e_r = np.arange(1.25, 9.26, 1.0)
    reg = _branch(e_r, 0.1 + 0.001 * e_r, np.full(e_r.size, 2), e_r < reg_threshold)
    return exact, reg


def test_monotone_regime_counts_agreement_and_the_change_shift():
    exact, reg = _monotone_case(reg_threshold=7.0)
    rows, pairs = sc.compare_stability(exact, reg)
    assert len(rows) == 1
    row = rows[0]
    # 5.25 lies between the exact orbits 5.0 (stable) and 5.5 (unstable): no exact verdict there
    assert row["n_at_exact_change"] == 1
    assert row["n_compared"] == 8
    # 1.25..4.25 stable in both, 7.25..9.25 unstable in both, 6.25 stable in the regularized model only
    assert (row["n_both_stable"], row["n_both_unstable"], row["n_regularized_stable_only"]) == (4, 3, 1)
    assert row["n_exact_stable_only"] == 0 and row["n_agree"] == 7
    assert row["agreement"] == pytest.approx(7 / 8)
    assert row["disagreement_energies"] == "6.25"
    assert (row["n_exact_changes"], row["n_regularized_changes"]) == (1, 1)
    assert len(pairs) == 1 and pairs[0]["becomes"] == "unstable"
    assert pairs[0]["exact_energy"] == pytest.approx(np.sqrt(5.0 * 5.5))
    assert pairs[0]["regularized_energy"] == pytest.approx(np.sqrt(6.25 * 7.25))
    assert pairs[0]["energy_ratio"] == pytest.approx(np.sqrt(6.25 * 7.25 / (5.0 * 5.5)))


def test_full_agreement_has_no_disagreement_interval():
    exact, reg = _monotone_case(reg_threshold=5.1)
    row = sc.compare_stability(exact, reg)[0][0]
    assert row["n_agree"] == row["n_compared"] == 8
    assert row["disagreement_energies"] == "none" and row["agreement"] == 1.0


def test_energy_fold_reads_the_verdict_of_the_piece_of_nearest_frequency():
    # exact regime folds at E = 10: lower piece (frequency 0.10 + ...) stable, upper piece
    # (frequency 0.20 + ...) unstable
    up = np.linspace(1.0, 10.0, 19)
    down = np.linspace(10.0, 2.0, 17)[1:]
    e_x = np.concatenate([up, down])
    f_x = np.concatenate([0.10 + 0.001 * up, 0.20 - 0.001 * down])
    exact = _branch(
        e_x, f_x, np.full(e_x.size, 4), np.concatenate([np.ones(up.size), np.zeros(down.size)]), sequence="FLF"
    )
    # regularized orbits on the upper piece, all unstable: every verdict agrees
    e_r = np.array([3.1, 4.1, 5.1, 6.1])
    reg = _branch(e_r, 0.20 - 0.001 * e_r, np.full(4, 4), np.zeros(4))
    row = sc.compare_stability(exact, reg)[0][0]
    assert row["n_compared"] == 4 and row["n_both_unstable"] == 4
    # the same energies on the lower piece, said unstable: every one disagrees
    reg_low = _branch(e_r, 0.10 + 0.001 * e_r, np.full(4, 4), np.zeros(4))
    row = sc.compare_stability(exact, reg_low)[0][0]
    assert row["n_exact_stable_only"] == 4 and row["disagreement_energies"] == "3.1-6.1"
    # one exact change, at the fold (between the last stable and the first unstable orbit)
    assert row["n_exact_changes"] == 1
    assert row["exact_change_energies"] == f"{np.sqrt(10.0 * down[0]):.4g}"


def test_orbits_without_regularized_verdict_are_counted_not_compared():
    exact, reg = _monotone_case(reg_threshold=7.0)
    resolved = np.ones(reg.sizes["point"], np.int8)
    resolved[[5, 6]] = 0  # energies 6.25 and 7.25: the regularized change is now bracketed by 5.25 and 8.25
    reg["stability_resolved"] = ("point", resolved)
    rows, pairs = sc.compare_stability(exact, reg)
    row = rows[0]
    assert row["n_no_regularized_verdict"] == 2
    assert row["n_compared"] == 6 and row["n_agree"] == 6
    assert pairs[0]["regularized_energy"] == pytest.approx(np.sqrt(5.25 * 8.25))


def test_changes_going_different_ways_are_not_paired():
    exact, reg = _monotone_case(reg_threshold=7.0)
    reg["stable"] = ("point", (reg["energy"].values > 7.0).astype(np.int8))  # becomes stable instead
    rows, pairs = sc.compare_stability(exact, reg)
    assert rows[0]["n_exact_changes"] == rows[0]["n_regularized_changes"] == 1
    assert pairs == []


def test_dataset_is_labelled_and_missing_flags_are_refused():
    exact, reg = _monotone_case(reg_threshold=7.0)
    ds = sc.stability_comparison_dataset(exact, reg)
    for name, var in {**ds.coords, **ds.data_vars}.items():
        assert "long_name" in var.attrs and "units" in var.attrs, name
    assert ds.attrs["compared_orbits"] == 8 and ds.attrs["agreeing_orbits"] == 7
    assert list(sc.stability_table(ds).columns) == list(sc.REGIME_COLUMNS)
    with pytest.raises(ValueError, match="'stable'"):
        sc.compare_stability(exact, reg.drop_vars("stable"))
    bad = reg.copy()
    bad["stable"] = ("point", np.full(reg.sizes["point"], 2, np.int8))
    with pytest.raises(ValueError, match="0 or 1"):
        sc.compare_stability(exact, bad)


def test_figure_marks_the_changes_and_refuses_nan():
    exact, reg = _monotone_case(reg_threshold=7.0)
    fig = stability_figure(exact, reg, sc.stability_comparison_dataset(exact, reg))
    markers = [line for line in fig.axes[0].lines if line.get_marker() in ("o", "s")]
    assert sorted(len(line.get_xdata()) for line in markers) == [1, 1]
    bad = reg.copy()
    bad["energy"] = bad["energy"].where(bad["point"] != 2)
    with pytest.raises(ValueError, match="NaN"):
        stability_figure(exact, bad)


def test_figure_zoom_windows_are_checked_and_optional():
    exact, reg = _monotone_case(reg_threshold=7.0)
    assert len(stability_figure(exact, reg, zoom_energy=[]).axes) == 1
    assert len(stability_figure(exact, reg, zoom_energy=[[2.0, 5.0]]).axes) == 2
    with pytest.raises(ValueError, match="low < high"):
        stability_figure(exact, reg, zoom_energy=[[5.0, 2.0]])


def test_default_zooms_hold_every_stability_change():
    """Without configured windows the zoomed panels are where the changes are: each change in one of them."""
    from nnmstop.figures.stability import change_clusters

    exact, reg = _monotone_case(reg_threshold=7.0)
    fig = stability_figure(exact, reg)
    changes = [
        c["energy"]
        for ds in (exact, reg)
        for c in sc.stability_changes(ds["energy"].values, ds["frequency"].values, sc.verdicts(ds))
    ]
    windows = [ax.get_xlim() for ax in fig.axes[1:] if ax.axison]
    assert windows and all(any(lo < e < hi for lo, hi in windows) for e in changes)
    far = change_clusters([1.0, 1.2, 100.0, 130.0, 1.0e4])
    assert len(far) == 3 and all(lo < e < hi for e, (lo, hi) in zip([1.1, 115.0, 1.0e4], far))
