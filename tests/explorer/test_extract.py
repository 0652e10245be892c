"""The explorer's data (nnmstop.explorer.extract, .exact_orbits, .page) against the datasets they come from."""

from __future__ import annotations

import base64
import hashlib
import json
import re

import numpy as np
import pytest
import xarray as xr

from nnmstop import fourier
from nnmstop.exact.problem import SequenceProblem
from nnmstop.explorer.exact_orbits import orbit_coefficients, orbit_unknowns
from nnmstop.explorer.extract import ExplorerSettings, extract_branch, read_manifest
from nnmstop.explorer.page import PLOTLY, encode, plotly_source
from nnmstop.models.two_dof import ModelParameters, total_energy

SETTINGS = ExplorerSettings(time_samples=256, exact_harmonics=48)


def record(build, kind, path):
    return extract_branch(kind, path, read_manifest(build / "results/MANIFEST.sha256"), SETTINGS, root=build)


def cosines(ds: xr.Dataset, name: str) -> np.ndarray:
    """Cosine coefficients (point, harmonic) of the paper's ``x``, ``u`` (``q_cos`` by ``dof_label``) or ``f``."""
    if name == "f":
        return ds["f_cos"].values[:, 0]
    return ds["q_cos"].values[:, list(ds["dof_label"].values).index(name)]


def test_regularized_orbits_survive_float32_and_dropped_harmonics(small_build):
    """The page's coefficients synthesize the dataset's orbits to float32 resolution."""
    path = "results/hbm/nnm1.nc"
    branch = record(small_build, "regularized", path)
    ds = xr.open_dataset(small_build / path)
    H = ds.sizes["harmonic"] - 1
    kept = branch["orbit"]["harmonics"]
    for name in ("x", "u", "f"):
        full = cosines(ds, name)
        stored = np.zeros_like(full)
        stored[:, kept] = branch["orbit"]["fields"][name]
        exact = fourier.to_time(full, H, 4 * H)
        page = fourier.to_time(stored, H, 4 * H)
        scale = np.abs(exact).max(axis=1, keepdims=True)
        assert np.abs(page - exact).max() <= 1e-6 * scale.max()
        assert (np.abs(page - exact) <= 1e-6 * scale + 1e-12).all()
    np.testing.assert_allclose(branch["orbit"]["omega"], np.sqrt(ds["omega_squared"].values), rtol=1e-15)


def test_labels_units_and_identity_come_from_the_dataset(small_build):
    path = "results/hbm/nnm1.nc"
    branch = record(small_build, "regularized", path)
    ds = xr.open_dataset(small_build / path)
    for name, meta in branch["meta"].items():
        assert meta["long_name"] == ds[name].attrs["long_name"] and meta["units"] == ds[name].attrs["units"]
    assert branch["meta"]["stability_reason"]["flag_meanings"] == ds["stability_reason"].attrs["flag_meanings"].split()
    assert branch["id"] == ds.attrs["id"] and branch["title"] == ds.attrs["title"]
    assert branch["sha256"] == hashlib.sha256((small_build / path).read_bytes()).hexdigest()
    assert branch["in_manifest"] and branch["path"] == path
    np.testing.assert_array_equal(branch["columns"]["energy"], ds["energy"].values)
    np.testing.assert_array_equal(branch["marks"]["folds"]["energy"], ds["fold_energy"].values)


def test_a_stale_manifest_is_refused(small_build, tmp_path):
    manifest = read_manifest(small_build / "results/MANIFEST.sha256")
    manifest["results/hbm/nnm2.nc"] = "0" * 64
    with pytest.raises(ValueError, match="differs from the manifest"):
        extract_branch("regularized", "results/hbm/nnm2.nc", manifest, SETTINGS, root=small_build)
    with pytest.raises(ValueError, match="unknown kind of branch 'forced'"):
        extract_branch("forced", "results/hbm/nnm2.nc", manifest, SETTINGS, root=small_build)


def test_exact_orbits_rebuilt_from_start_velocities_keep_energy_and_extremes(small_build):
    """Closed-form orbits from (xdot0, udot0, sequence, period): they close, conserve the stored energy
    and reach the stored x_max (from the family's own extrema), in every impact regime of the branch."""
    ds = xr.open_dataset(small_build / "results/exact/nnm1.nc")
    params = ModelParameters(
        alpha=float(ds.attrs["alpha"]), beta=float(ds.attrs["beta"]), delta=float(ds.attrs["delta"])
    )
    sequences = ds["phase_sequence"].values
    picks = [
        int(np.flatnonzero(sequences == s)[len(np.flatnonzero(sequences == s)) // 2]) for s in np.unique(sequences)
    ]
    assert len(picks) >= 2  # the small build reaches past the two-impact family
    for i in picks + [0]:  # point 0: the grazing orbit
        problem = SequenceProblem(params, str(sequences[i]))
        y = orbit_unknowns(problem, float(ds["xdot0"][i]), float(ds["udot0"][i]), float(ds["period"][i]) / 4)
        assert np.abs(problem.residual(y)).max() < 1e-10
        t = np.linspace(0.0, float(ds["period"][i]), 2001)
        history = problem.time_history(y, t)
        energy = total_energy(history.x, history.u, history.xdot, history.udot, params, model="piecewise")
        np.testing.assert_allclose(energy, float(ds["energy"][i]), rtol=1e-11)
        series = orbit_coefficients(problem, y, 64)
        assert series["sine_share"] < 1e-12  # even about the turning point: a cosine series
        theta = np.linspace(0.0, 2 * np.pi, 8192, endpoint=False)
        x = fourier.PhaseSynthesis(theta, 64).values(series["x"], np.zeros(65))
        # the truncated series of a C2 orbit: its peak within 1e-4 of the exact one
        assert abs(x.max() - float(ds["x_max"][i])) < 1e-4 * float(ds["x_max"][i])


def test_packed_arrays_decode_to_the_same_numbers():
    values = {
        "a": np.array([[1.5, -2.25e-300], [np.pi, 7.0]]),
        "b": np.arange(5, dtype=np.int64),
        "c": np.float32([0.1]),
    }
    packed = json.loads(json.dumps(encode(values)))
    a = np.frombuffer(base64.b64decode(packed["a"]["b64"]), "<f8").reshape(packed["a"]["shape"])
    np.testing.assert_array_equal(a, values["a"])
    assert packed["b"]["dtype"] == "i32"
    np.testing.assert_array_equal(np.frombuffer(base64.b64decode(packed["b"]["b64"]), "<i4"), values["b"])
    assert np.frombuffer(base64.b64decode(packed["c"]["b64"]), "<f4")[0] == np.float32(0.1)
    with pytest.raises(ValueError, match="finite"):
        encode(np.array([1.0, np.nan]))


def test_the_vendored_plotting_library_is_the_pinned_one():
    text = plotly_source()
    assert hashlib.sha256(text.encode()).hexdigest() == PLOTLY["sha256"]
    assert f"plotly.js (basic - minified) v{PLOTLY['version']}" in text[:200]


def test_the_page_is_self_contained(small_build):
    html = (small_build / "dist/explorer.html").read_text()
    assert not re.search(r"<(script|link|img|iframe)[^>]*(src|href)\s*=", html, flags=re.IGNORECASE)
    assert "@import" not in html and "url(" not in html.split("<script")[0]  # the style fetches nothing
    data = json.loads(
        re.search(r'<script type="application/json" id="explorer-data">(.*?)</script>', html, re.S).group(1)
    )
    assert {b["path"] for b in data["branches"]} >= {
        "results/hbm/nnm1.nc",
        "results/hbm/nnm2.nc",
        "results/exact/nnm1.nc",
    }


def generic_layout(ds: xr.Dataset, labels: list, columns: list) -> xr.Dataset:
    """The 2-DOF branch ``ds`` relabelled as another structure's: DOF ``labels``, each holding the paper's ``x`` or
    ``u`` named in ``columns`` (zero for "")."""
    zero = np.zeros_like(cosines(ds, "x"))
    q = np.stack([cosines(ds, name) if name else zero for name in columns], axis=1)
    # every variable over dof goes, and the first stop's DOF (the relabelled structure names it its own way)
    out = ds.drop_vars([name for name, var in ds.variables.items() if "dof" in var.dims or name == "stop_dof"])
    out["q_cos"] = (("point", "dof", "harmonic"), q, {"long_name": "cosine Fourier coefficients", "units": "1"})
    out["q_sin"] = (("point", "dof", "harmonic"), np.zeros_like(q))
    out["dof_label"] = ("dof", np.array(labels))
    return out


def test_the_structure_layout_gives_the_same_orbits(small_build):
    """A branch in the generic layout (labels x, u; or a beam's w<node>, theta<node> with its stop node) gives the
    page the same coefficients as in the 2-DOF layout."""
    from nnmstop.explorer.extract import regularized_branch

    ds = xr.open_dataset(small_build / "results/hbm/nnm2.nc").load()
    reference = regularized_branch(ds, SETTINGS).orbit
    two_dof = generic_layout(ds, ["x", "u"], ["x", "u"])  # as written, sines dropped
    beam = generic_layout(ds, ["w1", "theta1", "w2", "theta2", "w3"], ["u", "", "x", "", "u"])
    beam.attrs["stop_nodes"] = "2"
    for layout in (two_dof, beam):
        orbit = regularized_branch(layout, SETTINGS).orbit
        np.testing.assert_array_equal(orbit["harmonics"], reference["harmonics"])
        for name in ("x", "u", "f"):
            np.testing.assert_array_equal(orbit["fields"][name], reference["fields"][name])
    assert regularized_branch(beam, SETTINGS).orbit["labels"]["x"] == "w2"
    chain = generic_layout(
        ds, ["q0", "q1", "q2"], ["x", "", "u"]
    )  # a user's structure: stop_dof names the first stop's
    chain["stop_dof"] = ("stop", np.array([0], dtype=np.int32))
    chain["stop_gap"] = ("stop", np.array([1.0]))
    chain["stop_stiffness"] = ("stop", np.array([30.0]))
    branch = regularized_branch(chain, SETTINGS)
    for name in ("x", "u", "f"):
        np.testing.assert_array_equal(branch.orbit["fields"][name], reference["fields"][name])
    assert branch.attrs["model"]["alpha"] == 30.0 and branch.attrs["model"]["gap"] == 1.0
    # sines (a phase shift phi: c_k cos(k phi), -c_k sin(k phi)) are carried where they are not zero
    k = np.arange(ds.sizes["harmonic"])
    shifted = chain.copy(deep=True)
    shifted["q_sin"].values[:] = -shifted["q_cos"].values * np.sin(0.3 * k)
    shifted["q_cos"].values[:] = shifted["q_cos"].values * np.cos(0.3 * k)
    orbit = regularized_branch(shifted, SETTINGS).orbit
    kept = orbit["harmonics"]
    assert set(orbit["sines"]) == {"x", "u"}  # f has no sines here
    np.testing.assert_array_equal(orbit["sines"]["x"], shifted["q_sin"].values[:, 0][:, kept].astype(np.float32))
    np.testing.assert_array_equal(orbit["fields"]["u"], shifted["q_cos"].values[:, 2][:, kept].astype(np.float32))
    beam.attrs["stop_nodes"] = "7"
    with pytest.raises(ValueError, match="first stop's degree of freedom"):
        regularized_branch(beam, SETTINGS)


def test_a_structures_exact_family_is_rebuilt_on_the_structure(tmp_path):
    """Issue 29: the explorer draws the exact one-stop family of a structure of one's own. The orbits, rebuilt in
    closed form on the structure from the stored start velocities and periods and turned into the page's cosine
    series, reach at the struck stop the stored x_max (an independent quantity: the family's own extremum search),
    at the turning point t = 0 of the series."""
    from nnmstop.api import exact_family_dataset
    from nnmstop.exact.ndof import follow_one_stop_family
    from nnmstop.explorer.extract import one_stop_branch
    from nnmstop.models.structure import Stop, Structure

    chain = Structure(np.eye(3), [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]],
                      [Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)])  # fmt: skip
    ds = exact_family_dataset(chain, follow_one_stop_family(chain, step=0.1, max_points=15))
    branch = one_stop_branch(ds, ExplorerSettings(exact_harmonics=64, structure=chain))
    x = branch.orbit["fields"]["x"].astype(float)  # cosine coefficients of the kept harmonics
    assert branch.orbit["labels"]["x"] == "q0" and branch.orbit["force"] == "piecewise_law"
    # x(t = 0) = sum of the cosine coefficients; 64 harmonics of the kinked orbit leave about 1e-3 of it
    np.testing.assert_allclose(x.sum(axis=1), ds["x_max"].values, rtol=2e-3)
    with pytest.raises(ValueError, match="needs the structure"):
        one_stop_branch(ds, ExplorerSettings())


def test_the_atlas_record_holds_its_regions_curves_and_orbits(small_build):
    """The small build's atlas in the explorer: the region runs tile every slice row over the grid, each curve
    point's orbit synthesized from the float32 coefficients peaks at the dataset's amplitude, and the slices'
    response points come with their orbits."""
    from nnmstop.explorer.extract import extract_atlas

    path = "results/atlas/oscillator_force.nc"
    slices = sorted((small_build / "results/atlas/oscillator_force").glob("slice_*.nc"))
    record = extract_atlas(path, [s.relative_to(small_build) for s in slices], {}, root=small_build)
    with xr.open_dataset(small_build / path) as ds:
        runs = record["regions"]["runs"]
        assert len(np.unique(runs[:, 2])) == ds.sizes["slice"]
        width = np.ptp(ds["grid_frequency"].values) * ds.sizes["grid"] / (ds.sizes["grid"] - 1)
        for row in np.unique(runs[:, 2]):
            mine = runs[runs[:, 2] == row]
            assert np.isclose(np.sum(mine[:, 1] - mine[:, 0]), width)
        K = int(ds.attrs["orbit_harmonics"])
        theta = 2 * np.pi * np.arange(2048) / 2048
        k = np.arange(1, K + 1)
        for i in (0, ds.sizes["point"] // 2, ds.sizes["point"] - 1):
            c = record["curves"]["orbit"][i, 0].astype(float)
            x = c[0] + c[1 : K + 1] @ np.cos(np.outer(k, theta)) + c[K + 1 :] @ np.sin(np.outer(k, theta))
            assert np.abs(x).max() == pytest.approx(float(ds["amplitude"].values[i, 0]), rel=1e-5)
    assert record["responses"]["orbit"].shape[0] == record["responses"]["frequency"].shape[0] > 0
    page = (small_build / "dist" / "explorer.html").read_text()
    assert 'id="atlas-section"' in page and "showRegion" in page
