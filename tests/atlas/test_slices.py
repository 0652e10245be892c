"""Slices of an atlas: the one-parameter exact response read as regions on a frequency grid."""

import numpy as np
import pytest
from tests.atlas.conftest import WINDOW_HZ, located, oscillator

from nnmstop.bifurcation_atlas.flags import REGIONS
from nnmstop.bifurcation_atlas.slices import classify, compute_slice
from nnmstop.forced.responses import ExactSettings


def test_classify_counts_the_crossings_of_a_folded_curve():
    """A non-impacting piece up to 1.0, an impacting piece that folds back (stable, unstable, stable) and a
    non-impacting piece from 0.8: two stable responses between the folds, one outside; no contact below."""
    pieces = [
        (np.array([0.1, 0.5, 1.0]), np.array([1, 1, 1], bool), np.zeros(3, bool)),
        (np.array([1.0, 1.5, 2.0, 1.5, 0.8]), np.array([1, 1, 0, 0, 1], bool), np.ones(5, bool)),
        (np.array([0.8, 2.5, 3.0]), np.array([1, 1, 1], bool), np.zeros(3, bool)),
    ]
    grid = np.array([0.3, 0.9, 1.2, 1.7, 2.2, 2.8])
    out = classify(*zip(*pieces), [], grid)
    assert out["responses"].tolist() == [1, 3, 3, 3, 1, 1]
    names = [REGIONS[k] for k in out["region"]]
    assert names == ["no_contact", "coexisting", "coexisting", "coexisting", "no_contact", "no_contact"]


def test_classify_marks_the_span_between_second_contact_ends_not_covered():
    """Between the ends of families that end on a second contact, and where no response is known at all."""
    pieces = [(np.array([0.1, 2.5]), np.array([1, 1], bool), np.zeros(2, bool))]
    grid = np.linspace(0.1, 3.0, 30)
    out = classify(*zip(*pieces), [1.5, 2.0], grid)
    uncovered = grid[out["region"] == REGIONS.index("not_covered")]
    inside = (uncovered >= 1.5 - 0.1) & (uncovered <= 2.0 + 0.1)
    assert inside.sum() >= 5
    assert np.all(uncovered[~inside] >= 2.5)  # from the last point on nothing is known either


@pytest.mark.numerics
def test_the_jump_region_lies_between_the_folds(response_at):
    """At F = 0.15 two stable responses coexist between the lower fold and the upper fold of NNM1, where the
    upper branch is stable (beyond its last Neimark-Sacker point), and nowhere below the first grazing."""
    result = compute_slice(oscillator(0.15), "force", 0.15, WINDOW_HZ, ExactSettings())
    grid = np.linspace(*WINDOW_HZ, 600)
    out = classify(result.all_frequency, result.all_stable, result.all_impacting, result.end_frequency, grid)
    pieces = response_at(0.15)
    folds = sorted(omega / (2 * np.pi) for _, omega in located(pieces, "fold") if omega < 2 * np.pi * 0.2)
    ns = sorted(omega / (2 * np.pi) for _, omega in located(pieces, "neimark_sacker") if omega < 2 * np.pi * 0.2)
    inside = (grid > max(folds[0], ns[-1]) + 1e-4) & (grid < folds[1] - 1e-4)
    assert inside.sum() > 20
    assert np.all(out["region"][inside] == REGIONS.index("coexisting"))
    below = grid < ns[0] - 1e-4
    assert np.all(out["region"][below] == REGIONS.index("no_contact"))
    beyond = (grid > folds[1] + 1e-4) & (grid < 0.2)
    assert np.all(out["stable_responses"][beyond] == 1)
