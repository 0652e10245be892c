"""The tube in a circular hole at its plate through the tube target (tube.circular_hole), end to end on a coarse tube
(tests/data/small_circular_tube_config.yaml: 5 elements bending in two planes, H = 10), checked against independent
results:

* the planar NNM1 in the hole is the one-plane tube's NNM1 with the bilateral stop of the same gap, stiffness and
  eta (continued separately, at the same harmonics): along a diameter the radial law is the bilateral law;
* every node of the whirling NNM1 goes round a circle (constant radius over the period) and the stored wear power
  at the plate is F_N(R) omega R, with F_N the regularized radial law at the plate's radius R (docs/methods/wear.md);
  the planar orbits do not slide (zero wear power) and wear by impacts only.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy.interpolate import CubicSpline

from nnmstop.config import ConfigError, load_config, validate_config
from nnmstop.hbm.dataset import dataset_unknowns, system_arguments
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force
from nnmstop.netcdf import check_labelled
from nnmstop.stored_accuracy import check_orbits, structure_from_attributes
from nnmstop.tasks import hbm
from nnmstop.tasks.tube import circular_hole_config, tube_config
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]
CIRCULAR_CONFIG = REPO / "tests" / "data" / "small_circular_tube_config.yaml"
PLANAR_CONFIG = REPO / "tests" / "data" / "small_tube_config.yaml"


def snakemake(workdir: Path, config: Path, *args: str) -> str:
    return run_snakemake(workdir, config, *args, timeout=600).stdout


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("tube_circular")
    snakemake(workdir, CIRCULAR_CONFIG, "--cores", "2", "tube_circular")
    return workdir


def planned_rules(out: str) -> set:
    return set(re.findall(r"^(?:local)?rule (\w+):", out, flags=re.MULTILINE))


def test_the_tube_target_builds_the_circular_hole_only_when_configured(tmp_path):
    with_hole = snakemake(tmp_path / "with", CIRCULAR_CONFIG, "-n", "--forceall", "tube")
    assert {"tube_circular_stage", "tube_circular_branch", "tube_circular_figure"} <= planned_rules(with_hole)
    assert "results/tube/circular/whirl1.nc" in with_hole and "paper_figures/tube_circular_wear.pdf" in with_hole
    without = snakemake(tmp_path / "without", PLANAR_CONFIG, "-n", "--forceall", "tube")
    assert not any(rule.startswith("tube_circular") for rule in planned_rules(without))
    assert "circular" not in without


def test_circular_scene_datasets_and_figure(built):
    names = {p.name for p in (built / "paper_figures").iterdir()}
    assert names == {"tube_circular_wear.pdf", "tube_circular_wear.png"}
    for name in ("nnm1", "whirl1"):
        path = built / "results" / "tube" / "circular" / f"{name}.nc"
        with xr.open_dataset(path) as ds:
            check_labelled(ds)  # long_name and units everywhere, no NaN
            assert ds.attrs["planes"] == 2 and str(ds.stop_kind.values[0]) == "circular"
            assert int(ds.attrs["dofs"]) == 20  # 5 elements, clamped foot: 2 x 10 DOFs
            check_orbits(ds, path)  # the readers rebuild the beam bending in two planes and its orbits solve it
            # NNM1 throughout: a mode and its copy in the other plane are one (their split is round-off)
            assert np.all(ds.dominant_mode.values == 1) and ds.sizes["identity_change"] == 0


def _system(ds):
    return HarmonicBalanceSystem(
        structure_from_attributes(ds), int(ds.attrs["harmonics"]), **system_arguments(ds.attrs)
    )


def test_planar_nnm_in_the_hole_is_the_bilateral_tube_nnm(built):
    """The one-plane tube with a bilateral stop, continued on its own, has the same frequency-energy curve (to the
    interpolation between ANM points, about 1e-6 here; the whirl differs by percent), and the planar orbits stay in
    their plane."""
    config = load_config(CIRCULAR_CONFIG)
    circular = circular_hole_config(config)
    one_plane = {**tube_config(config), "hbm": circular["hbm"], "branches": {"nnm1": circular["branches"]["nnm1"]}}
    reference = hbm.build_stage(one_plane, "nnm1", 1)
    with xr.open_dataset(built / "results" / "tube" / "circular" / "nnm1.nc") as planar:
        energy, frequency = planar.energy.values, planar.frequency.values
        assert float(planar.attrs["rotation_angle"]) == 0.0  # planar motion along the first plane
        n = int(planar.attrs["dofs"]) // 2
        q = np.abs(np.concatenate([planar.q_cos.values, planar.q_sin.values], axis=-1))
        assert q[:, n:].max() <= 1e-10 * q[:, :n].max()
        assert np.all(planar.wear_power.values == 0.0) and np.all(planar.sliding_speed_max.values == 0.0)
        touching = planar.contact_force_max.values[:, 0] > 0
        assert touching.any() and np.all(planar.impact_work_rate.values[touching, 0] > 0)
    inside = (energy >= reference.energy.values.min()) & (energy <= reference.energy.values.max())
    assert inside.sum() >= 4 and energy[inside].max() > 10.0  # well into contact
    curve = CubicSpline(np.log(reference.energy.values), reference.frequency.values)
    np.testing.assert_allclose(curve(np.log(energy[inside])), frequency[inside], rtol=1e-5)
    with xr.open_dataset(built / "results" / "tube" / "circular" / "whirl1.nc") as whirl:  # what rtol tells apart
        whirl_curve = CubicSpline(np.log(whirl.energy.values), whirl.frequency.values)
    deep = inside & (energy > 10.0)
    assert np.all(np.abs(whirl_curve(np.log(energy[deep])) / frequency[deep] - 1) > 1e-2)


def test_whirl_of_the_tube_wears_at_F_N_omega_R(built):
    """On the whirl every node goes round a circle; the stored wear power is the regularized radial force at the
    plate's radius times the sliding speed omega R, and there is no impact work."""
    with xr.open_dataset(built / "results" / "tube" / "circular" / "whirl1.nc") as ds:
        system = _system(ds)
        U = dataset_unknowns(ds, system)
        stored = {name: ds[name].values[:, 0] for name in ("wear_power", "impact_work_rate", "sliding_speed_max")}
    stop = system.structure.stops[0]
    history = system.time_history(U, 256)
    q = np.moveaxis(history["q"], 1, 0)  # (dof, point, sample)
    x = stop.coordinates(q)  # the plate node's two displacements over the gap
    radius = np.hypot(x[0], x[1])
    R = radius.mean(axis=-1)
    np.testing.assert_allclose(radius, R[:, None] * np.ones_like(radius), rtol=1e-8)  # a circle
    omega = np.sqrt(U[:, system.i_lam])
    touching = R > 1.0
    assert touching.sum() >= 3 and (~touching).any()
    force = stop.gap * regularized_contact_force(R, ModelParameters(alpha=stop.stiffness, eta=stop.eta))
    speed = omega * R * stop.gap
    np.testing.assert_allclose(stored["sliding_speed_max"][touching], speed[touching], rtol=1e-8)
    np.testing.assert_allclose(stored["wear_power"][touching], (force * speed)[touching], rtol=1e-8)
    assert np.all(stored["wear_power"][~touching] == 0.0)
    assert np.all(np.abs(stored["impact_work_rate"]) <= 1e-6 * stored["wear_power"].max())


def test_a_circular_hole_needs_bilateral_plates():
    """Bad input is refused by name: a one-sided plate has no circular counterpart, an unknown motion or branch name
    is refused by the schema."""
    config = load_config(CIRCULAR_CONFIG)
    for key, value, named in (("motion", "spiral", "motion"), ("name", "orbit1", "orbit1")):
        bad = copy.deepcopy(config)
        branches = bad["tube"]["circular_hole"]["branches"]
        if key == "motion":
            branches["whirl1"]["motion"] = value
        else:
            branches[value] = branches.pop("whirl1")
        with pytest.raises(ConfigError, match=named):
            validate_config(bad)
    one_sided = copy.deepcopy(config)
    one_sided["tube"]["structure"]["stops"][0].update(kind="one_sided", side="positive")
    with pytest.raises(ValueError, match=r"tube.structure.stops\[0\] is 'one_sided'"):
        circular_hole_config(one_sided)
    plain = copy.deepcopy(config)
    del plain["tube"]["circular_hole"]
    with pytest.raises(ValueError, match="tube.circular_hole is not configured"):
        circular_hole_config(plain)
