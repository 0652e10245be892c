"""The regularization error per impact regime (nnmstop.compare.regimes) and its extra figure.

Two kinds of input, both built here (no pipeline output is read):

* a synthetic pair of branches whose exact frequency is linear in ``ln E`` on each
  monotone piece, so that the interpolation is exact and the error of each regime is a
  known offset put into the "regularized" frequencies;
* a real exact branch (closed form, first three phase-sequence segments), compared with
  itself and with a subsample of itself: an identity check independent of the HBM.
"""

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from nnmstop.compare.exact_branches import main as compare_main
from nnmstop.compare.regimes import REGIME_VARIABLES, regime_error_dataset, regime_table
from nnmstop.exact.dataset import exact_branch_dataset, two_impact_dataset
from nnmstop.exact.family import FamilySettings, follow_branch, follow_two_impact_family
from nnmstop.exact.problem import from_two_impact_unknowns
from nnmstop.figures.regime_errors import regime_error_figure
from nnmstop.netcdf import check_labelled
from nnmstop.tasks.compare import build_regime_error_dataset
from nnmstop.tasks.figures import build_regime_error_figure

PARAMS = {"alpha": 30.0, "beta": 1.0, "delta": 1.0}
REGULARIZED_ATTRS = {**PARAMS, "eta": 0.1, "harmonics": 16}

#: Offsets (Hz) put on the regularized frequency of each paired regime: 2, 6, 4 impacts.
OFFSETS = {2: 1e-3, 6: -2e-4, 4: 5e-5}


def _f_two_rising(e):
    return 0.1 + 0.01 * np.log(e)


def _f_two_falling(e):
    # the grazing arm: energy falls from 1.0 to the fold at 0.9, with another slope
    return _f_two_rising(0.9) + 0.05 * (np.log(0.9) - np.log(e))


def _f_six(e):
    return 0.15 + 0.002 * np.log(e)


def _f_four(e):
    return 0.13 + 0.01 * np.log(e)


def _branch(parts, attrs, sequences=True):
    """A branch dataset from (impacts, sequence, energies, frequencies) parts."""
    energy = np.concatenate([p[2] for p in parts])
    data = {
        "energy": ("point", energy, {"long_name": "energy", "units": "1"}),
        "frequency": ("point", np.concatenate([p[3] for p in parts]), {"long_name": "frequency", "units": "Hz"}),
        "impacts_per_period": (
            "point",
            np.concatenate([np.full(len(p[2]), p[0], dtype=np.int32) for p in parts]),
            {"long_name": "impacts", "units": "1"},
        ),
    }
    if sequences:
        data["phase_sequence"] = (
            "point",
            np.concatenate([np.full(len(p[2]), p[1], dtype=object) for p in parts]),
            {"long_name": "phase sequence", "units": "1"},
        )
    return xr.Dataset(data, coords={"point": np.arange(energy.size)}, attrs=dict(attrs))


@pytest.fixture(scope="module")
def synthetic():
    """Exact branch: grazing orbit, 2 impacts (with an energy fold), 6, then 4 impacts.

    Regularized branch: a linear regime, then 2, 6, 4 impacts with known offsets (one
    2-impact orbit beyond the exact range), then an 8-impact regime the exact one lacks.
    """
    falling = np.linspace(1.0, 0.9, 6)
    rising = np.geomspace(0.9, 10.0, 40)[1:]
    six, four = np.geomspace(10.0, 20.0, 25), np.geomspace(20.0, 50.0, 30)
    exact_ds = _branch(
        [
            (0, "F", np.array([1.0]), np.array([_f_two_falling(1.0)])),
            (
                2,
                "FR",
                np.concatenate([falling, rising]),
                np.concatenate([_f_two_falling(falling), _f_two_rising(rising)]),
            ),
            (6, "FLFR", six, _f_six(six)),
            (4, "FLF", four, _f_four(four)),
        ],
        PARAMS,
    )
    e_lin = np.geomspace(0.01, 0.5, 5)
    e_two = np.concatenate([[0.95], np.geomspace(1.5, 9.0, 12), [12.0]])  # 0.95: two exact orbits; 12: none
    e_six, e_four = np.geomspace(11.0, 19.0, 7), np.geomspace(21.0, 49.0, 9)
    f_two = _f_two_rising(e_two) + OFFSETS[2]
    regularized = _branch(
        [
            (0, "", e_lin, 0.1 + 0 * e_lin),
            (2, "", e_two, f_two),
            (6, "", e_six, _f_six(e_six) + OFFSETS[6]),
            (4, "", e_four, _f_four(e_four) + OFFSETS[4]),
            (8, "", np.array([60.0, 70.0]), np.array([0.14, 0.141])),
        ],
        REGULARIZED_ATTRS,
        sequences=False,
    )
    return exact_ds, regularized


@pytest.fixture(scope="module")
def exact_branch(paper_params):
    """A real exact NNM1: the two-impact family and the FLFR and FLF segments after it."""
    family = follow_two_impact_family(paper_params, step=0.1)
    y = from_two_impact_unknowns(family.unknowns)
    settings = FamilySettings(
        step=0.25, max_frequency_step=5e-4, max_log_energy_step=0.1, max_points=400, max_segments=3
    )
    segments = follow_branch(paper_params, "FR", y[-1], y[-1] - y[-2], settings)
    return exact_branch_dataset(two_impact_dataset(family), segments, paper_params)


def test_each_regime_reports_its_known_error(synthetic):
    exact_ds, regularized = synthetic
    ds = regime_error_dataset(exact_ds, regularized)
    assert list(ds["impacts_per_period"].values) == [2, 6, 4]
    assert list(ds["exact_sequence"].values) == ["FR", "FLFR", "FLF"]
    assert list(ds["n_matched"].values) == [13, 7, 9]
    assert list(ds["n_unmatched"].values) == [1, 0, 0]  # E = 12 lies beyond the exact 2-impact regime
    for k, impacts in enumerate(ds["impacts_per_period"].values):
        offset = OFFSETS[int(impacts)]
        r = ds.isel(regime=k)
        assert float(r["mean_frequency_error"]) == pytest.approx(offset, rel=1e-9)
        assert float(r["max_abs_frequency_error"]) == pytest.approx(abs(offset), rel=1e-9)
        assert float(r["median_abs_frequency_error"]) == pytest.approx(abs(offset), rel=1e-9)
        on = ds["point_regime"].values == k
        rel = abs(offset) / ds["exact_frequency"].values[on]
        assert float(r["max_rel_frequency_error"]) == pytest.approx(rel.max(), rel=1e-9)
    # at E = 0.95 the rising arm (frequency nearest to the regularized one) is the partner, not the grazing arm
    first = ds.isel(point=0)
    assert float(first["energy"]) == 0.95
    assert float(first["exact_frequency"]) == pytest.approx(_f_two_rising(0.95), rel=1e-12)
    assert float(ds["exact_energy_min"][0]) == 0.9 and float(ds["exact_energy_max"][0]) == 10.0
    # every compared orbit is traced back to its point of the regularized branch
    idx = ds["regularized_index"].values
    np.testing.assert_array_equal(ds["energy"].values, regularized["energy"].values[idx])
    np.testing.assert_array_equal(ds["frequency"].values, regularized["frequency"].values[idx])


def test_left_out_orbits_are_counted_and_nothing_is_nan(synthetic):
    exact_ds, regularized = synthetic
    ds = regime_error_dataset(exact_ds, regularized)
    check_labelled(ds)  # long_name and units everywhere, no NaN or inf
    assert ds.attrs["regularized_points"] == regularized.sizes["point"] == 37
    assert ds.attrs["matched_points"] == ds.sizes["point"] == 29
    assert ds.attrs["unpaired_points"] == 5 + 2  # the linear regime and the 8-impact regime
    assert ds.attrs["unmatched_points"] == ds.attrs["unpaired_points"] + int(ds["n_unmatched"].sum())
    assert "0 impacts per period (regularized points 0-4)" in ds.attrs["unpaired_regimes"]
    assert "8 impacts per period (regularized points 35-36)" in ds.attrs["unpaired_regimes"]
    assert {k: ds.attrs[k] for k in REGULARIZED_ATTRS} == REGULARIZED_ATTRS
    assert "point" not in regime_error_dataset(exact_ds, regularized, points=False).dims


def test_dataset_regimes_are_the_rows_of_the_command_line_table(synthetic, tmp_path, capsys):
    exact_ds, regularized = synthetic
    ds = regime_error_dataset(exact_ds, regularized)
    exact_ds.to_netcdf(tmp_path / "exact.nc")
    regularized.to_netcdf(tmp_path / "reg.nc")
    compare_main(["compare", str(tmp_path / "exact.nc"), str(tmp_path / "reg.nc")])
    lines = capsys.readouterr().out.splitlines()[2:-1]
    assert len(lines) == ds.sizes["regime"]
    for k, line in enumerate(lines):
        cols = line.split()
        r = ds.isel(regime=k)
        assert (int(cols[0]), cols[1], int(cols[4])) == (
            int(r["impacts_per_period"]),
            str(r["exact_sequence"].values),
            int(r["n_matched"]),
        )
        assert float(cols[5]) == pytest.approx(float(r["max_abs_frequency_error"]), rel=5e-3)
        assert float(cols[7]) == pytest.approx(float(r["median_abs_frequency_error"]), rel=5e-3)
        assert float(cols[9]) == pytest.approx(float(r["max_rel_frequency_error"]), rel=5e-3)


def test_real_exact_branch_against_its_subsample_shows_only_interpolation_error(exact_branch):
    """Every other orbit is interpolated from its neighbours: small errors, largest at the energy folds.

    The regularization error of these regimes (eta = 0.1) has medians of 1e-4 Hz (README);
    the interpolation of this coarse exact branch stays far below that, except on the short
    arms that end at an energy fold: the grazing arm (E < 0.7, energy falling to the fold at
    0.675) and the arm of FLFR from its energy maximum to its merge into FLF. Thinned, such an
    arm no longer covers the energies of its removed orbits, which are then paired with the
    other side of the fold (how many orbits an arm holds depends on the continuation's steps).
    """
    n = exact_branch.sizes["point"]
    regularized = exact_branch.isel(point=np.arange(1, n, 2))
    thinned = exact_branch.isel(point=np.r_[0, np.arange(2, n, 2)])
    regularized.attrs.update(eta=0.1, harmonics=100)
    ds = regime_error_dataset(thinned, regularized)
    assert list(ds["impacts_per_period"].values) == [2, 6, 4]
    assert ds.attrs["matched_points"] >= 0.95 * regularized.sizes["point"]
    assert float(ds["median_abs_frequency_error"].max()) < 5e-6
    rel, energy = np.abs(ds["relative_frequency_error"].values), ds["energy"].values
    flfr = exact_branch["energy"].values[exact_branch["phase_sequence"].values == "FLFR"]
    top = int(np.argmax(flfr))
    folded = (energy < 0.7) | ((energy >= flfr[top:].min()) & (energy <= flfr[top]))
    assert folded[np.argmax(rel)]
    assert rel[~folded].max() < 2e-3


@pytest.mark.parametrize(
    "side, variable",
    [
        ("exact", "frequency"),
        ("regularized", "impacts_per_period"),
        ("exact", "phase_sequence"),
        ("regularized", "energy"),
    ],
)
def test_a_missing_variable_is_named(synthetic, side, variable):
    exact_ds, regularized = synthetic
    inputs = {"exact": exact_ds, "regularized": regularized}
    inputs[side] = inputs[side].drop_vars(variable)
    with pytest.raises(ValueError, match=f"{side} dataset lacks.*{variable}"):
        regime_error_dataset(inputs["exact"], inputs["regularized"])


def test_bad_attributes_and_values_are_refused(synthetic):
    exact_ds, regularized = synthetic
    no_eta = regularized.copy()
    del no_eta.attrs["eta"]
    with pytest.raises(ValueError, match="regularized dataset lacks the global attribute.*eta"):
        regime_error_dataset(exact_ds, no_eta)
    other = regularized.copy()
    other.attrs["alpha"] = 20.0
    with pytest.raises(ValueError, match="alpha differs"):
        regime_error_dataset(exact_ds, other)
    negative = regularized.copy(deep=True)
    negative["energy"].values[3] = -1.0
    with pytest.raises(ValueError, match="regularized dataset's 'energy' must be finite and > 0"):
        regime_error_dataset(exact_ds, negative)
    far = regularized.copy(deep=True)
    far["energy"].values[:] = far["energy"].values * 1e3
    empty = regime_error_dataset(exact_ds, far)  # no regime compared: said, not filled with NaN
    assert (
        empty.sizes["regime"] == 0 and empty.attrs["skipped"] == 1 and "nothing to compare" in empty.attrs["end_reason"]
    )
    assert empty.attrs["matched_points"] == 0 and empty.attrs["unmatched_points"] == far.sizes["point"]


def test_pipeline_task_writes_the_dataset_and_its_table(synthetic, tmp_path):
    exact_ds, regularized = synthetic
    exact_ds.to_netcdf(tmp_path / "exact.nc")
    regularized.to_netcdf(tmp_path / "reg.nc")
    config = {"model": {**PARAMS, "eta": 0.1}}
    inputs = {"exact": str(tmp_path / "exact.nc"), "nnm1": str(tmp_path / "reg.nc")}
    outputs = {"dataset": tmp_path / "out" / "regimes.nc", "table": tmp_path / "out" / "regimes.csv"}
    build_regime_error_dataset(config, inputs, outputs)
    with xr.open_dataset(outputs["dataset"]) as out:
        ds = out.load()
    check_labelled(ds)
    assert ds.attrs["Conventions"] == "CF-1.10, ACDD-1.3" and ds.attrs["exact_source"] == inputs["exact"]
    table = pd.read_csv(outputs["table"], index_col="regime")
    assert list(table.columns) == list(REGIME_VARIABLES)
    expected = regime_table(ds)
    assert list(table["exact_sequence"]) == list(expected["exact_sequence"])
    np.testing.assert_allclose(table["max_abs_frequency_error"], expected["max_abs_frequency_error"], rtol=1e-9)
    assert not list((tmp_path / "out").glob("*.tmp*"))
    config["model"]["eta"] = 0.01
    with pytest.raises(ValueError, match=r"eta = 0.1 in the dataset but 0.01 in the configuration \(stale dataset\)"):
        build_regime_error_dataset(config, inputs, outputs)


def test_extra_figure_has_one_legend_entry_per_regime(synthetic, tmp_path):
    exact_ds, regularized = synthetic
    ds = regime_error_dataset(exact_ds, regularized)
    fig = regime_error_figure(ds)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["0: 2 impacts/period (FR)", "1: 6 impacts/period (FLFR)", "2: 4 impacts/period (FLF)"]
    path = tmp_path / "regimes.nc"
    ds.to_netcdf(path)
    pdf, png = build_regime_error_figure({"figures": {"png_dpi": 50}}, path, tmp_path / "fig.pdf")
    first = (pdf.read_bytes(), png.read_bytes())
    build_regime_error_figure({"figures": {"png_dpi": 50}}, path, tmp_path / "fig.pdf")
    assert (pdf.read_bytes(), png.read_bytes()) == first
    with pytest.raises(ValueError, match="points=True"):
        regime_error_figure(regime_error_dataset(exact_ds, regularized, points=False))
