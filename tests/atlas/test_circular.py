"""The atlas of a circular clearance (a body moving in two directions in a hole): no exact responses, so regularized
slices, the grazing curve in closed form and the regularized curves.

Two structures: a 2-DOF chain (unit masses, springs 2, -1) in each of two planes, DOFs ``(x0, x1, y0, y1)``, the
hole on ``(x0, y0)``, forced on ``x0``, stiffness-proportional damping ``C = 0.04 K``; isotropic (the same chain in
both planes, invariant under rotations) or stiffer across (``K_y = 2 K_x``). Along a diameter the circular law is
the bilateral one: the isotropic structure forced in one plane responds as the planar chain with a bilateral stop,
which is the independent check of the regularized curves; the grazing curve is checked against the orbit's largest
radius maximized over the phase, and the regions against the folds the forced path locates.
"""

import numpy as np
import pytest
import scipy.optimize

import nnmstop
from nnmstop.bifurcation_atlas.build import AtlasMap, curves_dataset, slice_dataset
from nnmstop.bifurcation_atlas.flags import REGIONS
from nnmstop.bifurcation_atlas.grazing import grazing_second, semi_major_axis, stop_reaches
from nnmstop.bifurcation_atlas.regularized import regularized_located, stability_settings
from nnmstop.continuation.anm import ANMSettings
from nnmstop.exact.forced import grazing_frequencies, non_impacting_response
from nnmstop.forced.responses import RegularizedSettings, locate_folds, regularized_response
from nnmstop.models.excitation import Damping, Excitation, HarmonicForce

CHAIN = np.array([[2.0, -1.0], [-1.0, 2.0]])
WINDOW_HZ = (0.12, 0.21)
ANM = ANMSettings(points_per_step=2)
REGULARIZED = {"harmonics": 15, "max_truncation": 1e-3, "steps": 128, "step": 0.5, "check_tolerance": 1e-5}


def hole(gap=1.0):
    return nnmstop.Stop(kind="circular", dofs=[0, 2], gap=gap, stiffness=5.0, eta=0.2)


def two_planes(across=1.0, coupling=0.0, rotation=False) -> nnmstop.Structure:
    """The chain in two planes; ``across`` scales the y-plane's springs, ``coupling`` a spring between x0 and y0."""
    K = np.zeros((4, 4))
    K[:2, :2], K[2:, 2:] = CHAIN, across * CHAIN
    K[0, 2] = K[2, 0] = -coupling
    pairs = [(0, 2), (1, 3)] if rotation else None
    return nnmstop.Structure(np.eye(4), K, [hole()], rotation_pairs=pairs)


def excitation(structure, force=0.2) -> Excitation:
    return Excitation(structure, Damping(0.0, 0.04), HarmonicForce(force, [0]))


def force_map(structure, values, **kwargs) -> AtlasMap:
    regularized = {**REGULARIZED, "seeds": [values[-1]], "checks": [values[0]]}
    return AtlasMap("hole", excitation(structure), "force", WINDOW_HZ, (0.01, 0.5), tuple(values), (values[-1],),
                    (values[0],), ("grazing",), regularized=regularized, **kwargs)  # fmt: skip


def largest_radius(C, samples=4096) -> float:
    """``max_theta |Re(C e^{i theta})|`` sampled, the best sample refined by a bounded scalar search."""
    theta = 2 * np.pi * np.arange(samples) / samples
    radii = np.linalg.norm(np.real(np.multiply.outer(np.exp(1j * theta), C)), axis=1)
    best, h = theta[np.argmax(radii)], 2 * np.pi / samples
    found = scipy.optimize.minimize_scalar(
        lambda t: -np.linalg.norm(np.real(C * np.exp(1j * t))), bounds=(best - h, best + h), method="bounded",
        options={"xatol": 1e-13},
    )  # fmt: skip
    return float(-found.fun)


# ------------------------------------------------------------------ the grazing curve in closed form


def test_the_semi_major_axis_is_the_orbits_largest_radius():
    """Random complex 2-vectors, and the linear response of the chain coupled across the planes (its clearance
    coordinates run over a true ellipse): sqrt((|Q|^2 + |Q^T Q|)/2) against the sampled, refined largest radius
    (1e-9); a one-component stop gets |C|."""
    rng = np.random.default_rng(31)
    C = rng.normal(size=(20, 2)) + 1j * rng.normal(size=(20, 2))
    np.testing.assert_allclose(semi_major_axis(C), [largest_radius(c) for c in C], rtol=1e-9)
    np.testing.assert_allclose(semi_major_axis(C[:, :1]), np.abs(C[:, 0]), rtol=1e-14)
    coupled = excitation(two_planes(across=1.3, coupling=0.4), force=1.0)
    omega = 2 * np.pi * np.linspace(*WINDOW_HZ, 7)
    Q = non_impacting_response(coupled, omega)[:, [0, 2]]
    ratio = np.abs(Q).min(axis=1) / np.abs(Q).max(axis=1)
    assert ratio.min() > 1e-2  # both coordinates move: an ellipse, not a segment
    np.testing.assert_allclose(stop_reaches(coupled, omega)[:, 0], [largest_radius(q) for q in Q], rtol=1e-9)


def test_an_isotropic_structure_forced_along_one_axis_grazes_along_a_line():
    """Forced along x, the isotropic structure's linear response stays on the x axis: a = |Q_x|, and the grazing
    force g / |Q_x| is that of the planar chain with a bilateral stop (its exact grazing frequencies, located by
    nnmstop.exact.forced.grazing_frequencies, give back the force to 1e-10)."""
    iso = excitation(two_planes(rotation=True), force=1.0)
    omega = 2 * np.pi * np.linspace(*WINDOW_HZ, 9)
    Q = non_impacting_response(iso, omega)
    assert np.abs(Q[:, 2:]).max() == 0.0
    np.testing.assert_allclose(stop_reaches(iso, omega)[:, 0], np.abs(Q[:, 0]), rtol=1e-14)
    stop = nnmstop.Stop(kind="bilateral", dof=0, gap=1.0, stiffness=5.0, eta=0.2)
    chain = Excitation(nnmstop.Structure(np.eye(2), CHAIN, [stop]), Damping(0.0, 0.04), HarmonicForce(0.2, [0]))
    grazing = grazing_frequencies(chain, *(2 * np.pi * f for f in WINDOW_HZ))
    assert len(grazing) == 2
    atlas = force_map(two_planes(rotation=True), (0.2,))
    np.testing.assert_allclose(grazing_second(atlas, grazing), 0.2, rtol=1e-10)


def test_the_grazing_curve_job_is_the_closed_form_and_checks_it():
    """curves_dataset('grazing') of the coupled structure: every point at g / a(Omega) (a from the sampled orbit,
    1e-9), the orbit stored at the grazing force touching the gap, and the checks at the check value (grazing
    frequencies located on the sampled orbit radius) within 1e-7."""
    structure = two_planes(across=1.3, coupling=0.4)
    atlas = force_map(structure, (0.15, 0.2))
    ds = curves_dataset(atlas, "grazing", [], [slice_like(0.15)])
    assert ds.sizes["curve"] >= 1 and ds.sizes["check"] == 2
    assert float(ds["check_deviation"].max()) < 1e-7
    omega = 2 * np.pi * ds["frequency"].values[::97]
    Q = non_impacting_response(excitation(structure, 1.0), omega)[:, [0, 2]]
    np.testing.assert_allclose(ds["second"].values[::97], [1.0 / largest_radius(q) for q in Q], rtol=1e-9)
    assert set(ds["curve_kind"].values.tolist()) == {0}


def slice_like(value):
    """A stand-in for a check slice (the grazing job reads only its value)."""
    import xarray as xr

    return xr.Dataset(attrs={"slice_value": value})


# ------------------------------------------------------------------ regularized slices


@pytest.mark.numerics
def test_regularized_slices_read_no_contact_below_grazing_and_coexistence_between_the_folds():
    """Stiffer across (the planar orbits stay stable out of plane): at F = 0.05, below the smallest grazing force of
    the window, one stable response that never reaches the gap (no_contact everywhere); at F = 0.2, a fold pair:
    the coexisting cells are exactly the grid cells between the two folds the forced path locates (locate_folds,
    the seeds of the regularized fold curves), impacting where the orbit's radius exceeds the gap."""
    structure = two_planes(across=2.0)
    atlas = force_map(structure, (0.05, 0.2), grid=90)
    below = slice_dataset(atlas, 0, ANM)
    assert below.attrs["slice_law"] == "regularized" and below.sizes["end"] == 0
    frequencies = np.linspace(*WINDOW_HZ, 400)
    assert grazing_second(atlas, 2 * np.pi * frequencies).min() > 0.05
    assert np.all(below["region"].values == REGIONS.index("no_contact"))
    assert not below["response_impacting"].any()
    above = slice_dataset(atlas, 1, ANM)
    folds = sorted(U[-1] / (2 * np.pi) for U in regularized_located(atlas, "regularized_fold", 0.2, ANM,
                                                                   stability_settings(atlas)))  # fmt: skip
    assert len(folds) == 2
    grid = above["grid_frequency"].values
    coexisting = above["region"].values == REGIONS.index("coexisting")
    np.testing.assert_array_equal(coexisting, (grid > folds[0]) & (grid < folds[1]))
    assert np.all(above["responses"].values[coexisting] == 3)
    # the stored fold changes are the located ones (both from the Floquet multipliers and from Omega's extremum)
    changes = np.sort(above["change_state"].values[:, -1] / (2 * np.pi))
    np.testing.assert_allclose(changes, folds, rtol=1e-7)
    impacting = above["response_impacting"].values.astype(bool)
    assert impacting.any() and np.all(above["response_amplitude"].values[impacting, 0] > 1.0)
    assert np.any(above["region"].values == REGIONS.index("impacting"))


# ------------------------------------------------------------------ planar responses of an isotropic structure


@pytest.fixture(scope="module")
def planar_and_bilateral():
    """The regularized responses (H = 15) at F = 0.2 of the isotropic structure (rotation pairs declared) and of the
    planar chain with a bilateral stop of the same gap, stiffness and eta, with their located folds."""
    from nnmstop.continuation.anm import ANMStepper

    stop = nnmstop.Stop(kind="bilateral", dof=0, gap=1.0, stiffness=5.0, eta=0.2)
    out = []
    for structure in (two_planes(rotation=True), nnmstop.Structure(np.eye(2), CHAIN, [stop])):
        system, branch = regularized_response(excitation(structure), WINDOW_HZ, RegularizedSettings(15, ANM, 1e-3))
        folds = locate_folds(system, ANMStepper(ANM), branch.points, system.i_omega)
        out.append((system, [U for _, U in folds]))
    return out


def test_the_planar_response_in_a_hole_is_the_bilateral_one(planar_and_bilateral):
    """Forced along x the isotropic structure's harmonic balance (no rotation condition: the force fixes the plane,
    the Jacobian is regular) stays planar, and its folds are the bilateral chain's: frequencies and orbits to the
    Newton threshold of the responses (1e-8), each fold orbit solving the other structure's equations."""
    (circular, planar_folds), (bilateral, bilateral_folds) = planar_and_bilateral
    assert len(planar_folds) == len(bilateral_folds) == 2
    nc = circular.nc
    for U, V in zip(planar_folds, bilateral_folds):
        assert abs(U[-1] - V[-1]) <= 1e-8 * V[-1]
        np.testing.assert_allclose(U[: 2 * nc], V[: 2 * nc], rtol=0, atol=1e-8 * np.abs(V[: 2 * nc]).max())
        assert np.abs(U[2 * nc : 4 * nc]).max() <= 1e-12  # y stays at rest
        # the fold is regular in (state, Omega): no direction of the hole's rotations is left free
        J = circular.jacobian(U)
        sigma = np.linalg.svd(J.toarray() if hasattr(J, "toarray") else J, compute_uv=False)
        assert sigma[-1] > 1e-6 * sigma[0]


@pytest.mark.numerics
def test_the_atlas_of_a_circular_clearance(planar_and_bilateral):
    """nnmstop.atlas(kinds=('grazing', 'regularized_fold')) of the isotropic structure in its hole: regularized
    slices, the closed-form grazing curve and the regularized fold curves, every check passing; the fold curves
    cross F = 0.2 where the bilateral chain's folds are (1e-7), the exact kinds still refused by name."""
    from nnmstop.bifurcation_atlas.curves import CurveSettings

    fast = CurveSettings(step=0.05, tolerance=1e-11, max_points=1200, max_frequency_step=0.002, max_log_second_step=0.2)
    structure = two_planes(rotation=True)
    ds = nnmstop.atlas(structure, WINDOW_HZ, [0], (0.2, 0.3), slices=2, damping=Damping(0.0, 0.04),
                       kinds=("grazing", "regularized_fold"), seeds=[0.2], checks=[0.3], frequency_samples=60,
                       curve=fast, regularized={"harmonics": 15, "range": [0.18, 0.32]})  # fmt: skip
    assert ds.attrs["dataset_kind"] == "atlas" and ds.sizes["slice"] == 2
    kinds = ds["curve_kind"].values
    assert set(kinds.tolist()) == {0, 1}  # grazing, fold
    grazing_checks = ds["check_curve"].isin(np.flatnonzero(kinds == 0)).values
    assert grazing_checks.sum() == 2 and ds["check_deviation"].values[grazing_checks].max() < 1e-7
    assert (~grazing_checks).sum() == 2 and ds["check_deviation"].values[~grazing_checks].max() < 1e-5
    # the fold curves, solved at the check force 0.3, pass through the bilateral chain's folds there
    (bilateral, _) = planar_and_bilateral[1]
    system, branch = regularized_response(excitation(bilateral.structure, 0.3), WINDOW_HZ,
                                          RegularizedSettings(15, ANM, 1e-3))  # fmt: skip
    from nnmstop.continuation.anm import ANMStepper

    folds = [U[-1] / (2 * np.pi) for _, U in locate_folds(system, ANMStepper(ANM), branch.points, system.i_omega)]
    on_curves = np.sort(ds["check_curve_frequency"].values[~grazing_checks])
    np.testing.assert_allclose(on_curves, np.sort(folds), rtol=1e-7)
    with pytest.raises(ValueError, match="circular clearance of q0, q2 is not piecewise linear.*regularized_fold"):
        nnmstop.atlas(structure, WINDOW_HZ, [0], (0.2, 0.3), damping=Damping(0.0, 0.04), kinds=("grazing", "fold"))


@pytest.mark.numerics
def test_the_configuration_route_takes_a_circular_clearance(tmp_path):
    """The workflow's jobs (:mod:`nnmstop.tasks.atlas`) on the 3-DOF example with a circular clearance on (x1, x2):
    regularized slices written and read back (slice_law, no family ends), the grazing curve the closed form
    1 / max_theta |(x1, x2)| of the chain's linear response at unit force (sampled orbit, 1e-9), the map assembled."""
    from pathlib import Path

    import yaml

    from nnmstop.config import validate_config
    from nnmstop.forced.scenes import forced_scenes
    from nnmstop.netcdf import read_dataset
    from nnmstop.tasks import atlas as tasks

    example = Path(__file__).resolve().parents[2] / "examples" / "three_dof_chain"
    config = yaml.safe_load((example / "config.yaml").read_text())
    matrices = config["structure"]["matrices"]
    for name in ("mass", "stiffness"):
        matrices[name] = str(example / f"{name}.mtx")
    matrices["stops"] = [{"kind": "circular", "dofs": [0, 1], "gap": 1.0, "stiffness": 5.0, "eta": 0.2}]
    config["atlas"]["maps"]["chain_force"].update(
        slices={"from": 0.02, "to": 0.04, "count": 2}, seeds=[0.04], checks=[0.02], kinds=["grazing"],
        regularized={"harmonics": 10, "max_truncation": 1.0e-2, "steps": 64, "seeds": [0.04], "checks": [],
                     "check_tolerance": 1.0e-5, "step": 0.5},
    )  # fmt: skip
    config["atlas"]["frequency_samples"] = 20
    config = validate_config(config)
    slices = [str(tmp_path / f"slice_{k}.nc") for k in range(2)]
    for k, path in enumerate(slices):
        tasks.atlas_slice(config, {}, {"dataset": path}, map="chain_force", index=str(k))
        written = read_dataset(path)
        assert written.attrs["slice_law"] == "regularized" and written.sizes["end"] == 0
    curves = str(tmp_path / "curves_grazing.nc")
    tasks.atlas_curves(config, {"seeds": slices[1:], "checks": slices[:1]}, {"dataset": curves}, map="chain_force",
                       kind="grazing")  # fmt: skip
    tasks.atlas_map(config, {"slices": slices, "curves": [curves]}, {"dataset": str(tmp_path / "map.nc")},
                    map="chain_force")  # fmt: skip
    ds = read_dataset(tmp_path / "map.nc")
    assert ds.sizes["point"] > 10 and ds.sizes["check"] >= 1 and float(ds["check_deviation"].max()) < 1e-7
    unit = forced_scenes({**config, "forced": {**config["forced"], "force": {"dofs": ["x3"], "amplitudes": [1.0]}}},
                         "structure")[0].excitation  # fmt: skip
    assert unit.structure.stops[0].kind == "circular"
    omega, force = 2 * np.pi * ds["frequency"].values[::53], ds["second"].values[::53]
    Q = non_impacting_response(unit, omega)[:, :2]
    np.testing.assert_allclose(force, [1.0 / largest_radius(q) for q in Q], rtol=1e-9)
