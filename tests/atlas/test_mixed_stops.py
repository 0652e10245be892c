"""The atlas of a structure whose bilateral stop stands beside a one-sided one (no half-wave symmetry).

The two sides of the bilateral stop graze together, and without the symmetry the family leaving that grazing has
two contact phases at once: the exact atlas does not follow it (``without_exact_responses`` says why), and the
map is the regularized one, like a circular clearance's. Independent checks: with the one-sided stop out of reach
(gap 20), the non-impacting response is the paper's oscillator's, whose grazing frequencies the exact forced code
locates; the regularized fold curves pass through the folds located on the regularized responses at the check
force (the atlas' own check, to the harmonic balance's tolerance).
"""

import dataclasses

import numpy as np
import pytest

import nnmstop
from nnmstop.bifurcation_atlas.build import without_exact_responses
from nnmstop.bifurcation_atlas.curves import CurveSettings
from nnmstop.exact.forced import grazing_frequencies
from nnmstop.models.contact import Stop
from nnmstop.models.excitation import Damping, Excitation, HarmonicForce

DAMPING = Damping(0.0, 0.02)  # Rayleigh: C = 0.02 K
FAST = CurveSettings(step=0.05, tolerance=1e-11, max_points=1200, max_frequency_step=0.002, max_log_second_step=0.2)


def mixed_structure() -> nnmstop.Structure:
    paper = nnmstop.two_dof_structure()
    far = Stop(dof=1, gap=20.0, stiffness=30.0, eta=0.1, kind="one_sided", side="positive")
    return dataclasses.replace(paper, stops=(paper.stops[0], far))


def test_why_a_structure_has_no_exact_atlas():
    paper = nnmstop.two_dof_structure()
    assert without_exact_responses(paper) is None  # bilateral: the half-wave symmetry
    one_sided = dataclasses.replace(paper, stops=(mixed_structure().stops[1],))
    assert without_exact_responses(one_sided) is None  # one contact per stop: the full period
    why = without_exact_responses(mixed_structure())
    assert why is not None and "bilateral stop on q0" in why and "graze together" in why


@pytest.mark.numerics
def test_the_atlas_of_a_bilateral_stop_beside_a_one_sided_one_is_the_regularized_one():
    structure = mixed_structure()
    ds = nnmstop.atlas(structure, (0.08, 0.2), ["u"], (0.1, 0.2), slices=2, kinds=("grazing", "regularized_fold"),
                       seeds=[0.2], checks=[0.1], frequency_samples=40, curve=FAST, damping=DAMPING,
                       regularized={"harmonics": 20, "max_truncation": 1e-2})  # fmt: skip
    assert ds.attrs["harmonics"] == 20  # regularized slices
    kinds = ds["curve_kind"].values
    assert set(kinds.tolist()) == {0, 1}  # grazing, fold
    grazing = ds["check_curve"].isin(np.flatnonzero(kinds == 0)).values
    assert ds["check_deviation"].values[grazing].max() < 1e-7
    assert ds["check_deviation"].values[~grazing].max() < 1e-5
    # the grazing curve crosses F = 0.1 where the paper's oscillator's linear response grazes (exact code)
    paper = Excitation(nnmstop.two_dof_structure(), DAMPING, HarmonicForce(0.1, (1,)))
    expected = np.sort(np.asarray(grazing_frequencies(paper, 2 * np.pi * 0.08, 2 * np.pi * 0.2)) / (2 * np.pi))
    np.testing.assert_allclose(np.sort(ds["check_curve_frequency"].values[grazing]), expected, rtol=1e-9)
    with pytest.raises(ValueError, match="graze together.*regularized_fold"):
        nnmstop.atlas(structure, (0.08, 0.2), ["u"], (0.1, 0.2), kinds=("grazing", "fold"))
