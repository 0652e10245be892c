"""The verifier (nnmstop.pipeline.verify) on a small build: identity, curves, every variable, damaged files.

The small configuration's build (tests/data/small_config.yaml: H = 16, short ranges; shared with
tests/test_workflow.py) is the reference. Copies of it are altered the way a build on another CPU
would differ (other points on the same curves) or the way a wrong or damaged build would (a moved
frequency, an inverted stability flag, a changed parameter, a NaN, a foreign, truncated or empty
file, a flipped byte), and the verifier must tell them apart, file by file, without stopping.
"""

from __future__ import annotations

import hashlib
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from nnmstop.pipeline.verify import file_verdicts, format_table, main, update_reference, verify
from nnmstop.tasks.manifest import dataset_manifest
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"
TARGETS = ["results/exact/nnm1_two_impacts.nc", "results/hbm/nnm1.nc"]


def _manifest(workdir: Path) -> Path:
    """Write the manifest of the datasets under ``workdir/results``, with paths as the workflow writes them."""
    datasets = sorted(str(p.relative_to(workdir)) for p in (workdir / "results").rglob("*.nc"))
    manifest = workdir / "results/MANIFEST.sha256"
    dataset_manifest({}, {"datasets": [str(workdir / d) for d in datasets]}, {"manifest": str(manifest)})
    manifest.write_text(manifest.read_text().replace(f"{workdir}/", ""))
    return workdir / "results"


def _build(workdir: Path, config: Path) -> Path:
    """Build TARGETS with the workflow and write their manifest; return the results directory."""
    result = run_snakemake(workdir, config, "--cores", "2", *TARGETS, check=False)
    assert result.returncode == 0, result.stderr[-3000:]
    return _manifest(workdir)


@pytest.fixture(scope="module")
def reference(small_build, tmp_path_factory):
    """The small build's results and the reference made from them."""
    results = small_build / "results"
    return results, update_reference(results, tmp_path_factory.mktemp("verify") / "reference")


@pytest.fixture(scope="module")
def targets_reference(small_build, tmp_path_factory):
    """A reference of TARGETS only (the two-impact family, NNM1 and its stages), from the small build."""
    workdir = tmp_path_factory.mktemp("targets")
    for target in TARGETS:
        (workdir / target).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(small_build / target, workdir / target)
    shutil.copytree(small_build / "results/hbm/stages", workdir / "results/hbm/stages")
    for stray in (workdir / "results/hbm/stages").glob("nnm2_*"):
        stray.unlink()
    results = _manifest(workdir)
    return results, update_reference(results, workdir / "reference")


def _copy(results: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(results, tmp_path / "results"))


def _rewrite(path: Path, change) -> None:
    """Apply ``change(ds)`` to the dataset at ``path`` and write it back as xarray does (no checks)."""
    ds = xr.load_dataset(path)
    change(ds)
    path.unlink()
    ds.to_netcdf(path)


def test_an_identical_copy_is_identical(reference, tmp_path):
    results, ref = reference
    verdicts = file_verdicts(verify(_copy(results, tmp_path), ref))
    assert set(verdicts.values()) == {"identical"} and len(verdicts) >= 12, verdicts
    assert main([str(results), "--reference", str(ref)]) == 0


def test_a_frequency_moved_by_1e5_is_a_discrepancy(reference, tmp_path):
    """One stored NNM1 frequency, halfway along the branch, moved by 1e-5 relative."""
    results, ref = reference
    copy = _copy(results, tmp_path)

    def move(ds):
        ds["frequency"].values[ds.sizes["point"] // 2] *= 1 + 1e-5

    _rewrite(copy / "hbm/nnm1.nc", move)
    rows = verify(copy, ref)
    assert file_verdicts(rows)["results/hbm/nnm1.nc"] == "discrepant"
    assert file_verdicts(rows)["results/hbm/stages/nnm1_stage1.nc"] == "identical"
    assert main([str(copy), "--reference", str(ref)]) == 1


def test_a_missing_file_fails(reference, tmp_path):
    results, ref = reference
    copy = _copy(results, tmp_path)
    (copy / "hbm/stages/nnm1_stage2.nc").unlink()
    rows = verify(copy, ref)
    assert [(r.file, r.build) for r in rows if r.verdict == "discrepant"] == [
        ("results/MANIFEST.sha256", "results/hbm/stages/nnm1_stage2.nc: missing"),  # the build's own manifest
        ("results/hbm/stages/nnm1_stage2.nc", "missing"),
    ]
    assert main([str(copy), "--reference", str(ref)]) == 1


def test_other_points_on_the_same_curve_pass(targets_reference, tmp_path):
    """A build storing 3 points per ANM step instead of 4 (other points, same curves) is within
    tolerance in every variable; its files are not identical."""
    results, ref = targets_reference
    config = yaml.safe_load(SMALL_CONFIG.read_text())
    config["hbm"]["points_per_step"] = 3
    resampled_config = tmp_path / "config.yaml"
    resampled_config.write_text(yaml.safe_dump(config))
    rows = verify(_build(tmp_path / "build", resampled_config), ref)
    verdicts = file_verdicts(rows)
    assert verdicts["results/hbm/nnm1.nc"] == "within tolerance"
    passing = {"identical", "identical data", "within tolerance"}
    assert set(verdicts.values()) <= passing, [r for r in rows if r.verdict == "discrepant"]
    compared = " ".join(r.quantity for r in rows if r.file == "results/hbm/nnm1.nc")
    for check in ("orbits (harmonics", "smooth quantities", "flags, counts and verdicts", "global attributes",
                  "variables: names"):  # fmt: skip
        assert check in compared, compared
    with xr.open_dataset(results / "hbm/nnm1.nc") as a, xr.open_dataset(tmp_path / "build/results/hbm/nnm1.nc") as b:
        assert a.sizes["point"] != b.sizes["point"]


def _flip_byte_of_a_harmonic(path: Path) -> None:
    """Flip one bit of the exponent byte of a stored harmonic coefficient, in the file's bytes."""
    with xr.open_dataset(path) as ds:
        value = float(ds["q_cos"].values[ds.sizes["point"] // 2, 0, 1])
    raw = bytearray(path.read_bytes())
    packed = struct.pack("<d", value)
    assert raw.count(packed) == 1, "the coefficient's bytes are not unique in the file"
    raw[raw.find(packed) + 7] ^= 0x40
    path.write_bytes(bytes(raw))


ALTERATIONS = {
    "hbm/nnm1.nc": "stable inverted",
    "hbm/nnm2.nc": "attribute alpha = 31",
    "hbm/stages/nnm1_stage4.nc": "one NaN in q_cos",
    "compare/nnm1_regimes.nc": "an unrelated dataset in its place",
    "hbm/stages/nnm1_stage1.nc": "one flipped byte in its harmonics",
    "exact/nnm1.nc": "truncated",
    "exact/nnm1_two_impacts.nc": "no frequency",
    "hbm/stages/nnm1_stage2.nc": "empty",
    "hbm/stages/nnm1_stage3.nc": "all-NaN curve",
    "hbm/stages/nnm2_stage1.nc": "x_max of one orbit moved by 1 %",
}


def _alter(copy: Path) -> None:
    def invert(ds):
        ds["stable"].values[:] = 1 - ds["stable"].values

    def alpha(ds):
        ds.attrs["alpha"] = 31.0

    def nan(ds):
        ds["q_cos"].values[ds.sizes["point"] // 2, 0, 1] = np.nan

    def no_frequency(ds):
        del ds["frequency"]

    def all_nan(ds):
        ds["frequency"].values[:] = np.nan

    def x_max(ds):
        ds["x_max"].values[ds.sizes["point"] // 2] *= 1.01

    _rewrite(copy / "hbm/nnm1.nc", invert)
    _rewrite(copy / "hbm/nnm2.nc", alpha)
    _rewrite(copy / "hbm/stages/nnm1_stage4.nc", nan)
    shutil.copyfile(copy / "exact/nnm1_two_impacts.nc", copy / "compare/nnm1_regimes.nc")
    _flip_byte_of_a_harmonic(copy / "hbm/stages/nnm1_stage1.nc")
    truncated = copy / "exact/nnm1.nc"
    truncated.write_bytes(truncated.read_bytes()[: truncated.stat().st_size // 2])
    _rewrite(copy / "exact/nnm1_two_impacts.nc", no_frequency)
    (copy / "hbm/stages/nnm1_stage2.nc").write_bytes(b"")
    _rewrite(copy / "hbm/stages/nnm1_stage3.nc", all_nan)
    _rewrite(copy / "hbm/stages/nnm2_stage1.nc", x_max)


@pytest.fixture(scope="module")
def altered(reference, tmp_path_factory):
    """A copy of the small build with the alterations of ALTERATIONS, and the verifier's rows for it."""
    results, ref = reference
    copy = _copy(results, tmp_path_factory.mktemp("altered"))
    _alter(copy)
    return copy, verify(copy, ref)


def test_damaged_and_altered_files_are_each_discrepant_and_named(reference, altered, capsys):
    """The adversarial copies of issue 25 (and one quantity of one orbit moved by 1 %): every altered
    file is discrepant with a reason, the others stay identical, the table and counts come out and the
    exit status is 1."""
    _, ref = reference
    copy, rows = altered
    verdicts = file_verdicts(rows)
    for relative, alteration in ALTERATIONS.items():
        assert verdicts[f"results/{relative}"] == "discrepant", (alteration, [r for r in rows if relative in r.file])
    untouched = {name for name in verdicts if name.removeprefix("results/") not in ALTERATIONS}
    untouched.discard("results/MANIFEST.sha256")  # the build's manifest no longer matches the altered files
    passing = ("identical", "identical data", "within tolerance")
    assert untouched and all(verdicts[name] in passing for name in untouched), verdicts
    assert verdicts["results/MANIFEST.sha256"] == "discrepant"
    assert main([str(copy), "--reference", str(ref)]) == 1
    out = capsys.readouterr().out
    assert f"{len(ALTERATIONS) + 1} discrepant" in out
    for relative in ALTERATIONS:
        assert f"results/{relative}" in out.splitlines()[-1]


@pytest.mark.parametrize("relative, reason", [
    ("hbm/nnm1.nc", "stable at"),
    ("hbm/nnm2.nc", "attribute alpha"),
    ("hbm/stages/nnm1_stage4.nc", "variable q_cos: NaN or infinite values"),
    ("compare/nnm1_regimes.nc", "variables missing"),
    ("hbm/stages/nnm1_stage1.nc", "orbits (harmonics"),
    ("exact/nnm1.nc", "readable NetCDF"),
    ("exact/nnm1_two_impacts.nc", "variable frequency"),
    ("hbm/stages/nnm1_stage2.nc", "readable NetCDF"),
    ("hbm/stages/nnm1_stage3.nc", "variable frequency: NaN or infinite values"),
    ("hbm/stages/nnm2_stage1.nc", "smooth quantities"),
])  # fmt: skip
def test_each_alteration_is_reported_with_its_reason(altered, relative, reason):
    _, rows = altered
    found = [r.quantity for r in rows if r.file == f"results/{relative}" and r.verdict == "discrepant"]
    assert any(reason in quantity for quantity in found), found


def test_the_table_comes_out_when_every_file_is_unreadable(reference, tmp_path):
    results, ref = reference
    copy = _copy(results, tmp_path)
    for path in copy.rglob("*.nc"):
        path.write_bytes(b"not NetCDF")
    rows = verify(copy, ref)
    table = format_table(rows)
    assert all(verdict == "discrepant" for name, verdict in file_verdicts(rows).items() if name.endswith(".nc"))
    assert "cannot be read as NetCDF" in table


def test_bad_directories_are_named(reference, tmp_path):
    results, ref = reference
    with pytest.raises(ValueError, match="does not exist"):
        verify(tmp_path / "nowhere", ref)
    with pytest.raises(ValueError, match="update-reference"):
        verify(results, tmp_path / "no_reference")
    assert main([str(tmp_path / "nowhere"), "--reference", str(ref)]) == 2


def test_the_marked_comparison_energies_follow_the_stored_points(reference, tmp_path):
    """The energies of a comparison's marked points are placed in the compared range, whose ends are stored
    points of the branches: another CPU's step sequence moves them (the orbits there are checked as a curve)."""
    results, ref = reference
    copy = _copy(results, tmp_path)
    _rewrite(copy / "compare/nnm1_exact_vs_regularized.nc", lambda ds: ds.attrs.update(point_a_energy=0.7300001))
    rows = verify(copy, ref)
    assert file_verdicts(rows)["results/compare/nnm1_exact_vs_regularized.nc"] != "discrepant"
    assert not [r for r in rows if "point_a_energy" in r.quantity and r.verdict == "discrepant"]


def test_a_regime_range_end_may_move_by_the_step_into_the_regime_and_no_further():
    """A regime's lowest energy is its first stored orbit: it moves by up to the step that crosses into the
    regime when the orbits are stored elsewhere on the curve (here a longer step than any inside the regime)."""
    from nnmstop.pipeline.verify import _check_regimes, _regime_sampling

    energy = np.array([1.0, 1.1, 1.2, 1.3, 2.0, 2.05, 2.1, 2.15])  # the step into regime 1 is the longest
    frequency = np.linspace(0.1, 0.2, 8)
    regimes = xr.Dataset(
        {
            "point_regime": ("point", np.repeat([0, 1], 4)),
            "energy": ("point", energy),
            "frequency": ("point", frequency),
            "frequency_error": ("point", 1e-3 * frequency),
            "relative_frequency_error": ("point", 1e-2 * np.ones(8)),
            "impacts_per_period": ("regime", [2, 6]),
        }
    )
    sampling = _regime_sampling(regimes)
    assert sampling[1][0] == pytest.approx(np.log(2.0 / 1.3))  # the crossing step, not the steps inside
    table = {"regime": [0, 1], "impacts_per_period": [2, 6], "exact_sequence": ["FR", "FLFR"],
             "regularized_energy_min": [1.0, 2.0]}  # fmt: skip
    columns = ["d_log_energy", "d_frequency", "d_frequency_error", "d_relative_frequency_error"]
    reference_sampling = {name: [row[j] for row in sampling] for j, name in enumerate(columns)}
    for factor, verdict in ((0.99, "within tolerance"), (2.0, "discrepant")):
        build = dict(table, regularized_energy_min=[1.0, 2.0 * (1.3 / 2.0) ** factor])
        (row,) = _check_regimes("regimes", table, reference_sampling, build, sampling)
        assert row.verdict == verdict, (factor, row)


def _files(folder: Path) -> dict:
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_update_reference_refuses_a_truncated_dataset_and_leaves_the_reference_as_it_was(reference, tmp_path, capsys):
    """Issue 33, reproduction 2: one truncated dataset in the build deleted the reference before reading the build,
    leaving only its manifest and an empty curves/. Every listed file is read first; the truncated one is a refused
    row with its reason, the exit status 1, and reference/ is byte for byte what it was."""
    results, ref = reference
    kept = Path(shutil.copytree(ref, tmp_path / "reference"))
    before = _files(kept)
    copy = _copy(results, tmp_path)
    truncated = copy / "hbm/nnm2.nc"
    truncated.write_bytes(truncated.read_bytes()[:4000])
    manifest = copy / "MANIFEST.sha256"  # the manifest says what the file now is: the reader must find it out
    digest = hashlib.sha256(truncated.read_bytes()).hexdigest()
    entries = [line.split("  ") for line in manifest.read_text().splitlines()]
    new = [(digest if name == "results/hbm/nnm2.nc" else old, name) for old, name in entries]
    manifest.write_text("".join(f"{old}  {name}\n" for old, name in new))
    assert main([str(copy), "--update-reference", "--reference", str(kept)]) == 1
    out = capsys.readouterr()
    refused = [line for line in out.out.splitlines() if line.startswith("results/")]
    assert len(refused) == 1 and "results/hbm/nnm2.nc" in refused[0] and "cannot be read as NetCDF" in refused[0]
    assert "left as it was" in out.err
    assert _files(kept) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["reference", "results"]  # no half-written sibling


def test_an_interrupted_update_leaves_the_reference_whole_and_a_finished_one_replaces_it_whole(
    reference, tmp_path, monkeypatch
):
    from nnmstop.pipeline import verify as verifier

    results, ref = reference
    kept = Path(shutil.copytree(ref, tmp_path / "reference"))
    before = _files(kept)
    write = verifier._write_reference

    def interrupted(results_dir, folder, lines):
        write(results_dir, folder, lines[: len(lines) // 2])
        raise KeyboardInterrupt  # Ctrl-C halfway

    monkeypatch.setattr(verifier, "_write_reference", interrupted)
    with pytest.raises(KeyboardInterrupt):
        update_reference(results, kept)
    assert _files(kept) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["reference"]
    monkeypatch.setattr(verifier, "_write_reference", write)
    (kept / "curves" / "stale_from_an_old_build.csv").write_text("energy,frequency\n")
    update_reference(results, kept)
    assert _files(kept) == before  # the same build: the same reference, and nothing of the old one left


def test_the_build_manifest_is_checked_against_its_files(reference, tmp_path):
    """Issue 33, reproduction 7: the build's MANIFEST.sha256 was written but never checked."""
    results, ref = reference
    copy = _copy(results, tmp_path)
    manifest = copy / "MANIFEST.sha256"
    lines = manifest.read_text().splitlines()
    manifest.write_text("\n".join(["0" * 64 + "  " + lines[0].split("  ")[1], *lines[2:]]) + "\n")
    rows = verify(copy, ref)
    found = [r for r in rows if r.file == "results/MANIFEST.sha256" and r.verdict == "discrepant"]
    assert len(found) == 2, found
    assert "SHA-256 differs" in found[0].build and lines[0].split("  ")[1] in found[0].build
    assert "in no manifest of the build" in found[1].quantity and lines[1].split("  ")[1] in found[1].build
    assert all(v != "discrepant" for name, v in file_verdicts(rows).items() if name != "results/MANIFEST.sha256")
