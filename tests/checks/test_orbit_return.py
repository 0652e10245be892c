"""python -m nnmstop.checks.orbit_return: a stored orbit integrated by DOP853 over several periods returns.

The exact orbits are closed-form solutions of the non-smooth equations: integrated region by region by DOP853
(another method) they return to their start to the integrator's tolerance, period after period. A regularized
HBM orbit returns to about its own error (its stored time residual bounds it). The structure's regularized
integrator is checked against the 2-DOF one of the paper's oscillator (its own vector field).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from nnmstop.checks.orbit_return import main, orbit_return
from nnmstop.checks.time_integration import integrate_regularized, integrate_structure_regularized
from nnmstop.config import load_config
from nnmstop.exact.dataset import two_impact_dataset
from nnmstop.exact.family import follow_two_impact_family
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters
from nnmstop.tasks.hbm import build_stage


@pytest.fixture(scope="module")
def exact():
    ds = two_impact_dataset(follow_two_impact_family(ModelParameters(), step=0.1, max_points=60))
    ds.attrs.update(ModelParameters().as_attrs())
    return ds


def test_an_exact_orbit_returns_to_the_integrators_tolerance(exact):
    result = orbit_return(exact, 30, periods=4, structure=two_dof_structure())
    assert result.model == "non-smooth"
    assert np.all(result.return_error < 1e-9)
    assert np.all(np.abs(result.energy_drift) < 1e-10)


def test_a_regularized_orbit_returns_within_its_own_error():
    """An orbit of NNM1 at H = 40 (past grazing): the return error after each period stays below ten times its
    stored time residual; the energy is conserved by the integration to its tolerance."""
    config = copy.deepcopy(load_config("config/config.yaml"))
    config["hbm"].update(harmonics=40, points_per_step=1)
    config["branches"]["nnm1"]["stages"] = [{"name": "to_E5", "until": {"energy_above": 5.0}}]
    ds = build_stage(config, "nnm1", 1)
    i = int(np.flatnonzero(ds["impacts_per_period"].values == 2)[-1])
    result = orbit_return(ds, i, periods=3, structure=two_dof_structure(ModelParameters.from_config(config["model"])))
    assert result.model == "regularized"
    assert np.all(result.return_error < 10 * float(ds["time_residual"].values[i]) + 1e-9)
    assert np.all(np.abs(result.energy_drift) < 1e-9)


def test_the_structure_integrator_is_the_2dof_one_on_the_paper_oscillator():
    params = ModelParameters()
    z0 = np.array([0.3, -0.2, 1.5, 0.4])
    t = np.linspace(0.0, 20.0, 11)
    a = integrate_regularized(params, z0, t).states
    b = integrate_structure_regularized(two_dof_structure(params), z0, t).states
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-9)


def test_the_command_prints_each_period(exact, tmp_path, capsys):
    path = tmp_path / "exact.nc"
    exact.to_netcdf(path)
    assert main([str(path), "--point", "10", "--periods", "2"]) == 0
    out = capsys.readouterr().out
    assert "after   2 period(s)" in out and "non-smooth equations" in out


def test_bad_input_is_named(exact):
    with pytest.raises(ValueError, match="periods"):
        orbit_return(exact, 0, periods=0, structure=two_dof_structure())
    with pytest.raises(ValueError, match="point must be in"):
        orbit_return(exact, 10_000, structure=two_dof_structure())
