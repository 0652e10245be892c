"""Every script in benchmarks/ runs, on a tiny case, so that none can rot unseen.

The scripts measure; these tests only check that each one still runs to its report (no timing is
asserted). Each gets its smallest real run: a small configuration (tests/data/small_config.yaml),
datasets of a small build made once here, few harmonics, one repetition, and ``HEAD`` against itself
where a script compares two commits. The imports of every script are also resolved statically (a
name that moved out of the package fails here even in a branch of a script the tiny run skips).
"""

from __future__ import annotations

import ast
import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[1]
BENCHMARKS = REPO / "benchmarks"
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"
#: Helper modules of the scripts (imported by them, not run).
HELPERS = {"timing", "branch_orbits", "pyharm_side"}
NNM2 = "results/hbm/nnm2.nc"
NNM1_STAGE1 = "results/hbm/stages/nnm1_stage1.nc"
SMALL = str(SMALL_CONFIG)

#: The tiny run of each script: its arguments ({build}: the small build, {out}: a report file).
# fmt: off
TINY_RUNS = {
    "atlas_artefacts": ["--exponent-only", "--output", "{out}"],
    "cold_build": ["--target", "results/exact/nnm1_two_impacts.nc", "--configfile", SMALL, "--output", "{out}"],
    "continuation_benchmark": ["--harmonics", "5", "--branches", "NNM2", "--repeat", "1", "--output", "{out}"],
    "exact_build": ["--compare", "HEAD", "HEAD", "--repeat", "1", "--configfile", SMALL,
                    "--tasks", "exact_two_impacts"],
    "explorer": None,  # times a built dist/explorer.html in Chromium: its --help here; the page has its own tests
    "target_cost": ["--targets", "results/exact/nnm1_two_impacts.nc", "--configfile", SMALL, "--output", "{out}"],
    "exact_slices": ["--compare", "HEAD", "HEAD", "--nnm1-stage1", "{build}/" + NNM1_STAGE1, "--configfile", SMALL,
                     "--slices", "2", "--points", "20", "--energies", "2"],
    "forced_build": None,  # a cold build of the forced target (over a minute): its --help
    "forced_vs_pyharm": None,  # installs pyHarm into a venv of its own: its --help
    "fe_scaling": ["--tiny", "--output", "{out}"],
    "figure_cost": ["--figures", "fig06", "--repeat", "1", "--results", "{build}/results", "--configfile", SMALL,
                    "--output", "{out}"],
    "monodromy_calibration": ["{build}/" + NNM2, "--config", SMALL, "--stride", "40"],
    "one_sided_convergence": ["--etas", "0.2", "0.1", "--hbm-etas", "0.2", "0.1", "--harmonics", "20", "--output",
                              "{out}"],
    "quickstart": ["--tiny", "--output", "{out}"],
    "reduction_convergence": ["--tiny", "--output", "{out}"],
    "reduction_scaling": ["--tiny", "--output", "{out}"],
    "refinement_benchmark": ["{build}/" + NNM2, "--config", SMALL, "--repeat", "1", "--output", "{out}"],
    "stability_benchmark": ["{build}/" + NNM2, "--config", SMALL, "--stride", "20", "--repeat", "1",
                            "--output", "{out}"],
    "stability_compare": ["{build}/" + NNM2, "--compare", "HEAD", "HEAD", "--config", SMALL, "--repeat", "1",
                          "--output", "{out}"],
    "structure_stability": ["--reference", "fc5e57b", "--energy-max", "0.05", "--harmonics", "8", "--output", "{out}"],
}
# fmt: on


#: Scripts whose tiny run fails on this commit, with why: strict, so the test says when one runs again.
BROKEN = {}


def scripts() -> list[str]:
    return sorted(p.stem for p in BENCHMARKS.glob("*.py") if p.stem not in HELPERS)


def test_every_script_has_a_tiny_run():
    assert set(scripts()) == set(TINY_RUNS), "add a tiny run to TINY_RUNS for every benchmark script"


def imported_names(path: Path):
    """``(module, name or None, line)`` of every import of the package or a sibling script in ``path``."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            root = node.module.split(".")[0]
            if root == "nnmstop" or root in HELPERS | set(TINY_RUNS):
                for alias in node.names:
                    yield node.module, alias.name, node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "nnmstop":
                    yield alias.name, None, node.lineno


@pytest.mark.parametrize(
    "script",
    [
        pytest.param(s, marks=pytest.mark.xfail(strict=True, reason=BROKEN[s])) if s in BROKEN else s
        for s in scripts() + sorted(HELPERS)
    ],
)
def test_imports_of_the_script_resolve(script, monkeypatch):
    """Every ``from nnmstop... import name`` of the script, even inside functions, names something that exists."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    missing = []
    for module, name, line in imported_names(BENCHMARKS / f"{script}.py"):
        try:
            imported = importlib.import_module(module)
        except ImportError as error:
            missing.append(f"line {line}: {module} ({error})")
            continue
        if name is not None and not hasattr(imported, name):
            try:
                importlib.import_module(f"{module}.{name}")
            except ImportError:
                missing.append(f"line {line}: {name} from {module}")
    assert not missing, f"benchmarks/{script}.py: " + "; ".join(missing)


@pytest.fixture(scope="module")
def small_build(tmp_path_factory):
    """NNM2 and NNM1 stage 1 of the small configuration: the datasets the stability scripts read."""
    workdir = tmp_path_factory.mktemp("benchmark_build")
    run_snakemake(workdir, SMALL_CONFIG, "--cores", "2", NNM2, NNM1_STAGE1)
    return workdir


def tiny_run_params():
    return [
        pytest.param(s, marks=pytest.mark.xfail(strict=True, reason=BROKEN[s])) if s in BROKEN else s
        for s in sorted(k for k, v in TINY_RUNS.items() if v is not None)
    ]


def test_scripts_without_a_tiny_run_answer_help():
    for script in sorted(k for k, v in TINY_RUNS.items() if v is None):
        run = subprocess.run(
            [sys.executable, str(BENCHMARKS / f"{script}.py"), "--help"], capture_output=True, text=True
        )
        assert run.returncode == 0 and "usage" in run.stdout, run.stderr[-2000:]


@pytest.mark.parametrize("script", tiny_run_params())
def test_script_runs_on_a_tiny_case(script, small_build, tmp_path):
    out = tmp_path / "report.md"
    args = [a.format(build=small_build, out=out) for a in TINY_RUNS[script]]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO / "src"), os.environ.get("PYTHONPATH", "")])}
    env["OPENBLAS_NUM_THREADS"] = "1"
    run = subprocess.run(
        [sys.executable, str(BENCHMARKS / f"{script}.py"), *args],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, f"{script} failed:\n{run.stdout[-2000:]}\n{run.stderr[-3000:]}"
    report = out.read_text() if "{out}" in TINY_RUNS[script] else run.stdout
    assert report.strip() and "nan" not in report.replace("nano", "").lower().split(), report[-2000:]
    if "{out}" in TINY_RUNS[script] and script != "continuation_benchmark":
        assert "commit" in report and "load average" in report  # timing.run_header: commit, machine, load
