"""Matching a structure's exact and regularized branches at energies, on constructed branches."""

import numpy as np
import pytest

from nnmstop.compare.structure_branches import compare_at_energies, first_crossing


def test_first_crossing_takes_the_first_pass_in_branch_order():
    energy = np.array([1.0, 2.0, 3.0, 2.0, 1.0, 4.0])  # reaches 1.5 three times
    values = np.array([10.0, 20.0, 30.0, 40.0, 50.0, 60.0])
    assert first_crossing(energy, values, 1.5) == pytest.approx(15.0)
    assert first_crossing(energy, values, 3.5) == pytest.approx(50.0 + 10.0 * 2.5 / 3.0)  # 1 -> 4 segment
    assert np.isnan(first_crossing(energy, values, 5.0))


def test_compare_at_energies_on_two_linear_branches():
    e = np.linspace(1.0, 10.0, 50)
    ds = compare_at_energies(e, 1.0 + 0.01 * e, e + 0.5, 1.0 + 0.01 * (e + 0.5) + 1e-3, 5)  # same law + 1e-3
    exact = 1.0 + 0.01 * ds.energy.values
    np.testing.assert_allclose(ds.exact_frequency.values, exact, rtol=1e-12)
    np.testing.assert_allclose(ds.relative_difference.values, 1e-3 / exact, rtol=1e-9)
    assert ds.energy.values.min() > 1.5 and ds.energy.values.max() < 10.0


def test_disjoint_branches_compare_nothing_and_say_why():
    ds = compare_at_energies([1.0, 2.0], [1.0, 1.0], [3.0, 4.0], [1.0, 1.0], 4)
    assert ds.sizes["energy"] == 0 and int(ds.attrs["skipped"]) == 1
    assert "share no energy range" in ds.attrs["end_reason"]


def test_energies_where_the_regularized_orbit_is_of_another_type_are_not_compared():
    """Issue 29: a regularized point outside the exact family's type (here the second half of the branch) makes
    the energies it brackets no counterparts: their difference is missing, the others are compared."""
    energy = np.geomspace(1.0, 10.0, 11)
    comparable = energy < 4.0
    ds = compare_at_energies(energy, np.ones(11), energy, 1.01 * np.ones(11), 6, comparable=comparable)
    unlike = ds["no_counterpart"].values == 1
    assert unlike.any() and not unlike.all()
    assert np.all(np.isnan(ds["relative_difference"].values[unlike]))
    np.testing.assert_allclose(ds["relative_difference"].values[~unlike], 0.01, rtol=1e-12)
    assert np.all(ds["energy"].values[unlike] > 3.0)


def test_first_crossing_never_brackets_across_segments():
    energy = [1.0, 2.0, 5.0, 6.0]
    values = [10.0, 20.0, 50.0, 60.0]
    segment = [0, 0, 1, 1]
    assert first_crossing(energy, values, 3.0) == pytest.approx(30.0)  # the line from 2 to 5 joins two curves
    assert np.isnan(first_crossing(energy, values, 3.0, segment))
    assert first_crossing(energy, values, 5.5, segment) == pytest.approx(55.0)
