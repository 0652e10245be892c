"""Every variable a figure reads is verified (issue 33.1): figures of the default target drawn from datasets whose
unverified variables are scrambled.

:func:`nnmstop.pipeline.reference.unverified_variables` names, per dataset, the variables ``verify`` does not
compare (those that follow the continuation's steps: step numbers, indices of stored points, arclength). Each
figure task of the small build's default target is run again on copies of its datasets with every one of them
changed (shifted values, other indices): it must draw the build's figure byte for byte, so no figure depends
on a variable the verifier leaves unchecked. The forced figures get the same test in
tests/pipeline/test_verify_forced.py (their build).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from nnmstop.config import validate_config
from nnmstop.pipeline.reference import unverified_variables
from nnmstop.pipeline.run import TASK_INDEX, find_task
from snakemake_cli import run_snakemake

REPO = Path(__file__).resolve().parents[2]
SMALL_CONFIG = REPO / "tests" / "data" / "small_config.yaml"
PAPER_FIGURES = [name for name in TASK_INDEX["figures"] if name.startswith("paper_fig")]


@pytest.fixture(scope="module")
def figure_inputs(small_build) -> dict:
    """The datasets each paper figure of the small build reads, from the workflow (``--detailed-summary``)."""
    summary = run_snakemake(small_build, SMALL_CONFIG, "--cores", "1", "--detailed-summary").stdout
    found = {}
    for line in summary.splitlines()[1:]:
        columns = line.split("\t")
        if len(columns) > 4 and columns[0].endswith(".pdf") and columns[2] in PAPER_FIGURES:
            found[columns[2]] = (columns[0], [f for f in columns[4].split(",") if f.endswith(".nc")])
    assert sorted(found) == sorted(PAPER_FIGURES), sorted(found)
    return found


def named_inputs(rule: str, files: list[str]) -> dict:
    """The rule's named inputs (workflow/rules/figures.smk) from its input files."""
    inputs: dict = {}
    for path in sorted(files):
        if rule == "paper_fig02" and "/stages/nnm1_stage" in path:
            inputs["nnm1"] = path  # Fig 2 reads NNM1's first stage as ``nnm1``
        elif "/stages/nnm1_stage" in path:
            inputs.setdefault("nnm1_stages", []).append(path)
        elif "/bifurcated/" in path:
            inputs.setdefault("bifurcated", []).append(path)
        elif path.endswith("hbm/nnm1.nc"):
            inputs["nnm1"] = path
        elif path.endswith("hbm/nnm2.nc"):
            inputs["nnm2"] = path
        elif "/exact/" in path:
            inputs["exact"] = path
        elif path.endswith("compare/nnm1_exact_vs_regularized.nc"):
            inputs["comparison"] = path
        else:
            raise AssertionError(f"{rule}: no named input known for {path}")
    return inputs


def scrambled(ds: xr.Dataset) -> tuple[xr.Dataset, list[str]]:
    """``ds`` with every variable verify does not compare changed (each value replaced by its neighbour's, plus
    one, scaled for floats); their names."""
    names = sorted(unverified_variables(ds))
    out = ds.copy(deep=True)
    for name in names:
        values = np.roll(np.asarray(out[name].values), 1, axis=0)
        values = values * 1.5 + 1 if values.dtype.kind == "f" else values + 1
        out = out.assign_coords({name: (out[name].dims, values, out[name].attrs)}) if name in out.coords else \
            out.assign({name: (out[name].dims, values, out[name].attrs)})  # fmt: skip
    return out, names


def scrambled_copy(source: Path, target: Path) -> list[str]:
    """Copy the dataset ``source`` to ``target`` with its unverified variables scrambled; their names."""
    ds, names = scrambled(xr.load_dataset(source))
    target.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(target)
    return names


@pytest.mark.parametrize("rule", PAPER_FIGURES)
def test_a_paper_figure_draws_from_verified_variables_only(small_build, figure_inputs, tmp_path, rule):
    config = validate_config(yaml.safe_load(SMALL_CONFIG.read_text()))
    pdf, files = figure_inputs[rule]
    changed = {relative: scrambled_copy(small_build / relative, tmp_path / relative) for relative in files}
    assert any(changed.values()), "the datasets hold no variable that follows the steps: nothing was changed"
    inputs = {
        key: [str(tmp_path / p) for p in value] if isinstance(value, list) else str(tmp_path / value)
        for key, value in named_inputs(rule, files).items()
    }
    outputs = {"pdf": str(tmp_path / pdf), "png": str(tmp_path / pdf.replace(".pdf", ".png"))}
    find_task(rule)(config, inputs, outputs)
    assert (tmp_path / pdf).read_bytes() == (small_build / pdf).read_bytes(), (
        f"{rule} drew another figure with {changed} changed: it reads a variable the verifier does not compare"
    )
