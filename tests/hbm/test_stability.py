"""Stability dispatch (nnmstop.hbm.stability): both methods on orbits near rest, settings checks, and no verdict
resolved on an orbit beyond the calibrated range of the orbit-error estimate (issue 25.3)."""

import copy

import numpy as np
import pytest

from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.hill import DEFAULT_TOL
from nnmstop.hbm.monodromy import MonodromySettings
from nnmstop.hbm.stability import StabilitySettings, orbit_stability
from nnmstop.hbm.stages import start_point
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import linear_modes
from nnmstop.settings import stability_settings
from nnmstop.tasks.hbm import build_stage, system_from_config


@pytest.mark.parametrize("method", ["hill", "monodromy"])
def test_both_methods_give_the_modal_multipliers_near_rest(paper_params, method):
    """Near rest NNM1 is the linear mode: the non-trivial pair is exp(+-i omega_2 T), elliptic."""
    system = HarmonicBalanceSystem(two_dof_structure(paper_params), harmonics=8)
    U = np.array([start_point(system, 1, amplitude)[0] for amplitude in (1e-3, 2e-3)])
    result = orbit_stability(system, U, StabilitySettings(method=method))
    omega = linear_modes(paper_params, "regularized")[0]
    period = 2 * np.pi / omega[0]
    expected = np.exp(1j * omega[1] * period)
    assert result.stable.all() and result.resolved.all()
    for mu in result.multipliers:
        assert mu[:2] == pytest.approx([1.0, 1.0], abs=1e-6)
        assert np.abs(mu[2:]) == pytest.approx([1.0, 1.0], abs=1e-9)
        assert sorted(np.angle(mu[2:])) == pytest.approx(sorted([np.angle(expected), -np.angle(expected)]), abs=1e-5)
    data = result.data_vars()
    assert data["multiplier_real"][0] == ("point", "multiplier")


def test_settings_from_the_configuration_and_bad_values():
    assert stability_settings({}) == StabilitySettings()
    hill = stability_settings({"stability": {"method": "hill", "hill_tol": 1e-7}})
    assert hill.method == "hill" and hill.hill_tol == 1e-7
    mono = stability_settings({"stability": {"method": "monodromy", "steps": 128}})
    assert mono.monodromy == MonodromySettings(steps=128) and mono.hill_tol == DEFAULT_TOL
    with pytest.raises(ValueError, match="'qz'"):
        StabilitySettings(method="qz")
    with pytest.raises(ValueError, match="tol"):
        StabilitySettings(hill_tol=-1.0)
    with pytest.raises(ValueError, match="StabilitySettings"):
        orbit_stability(None, np.zeros((1, 3)), {"method": "hill"})


def test_orbits_beyond_the_calibrated_residual_are_never_resolved_on_their_own(h40_config):
    """Issue 25.3: a loosened truncation guard (max_truncation 0.5) on a stiff stop (alpha = 1e4) at H = 12 lets
    orbits with time residuals near 1 into the branch. None of them may be marked resolved on its own HBM orbit
    (reason 0): their verdict comes from the orbit refined by shooting (reason 3, its closure within the shooting
    tolerance and its period within refine_max_change) or stays unresolved; Hill's method marks none resolved.
    Below the limit nothing changes (the paper's branches: tests/hbm/test_monodromy.py)."""
    config = copy.deepcopy(h40_config)
    config["model"]["alpha"] = 1.0e4
    config["hbm"].update(harmonics=12, max_truncation=0.5)
    ds = build_stage(config, "nnm1", 1)
    settings = stability_settings(config).monodromy
    beyond = ds.time_residual.values > settings.max_orbit_residual
    assert beyond.sum() >= 3  # the reproduction: residuals up to about 1
    reason = ds.stability_reason.values[beyond]
    assert not np.any(reason == 0)
    refined = ds.stability_refined.values[beyond].astype(bool)
    assert np.all(refined | (reason == 2))
    resolved = ds.stability_resolved.values[beyond].astype(bool)
    assert np.all(reason[resolved] == 3)
    assert np.all(ds.stability_refined_residual.values[beyond][resolved] <= settings.refine_tol)
    assert np.all(np.abs(ds.stability_refined_frequency_change.values[beyond][resolved]) <= settings.refine_max_change)
    system = system_from_config(config)
    U = dataset_unknowns(ds, system)[beyond]
    hill = orbit_stability(system, U, StabilitySettings(method="hill"), time_residual=ds.time_residual.values[beyond])
    assert not hill.resolved.any()
