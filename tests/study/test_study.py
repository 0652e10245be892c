"""The study (issue 5): sweep cases, the error split, gathering, figures, bad input and faults.

Small settings only (H <= 60, H_ref = 120, two energies): the machinery -- what is measured,
how the failures the method expects are stored and every other one fails the job, how files
are checked -- and the behaviour of the split (the truncation part falls with H, the
regularization part scales with eta, the sparse linear algebra gives the dense one's numbers),
not the numbers of the full study (``snakemake --cores 2 study``).
"""

import copy
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr
import yaml

from nnmstop.atomic import temporary_name
from nnmstop.config import load_config
from nnmstop.continuation.core import ContinuationError
from nnmstop.figures.study import pareto_front
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters
from nnmstop.netcdf import write_dataset
from nnmstop.settings import study_settings
from nnmstop.study import error_runtime as er
from nnmstop.study.runs import Status, format_number
from nnmstop.tasks import study as ts
from nnmstop.tasks.figures import build_error_vs_runtime_figure

SNAKEMAKE = [sys.executable, "-m", "snakemake"]  # the environment's own Snakemake, never skipped


@pytest.fixture(scope="module")
def config(repo_root):
    return load_config(repo_root / "config" / "config.yaml")


def small_study(config, harmonics=(10, 30, 60), eta=(0.1, 0.01), anm_orders=(10, 20)):
    """A small study: energies 3 and 12, H_ref = 120 seeded at H = 60, ANM sweep at H = 30."""
    cfg = copy.deepcopy(config)
    study = cfg["study"]
    study["energies"] = [3.0, 12.0]
    study["phase_samples"] = 512
    study["error_runtime"].update(
        harmonics=list(harmonics),
        eta=list(eta),
        reference_harmonics=120,
        reference_seed_harmonics=60,
        anm_harmonics=30,
        anm_orders=list(anm_orders),
        anm_tolerances=[1e-6],
    )
    return cfg


@pytest.fixture(scope="module")
def small(config):
    """H in {10, 30, 60}, eta in {0.1, 0.01}, ANM 2 x 1."""
    return small_study(config)


@pytest.fixture(scope="module")
def exact(config):
    from nnmstop.exact.dataset import two_impact_dataset
    from nnmstop.exact.family import follow_two_impact_family

    params = ModelParameters.from_config(config["model"])
    return two_impact_dataset(follow_two_impact_family(params, step=0.05, max_points=4000))


def build_study(small, exact, root):
    """Every sweep file of ``small`` written through the pipeline builders, then gathered."""
    exact_path = write_dataset(
        exact, root / "exact.nc", title="exact", summary="exact family", kind="two_impact_family"
    )
    inputs = {"exact": str(exact_path)}
    cases = er.sweep_cases(study_settings(small))
    out = {kind: [] for kind in ("cases", "anm_cases", "references")}
    for H, eta in cases["cases"]:
        path = ts.build_error_case(small, inputs, root / f"H{H}_eta{eta:g}.nc", str(H), format_number(eta))
        out["cases"].append(str(path))
    for eta in cases["references"]:
        path = ts.build_reference(small, inputs, root / f"reference_eta{eta:g}.nc", format_number(eta))
        out["references"].append(str(path))
    for order, tol in cases["anm_cases"]:
        path = root / f"anm_N{order}_tol{tol:g}.nc"
        H_anm, eta_anm = small["study"]["error_runtime"]["anm_harmonics"], small["model"]["eta"]
        out["anm_cases"].append(
            str(ts.build_error_case(small, inputs, path, H_anm, eta_anm, str(order), format_number(tol)))
        )
    out["exact_cost"] = str(ts.build_exact_cost(small, inputs, root / "exact_cost.nc"))
    target = root / "results/study/error_vs_runtime.nc"
    ts.build_error_vs_runtime(small, out, target)
    with xr.open_dataset(target) as ds:
        return root, out, ds.load()


@pytest.fixture(scope="module")
def gathered(small, exact, tmp_path_factory):
    return build_study(small, exact, tmp_path_factory.mktemp("study"))


# --------------------------------------------------------------------------- helpers


def test_pareto_front():
    assert pareto_front([1.0, 2.0, 3.0, 4.0], [5.0, 6.0, 1.0, 1.0]).tolist() == [0, 2]
    assert pareto_front([3.0, np.nan, 1.0], [1.0, 0.0, 2.0]).tolist() == [2, 0]
    with pytest.raises(ValueError, match="same shape"):
        pareto_front([1.0], [1.0, 2.0])


def test_format_number_for_wildcards():
    assert [format_number(v) for v in (0.001, 1.0, 1e-8, 1e6, 300.0)] == ["0.001", "1", "1e-08", "1e06", "300"]
    assert float(format_number(1e6)) == 1e6
    with pytest.raises(ValueError, match="nan"):
        format_number(float("nan"))


def test_case_run_varies_the_settings_not_the_configuration(config):
    settings = study_settings(config)
    run = er.case_run(settings, 20, 0.01, order=10)
    assert (run.harmonics, run.params.eta, run.continuation.order) == (20, 0.01, 10)
    assert run.params.alpha == config["model"]["alpha"] and run.continuation.tolerance == config["anm"]["tolerance"]
    assert settings.run.params.eta == config["model"]["eta"]  # the base is left alone
    with pytest.raises(ValueError, match="eta must be smaller than alpha"):
        er.case_run(settings, 20, 50.0)


def test_truncation_indicator_sees_the_odd_top_harmonic():
    """NNM1 orbits carry odd harmonics only: the top share must hold an odd harmonic even at H = 10."""
    system = HarmonicBalanceSystem(two_dof_structure(ModelParameters()), harmonics=10)
    U = system.linear_mode_guess(1, 0.5)
    x, u, f, z, lam, _ = system.split(U)
    f = f.copy()
    f[9] = 0.1 * f[1]  # harmonic 9 (cosine basis: index k)
    U = system.pack(x, u, f, z, lam)
    assert system.truncation_indicator(f) == pytest.approx(0.01 / 1.01, rel=1e-12)  # what the datasets record
    assert system.truncation(U) == pytest.approx(0.01 / 1.01, rel=1e-12)  # what the study's guard reads


# --------------------------------------------------------------------------- one case, failures


def test_unresolved_case_is_reported_not_computed(small, exact):
    ds = er.error_case_dataset(study_settings(small), exact, 10, 0.01)
    assert not bool(ds["converged"]) and not bool(ds["compared"])
    failure = str(ds["failure"].values)
    assert "truncation indicator" in failure and "H = 10" in failure and "eta = 0.01" in failure
    assert np.isnan(ds["relative_frequency_difference"].values).all()  # not computed: the status says why
    assert int(ds["factorizations"]) == -1 and float(ds["runtime"]) > 0


def test_setting_compared_on_part_of_the_energies_says_which(small, exact):
    cfg = copy.deepcopy(small)
    cfg["study"]["energies"] = [3.0, 80.0]  # the exact family ends at 55.9
    ds = er.error_case_dataset(study_settings(cfg), exact, 30, 0.1)
    assert bool(ds["converged"]) and not bool(ds["compared"])
    assert "energy 80" in str(ds["failure"].values)
    assert int(ds["status"]) == Status.OUTSIDE_COMMON_RANGE
    assert ds["energy_status"].values.tolist() == [Status.COMPUTED, Status.OUTSIDE_COMMON_RANGE]
    assert np.isfinite(ds["max_x_difference"].values[0]) and np.isnan(ds["max_x_difference"].values[1])


def test_an_unexpected_error_fails_the_study_job_and_leaves_no_dataset(small, exact, tmp_path, monkeypatch):
    """Only the outcomes the method expects are results; a failed solve inside the compared range is not."""
    import nnmstop.compare.matching as matching
    from nnmstop.pipeline.run import run_task

    exact_path = write_dataset(
        exact, tmp_path / "exact.nc", title="exact", summary="exact family", kind="two_impact_family"
    )

    def failing(self, energy, tol=1e-13):
        raise ValueError(f"Newton's method did not converge for the regularized orbit at energy {energy!r}")

    monkeypatch.setattr(matching.EnergyMatcher, "regularized_orbit", failing)
    output = tmp_path / "results/study/cases/H30_eta0.1.nc"
    with pytest.raises(ValueError, match="did not converge for the regularized orbit at energy 3.0"):
        run_task(
            "study_error_case",
            small,
            {"exact": str(exact_path)},
            {"dataset": str(output)},
            log=str(tmp_path / "log.txt"),
            harmonics="30",
            eta="0.1",
        )
    assert not output.exists() and not output.with_name(output.name + ".tmp").exists()


# --------------------------------------------------------------------------- gathered dataset


def test_gathered_dataset_layout(gathered, small):
    _, _, ds = gathered
    assert ds["frequency_error"].dims == ("harmonics", "eta")
    assert ds["harmonics"].values.tolist() == [10, 30, 60] and ds["eta"].values.tolist() == [0.1, 0.01]
    assert ds["anm_runtime"].dims == ("order", "tolerance")
    for name in (
        "runtime",
        "cpu_time",
        "factorizations",
        "x_error",
        "u_error",
        "force_error",
        "status",
        "failure",
        "frequency_error_truncation",
        "frequency_error_regularization",
        "exact_seconds_per_orbit",
    ):
        assert name in ds, name
    assert ds["runtime"].attrs["units"] == "s"
    # H = 10 does not resolve the stop: reported with its reason, never a number
    unresolved = ds.sel(harmonics=10)
    assert (unresolved["status"] == Status.UNRESOLVED).all() and not unresolved["converged"].any()
    assert np.isnan(unresolved["frequency_error"]).all() and np.isnan(unresolved["frequency_error_truncation"]).all()
    assert all("truncation indicator" in s for s in unresolved["failure"].values)
    # H = 30 and 60 converge and are compared at every energy, with an error and a cost
    ok = ds.sel(harmonics=[30, 60])
    assert (ok["status"] == Status.COMPUTED).all() and (ok["energy_status"] == Status.COMPUTED).all()
    assert (ok["frequency_error"] > 0).all() and (ok["factorizations"] > 0).all() and (ok["runtime"] > 0).all()
    assert np.isfinite(ok["frequency_error_truncation"]).all() and np.isfinite(ds["x_error_regularization"]).all()
    assert float(ds["exact_seconds_per_orbit"]) > 0 and float(ds["exact_family_seconds_per_orbit"]) > 0


def test_error_split_is_consistent(gathered):
    """Per energy: |total| <= regularization + truncation (triangle inequality, same phase alignment),
    up to the refinement of each maximum (each is refined around its own grid maximum: ~0.5 % for the
    force, whose exact law has a kink); frequencies add up (up to f_ref / f_exact)."""
    _, _, ds = gathered
    ok = ds.sel(harmonics=[30, 60])
    for key in ("max_x_difference", "max_u_difference", "max_force_difference"):
        total = ok[f"{key}_at_energy"]
        bound = ds[f"{key}_regularization_at_energy"] + ok[f"{key}_truncation_at_energy"]
        assert (total <= bound * 1.01 + 1e-12).all(), key
    freq = ok["relative_frequency_difference_at_energy"]
    split = (
        ds["relative_frequency_difference_regularization_at_energy"]
        + ok["relative_frequency_difference_truncation_at_energy"]
    )
    xr.testing.assert_allclose(freq, split.transpose(*freq.dims), rtol=1e-3, atol=1e-9)


def test_truncation_part_falls_with_H(gathered):
    """Doubling H shrinks the truncation part at every energy, for every eta (the series converge)."""
    _, _, ds = gathered
    for key in ("relative_frequency_difference", "max_x_difference", "max_force_difference"):
        part = np.abs(ds[f"{key}_truncation_at_energy"])
        coarse, fine = part.sel(harmonics=30), part.sel(harmonics=60)
        assert (fine < coarse).all(), (key, coarse.values, fine.values)


def test_regularization_part_scales_with_eta(gathered):
    """The regularization part is a potential excess over the piecewise law (the linear spring eta x in
    free flight, (eta/2) log(alpha (|x| - 1) / eta) in contact): shift = eta (a + b log(1/eta)), a, b >= 0.
    Ten times eta gives a ratio between 10 log(100)/log(1000) = 6.67 (log term alone) and 10 (no log term),
    up to the next order in the knee width sqrt(eta / alpha) (0.06 at eta = 0.1); the regularized stop is
    stiffer everywhere, so the frequency is higher."""
    _, _, ds = gathered
    freq = ds["relative_frequency_difference_regularization_at_energy"]
    assert (freq > 0).all(), freq.values
    ratio = freq.sel(eta=0.1) / freq.sel(eta=0.01)
    assert ((ratio > 0.9 * 10 * np.log(100) / np.log(1000)) & (ratio < 1.1 * 10)).all(), ratio.values


def test_sparse_linear_algebra_gives_the_same_split(small, exact, gathered, tmp_path, monkeypatch):
    """The study through the sparse path (systems above DENSE_MAX_UNKNOWNS unknowns: here H = 60 and the
    H_ref = 120 reference, with the limit lowered to 200) has a finite split, equal to the dense one's:
    the matched orbits are Newton-solved at the same energies to 1e-13, whatever the factorization."""
    import nnmstop.compare.matching as matching
    import nnmstop.hbm.system as hbm_system

    monkeypatch.setattr(hbm_system, "DENSE_MAX_UNKNOWNS", 200)
    sparse_solves = []
    real_splu = matching.splu
    monkeypatch.setattr(matching, "splu", lambda matrix: sparse_solves.append(matrix.shape) or real_splu(matrix))
    cfg = small_study(small, harmonics=(30, 60), eta=(0.1,), anm_orders=(20,))
    _, _, sparse = build_study(cfg, exact, tmp_path)
    assert {shape[0] for shape in sparse_solves} == {245, 485}  # H = 60 (case) and H = 120 (reference)
    for name in ("frequency_error", "x_error", "force_error"):
        for part in ("truncation", "regularization"):
            values = sparse[f"{name}_{part}"]
            assert np.isfinite(values).all(), (name, part)
            dense = gathered[2][f"{name}_{part}"].sel(eta=[0.1])
            if "harmonics" in dense.dims:
                dense = dense.sel(harmonics=[30, 60])
            np.testing.assert_allclose(values, dense, rtol=1e-6, err_msg=f"{name}_{part}")


def test_tables_print_every_setting_and_the_advice_from_the_dataset(gathered):
    from nnmstop.study.tables import error_split_rows, harmonics_advice_rows

    _, _, ds = gathered
    header, rows = error_split_rows(ds, times=False)
    assert "CPU time (s)" not in header and len(rows) == ds.sizes["harmonics"] * ds.sizes["eta"]
    reasons = {(row[0], row[1]): row[-1] for row in rows}
    assert all("not resolved" in reasons[(f"{eta:g}", 10)] for eta in ds["eta"].values)
    assert all(reasons[(f"{eta:g}", H)] == "" for eta in ds["eta"].values for H in (30, 60))
    # the advice: the smallest H whose truncation part is below the regularization part of its eta
    _, advice = harmonics_advice_rows(ds, times=False)
    for row, eta in zip(advice, ds["eta"].values):
        case = ds.sel(eta=eta)
        below = case["frequency_error_truncation"] < case["frequency_error_regularization"]
        expected = int(case["harmonics"][below][0]) if below.any() else None
        assert (row[2] == expected) if expected else row[2].startswith("none"), (eta, row)


def test_gather_refuses_stale_case_files(gathered, small):
    root, inputs, _ = gathered
    other = copy.deepcopy(small)
    other["study"]["energies"] = [3.0, 13.0]
    with pytest.raises(ValueError, match="energies"):
        ts.build_error_vs_runtime(other, inputs, root / "stale.nc")
    other = copy.deepcopy(small)
    other["anm"]["order"] = 15
    with pytest.raises(ValueError, match="order"):
        ts.build_error_vs_runtime(other, inputs, root / "stale.nc")
    assert not (root / "stale.nc").exists()
    other = copy.deepcopy(small)
    other["study"]["error_runtime"]["harmonics"] = [10, 20, 30, 60]
    with pytest.raises(ValueError, match="6 cases datasets given, the configuration's sweep has 8"):
        ts.build_error_vs_runtime(other, inputs, root / "stale.nc")


def test_error_vs_runtime_figure(gathered, small, tmp_path):
    root, _, _ = gathered
    pdf, png = build_error_vs_runtime_figure(small, root / "results/study/error_vs_runtime.nc", tmp_path / "evr.pdf")
    assert pdf.stat().st_size > 1000 and png.stat().st_size > 1000


def test_error_vs_runtime_labels_cover_no_marker_and_no_other_label(gathered, tmp_path):
    """The H and N labels beside their settings: off every marker, Pareto ring, legend and other label."""
    from nnmstop.figures.common import save_figure
    from nnmstop.figures.labels import label_overlaps, place_labels
    from nnmstop.figures.study import error_vs_runtime_figure
    from nnmstop.netcdf import read_dataset

    root, _, _ = gathered
    fig = error_vs_runtime_figure(read_dataset(root / "results/study/error_vs_runtime.nc"))
    found = {}

    def check(figure):
        place_labels(figure)
        found["labels"] = sum(t.get_gid() == "point-label" for ax in figure.axes for t in ax.texts)
        found["overlaps"] = label_overlaps(figure)

    save_figure(fig, tmp_path / "evr.pdf", png_dpi=60, after_layout=check)
    assert found["labels"] > 0 and found["overlaps"] == []


def test_stiff_gather_tables_and_figure(small, gathered, tmp_path, capsys):
    from nnmstop.study import stiff_cases as sc
    from nnmstop.tasks.figures import build_stiff_cases_figure

    cfg = copy.deepcopy(small)
    cfg["study"]["stiff"].update(
        harmonics=[20, 40],
        alpha=[30.0, 300.0],
        eta=[0.1],
        ratios=[1.0],
        energies=[1e-6, 1e3],
        energy_alpha=[30.0],
        max_steps=150,
        compare_count=2,
    )
    cases = sc.stiff_case_parameters(study_settings(cfg))
    assert len(cases["exact"]) == 2 and len(cases["branches"]) == 2
    inputs = {"exact": [], "branches": [], "energy": []}
    for a, b, d in cases["exact"]:
        inputs["exact"].append(ts.build_stiff_exact(cfg, {}, tmp_path / f"exact_{a:g}_{b:g}_{d:g}.nc", a, b, d))
    for a, b, d, e in cases["branches"]:
        exact_path = tmp_path / f"exact_{a:g}_{b:g}_{d:g}.nc"
        path = tmp_path / f"nnm1_{a:g}_{b:g}_{d:g}_{e:g}.nc"
        inputs["branches"].append(ts.build_stiff_branch(cfg, {"exact": exact_path}, path, a, b, d, e))
    inputs["energy"].append(ts.build_stiff_energy(cfg, {}, tmp_path / "energy_30.nc", "30"))
    target = ts.build_stiff_cases(cfg, inputs, tmp_path / "stiff_cases.nc")
    with xr.open_dataset(target) as ds:
        assert ds["converged"].dims == ("alpha", "eta") and ds["failure"].dtype.kind in "OU"
        assert bool(ds["converged"].sel(alpha=30.0, eta=0.1)) and int(ds["harmonics"].sel(alpha=30.0, eta=0.1)) == 40
        assert float(ds["exact_relative_residual"].max()) < 1e-13
        assert float(ds["exact_periodicity_error"].max()) < 1e-10
        assert ds["energy_kind"].sel(energy_alpha=30.0).values.tolist() == ["linear", "high_energy"]
        assert bool(ds["energy_hbm_converged"].sel(energy_alpha=30.0).values[0])
    from nnmstop.study.tables import main as print_tables

    (tmp_path / "error_vs_runtime.nc").symlink_to(gathered[0] / "results/study/error_vs_runtime.nc")
    print_tables([str(tmp_path), "--no-times"])
    printed = capsys.readouterr().out
    assert "## Stiff cases" in printed and "| 300 |" in printed and "CPU time" not in printed
    pdf, png = build_stiff_cases_figure(cfg, target, tmp_path / "stiff.pdf")
    assert pdf.stat().st_size > 1000 and png.stat().st_size > 1000


# --------------------------------------------------------------------------- bad input and faults


def _run_snakemake(args, cwd, timeout=300):
    return subprocess.run([*SNAKEMAKE, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize(
    "override, expected",
    [
        ({"study": {"max_truncation": 2.0}}, "study.max_truncation"),
        ({"study": {"error_runtime": {"harmonics": [0]}}}, "study.error_runtime.harmonics.0"),
        ({"study": {"energies": [3.0, 1.0]}}, "study.energies"),
    ],
)
def test_dry_run_refuses_a_bad_study_section(repo_root, tmp_path, override, expected):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(override))
    proc = _run_snakemake(["-n", "study", "--configfile", str(path)], repo_root, timeout=180)
    output = proc.stdout + proc.stderr
    assert proc.returncode != 0, output
    assert expected in output, output


def test_numerical_failure_mid_branch_names_step_and_energy_and_leaves_no_dataset(config, tmp_path, monkeypatch):
    import nnmstop.continuation.anm as anm
    from nnmstop.pipeline.run import run_task

    real_step = anm.anm_step
    calls = {"n": 0}

    def failing_step(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 3:
            raise np.linalg.LinAlgError("bordered Jacobian is singular to working precision")
        return real_step(*args, **kwargs)

    monkeypatch.setattr(anm, "anm_step", failing_step)
    cfg = copy.deepcopy(config)
    cfg["hbm"]["harmonics"] = 10
    output = tmp_path / "results/hbm/stages/nnm1_stage1.nc"
    with pytest.raises(ContinuationError, match=r"nnm1 stage 1 .*: step 3 failed at energy [0-9.e+-]+ \(frequency"):
        run_task(
            "hbm_stage", cfg, {}, {"dataset": str(output)}, log=str(tmp_path / "log.txt"), branch="nnm1", stage="1"
        )
    assert not output.exists() and not temporary_name(output).exists()
    assert "step 3 failed at energy" in (tmp_path / "log.txt").read_text()


def _small_pipeline(tmp_path, repo_root, name):
    """A copy of the workflow in ``tmp_path/name`` with a small configuration (H = 20)."""
    work = tmp_path / name
    work.mkdir()
    shutil.copy(repo_root / "Snakefile", work / "Snakefile")
    shutil.copytree(repo_root / "workflow", work / "workflow")
    shutil.copytree(repo_root / "config", work / "config")
    # coarse on purpose (this test is about restarting, not accuracy)
    small = {
        "hbm": {"harmonics": 40, "time_samples": 0, "points_per_step": 2, "max_truncation": 1.0e-2},
        "exact": {"step": 0.05, "max_points": 4000},
    }
    (work / "small.yaml").write_text(yaml.safe_dump(small))
    return work


TARGETS = [
    "results/exact/nnm1_two_impacts.nc",
    "results/hbm/stages/nnm1_stage1.nc",
    "results/hbm/stages/nnm1_stage2.nc",
]


def test_interrupted_run_restarts_to_the_outputs_of_a_clean_run(repo_root, tmp_path):
    env = {**os.environ, "SOURCE_DATE_EPOCH": "0"}
    clean = _small_pipeline(tmp_path, repo_root, "clean")
    proc = subprocess.run(
        [*SNAKEMAKE, "--cores", "1", *TARGETS, "--configfile", "small.yaml"],
        cwd=clean,
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]

    broken = _small_pipeline(tmp_path, repo_root, "interrupted")
    runner = subprocess.Popen(
        [*SNAKEMAKE, "--cores", "1", *TARGETS, "--configfile", "small.yaml"],
        cwd=broken,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
        start_new_session=True,
    )
    deadline = time.monotonic() + 300
    first = broken / TARGETS[1]
    while not first.exists() and runner.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    assert first.exists(), "the first continuation stage never finished"
    os.killpg(runner.pid, signal.SIGKILL)  # kill snakemake and its running job mid-way
    runner.wait(timeout=60)
    interrupted = not (broken / TARGETS[2]).exists()
    # what an interruption can leave behind: a temporary file of the atomic writer
    stale = temporary_name(broken / TARGETS[2])
    stale.parent.mkdir(parents=True, exist_ok=True)
    stale.write_bytes(b"partial netcdf")
    # a hard kill leaves the working directory locked: unlock (as after a lost cluster node), then rerun
    proc = subprocess.run(
        [*SNAKEMAKE, "--unlock", *TARGETS, "--configfile", "small.yaml"],
        cwd=broken,
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    proc = subprocess.run(
        [*SNAKEMAKE, "--cores", "1", "--rerun-incomplete", *TARGETS, "--configfile", "small.yaml"],
        cwd=broken,
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    for target in TARGETS:
        with xr.open_dataset(clean / target) as a, xr.open_dataset(broken / target) as b:
            xr.testing.assert_identical(a.load(), b.load())
        assert (clean / target).read_bytes() == (broken / target).read_bytes(), target
    if interrupted:  # the rerun job replaced the leftover temporary file by the dataset
        assert not stale.exists()


def test_study_datasets_pass_the_cf_and_acdd_checkers(gathered):
    """The gathered study dataset and its case files pass cf:1.10 and acdd:1.3 but for the documented exclusions."""
    from nnmstop.pipeline.compliance import checker_findings

    root, out, _ = gathered
    for path in [root / "results/study/error_vs_runtime.nc", out["cases"][0], out["references"][0], out["exact_cost"]]:
        assert checker_findings(path) == [], path
