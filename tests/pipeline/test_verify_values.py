"""How verify compares the values of a dataset off its curve (nnmstop.pipeline.verify._check_other_values).

Synthetic datasets through the reference's own profile: a large array changed by round-off passes and by one
value fails; text compares its words, integers their digits; a missing value must be missing in both builds; the
study's measurements are not compared and are listed as unverified; interpolated values agree within both builds'
interpolation estimates.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nnmstop.pipeline.reference import profile, unverified_variables
from nnmstop.pipeline.verify import _check_other_values


def rows_of(reference: xr.Dataset, build: xr.Dataset) -> list:
    entry = profile(reference, {})
    entry["base"] = 1e-9
    return [row for row in _check_other_values("f.nc", build, entry) if row.verdict == "discrepant"]


def test_a_large_array_within_round_off_passes_and_one_changed_value_does_not():
    rng = np.random.default_rng(1)
    shape = rng.standard_normal((40, 20))
    reference = xr.Dataset({"gap_zero_shape": (("dof", "mode"), shape)})
    assert rows_of(reference, reference.copy(deep=True)) == []
    round_off = reference.copy(deep=True)
    round_off["gap_zero_shape"].values *= 1 + 1e-13 * rng.standard_normal(shape.shape)
    assert rows_of(reference, round_off) == []
    changed = reference.copy(deep=True)
    changed["gap_zero_shape"].values[7, 3] += 1e-3
    (row,) = rows_of(reference, changed)
    assert "weighted sums" in row.quantity and row.verdict == "discrepant"


def test_text_compares_its_words_and_integers_their_digits():
    reference = xr.Dataset({"failure": ("case", ["stopped at energy 2.5", ""]), "harmonics": ("case", [50, 100])})
    reworded = reference.copy(deep=True)
    reworded["failure"] = ("case", ["stopped at energy 2.5000001", ""])
    assert rows_of(reference, reworded) == []  # the number restates data compared elsewhere
    reworded["failure"] = ("case", ["failed at energy 2.5", ""])
    assert [r.quantity for r in rows_of(reference, reworded)] == ["variable failure"]
    other = reference.copy(deep=True)
    other["harmonics"] = ("case", [50, 200])
    assert [r.quantity for r in rows_of(reference, other)] == ["variable harmonics"]


def test_a_missing_value_must_be_missing_in_both_builds():
    reference = xr.Dataset({"frequency_error": ("case", [1e-3, np.nan, 2e-3])})
    moved = xr.Dataset({"frequency_error": ("case", [1e-3, 5e-4, np.nan])})
    (row,) = rows_of(reference, moved)
    assert "missing values" in row.quantity and row.verdict == "discrepant"


def test_the_studys_measurements_are_not_compared_and_are_named():
    reference = xr.Dataset(
        {"runtime": ("case", [1.0, 2.0]), "steps": ("case", [10, 20]), "frequency_error": ("case", [1e-3, 2e-3])},
        attrs={"dataset_kind": "error_vs_runtime"},
    )
    slower = reference.copy(deep=True)
    slower["runtime"] = ("case", [3.0, 9.0])
    slower["steps"] = ("case", [11, 19])
    assert rows_of(reference, slower) == []
    unverified = unverified_variables(reference)
    assert set(unverified) == {"runtime", "steps"} and "measurement" in unverified["runtime"]
    slower["frequency_error"] = ("case", [1e-3, 3e-3])  # the study's result is compared
    assert [r.quantity.split(" (")[0] for r in rows_of(reference, slower)] == ["variable frequency_error"]


def test_interpolated_values_agree_within_both_builds_estimates():
    def comparison(regularized, estimate):
        return xr.Dataset(
            {
                "exact_frequency": ("energy", [0.16, 0.17]),
                "regularized_frequency": ("energy", regularized),
                "relative_difference": ("energy", (np.array(regularized) - [0.16, 0.17]) / [0.16, 0.17]),
                "exact_interpolation_error": ("energy", [0.0, 0.0]),
                "regularized_interpolation_error": ("energy", estimate),
            }
        )

    reference = comparison([0.1630, 0.1710], [2e-6, 2e-6])
    assert rows_of(reference, comparison([0.163003, 0.171003], [2e-6, 2e-6])) == []
    rows = rows_of(reference, comparison([0.163010, 0.171010], [2e-6, 2e-6]))
    named = {r.quantity.split(" (")[0] for r in rows}
    assert named == {"variable regularized_frequency", "variable relative_difference"}


def test_an_array_attribute_is_compared_entry_by_entry_like_a_number():
    """A derived array (the analytic frequencies scaled by the model's own first eigenvalue) that moved at
    round-off on another CPU passes with the scalar's relative tolerance; a changed entry, a changed length or an
    integer array off by one does not."""
    from nnmstop.pipeline.verify import _compare_attribute

    frequencies = [0.15915494309086567, 0.515763955883428, 1.076100325927787]
    moved = [f * (1 + 2e-15) for f in frequencies]
    assert _compare_attribute("euler_bernoulli_frequency", frequencies, moved, 1e-8)[2]
    changed = [frequencies[0], frequencies[1] * (1 + 1e-6), frequencies[2]]
    assert not _compare_attribute("euler_bernoulli_frequency", frequencies, changed, 1e-8)[2]
    assert not _compare_attribute("euler_bernoulli_frequency", frequencies, frequencies[:2], 1e-8)[2]
    assert not _compare_attribute("boundary_full_dofs", [12, 25, 37], [12, 25, 38], 1e-8)[2]
    assert _compare_attribute("boundary_full_dofs", [12, 25, 37], [12, 25, 37], 1e-8)[2]
