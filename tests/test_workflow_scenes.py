"""The default target at other parameters: every figure and dataset is built, and says what it cannot show.

The paper's scene (config/config.yaml: its stages, switched branches, labelled points) is followed at three
other parameter sets with tiny numerics (H = 14): where a stage's condition never comes the stage ends at its
bound or where the harmonics stop resolving the stop, and the stages after it are skipped; a figure whose
stages were all skipped draws its scene by physics (or the whole branch, unlettered, where the scene does not
exist); a feature the branch does not have (a 3:1 branch point, a regime of four impacts) is named in the
figures instead of failing them. Checked against the datasets themselves and the closed-form linear limits.
The same parameter sets at the configured numerics: tests/test_configured_numerics.py (marked slow).
"""

from __future__ import annotations

import copy
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from PIL import Image

from nnmstop.config import load_config, validate_config
from nnmstop.figures.modal_lines import label_specs, locate_label
from nnmstop.hbm.dataset import is_skipped
from nnmstop.models.two_dof import ModelParameters, linear_modes
from nnmstop.netcdf import check_labelled
from nnmstop.tasks.figures import combine_nnm1_stages
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[1]
PARAMETER_SETS = {
    "alpha10": {"alpha": 10.0},
    "alpha100_eta0.05": {"alpha": 100.0, "eta": 0.05},
    "beta2_delta0.5": {"beta": 2.0, "delta": 0.5},
}
MAX_TRUNCATION = 1e-2


def scene_config(model: dict) -> dict:
    """config/config.yaml with ``model`` changed and tiny numerics: the paper's scene, fast."""
    config = copy.deepcopy(load_config(REPO / "config" / "config.yaml"))
    config["model"].update(model)
    config["hbm"].update(harmonics=14, points_per_step=1, max_truncation=MAX_TRUNCATION)
    config["anm"].update(max_steps=400)
    config["exact"].update(step=0.1)
    config["exact_multi"].update(
        step=0.25, max_points=60, energy_max=60.0, max_log_energy_step=0.2, max_frequency_step=1e-3
    )
    config["compare"].update(energy_count=4, phase_samples=256, png_dpi=50)
    config["stability"].update(steps=64, max_steps=128, refine=False)
    config["figures"]["png_dpi"] = 50
    for section in ("tube", "study", "atlas"):
        config.pop(section, None)
    config["forced"].pop("tube", None)  # the tube's forced response needs the tube section (issue 33.7)
    return validate_config(config)


@pytest.fixture(scope="module", params=sorted(PARAMETER_SETS))
def built(request, tmp_path_factory):
    workdir = tmp_path_factory.mktemp(request.param)
    config = scene_config(PARAMETER_SETS[request.param])
    path = workdir / "config.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    run_snakemake(workdir, path, "--cores", "2", timeout=900)
    return workdir, config


def _description(png: Path) -> str:
    return Image.open(png).info.get("Description", "")


def _load(path: Path) -> xr.Dataset:
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    ds.encoding["source"] = str(path)
    return ds


def test_every_figure_and_dataset_is_built_and_labelled(built):
    workdir, config = built
    figures = {p.name for p in (workdir / "paper_figures").iterdir()}
    assert figures == {f"fig{n:02d}.{ext}" for n in range(2, 12) for ext in ("pdf", "png")}
    params = ModelParameters.from_config(config["model"])
    for path in (workdir / "results").rglob("*.nc"):
        ds = _load(path)
        check_labelled(ds)  # long_name and units everywhere, no NaN
        for key in ("alpha", "beta", "delta"):
            assert ds.attrs[key] == getattr(params, key), (path, key)
    for n in range(5, 12):
        text = _description(workdir / "paper_figures" / f"fig{n:02d}.png")
        assert text.startswith(f"Fig. {n}:") and f"α = {params.alpha:g}, β = {params.beta:g}" in text


def test_stages_end_honestly_and_the_branch_starts_at_its_linear_mode(built):
    """A stage ends at its condition, or at its bound or its last resolved orbit; the stages after it then hold
    no orbit and repeat why."""
    workdir, config = built
    params = ModelParameters.from_config(config["model"])
    branch = config["branches"]["nnm1"]
    skip = ""
    for k, stage in enumerate(branch["stages"], start=1):
        ds = _load(workdir / "results" / "hbm" / "stages" / f"nnm1_stage{k}.nc")
        if skip:
            assert is_skipped(ds) and ds.attrs["end_reason"] == skip
            continue
        assert not is_skipped(ds)
        assert float(ds["truncation"].max()) <= MAX_TRUNCATION  # every stored orbit resolved
        energy = ds["energy"].values
        if ds.attrs["stage_condition_met"]:
            assert ds.attrs["end_reason"].startswith(ds.attrs["stage_condition"])
        elif ds.attrs["stage_end"] == "bound":
            assert energy[-1] > branch["energy_max"] >= energy[:-1].max()
        else:
            assert ds.attrs["stage_end"] == "truncation" and ds.attrs["end_reason"].startswith("unresolved")
        if not ds.attrs["stage_condition_met"]:
            condition = ds.attrs["stage_condition"]
            skip = f"skipped: stage {k} ({stage['name']}) ended without its condition ({condition}): "
            skip += ds.attrs["end_reason"]
    nnm1 = _load(workdir / "results" / "hbm" / "nnm1.nc")
    start = linear_modes(params, "regularized")[0][0] / (2 * np.pi)  # closed form, the regularized law near rest
    assert float(nnm1["frequency"][0]) == pytest.approx(start, rel=1e-4)


def test_what_a_figure_cannot_show_it_names(built):
    """Each label either lands on the branch, or the figure names it; skipped stages and missing switches too."""
    workdir, config = built
    results = workdir / "results" / "hbm"
    for n in range(7, 12):
        name = f"fig{n:02d}"
        spec = config["figures"][name]
        stages = [_load(results / "stages" / f"nnm1_stage{k}.nc") for k in spec["nnm1_stages"]]
        nnm1 = combine_nnm1_stages(stages, name, spec["nnm1_stages"])
        text = _description(workdir / "paper_figures" / f"{name}.png")
        for ds in stages:
            if is_skipped(ds):
                assert f"stage {ds.attrs['skipped_stage']} ({ds.attrs['stage_name']}) not continued" in text
        not_drawn = text.split("not on this branch:")[1] if "not on this branch:" in text else ""
        if is_skipped(nnm1):  # every stage of the figure skipped: its scene by physics, or the branch unlettered
            assert "drawn instead" in text or "the whole branch is drawn" in text, (name, text)
            if "the whole branch is drawn" in text:
                assert all(re.search(rf"(^|[ ;]){label.label}\)", not_drawn) for label in label_specs(spec["labels"]))
            continue
        for label in label_specs(spec["labels"]):
            missing = locate_label(nnm1, label).point is None
            named = re.search(rf"(^|[ ;]){label.label}\)[ ,]", not_drawn) is not None
            assert named == missing, (name, label.describe())
        for bifurcated in spec.get("bifurcated", []):
            ds = _load(results / "bifurcated" / f"{bifurcated}.nc")
            resonance = int(ds.attrs["resonance"])
            assert is_skipped(ds) == (f"no branch switched at a {resonance}:1 branch point" in text)
            whole = _load(results / "nnm1.nc")
            assert is_skipped(ds) == (resonance not in whole["branch_point_resonance"].values)
