"""Curves of codimension-one points in two parameters, checked against independent one-parameter responses."""

import numpy as np
import pytest
from tests.atlas.conftest import WINDOW_HZ, located, oscillator

from nnmstop.bifurcation_atlas.build import AtlasMap, check_curves, follow_kind
from nnmstop.bifurcation_atlas.curves import CurveSettings
from nnmstop.bifurcation_atlas.slices import compute_slice
from nnmstop.forced.responses import ExactSettings

pytestmark = pytest.mark.numerics


def atlas_map(plane="force", second=(0.085, 0.125), force=0.1, kinds=("fold",), values=(0.1,)) -> AtlasMap:
    return AtlasMap(
        "test", oscillator(force), plane, WINDOW_HZ, second, tuple(values), (values[0],), (), kinds,
        exact=ExactSettings(),
        curve=CurveSettings(step=0.05, tolerance=1e-11, max_points=1200, max_frequency_step=0.002),
    )  # fmt: skip


def seed_slice(atlas, value):
    """A slice dataset-like object with what the seeds read (the located changes of the exact response)."""
    from nnmstop.bifurcation_atlas.build import slice_dataset

    return slice_dataset(atlas, atlas.slice_index(value))


def test_fold_curve_in_force_passes_through_the_folds_located_at_other_forces(response_at):
    """The fold curve seeded at F = 0.1 holds the folds that the exact responses at F = 0.09 and 0.12 locate, to
    their location tolerance (both are roots to round-off: 1e-9 relative here)."""
    atlas = atlas_map()
    curves = follow_kind(atlas, "fold", [seed_slice(atlas, 0.1)])
    assert curves, "no fold curve"
    for force in (0.09, 0.12):
        points = located(response_at(force), "fold")
        nnm1 = [(force, omega) for _, omega in points if omega < 2 * np.pi * 0.2]
        assert len(nnm1) == 2, nnm1
        rows = check_curves(atlas, "fold", curves, nnm1, tolerance=1e-9)
        assert len(rows) == 2 and max(r[-1] for r in rows) < 1e-9, rows


def test_fold_curve_in_damping_ratio_passes_through_the_folds_at_another_damping(response_at):
    """In (Omega, damping ratio) at F = 0.1: the fold curve seeded at zeta = 0.01 holds the folds of the exact
    response at zeta = 0.012 (a response computed with that damping, independently of the curve)."""
    atlas = atlas_map("damping_ratio", (0.008, 0.014), values=(0.01,))
    # seeds: the folds of the response at zeta = 0.01 (the map's own damping), as a slice gives them
    seeds = compute_slice(atlas.excitation, "damping_ratio", 0.01, WINDOW_HZ, ExactSettings())
    from nnmstop.bifurcation_atlas.augmented import FoldTest

    equations = atlas.exact_equations()
    seed_list = [
        (FoldTest(), state[:-1], np.zeros(0), atlas.params_at(state[-1], 0.01))
        for kind, state in zip(seeds.change_kind, seeds.change_state)
        if kind == 0 and state[-1] < 2 * np.pi * 0.2
    ]
    curves = follow_kind(atlas, "fold", [], equations=equations, seeds=seed_list)
    at = [(0.012, omega) for _, omega in located(response_at(0.1, zeta=0.012), "fold") if omega < 2 * np.pi * 0.2]
    rows = check_curves(atlas, "fold", curves, at, tolerance=1e-9)
    assert len(rows) == 2, rows


def test_the_gap_map_is_the_force_map_rescaled():
    """The piecewise-linear law is homogeneous of degree one in (q, gap, F): the fold at gap g and force F is the
    fold at gap 1 and force F / g. The fold curve continued in (Omega, gap) at F = 0.1 meets g = 10/9 where the
    curve in (Omega, F) meets F = 0.09, to round-off."""
    from nnmstop.bifurcation_atlas.build import _crossings

    force_map = atlas_map()
    gap_map = atlas_map("gap", (0.8, 1.2), values=(1.0,))
    force_curves = follow_kind(force_map, "fold", [seed_slice(force_map, 0.1)])
    gap_seeds = compute_slice(gap_map.excitation, "gap", 1.0, WINDOW_HZ, ExactSettings())
    from nnmstop.bifurcation_atlas.augmented import FoldTest

    seed_list = [
        (FoldTest(), state[:-1], np.zeros(0), gap_map.params_at(state[-1], 1.0))
        for kind, state in zip(gap_seeds.change_kind, gap_seeds.change_state)
        if kind == 0 and state[-1] < 2 * np.pi * 0.2
    ]
    gap_curves = follow_kind(gap_map, "fold", [], seeds=seed_list)
    by_force = sorted(c for curve in force_curves for c in _crossings(curve, force_map, 0.09, 1e-11))
    by_gap = sorted(c for curve in gap_curves for c in _crossings(curve, gap_map, 1.0 / 0.9, 1e-11))
    assert len(by_force) == 2 and len(by_gap) == 2
    np.testing.assert_allclose(by_gap, by_force, rtol=1e-10)


def test_continued_grazing_curve_is_the_closed_form():
    """The grazing curve continued on the exact formulation (zero contact duration) is F_g(Omega) = gap /
    max_t |x(t)| of the linear response at unit force, to round-off, over the whole window."""
    from nnmstop.exact.forced import non_impacting_response

    atlas = atlas_map(kinds=("grazing",), second=(0.005, 0.3))
    curves = follow_kind(atlas, "grazing", [seed_slice(atlas, 0.1)])
    assert len(curves) == 1  # both grazing orbits of NNM1's resonance at F = 0.1 lie on one U-shaped curve
    unit = oscillator(1.0)
    for curve in curves:
        params = curve.params()
        closed = 1.0 / np.abs(non_impacting_response(unit, params[:, 0])[:, 0])
        np.testing.assert_allclose(params[:, 1], closed, rtol=1e-10)


def test_one_neimark_sacker_curve_holds_every_point_the_responses_locate(response_at):
    """The Neimark-Sacker curve of NNM1 seeded at F = 0.1 passes through the four Neimark-Sacker points of the
    exact response at F = 0.15 (two near grazing, two on the upper branch): one closed loop of the curve in the
    plane, ending at two 1:1 resonances where the pair of multipliers becomes real."""
    atlas = atlas_map(kinds=("neimark_sacker",), second=(0.002, 0.22))
    curves = follow_kind(atlas, "neimark_sacker", [seed_slice(atlas, 0.1)])
    nnm1 = [c for c in curves if c.params()[:, 0].max() < 2 * np.pi * 0.2]
    assert len(nnm1) == 1
    at = [(0.15, omega) for _, omega in located(response_at(0.15), "neimark_sacker") if omega < 2 * np.pi * 0.2]
    assert len(at) == 4
    rows = check_curves(atlas, "neimark_sacker", nnm1, at, tolerance=1e-9)
    assert len(rows) == 4
    kinds = sorted(point.kind for point in nnm1[0].codim2)
    assert kinds == ["resonance_1_1", "resonance_1_1"], kinds
    # at each end the pair of the half-period map is real and double: cos(theta) = 1
    equations = nnm1[0].system.equations
    for U in (nnm1[0].points[0], nnm1[0].points[-1]):
        x, extra, params = nnm1[0].system.split(U)
        assert extra[0] == pytest.approx(1.0, abs=1e-9)
        nu = np.linalg.eigvals(equations.monodromy(x, params))
        pair = nu[np.argsort(np.abs(np.abs(nu) - 1.0))[:2]]
        assert np.abs(pair.imag).max() < 1e-4 and np.abs(pair - 1.0).max() < 1e-4
