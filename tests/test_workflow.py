"""End-to-end runs of the Snakemake workflow on a small configuration.

The small configuration (tests/data/small_config.yaml) keeps the paper's physics with
16 harmonics and short energy ranges, so the whole default target (Figs 2-11, every
dataset, the manifest) builds in well under a minute.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from nnmstop.models.two_dof import ModelParameters, linear_modes
from nnmstop.netcdf import check_labelled
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[1]
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"
ACDD = (
    "Conventions",
    "title",
    "summary",
    "keywords",
    "date_created",
    "source",
    "references",
    "creator_name",
    "license",
)


def snakemake(workdir: Path, *args: str, check: bool = True) -> subprocess.CompletedProcess:
    return run_snakemake(workdir, SMALL_CONFIG, *args, check=check)


def planned_rules(workdir: Path, target: str) -> set[str]:
    """Rules a dry run plans for ``target`` from scratch."""
    out = snakemake(workdir, "-n", "--forceall", target).stdout
    return set(re.findall(r"^(?:local)?rule (\w+):", out, flags=re.MULTILINE))


@pytest.fixture(scope="module")
def built(small_build):
    """The default target of the workflow, built once from scratch (shared with the verifier's tests)."""
    return small_build


def outputs(workdir: Path) -> list[Path]:
    return sorted(p for d in ("results", "paper_figures") for p in (workdir / d).rglob("*") if p.is_file())


def test_every_declared_output_exists(built):
    figures = {p.name for p in (built / "paper_figures").iterdir()}
    assert figures == {f"fig{n:02d}.{ext}" for n in range(2, 12) for ext in ("pdf", "png")}
    for name in (
        "exact/nnm1_two_impacts.nc",
        "exact/nnm1.nc",
        "hbm/nnm1.nc",
        "hbm/nnm2.nc",
        "compare/nnm1_exact_vs_regularized.nc",
        "compare/nnm1_regimes.nc",
        "compare/nnm1_regimes.csv",
        "MANIFEST.sha256",
    ):
        assert (built / "results" / name).is_file(), name
    assert not [p for p in outputs(built) if p.name.endswith(".tmp") or ".tmp." in p.name]


def test_datasets_are_labelled_and_shareable(built):
    for path in (built / "results").rglob("*.nc"):
        with xr.open_dataset(path) as ds:
            check_labelled(ds)  # long_name and units everywhere, no NaN
            missing = [a for a in ACDD if a not in ds.attrs]
            assert not missing, f"{path.name} lacks {missing}"
            assert "ACDD-1.3" in ds.attrs["Conventions"] and "CF" in ds.attrs["Conventions"]
            for key in ("alpha", "beta", "delta"):
                assert key in ds.attrs


def test_manifest_lists_every_dataset_with_its_sha256(built):
    lines = (built / "results" / "MANIFEST.sha256").read_text().splitlines()
    listed = {}
    for line in lines:
        digest, path = line.split("  ")
        listed[path] = digest
    on_disk = {str(p.relative_to(built)) for p in (built / "results").rglob("*.nc")}
    assert set(listed) == on_disk
    for path, digest in listed.items():
        assert hashlib.sha256((built / path).read_bytes()).hexdigest() == digest


def test_physics_sanity_of_the_outputs(built):
    with xr.open_dataset(built / "results/hbm/nnm1.nc") as nnm1, xr.open_dataset(built / "results/hbm/nnm2.nc") as nnm2:
        params = ModelParameters(**{k: float(nnm1.attrs[k]) for k in ("alpha", "beta", "delta", "eta")})
        start = linear_modes(params, "regularized")[0] / (2 * np.pi)
        gap0 = linear_modes(params, "gap_zero")[0] / (2 * np.pi)
        # linear limits at low energy, hardening towards the gap-0 modes, never beyond them
        assert nnm1["frequency"].values[0] == pytest.approx(start[0], rel=1e-4)
        assert nnm2["frequency"].values[0] == pytest.approx(start[1], rel=1e-4)
        assert np.all(nnm1["frequency"].values < gap0[0])
        assert 0.7 * gap0[1] <= nnm2["frequency"].values[-1] < gap0[1]
        assert nnm1["energy"].values[-1] > 30.0  # the last stage's criterion
        assert np.all(np.diff(nnm1["stage"].values) >= 0)
        assert nnm1.attrs["harmonics"] == 16
    with xr.open_dataset(built / "results/exact/nnm1_two_impacts.nc") as exact:
        assert float(exact["residual"].max()) < 1e-11
        no_contact = linear_modes(params, "no_contact")[0][0] / (2 * np.pi)
        assert exact["frequency"].values[0] == pytest.approx(no_contact, rel=1e-9)
    with xr.open_dataset(built / "results/compare/nnm1_exact_vs_regularized.nc") as cmp:
        # near grazing the regularized law (f >= the piecewise law, f ~ eta x inside the gap)
        # is clearly stiffer: the regularized NNM1 sits above the exact one there
        assert cmp["frequency_regularized"].values[0] > cmp["frequency_exact"].values[0] * 1.01
        assert float(np.abs(cmp["relative_frequency_difference"]).max()) < 0.05
    with xr.open_dataset(built / "results/compare/nnm1_regimes.nc") as regimes:
        # the small branches share one regime, one impact per stop; eta = 0.1 shifts the
        # frequency by well under 1 % there (README table: 2.8e-3 at most at H = 100)
        assert list(regimes["impacts_per_period"].values) == [2]
        assert str(regimes["exact_sequence"].values[0]) == "FR"
        assert int(regimes["n_matched"][0]) > 10
        assert 0 < float(regimes["max_rel_frequency_error"][0]) < 0.01
        assert regimes.attrs["harmonics"] == 16 and regimes.attrs["eta"] == 0.1
    table = (built / "results/compare/nnm1_regimes.csv").read_text().splitlines()
    assert table[0].startswith("regime,impacts_per_period,exact_sequence") and len(table) == 2


def test_rerun_from_scratch_is_byte_identical(built, tmp_path):
    """A second fresh run of the same targets reproduces datasets and figures byte for byte."""
    targets = [
        "results/hbm/nnm2.nc",
        "paper_figures/fig06.pdf",
        "results/exact/nnm1_two_impacts.nc",
        "results/compare/nnm1_exact_vs_regularized.nc",
        "paper_figures/fig02.pdf",
        "results/compare/nnm1_regimes.nc",
    ]
    snakemake(tmp_path, "--cores", "2", *targets)
    produced = outputs(tmp_path)
    assert len(produced) >= 8
    for path in produced:
        reference = built / path.relative_to(tmp_path)
        assert path.read_bytes() == reference.read_bytes(), f"{path.relative_to(tmp_path)} differs between runs"


def test_a_figure_alone_plans_only_what_it_needs(tmp_path):
    fig06 = planned_rules(tmp_path, "paper_figures/fig06.pdf")
    assert fig06 == {"hbm_stage", "hbm_branch", "paper_fig06"}
    fig02 = planned_rules(tmp_path, "paper_figures/fig02.pdf")
    assert "exact_two_impacts" in fig02 and "hbm_branch" not in fig02
    out = snakemake(tmp_path, "-n", "--forceall", "paper_figures/fig02.pdf").stdout
    assert "nnm2" not in out and "nnm1_stage2" not in out


def test_a_job_reruns_when_the_configuration_its_task_reads_changes(built, tmp_path):
    """Each rule passes its task only the sections it reads (params.config): an edit reruns exactly those jobs."""
    config = yaml.safe_load(SMALL_CONFIG.read_text())
    config["figures"]["fig07"]["labels"][0]["energy"] *= 1.5
    config["branches"]["nnm2"]["start_amplitude"] *= 2
    edited = tmp_path / "edited.yaml"
    edited.write_text(yaml.safe_dump(config, sort_keys=False))  # same key order: only the values change
    cmd = [
        sys.executable,
        "-m",
        "snakemake",
        "-s",
        str(REPO / "Snakefile"),
        "--directory",
        str(built),
        "--configfile",
        str(edited),
        "-n",
    ]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=True).stdout
    planned = set(re.findall(r"^(?:local)?rule (\w+):", out, flags=re.MULTILINE)) - {"all"}
    # Fig 7 is redrawn; NNM2 is recomputed, then what reads it; NNM1 and the exact branches are not touched
    assert planned == {
        "paper_fig07",
        "hbm_stage",
        "hbm_branch",
        "paper_fig05",
        "paper_fig06",
        "paper_fig08",
        "paper_fig09",
        "paper_fig10",
        "dataset_manifest",
    }, out[-3000:]
    outputs = set(re.findall(r"^\s+output: (.+)$", out, flags=re.MULTILINE))
    assert not any("nnm1" in line for line in outputs), outputs


def test_slurm_profile_plans_the_jobs(tmp_path):
    """A dry run with the SLURM profile plans the cluster jobs (no cluster needed)."""
    profile = REPO / "profiles" / "slurm"
    out = snakemake(tmp_path, "-n", "--forceall", "--profile", str(profile), "results/hbm/nnm1.nc").stdout
    assert "hbm_stage" in out and "hbm_branch" in out


def test_report_holds_the_figures(built):
    report = built / "report.html"
    snakemake(built, "--report", str(report))
    text = report.read_text(errors="replace")
    assert report.stat().st_size > 10_000
    figures = sorted(p.name for p in (built / "paper_figures").glob("*.png"))
    assert figures and all(name in text for name in figures), [n for n in figures if n not in text]


def test_every_figure_rule_puts_its_png_in_the_report():
    """Each rule output that is a figure (a PNG under paper_figures/) is wrapped in report(): `--report` shows it."""
    unreported = [
        f"{path.name}: {line.strip()}"
        for path in sorted((REPO / "workflow" / "rules").glob("*.smk"))
        for line in path.read_text().splitlines()
        if re.match(r"\s+\w+=.*paper_figures.*\.png", line)
        and "report(" not in line
        and "input" not in line
        and "rules." not in line
    ]
    assert not unreported, unreported


def test_docs_pages_are_generated_from_the_build(built):
    """`snakemake docs` writes the results page from the build's datasets (the digests it lists are theirs)."""
    from nnmstop.docpages.results import page_inputs
    from nnmstop.pipeline.verify import data_digest

    snakemake(built, "--cores", "1", "docs")
    page = (built / "docs" / "results.md").read_text()
    listed = page_inputs(page)
    assert listed and all(data_digest(built / "results" / path) == digest for path, digest in listed.items())
    nnm1 = xr.open_dataset(built / "results" / "hbm" / "nnm1.nc")
    assert f"| regularized NNM1 (`hbm/nnm1.nc`) | {nnm1.sizes['point']} |" in page
    assert not re.search(r"\bnan\b", page.lower())
    assert (built / "docs" / "nnm1_frequency_energy.png").read_bytes() == (
        built / "paper_figures" / "fig02.png"
    ).read_bytes()


def _with_a_nan(built: Path, tmp_path: Path) -> Path:
    """A copy of the build's results with one NaN in one coefficient of NNM1 (written as xarray writes, no checks)."""
    copy = Path(shutil.copytree(built / "results", tmp_path / "results"))
    ds = xr.load_dataset(copy / "hbm/nnm1.nc")
    ds["q_cos"].values[5, 0, 1] = np.nan
    (copy / "hbm/nnm1.nc").unlink()
    ds.to_netcdf(copy / "hbm/nnm1.nc")
    return copy


def test_a_nan_stops_the_manifest_the_docs_page_and_the_explorer_naming_the_file(built, tmp_path):
    """Issue 33, reproduction 3: a NaN in results/hbm/nnm1.nc got its digest into docs/results.md and its hash into
    the manifest (those tasks read with plain xarray), and the explorer failed naming no file. They read through
    the reader of every task now: each refuses naming the file, the variable and the point, and writes nothing."""
    from nnmstop.docpages.results import RESULT_DATASETS
    from nnmstop.pipeline.run import find_task

    results = _with_a_nan(built, tmp_path)
    named = rf"{results / 'hbm/nnm1.nc'} holds NaN or infinite values where numbers must be: q_cos \(1 values, first "
    named += r"at point 5\)"
    manifest = tmp_path / "MANIFEST.sha256"
    with pytest.raises(ValueError, match=named):
        find_task("dataset_manifest")({}, {"datasets": sorted(map(str, results.rglob("*.nc")))}, {"manifest": manifest})
    config = yaml.safe_load(SMALL_CONFIG.read_text())
    inputs = {name: str(results / path) for name, path in RESULT_DATASETS.items() if (results / path).exists()}
    docs = {"results": tmp_path / "results.md", "figure": tmp_path / "figure.png"}
    with pytest.raises(ValueError, match=named):
        find_task("docs")(config, {**inputs, "figure": str(built / "paper_figures/fig02.png")}, docs)
    page = tmp_path / "explorer.html"
    explorer_inputs = {"regularized": [str(results / "hbm/nnm1.nc")], "exact": [str(results / "exact/nnm1.nc")],
                       "manifest": str(built / "results/MANIFEST.sha256")}  # fmt: skip
    with pytest.raises(ValueError, match=named):
        find_task("explorer")(config, explorer_inputs, {"page": page})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]


FULL_DISK_PAGES = """
import sys
from pathlib import Path
from nnmstop.explorer.page import build_explorer
from nnmstop.tasks.docs import docs
folder, build = Path(sys.argv[1]), Path({build!r})
for name, write in (
    ("explorer", lambda: build_explorer({{"regularized": [build / "results/hbm/nnm2.nc"]}},
                                        build / "results/MANIFEST.sha256", folder / "explorer.html")),
    ("docs", lambda: docs({config!r}, {{**{inputs!r}, "figure": str(build / "paper_figures/fig02.png")}},
                          {{"results": folder / "results.md", "paper_table": folder / "paper_vs_build.md",
                            "figure": folder / "front.png"}})),
):
    try:
        write()
    except OSError as error:
        print("REFUSED", name, error)
print("LEFT", sorted(p.name for p in folder.iterdir()))
"""


def test_the_explorer_and_docs_pages_on_a_full_disk_name_their_path_and_leave_nothing(built):
    """Issue 33, reproduction 5: the explorer and the docs pages wrote outside nnmstop.atomic: a full disk gave a bare
    OSError naming no path and left a 1 MiB dist/explorer.html.tmp. An 8 kB tmpfs holds neither page."""
    from nnmstop.docpages.results import RESULT_DATASETS
    from test_netcdf import run_in_small_tmpfs

    config = yaml.safe_load(SMALL_CONFIG.read_text())
    inputs = {name: str(built / "results" / path) for name, path in RESULT_DATASETS.items()
              if (built / "results" / path).exists()}  # fmt: skip
    out = run_in_small_tmpfs(FULL_DISK_PAGES.format(build=str(built), config=config, inputs=inputs), "size=8k")
    assert re.search(r"REFUSED explorer .*cannot write \S*/explorer\.html: No space left on device", out), out
    pages = r"(results|paper_vs_build)\.md|front\.png"
    assert re.search(rf"REFUSED docs .*cannot write \S*/({pages}): No space left on device", out), out
    left = re.search(r"LEFT \[(.*)\]", out)
    assert left, out  # each page whole or not at all, no temporary
    assert set(re.findall(r"'([^']*)'", left.group(1))) <= {"results.md", "paper_vs_build.md"}, out


def test_workflow_lint_is_clean():
    result = subprocess.run(
        [sys.executable, "-m", "snakemake", "--lint"], cwd=REPO, capture_output=True, text=True, timeout=120
    )
    assert "Congratulations" in result.stdout + result.stderr, (result.stdout + result.stderr)[-2000:]


# Issue 15: metadata that passes the standard checkers, and the result bundle.


def test_datasets_pass_the_cf_and_acdd_checkers(built):
    """A dataset of every kind passes cf:1.10 and acdd:1.3 but for the README's documented exclusions."""
    from nnmstop.pipeline.compliance import checker_findings, one_file_per_kind

    datasets = one_file_per_kind((built / "results").rglob("*.nc"))
    assert len(datasets) >= 5  # the small build writes five kinds
    findings = {str(p.relative_to(built)): checker_findings(p) for p in datasets}
    assert not any(findings.values()), {name: found for name, found in findings.items() if found}
    # what the exclusions hide is only the documented kinds of finding
    raw = checker_findings(built / "results/hbm/nnm2.nc", exclude=False)
    assert raw and all(re.search(r"standard_name$|geospatial_|time_coverage_", f) for f in raw), raw
    with xr.open_dataset(built / "results/hbm/nnm2.nc") as ds:
        assert all("coverage_content_type" in ds[name].attrs for name in ds.variables)
        assert ds.attrs["id"] == "hbm/nnm2"


def test_the_checker_reports_what_breaks_cf(built, tmp_path):
    """A unit UDUNITS does not know and a missing ACDD attribute are reported, not excluded."""
    from nnmstop.pipeline.compliance import checker_findings

    with xr.open_dataset(built / "results/exact/nnm1_two_impacts.nc") as ds:
        broken = ds.load()
    broken["frequency"].attrs["units"] = "cycles per nondimensional time"
    del broken.attrs["institution"]
    broken.to_netcdf(tmp_path / "broken.nc")
    findings = checker_findings(tmp_path / "broken.nc")
    assert any(f.startswith("cf:1.10") and "frequency" in f for f in findings), findings
    assert any(f.startswith("acdd:1.3") and "institution" in f for f in findings), findings


@pytest.fixture(scope="module")
def bundle(built):
    """dist/nnmstop-results.zip of the small build."""
    snakemake(built, "--cores", "1", "bundle")
    return built / "dist" / "nnmstop-results.zip"


def test_bundle_describes_the_run_and_every_file(built, bundle, tmp_path):
    from rocrate.rocrate import ROCrate

    from nnmstop.pipeline.bundle import verify_bundle

    with zipfile.ZipFile(bundle) as archive:
        names = archive.namelist()
        archive.extractall(tmp_path)
    assert names == sorted(names)
    assert {
        "ro-crate-metadata.json",
        "CITATION.cff",
        "environment.lock",
        "config/config.yaml",
        "Snakefile",
        "results/MANIFEST.sha256",
    } <= set(names)
    crate = ROCrate(tmp_path)
    workflow = crate.mainEntity
    assert workflow.id == "Snakefile" and "ComputationalWorkflow" in workflow.type
    (run,) = crate.get_by_type("CreateAction")
    assert run["instrument"].id == "Snakefile"
    assert [entity.id for entity in run["object"]] == ["config/config.yaml"]
    # the small atlas is built for the explorer page (explorer: {atlas: true}), which embeds what it shows; the
    # bundle holds the default target's run
    produced = {
        str(p.relative_to(built))
        for p in outputs(built)
        if p.suffix in (".nc", ".pdf", ".png") and not str(p.relative_to(built)).startswith("results/atlas/")
    }
    produced.add("dist/explorer.html")  # the explorer page is a result of the run too
    assert {entity.id for entity in run["result"]} == produced
    files = [entity for entity in crate.data_entities if "File" in entity.type]
    assert {entity.id for entity in files} == set(names) - {"ro-crate-metadata.json"}
    for entity in files:
        data = (tmp_path / entity.id).read_bytes()
        assert entity["encodingFormat"] and int(entity["contentSize"]) == len(data)
        assert entity["sha256"] == hashlib.sha256(data).hexdigest()
        if entity.id in produced:  # the archived copy is the built file itself
            assert data == (built / entity.id).read_bytes()
    used = yaml.safe_load((tmp_path / "config/config.yaml").read_text())
    assert used["hbm"]["harmonics"] == 16 and used["metadata"]["license"]
    assert verify_bundle(bundle) == []


def readme_python_blocks() -> list[str]:
    """The ```python blocks of README.md, in order."""
    return re.findall(r"^```python\n(.*?)^```", (REPO / "README.md").read_text(), flags=re.MULTILINE | re.DOTALL)


def test_readme_python_snippets_run_from_the_repository_root(bundle, tmp_path):
    """Every Python block of README runs as written in a built tree (results/ and dist/ where README says)."""
    blocks = readme_python_blocks()
    assert blocks, "README.md has no python block"
    workdir = tmp_path / "root"  # a copy of the build's root: the snippets extract into it
    shutil.copytree(bundle.parents[1] / "results", workdir / "results")
    shutil.copytree(bundle.parent, workdir / "dist")
    for block in blocks:
        run = subprocess.run([sys.executable, "-c", block], cwd=workdir, capture_output=True, text=True, timeout=120)
        assert run.returncode == 0, f"README block failed:\n{block}\n{run.stderr[-2000:]}"
        assert run.stdout.strip()


def test_bundle_check_fails_on_missing_or_altered_file(bundle, tmp_path):
    from nnmstop.pipeline.bundle import verify_bundle

    broken = tmp_path / "broken.zip"
    with zipfile.ZipFile(bundle) as source, zipfile.ZipFile(broken, "w") as target:
        for info in source.infolist():
            data = source.read(info)
            if info.filename == "results/hbm/nnm2.nc":
                continue  # missing
            if info.filename == "paper_figures/fig06.png":
                data = data[:-1] + bytes([data[-1] ^ 1])  # one bit flipped, same size
            target.writestr(info, data)
    problems = verify_bundle(broken)
    assert len(problems) == 2, problems
    assert any(p.startswith("results/hbm/nnm2.nc") and "missing" in p for p in problems)
    assert any(p.startswith("paper_figures/fig06.png") and "SHA-256" in p for p in problems)


def test_a_bundle_is_exactly_what_its_crate_lists(bundle, tmp_path, capsys):
    """Issue 33, reproduction 4: a zip with results/hbm/nnm1.nc replaced by garbage and dropped from the crate, an
    added run_me.sh, a member named ../escape.sh and an @id of ../../../../../../etc/hostname was reported intact.
    Each is a problem now; the unsafe member is never extracted and the outside @id never opened."""
    import json

    from nnmstop.pipeline.bundle import verify_bundle

    dropped, outside = "results/hbm/nnm1.nc", "../../../../../../etc/hostname"
    broken = tmp_path / "broken.zip"
    with zipfile.ZipFile(bundle) as source, zipfile.ZipFile(broken, "w") as target:
        for info in source.infolist():
            data = source.read(info)
            if info.filename == dropped:
                data = b"garbage" * 100
            elif info.filename == "ro-crate-metadata.json":
                crate = json.loads(data)
                graph = [e for e in crate["@graph"] if e.get("@id") != dropped]
                for entity in graph:
                    for key in ("hasPart", "result"):
                        if isinstance(entity.get(key), list):
                            entity[key] = [part for part in entity[key] if part.get("@id") != dropped]
                    if entity.get("@id") == "./":
                        entity["hasPart"].append({"@id": outside})
                graph.append({"@id": outside, "@type": "File", "name": "a file of the machine"})
                data = json.dumps({**crate, "@graph": graph}).encode()
            target.writestr(info, data)
        target.writestr("run_me.sh", "#!/bin/sh\necho surprise\n")
        target.writestr("../escape.sh", "#!/bin/sh\n")
    problems = verify_bundle(broken)
    printed = capsys.readouterr().out
    expected = [
        "../escape.sh: a name with '..', outside the archive's folder (not extracted)",
        f"{outside}: the crate lists a file outside the archive (not opened)",
        f"{dropped}: in the archive but not listed in the crate",
        "run_me.sh: in the archive but not listed in the crate",
        f"{dropped}: listed in results/MANIFEST.sha256 but not a file of the crate",
    ]
    assert problems == expected, problems
    assert "archive members" in printed and "datasets of the bundled manifests" in printed and "5 problem(s)" in printed


def test_a_bundled_dataset_must_match_the_bundled_manifest(bundle, tmp_path):
    """A dataset and its crate record replaced together (size and SHA-256 agree) still differ from the manifest."""
    import json

    from nnmstop.pipeline.bundle import verify_bundle

    name, garbage = "results/hbm/nnm2.nc", b"another file" * 50
    broken = tmp_path / "replaced.zip"
    with zipfile.ZipFile(bundle) as source, zipfile.ZipFile(broken, "w") as target:
        for info in source.infolist():
            data = source.read(info)
            if info.filename == name:
                data = garbage
            elif info.filename == "ro-crate-metadata.json":
                crate = json.loads(data)
                for entity in crate["@graph"]:
                    if entity.get("@id") == name:
                        entity.update(contentSize=str(len(garbage)), sha256=hashlib.sha256(garbage).hexdigest())
                data = json.dumps(crate).encode()
            target.writestr(info, data)
    assert verify_bundle(broken, quiet=True) == [f"{name}: SHA-256 differs from the bundled manifest's"]


def test_bundle_is_byte_identical_when_rebuilt(built, bundle):
    first = bundle.read_bytes()
    bundle.unlink()
    snakemake(built, "--cores", "1", "bundle")
    assert bundle.read_bytes() == first


CFFCONVERT_VERSION = "2.0.0"


def cffconvert_command() -> str | None:
    """cffconvert from CFFCONVERT or PATH; else installed once into its own venv under ~/.cache.

    cffconvert pins jsonschema < 4, which conflicts with environment.lock, so it never goes into
    the project's environment. Returns None when it cannot be installed (no package index).
    """
    found = os.environ.get("CFFCONVERT") or shutil.which("cffconvert")
    if found:
        return found
    venv = Path.home() / ".cache" / "nnmstop" / f"cffconvert-{CFFCONVERT_VERSION}"
    executable = venv / "bin" / "cffconvert"
    if not executable.exists():
        subprocess.run([sys.executable, "-m", "venv", "--clear", str(venv)], check=True, timeout=120)
        install = subprocess.run(
            [str(venv / "bin" / "pip"), "install", "-q", f"cffconvert=={CFFCONVERT_VERSION}"],
            capture_output=True,
            text=True,
            timeout=600,
        )
        if install.returncode != 0:
            shutil.rmtree(venv, ignore_errors=True)
            return None
    return str(executable)


def test_bundle_ships_the_repository_citation(bundle):
    """The bundle's CITATION.cff is the repository's own file, byte for byte (one citation, not two)."""
    with zipfile.ZipFile(bundle) as archive:
        assert archive.read("CITATION.cff") == (REPO / "CITATION.cff").read_bytes()


def test_bundle_citation_is_valid_cff(bundle, tmp_path):
    """CITATION.cff validates with cffconvert (kept out of environment.lock: it pins jsonschema < 4)."""
    cffconvert = cffconvert_command()
    if not cffconvert:
        if os.environ.get("CI"):
            pytest.fail(f"cffconvert {CFFCONVERT_VERSION} could not be installed into its own venv")
        pytest.skip(f"cffconvert {CFFCONVERT_VERSION} not found and not installable (set CFFCONVERT)")
    with zipfile.ZipFile(bundle) as archive:
        (tmp_path / "CITATION.cff").write_bytes(archive.read("CITATION.cff"))
    result = subprocess.run(
        [cffconvert, "--validate", "-i", str(tmp_path / "CITATION.cff")], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_task_logs_its_cost_and_the_build_sums_them(built):
    """The CPU time of the tasks, which run outside the jobs' process trees in the warm worker, is in
    each log's last line and summed by `python -m nnmstop.pipeline.usage` (docs/methods/warm_worker.md)."""
    from nnmstop.pipeline.usage import read_usage

    logs = sorted((built / "logs").rglob("*.log"))
    usages = read_usage(built / "logs")
    assert sorted(u["log"] for u in usages) == sorted(str(p) for p in logs)
    assert all(u["outcome"] == "finished" for u in usages), usages
    assert sum(u["cpu"] for u in usages if u["task"] == "hbm_stage") > 0
    result = subprocess.run(
        [sys.executable, "-m", "nnmstop.pipeline.usage", str(built / "logs")], capture_output=True, text=True
    )
    assert result.returncode == 0 and "hbm_stage" in result.stdout and "all tasks:" in result.stdout, result.stderr
