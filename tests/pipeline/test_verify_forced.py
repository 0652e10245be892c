"""The verifier on forced responses (issue 23): the exact and the regularized response and their manifest.

A small forced scene (the soft-stop oscillator alpha = 3, eta = 0.3, one force level over its NNM1 peak,
H = 12) is computed by the forced rules' tasks and recorded as a reference the way ``update_reference``
records a build (``results/forced/MANIFEST.sha256``). A build of the same scene storing other points on the
same curves (other ANM points per step, other pseudo-arclength steps of the exact contact family) must pass
in every variable; moved amplitudes, a flipped stability verdict and a moved stability change must not.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from nnmstop.config import load_config
from nnmstop.pipeline.verify import FORCED_MANIFEST, build_manifests, file_verdicts, update_reference, verify
from nnmstop.tasks.forced import forced_exact, forced_figure, forced_manifest, forced_regularized

REPO = Path(__file__).resolve().parents[2]
SCENE = "F0.05"
FILES = [f"forced/exact_{SCENE}.nc", f"forced/regularized_{SCENE}.nc"]
PASSING = {"identical", "identical data", "within tolerance"}


def _config(points_per_step: int, exact_max_step: float) -> dict:
    config = load_config(REPO / "config" / "config.yaml")
    config["model"].update(alpha=3.0, eta=0.3)
    forced = config["forced"]
    forced["force"]["amplitudes"] = [0.05]
    forced.update(frequency_range=[0.09, 0.16], harmonics=12, points_per_step=points_per_step, max_truncation=0.5)
    forced["stability"] = {"steps": 16, "max_steps": 256, "resolution_factor": 2.0}
    forced["exact"].update(initial_step=0.01, max_step=exact_max_step, frequency_samples=60)
    forced.pop("tube", None)
    return config


def _build(workdir: Path, config: dict) -> Path:
    """The scene's exact and regularized responses and their manifest (paths as the workflow writes them)."""
    results = workdir / "results"
    (results / "forced").mkdir(parents=True)
    forced_exact(config, {}, {"dataset": str(results / FILES[0])}, scene=SCENE)
    forced_regularized(config, {}, {"dataset": str(results / FILES[1])}, scene=SCENE)
    (results / "MANIFEST.sha256").write_text("")  # the paper's datasets: none in this build
    manifest = results / FORCED_MANIFEST
    forced_manifest(config, {"datasets": [str(results / f) for f in FILES]}, {"manifest": str(manifest)})
    manifest.write_text(manifest.read_text().replace(f"{workdir}/", ""))
    return results


@pytest.fixture(scope="module")
def forced_reference(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("forced_reference")
    results = _build(workdir, _config(points_per_step=2, exact_max_step=0.05))
    assert build_manifests(results) == ["MANIFEST.sha256", FORCED_MANIFEST]
    return results, update_reference(results, workdir / "reference")


def _rewrite(path: Path, change) -> None:
    ds = xr.load_dataset(path)
    change(ds)
    path.unlink()
    ds.to_netcdf(path)


def test_the_reference_records_the_forced_responses_as_curves(forced_reference):
    results, reference = forced_reference
    listed = (reference / "MANIFEST.sha256").read_text()
    for relative in FILES:
        assert f"results/{relative}" in listed
        assert (reference / "curves" / (relative.removesuffix(".nc").replace("/", "__") + ".csv")).is_file()
    verdicts = file_verdicts(verify(Path(shutil.copytree(results, reference.parent / "copy")), reference))
    assert set(verdicts.values()) == {"identical"} and len(verdicts) == 4, verdicts  # two datasets, two manifests


@pytest.mark.numerics
def test_other_points_on_the_same_forced_curves_pass(forced_reference, tmp_path):
    """Three points per ANM step instead of two, a shorter largest step of the exact contact family: other
    stored points on the same curves, within tolerance in every variable (amplitudes, phase lags, orbits,
    multipliers, verdicts outside the band of a change, located changes)."""
    _, reference = forced_reference
    build = _build(tmp_path, _config(points_per_step=3, exact_max_step=0.03))
    rows = verify(build, reference)
    verdicts = file_verdicts(rows)
    assert set(verdicts.values()) <= PASSING, [r for r in rows if r.verdict == "discrepant"]
    for relative in FILES:
        assert verdicts[f"results/{relative}"] == "within tolerance"
        compared = " ".join(r.quantity for r in rows if r.file == f"results/{relative}")
        for check in ("build points on reference curve", "smooth quantities", "stability numbers",
                      "flags, counts and verdicts"):  # fmt: skip
            assert check in compared, compared
    with xr.open_dataset(build / FILES[1]) as ds, xr.open_dataset(reference.parent / "results" / FILES[1]) as ref:
        assert ds.sizes["point"] != ref.sizes["point"]


def _middle_stable_point(ds: xr.Dataset) -> int:
    """A resolved point in the middle of a run of equal verdicts (outside the band of any change)."""
    stable, resolved = ds["stable"].values, ds["stability_resolved"].values.astype(bool)
    same = np.ones(len(stable), dtype=bool)
    for shift in (-3, -2, -1, 1, 2, 3):
        same &= np.roll(stable, shift) == stable
    candidates = np.flatnonzero(same & resolved)[5:-5]
    return int(candidates[len(candidates) // 2])


def _scale_middle(name: str, factor: float, dof: int | None = None):
    def change(ds):
        index = ds.sizes["point"] // 2 if dof is None else (ds.sizes["point"] // 2, dof)
        ds[name].values[index] *= factor

    return change


def _flip_verdict(ds):
    j = _middle_stable_point(ds)
    ds["stable"].values[j] = 1 - ds["stable"].values[j]


def _move_fold(ds):
    ds["change_frequency"].values[0] *= 1 + 1e-4


ALTERATIONS = {
    "moved amplitude": (FILES[1], _scale_middle("x_amplitude", 1.001), "build points on reference curve"),
    "moved phase lag": (FILES[0], _scale_middle("phase_lag", 1.01, dof=1), "smooth quantities"),
    "flipped verdict": (FILES[1], _flip_verdict, "stable at"),
    "moved fold": (FILES[1], _move_fold, "variable change_frequency"),
}


@pytest.mark.parametrize("alteration", list(ALTERATIONS))
def test_altered_forced_responses_are_discrepant_with_their_reason(forced_reference, tmp_path, alteration):
    results, reference = forced_reference
    relative, change, reason = ALTERATIONS[alteration]
    copy = Path(shutil.copytree(results, tmp_path / "results"))
    _rewrite(copy / relative, change)
    rows = verify(copy, reference)
    verdicts = file_verdicts(rows)
    assert verdicts[f"results/{relative}"] == "discrepant"
    assert verdicts[f"results/{FORCED_MANIFEST}"] == "discrepant"  # the build's manifest no longer matches it
    others = set(verdicts) - {f"results/{relative}", f"results/{FORCED_MANIFEST}"}
    assert all(verdicts[name] in PASSING for name in others), verdicts
    found = [r.quantity for r in rows if r.file == f"results/{relative}" and r.verdict == "discrepant"]
    assert any(reason in quantity for quantity in found), found


def test_stored_multipliers_follow_the_multipliers_not_round_off():
    """A complex pair whose moduli differ by round-off is stored in one order whichever comes first (the order
    of the multiplier columns is compared by the verifier), positive imaginary part first."""
    from nnmstop.forced.dataset import canonical_order

    pair = 0.9 * np.exp(0.7j)
    rows = np.array([[-1.2, pair, np.conj(pair) * (1 + 1e-15), 0.1], [-1.2, np.conj(pair), pair * (1 + 1e-15), 0.1]])
    ordered = canonical_order(rows)
    np.testing.assert_allclose(ordered[0], ordered[1], rtol=1e-14)
    np.testing.assert_allclose(ordered[0], [-1.2, pair, np.conj(pair), 0.1], rtol=1e-14)


def test_scaled_contact_states_are_discrepant_and_refused_by_the_figure(forced_reference, tmp_path):
    """Issue 33, reproduction 1: contact_unknowns (kept at the contact points only) were left out of the reference,
    yet the orbits figure integrates them: scaled by 1.5 they passed verify and drew a contact force six times too
    large. Each contact state must reproduce its point (closed-form flow): verify and the figure's reader refuse."""
    from nnmstop.netcdf import read_dataset

    results, reference = forced_reference
    copy = Path(shutil.copytree(results, tmp_path / "results"))

    def scale(ds):
        ds["contact_unknowns"].values[:, :4] *= 1.5

    _rewrite(copy / FILES[0], scale)
    rows = verify(copy, reference)
    assert file_verdicts(rows)[f"results/{FILES[0]}"] == "discrepant"
    found = [r.quantity for r in rows if r.file == f"results/{FILES[0]}" and r.verdict == "discrepant"]
    assert any("contact" in quantity and "contact_unknowns" in quantity for quantity in found), found
    with pytest.raises(ValueError, match=rf"{copy / FILES[0]}: contact_unknowns.* at contact_point \d+ \(point \d+\)"):
        read_dataset(copy / FILES[0])
    config = _config(points_per_step=2, exact_max_step=0.05)
    outputs = {"pdf": str(tmp_path / "forced_orbits.pdf"), "png": str(tmp_path / "forced_orbits.png")}
    with pytest.raises(ValueError, match="contact_unknowns"):
        forced_figure(config, {"exact": [str(copy / FILES[0])], "regularized": [str(copy / FILES[1])]}, outputs,
                      figure="orbits")  # fmt: skip
    assert not list(tmp_path.glob("forced_orbits*"))


#: The datasets each forced figure reads (workflow/rules/forced.smk); the tube figure drawn from the oscillator's.
FIGURE_INPUTS = {
    "frequency_response": ("exact", "regularized", "backbone"),
    "phase_lag": ("exact", "regularized"),
    "orbits": ("exact", "regularized"),
    "prediction_error": ("prediction",),
    "tube": ("regularized",),
}


@pytest.fixture(scope="module")
def forced_figure_data(forced_reference, tmp_path_factory):
    """The scene's responses, and its backbones and prediction errors (written as the workflow writes them)."""
    from nnmstop.netcdf import write_dataset
    from nnmstop.tasks.forced import backbone_prediction_dataset, prediction_error_dataset

    results, _ = forced_reference
    config = _config(points_per_step=2, exact_max_step=0.05)
    folder = tmp_path_factory.mktemp("forced_figures")
    paths = {"exact": results / FILES[0], "regularized": results / FILES[1]}
    for key, make, kind in (("backbone", backbone_prediction_dataset, "forced_backbone"),
                            ("prediction", prediction_error_dataset, "forced_prediction")):  # fmt: skip
        paths[key] = write_dataset(make(config), folder / f"{key}.nc", title=key, summary=key, kind=kind)
    return config, paths


@pytest.mark.parametrize("figure", list(FIGURE_INPUTS))
def test_a_forced_figure_draws_from_verified_variables_only(forced_figure_data, tmp_path, figure):
    """Issue 33.1: each forced figure drawn from its datasets with the variables verify does not compare
    (nnmstop.pipeline.reference.unverified_variables) scrambled is the same figure, byte for byte."""
    from test_verified_reads import scrambled

    config, paths = forced_figure_data
    drawn = {}
    for label in ("whole", "verified"):
        folder = tmp_path / label
        folder.mkdir()
        inputs = {}
        for key in FIGURE_INPUTS[figure]:
            path = paths[key]
            if label == "verified":
                ds, _ = scrambled(xr.load_dataset(path))
                path = folder / Path(path).name
                ds.to_netcdf(path)
            inputs[key] = [str(path)]
        outputs = {"pdf": str(folder / f"forced_{figure}.pdf"), "png": str(folder / f"forced_{figure}.png")}
        forced_figure(config, inputs, outputs, figure=figure)
        drawn[label] = (folder / f"forced_{figure}.pdf").read_bytes()
    assert drawn["whole"] == drawn["verified"], f"forced_{figure} reads a variable the verifier does not compare"
