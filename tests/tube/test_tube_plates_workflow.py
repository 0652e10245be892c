"""The tube on three plates end to end, reduced (tests/data/small_plates_config.yaml: 16 elements, 8 modes, H = 12).

The branch is computed on the Craig-Bampton reduced structure; its orbits are checked against the full
model's (Newton on the full, unreduced system at the same amplitude of the middle plate) within the a-priori
estimate of docs/reduction.md, and the deformed shapes drawn through the dataset's recovery matrix against the
plates' own DOFs.
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
    assert names == {f"tube_plates_{n}.{e}" for n in figures for e in ("pdf", "png")}
    for path in (built / "results" / "tube_plates").rglob("*.nc"):
        with xr.open_dataset(path) as ds:
            check_labelled(ds)
            assert int(ds.attrs["full_dofs"]) == 31 and ds.attrs["reduction"] == "craig_bampton"
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
