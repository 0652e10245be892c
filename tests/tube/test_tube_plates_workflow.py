"""The tube on three plates end to end, reduced (tests/data/small_plates_config.yaml: 16 elements, 8 modes, H = 12).

The branch is computed on the Craig-Bampton reduced structure; its orbits are checked against the full
model's (Newton on the full, unreduced system at the same amplitude of the middle plate) within the a-priori
estimate of docs/reduction.md, and the deformed shapes drawn through the dataset's recovery matrix against the
plates' own DOFs.

In circular holes (``tube_plates.circular_hole``: the same mesh bending in two planes, 16 modes in pairs, H = 12),
against independent results: the planar NNM1 is the bilateral tube's NNM1 (a different structure, reduction and
system, both Newton-corrected at the same amplitude of the middle plate); the whirling NNM1 turns each plate round a
circle, its first harmonic solves the one-plane tube's nonlinear eigenproblem ``(K - omega^2 M) a + F(a) = 0`` with
the bilateral law at rest (the multi-DOF form of ``omega^2 = (k + F_N(R) / R) / m``), it agrees with the full,
unreduced two-plane model within the a-priori estimate, and its stored wear power at each plate is ``F_N(R) omega R``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from nnmstop import fourier
from nnmstop.config import load_config
from nnmstop.netcdf import check_labelled
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]
PLATES_CONFIG = REPO / "tests" / "data" / "small_plates_config.yaml"


def snakemake(workdir: Path, *args: str) -> str:
    return run_snakemake(workdir, PLATES_CONFIG, *args, timeout=900).stdout


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("plates")
    snakemake(workdir, "--cores", "2", "tube_plates")
    return workdir


@pytest.fixture(scope="module")
def nnm1(built):
    with xr.open_dataset(built / "results" / "tube_plates" / "nnm1.nc") as ds:
        return ds.load()


def test_target_builds_the_branch_the_forced_response_and_the_figures(built):
    names = {p.name for p in (built / "paper_figures").iterdir()}
    figures = ("frequency_energy", "shapes", "contact_force", "forced")
    figures += tuple(f"circular_{n}" for n in ("wear", "hole_shapes", "hole_contact"))
    assert names == {f"tube_plates_{n}.{e}" for n in figures for e in ("pdf", "png")}
    for path in (built / "results" / "tube_plates").rglob("*.nc"):
        with xr.open_dataset(path) as ds:
            check_labelled(ds)
            # one plane: 31 DOFs; in circular holes two planes, reduced onto both components of the 3 plates
            circular = "circular" in path.parts
            assert int(ds.attrs["full_dofs"]) == (62 if circular else 31) and ds.attrs["reduction"] == "craig_bampton"
            assert int(ds.attrs["boundary_dofs"]) == (6 if circular else 3) or path.name.startswith("forced")
    manifest = (built / "results" / "tube_plates" / "MANIFEST.sha256").read_text()
    assert "circular/whirl1.nc" in manifest and "circular/stages/nnm1_stage1.nc" in manifest
    with xr.open_dataset(built / "results" / "tube_plates" / "forced_F3.nc") as ds:
        # the forced DOF joined the boundary: 3 plates + w6, then the modes
        assert [str(v) for v in ds.dof_label.values[:4]] == ["w4", "w6", "w8", "w12"]
        assert ds.sizes["point"] > 2 and float(ds.amplitude.max()) > 1.0  # past grazing at the middle plate


def test_reduced_orbits_match_the_full_model_within_the_estimate(nnm1):
    """Each stored orbit against the full model's orbit at the same amplitude: errors below (f / f_next)^2."""
    from nnmstop.hbm.dataset import dataset_unknowns
    from nnmstop.hbm.reduced import full_unknowns, orbit_at_amplitude, orbit_difference
    from nnmstop.hbm.system import HarmonicBalanceSystem
    from nnmstop.settings import system_from_config
    from nnmstop.tasks.tube_plates import plates_config

    config = plates_config(load_config(PLATES_CONFIG))
    reduced = system_from_config(config)
    full_structure = system_from_config({**config, "structure": {"kind": "beam", "beam": config["structure"]["beam"]}})
    full = HarmonicBalanceSystem(full_structure.structure, reduced.H)
    assert reduced.n_dofs == 3 + 8 and full.n_dofs == 31
    U = dataset_unknowns(nnm1, reduced)
    f_next = float(nnm1.attrs["first_neglected_frequency"])
    assert nnm1.stop_impacts.values[:, 0].max() == 2  # the middle plate is hit on the part compared
    for point in U[:: max(1, len(U) // 4)]:
        amplitude = point[reduced.slices["x"].start + 1] / reduced.gaps[0]
        exact = orbit_at_amplitude(full, full_unknowns(reduced, full, point), amplitude)
        errors = orbit_difference(reduced, point, full, exact)
        estimate = (float(reduced.frequency_hz(point)) / f_next) ** 2
        assert errors["frequency"] < estimate and errors["harmonics"] < estimate, (errors, estimate)


def test_deformed_shapes_through_the_recovery_meet_the_plates_own_dofs(nnm1):
    """The shapes are drawn on the full mesh through `recovery`; at a plate they are that plate's reduced DOF."""
    from nnmstop.figures.structure import _deflection, _stop_positions

    H = int(nnm1.attrs["harmonics"])
    i = int(np.argmax(nnm1.energy.values))
    q = fourier.to_time(fourier.from_cos_sin(nnm1.q_cos.values[i], nnm1.q_sin.values[i]), H, 4 * H)  # (dof, t)
    w = _deflection(nnm1, q.T, _stop_positions(nnm1))  # (t, stop)
    np.testing.assert_allclose(w, q[nnm1.stop_dof.values].T, atol=1e-12 * np.abs(w).max())
    # the foot is clamped and the top pinned: no deflection there
    np.testing.assert_allclose(_deflection(nnm1, q.T, np.array([0.0, 1.0])), 0.0, atol=1e-12)


def test_a_plates_figure_alone_plans_only_what_it_needs(tmp_path):
    out = snakemake(tmp_path, "-n", "--forceall", "paper_figures/tube_plates_contact_force.pdf")
    rules = set(re.findall(r"^(?:local)?rule (\w+):", out, flags=re.MULTILINE))
    assert rules == {"tube_plates_stage", "tube_plates_branch", "tube_plates_figure"}


# --------------------------------------------------------------------------- circular holes


@pytest.fixture(scope="module")
def holes(built):
    """The circular holes' configuration, branches and systems (each with the arguments its dataset was built with)."""
    from nnmstop.hbm.dataset import system_arguments
    from nnmstop.hbm.system import HarmonicBalanceSystem
    from nnmstop.settings import system_from_config
    from nnmstop.tasks.tube_plates import plates_circular_config, plates_config

    config = load_config(PLATES_CONFIG)
    cases = {"circular": plates_circular_config(config), "bilateral": plates_config(config)}
    structures = {name: system_from_config(case).structure for name, case in cases.items()}
    found = {"cases": cases, "structures": structures}
    for name, path in (("nnm1", "circular/nnm1.nc"), ("whirl1", "circular/whirl1.nc"), ("bilateral", "nnm1.nc")):
        with xr.open_dataset(built / "results" / "tube_plates" / path) as ds:
            ds = ds.load()
        structure = structures["bilateral" if name == "bilateral" else "circular"]
        system = HarmonicBalanceSystem(structure, int(ds.attrs["harmonics"]), **system_arguments(ds.attrs))
        found[name] = (ds, system)
    return found


def _newton_at_stored_amplitudes(ds, system):
    """The stored orbits, each Newton-corrected to round-off at its own amplitude of the middle plate."""
    from nnmstop.hbm.dataset import dataset_unknowns
    from nnmstop.hbm.reduced import orbit_at_amplitude

    index = system.slices["x"].start + 1  # the first stop's first component, cos(theta)
    return np.array([orbit_at_amplitude(system, U, U[index] / system.gaps[0]) for U in dataset_unknowns(ds, system)])


def _displacements(system, U):
    return U[: system.n_dofs * system.nc].reshape(system.n_dofs, system.nc)


def test_planar_branch_in_the_holes_is_the_bilateral_branch(holes):
    """At each stored amplitude of the middle plate, the planar orbit in the holes and the bilateral tube's orbit
    (Newton on each system to round-off) have the same frequency and plate harmonics to round-off of the two
    reductions (the same basis in the first plane), and nothing moves in the second plane."""
    from nnmstop.hbm.dataset import dataset_unknowns
    from nnmstop.hbm.reduced import orbit_at_amplitude

    planar, circular = holes["nnm1"]
    bilateral, one_plane = holes["bilateral"]
    assert planar.attrs.get("motion", "planar") == "planar" and int(planar.attrs["rotation_condition"]) == 1
    orbits = _newton_at_stored_amplitudes(planar, circular)
    stored = dataset_unknowns(bilateral, one_plane)
    labels = list(circular.structure.dof_labels)
    w = [labels.index(name) for name in one_plane.structure.dof_labels[:3]]
    v = [labels.index(name.replace("w", "v")) for name in one_plane.structure.dof_labels[:3]]
    index = one_plane.slices["x"].start + 1
    amplitudes = orbits[:, circular.slices["x"].start + 1] / circular.gaps[0]
    assert amplitudes.max() > 1.0  # into contact with the middle plate
    for U, amplitude in zip(orbits, amplitudes):
        guess = stored[np.argmin(np.abs(stored[:, index] / one_plane.gaps[0] - amplitude))]
        reference = orbit_at_amplitude(one_plane, guess, amplitude)
        assert abs(circular.frequency_hz(U) / one_plane.frequency_hz(reference) - 1) < 1e-11
        Q, Q_ref = _displacements(circular, U), _displacements(one_plane, reference)
        np.testing.assert_allclose(Q[w], Q_ref[:3], rtol=0, atol=1e-11 * np.abs(Q_ref[:3]).max())
        assert np.abs(Q[v]).max() <= 1e-12 * np.abs(Q[w]).max()
        # the truncation indicator reads the plane of motion, not the round-off of the other component
        assert circular.truncation(U) == pytest.approx(one_plane.truncation(reference), rel=1e-6, abs=1e-20)
    assert np.all(planar.wear_power.values <= 1e-20 * planar.contact_force_max.values.max() ** 2)


def test_whirl_goes_round_circles_and_solves_the_rotating_eigenproblem(holes):
    """Each Newton-corrected whirl: every plate at a constant radius, its second component a quarter period behind
    the first; only the first harmonic (a rigid rotation of one shape ``a``), and ``a`` solves the one-plane tube's
    ``(K - omega^2 M) a + F(a) = 0`` (F: the stops' static regularized law), to round-off."""
    whirl, system = holes["whirl1"]
    one_plane = holes["structures"]["bilateral"]
    assert whirl.attrs["motion"] == "whirl"
    orbits = _newton_at_stored_amplitudes(whirl, system)
    samples = 256
    q = np.moveaxis(system.time_history(orbits, samples)["q"], 1, 0)  # (dof, point, sample)
    for stop in system.structure.stops:
        x = stop.coordinates(q)
        radius = np.hypot(x[0], x[1])
        R = radius.mean(axis=-1, keepdims=True)
        np.testing.assert_allclose(radius, R * np.ones_like(radius), rtol=1e-9)
        np.testing.assert_allclose(np.roll(x[0], samples // 4, axis=-1), x[1], atol=1e-9 * R.max())
    assert np.hypot(*system.structure.stops[0].coordinates(q))[:, 0].max() > 1.0  # in contact
    M, K = one_plane.dense_matrices()
    full = system.structure.reduction.recovery
    planar_recovery = one_plane.reduction.recovery
    n = planar_recovery.shape[0]
    for U in orbits:
        Q = _displacements(system, U)
        higher = np.delete(Q, [1, system.H + 1], axis=1)
        assert np.abs(higher).max() <= 1e-12 * np.abs(Q).max()
        shape = full @ Q[:, 1]  # the orbit at t = 0, on the full two-plane mesh: in the first plane
        assert np.abs(shape[n:]).max() <= 1e-12 * np.abs(shape[:n]).max()
        a = np.linalg.lstsq(planar_recovery, shape[:n], rcond=None)[0]
        force = np.zeros(one_plane.n_dofs)
        one_plane.contact.apply(force, one_plane.contact.forces(one_plane.contact.coordinates(a[:, None]))[:, 0])
        residual = K @ a + force - U[system.i_lam] * (M @ a)
        assert np.abs(residual).max() <= 1e-11 * np.abs(K @ a).max()


def test_whirl_against_the_full_model_and_its_wear(holes):
    """The whirl against the full, unreduced two-plane tube (Newton at the same amplitude of the middle plate) within
    the a-priori estimate (f / f_next)^2; at each plate the stored wear power is the regularized radial force at the
    plate's radius times the sliding speed omega R, zero where the plate is not touched, with no impact work."""
    from nnmstop.hbm.dataset import dataset_unknowns
    from nnmstop.hbm.reduced import full_unknowns, orbit_at_amplitude, orbit_difference
    from nnmstop.hbm.system import HarmonicBalanceSystem
    from nnmstop.models.beam import Beam, beam_structure
    from nnmstop.models.two_dof import ModelParameters, regularized_contact_force

    whirl, system = holes["whirl1"]
    beam = holes["cases"]["circular"]["structure"]["beam"]
    full = HarmonicBalanceSystem(beam_structure(Beam.from_parameters(dict(beam))), system.H, basis="full",
                                 rotation=False)  # fmt: skip
    assert full.n_dofs == 62 and system.n_dofs == 6 + 16
    U = dataset_unknowns(whirl, system)
    f_next = float(whirl.attrs["first_neglected_frequency"])
    index = system.slices["x"].start + 1
    for point in U[:: max(1, len(U) // 4)]:
        exact = orbit_at_amplitude(full, full_unknowns(system, full, point), point[index] / system.gaps[0])
        errors = orbit_difference(system, point, full, exact)
        estimate = (float(system.frequency_hz(point)) / f_next) ** 2
        assert errors["frequency"] < estimate and errors["harmonics"] < estimate, (errors, estimate)
    q = np.moveaxis(system.time_history(U, 64)["q"], 1, 0)
    omega = np.sqrt(U[:, system.i_lam])
    touched = 0
    for k, stop in enumerate(system.structure.stops):
        R = np.hypot(*stop.coordinates(q)).mean(axis=-1)
        touching = R > 1.0
        touched += touching.any()
        force = stop.gap * regularized_contact_force(R, ModelParameters(alpha=stop.stiffness, eta=stop.eta))
        np.testing.assert_allclose(whirl.wear_power.values[touching, k], (force * omega * R * stop.gap)[touching],
                                   rtol=1e-8)  # fmt: skip
        assert np.all(whirl.wear_power.values[~touching, k] == 0.0)
    assert touched >= 2  # the middle and the upper plates
    assert np.all(np.abs(whirl.impact_work_rate.values) <= 1e-6 * whirl.wear_power.values.max())


def test_circular_holes_config_is_checked_by_name():
    from nnmstop.config import ConfigError, validate_config
    from nnmstop.tasks.tube_plates import plates_circular_config

    config = load_config(PLATES_CONFIG)
    for key, value, named in (("reduction", {"modes": 15}, "multiple of 2"), ("structure", {"length": 2.0}, "length")):
        bad = {**config, "tube_plates": {**config["tube_plates"]}}
        bad["tube_plates"]["circular_hole"] = {**config["tube_plates"]["circular_hole"], key: value}
        with pytest.raises(ConfigError, match=named):
            validate_config(bad)
        if key == "structure":
            with pytest.raises(ValueError, match=r"tube_plates.circular_hole.structure: unknown keys \['length'\]"):
                plates_circular_config(bad)
    one_sided = load_config(PLATES_CONFIG)
    one_sided["tube_plates"]["structure"]["stops"][1].update(kind="one_sided", side="positive")
    with pytest.raises(ValueError, match=r"tube_plates.structure.stops\[1\] is 'one_sided'"):
        plates_circular_config(one_sided)
    del one_sided["tube_plates"]["circular_hole"]
    with pytest.raises(ValueError, match="tube_plates.circular_hole is not configured"):
        plates_circular_config(one_sided)
