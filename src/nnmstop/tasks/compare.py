"""Tasks of ``workflow/rules/compare.smk``: read the datasets, check them against the configuration, write.

The numerics take datasets and parameters (:mod:`nnmstop.compare.matching`,
:mod:`nnmstop.compare.regimes`, :mod:`nnmstop.compare.stability`); the functions here are
the only ones of the comparison that read the configuration and files, check that the
inputs were computed with the configured model, and write the NetCDF datasets and CSV
tables (atomically: no partial file is left behind a failure).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from nnmstop.compare.dataset import comparison_dataset
from nnmstop.compare.matching import PARAMETER_KEYS
from nnmstop.compare.regimes import regime_error_dataset, regime_table
from nnmstop.compare.stability import stability_comparison_dataset, stability_table
from nnmstop.netcdf import read_dataset, write_dataset
from nnmstop.settings import compare_settings

__all__ = [
    "build_comparison_dataset",
    "build_regime_error_dataset",
    "build_stability_comparison",
    "read_exact_and_regularized",
    "write_table",
    "main",
]

logger = logging.getLogger(__name__)


def build_comparison_dataset(config: dict, inputs: dict, output_path) -> Path:
    """Task of rule ``compare_nnm1``: compare the exact family and regularized NNM1 stage 1; write NetCDF.

    Parameters
    ----------
    config : dict
        Validated configuration with the ``model`` and ``compare`` sections.
    inputs : dict
        ``exact`` (the exact family) and ``nnm1`` (regularized NNM1 stage 1) paths.
    output_path : str or Path

    Raises
    ------
    ValueError
        If a section or input is missing, or the datasets do not match the configuration.
    """
    for key in ("model", "compare"):
        if key not in config:
            raise ValueError(f"config lacks the section {key!r}")
    for key in ("exact", "nnm1"):
        if key not in inputs:
            raise ValueError(f"the comparison needs the input {key!r}, got {sorted(inputs)}")
    spec = compare_settings(config)
    exact, branch = read_dataset(inputs["exact"]), read_dataset(inputs["nnm1"])
    for key in PARAMETER_KEYS:
        ds = branch if key == "eta" else exact
        if not np.isclose(float(ds.attrs[key]), float(config["model"][key]), rtol=1e-12, atol=0):
            raise ValueError(
                f"model.{key} = {config['model'][key]!r} in the configuration but {ds.attrs[key]!r} in "
                f"{inputs['nnm1'] if ds is branch else inputs['exact']} (stale dataset?)"
            )
    if int(branch.attrs["harmonics"]) != int(config["hbm"]["harmonics"]):
        raise ValueError(
            f"hbm.harmonics = {config['hbm']['harmonics']!r} in the configuration but {branch.attrs['harmonics']!r} in "
            f"{inputs['nnm1']} (stale dataset?)"
        )
    marked = {label: spec.points[label] for label in ("a", "b")}
    ds = comparison_dataset(
        exact,
        branch,
        count=spec.energy_count,
        marked=marked,
        phase_samples=spec.phase_samples,
        end_margin=spec.end_margin,
    )
    p = ds.attrs
    summary = (
        "Exact (non-smooth) versus regularized (HBM, "
        f"H = {p['harmonics']}, eta = {p['eta']:g}) NNM1 at matched energies over the range with one impact per "
        "stop per period: frequencies and their difference, largest differences of x, u, velocities and contact "
        "force over the period on the phase t/T aligned at the maximum of x, and both orbits."
    )
    path = write_dataset(
        ds,
        output_path,
        kind="exact_vs_regularized",
        title="NNM1: exact non-smooth vs regularized orbits at matched energies",
        summary=summary,
        keywords="exact solution, regularization, comparison",
        metadata=config.get("metadata"),
    )
    for label in ("a", "b"):
        i = int(np.flatnonzero(ds["marked"].values == ("ab".index(label) + 1))[0])
        logger.info(
            "point %s) E = %.6g: frequency %.8f (exact) vs %.8f Hz (regularized), relative difference %+.3e; "
            "max |dx| = %.3e, |du| = %.3e, |df| = %.3e",
            label,
            float(ds["energy"][i]),
            float(ds["frequency_exact"][i]),
            float(ds["frequency_regularized"][i]),
            float(ds["relative_frequency_difference"][i]),
            float(ds["max_x_difference"][i]),
            float(ds["max_u_difference"][i]),
            float(ds["max_force_difference"][i]),
        )
    return path


def write_table(table: pd.DataFrame, path) -> Path:
    """Write ``table`` as CSV under a temporary name, then rename (no partial file)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    table.to_csv(tmp, float_format="%.10g", lineterminator="\n")
    os.replace(tmp, path)
    return path


def read_exact_and_regularized(config: dict, inputs: dict) -> tuple[xr.Dataset, xr.Dataset]:
    """Load the exact and regularized NNM1 of a comparison task and check them against the configuration.

    Parameters
    ----------
    config : dict
        Validated configuration; its ``model`` must match both datasets (``eta`` the regularized one).
    inputs : dict
        ``exact`` (``results/exact/nnm1.nc``) and ``nnm1`` (``results/hbm/nnm1.nc``).

    Returns
    -------
    exact, regularized : xarray.Dataset
        Both loaded into memory.

    Raises
    ------
    ValueError
        For a missing input, or a model parameter of a dataset that differs from the configuration.
    """
    for key in ("exact", "nnm1"):
        if key not in inputs:
            raise ValueError(f"missing input {key!r}; inputs are {sorted(inputs)}")
    exact, regularized = read_dataset(inputs["exact"]), read_dataset(inputs["nnm1"])
    for key in ("alpha", "beta", "delta", "eta"):
        for ds in (exact, regularized) if key != "eta" else (regularized,):
            if not np.isclose(float(ds.attrs[key]), float(config["model"][key]), rtol=1e-14, atol=0):
                raise ValueError(
                    f"{key} = {ds.attrs[key]} in the inputs differs from the configuration ({config['model'][key]}); "
                    "rebuild them"
                )
    return exact, regularized


def build_regime_error_dataset(config: dict, inputs: dict, outputs: dict) -> Path:
    """Write the regime error dataset (and its CSV table); the task of rule ``compare_regimes``.

    Parameters
    ----------
    config : dict
        Validated configuration; its ``model`` must match both inputs.
    inputs : dict
        ``exact`` (``results/exact/nnm1.nc``) and ``nnm1`` (``results/hbm/nnm1.nc``).
    outputs : dict
        ``dataset`` (NetCDF) and optionally ``table`` (CSV of the ``regime`` variables).

    Returns
    -------
    Path
        The dataset.
    """
    if "dataset" not in outputs:
        raise ValueError(f"missing output 'dataset'; outputs are {sorted(outputs)}")
    exact, regularized = read_exact_and_regularized(config, inputs)
    ds = regime_error_dataset(exact, regularized, points=True)
    ds.attrs["exact_source"] = str(inputs["exact"])
    ds.attrs["regularized_source"] = str(inputs["nnm1"])
    path = write_dataset(
        ds,
        outputs["dataset"],
        kind="regime_errors",
        title="Regularized vs exact NNM1: frequency error per impact regime, whole branch",
        summary=(
            "Frequency of the regularized NNM1 (HBM with "
            f"{ds.attrs['harmonics']} harmonics, eta = {ds.attrs['eta']:g}) against the exact NNM1 of the "
            "non-smooth system at the same energy, in each impact regime of the branch (dimension regime), "
            "with the compared orbits (dimension point)."
        ),
        keywords="regularization error, exact solution, impact regimes",
        metadata=config.get("metadata"),
    )
    if "table" in outputs:
        write_table(regime_table(ds), outputs["table"])
    logger.info(
        "wrote %s: %d regimes, %d of %d regularized orbits compared",
        path,
        ds.sizes["regime"],
        ds.attrs["matched_points"],
        ds.attrs["regularized_points"],
    )
    return path


def build_stability_comparison(config: dict, inputs: dict, outputs: dict) -> Path:
    """Write the stability comparison dataset and its CSV table; the task of rule ``compare_stability``.

    ``config`` and ``inputs`` as for :func:`build_regime_error_dataset`; ``outputs``: ``dataset``
    (NetCDF) and ``table`` (CSV).
    """
    for key in ("dataset", "table"):
        if key not in outputs:
            raise ValueError(f"missing output {key!r}; outputs are {sorted(outputs)}")
    exact, regularized = read_exact_and_regularized(config, inputs)
    ds = stability_comparison_dataset(exact, regularized)
    ds.attrs.update({key: float(config["model"][key]) for key in ("alpha", "beta", "delta", "eta")})
    path = write_dataset(
        ds,
        outputs["dataset"],
        kind="stability_comparison",
        title="Exact vs regularized NNM1: Floquet stability per impact regime",
        summary=(
            "Agreement of the stability verdicts of the exact NNM1 (non-smooth model, monodromy from the linear "
            "phases) and the regularized NNM1 (HBM) at the same energy in each impact regime, and the stability "
            "changes of both branches with the energy shift of the paired ones."
        ),
        keywords="Floquet stability, exact solution, impact regimes",
        metadata=config.get("metadata"),
    )
    write_table(stability_table(ds), outputs["table"])
    logger.info(
        "wrote %s: %d regimes, %d of %d compared orbits agree",
        path,
        ds.sizes["regime"],
        ds.attrs["agreeing_orbits"],
        ds.attrs["compared_orbits"],
    )
    return path


def main(argv=None) -> None:
    """Command line: ``python -m nnmstop.tasks.compare EXACT.nc REGULARIZED.nc`` prints the stability table."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m nnmstop.tasks.compare",
        description="Exact vs regularized NNM1: Floquet verdicts per impact regime (nnmstop.compare.stability)",
    )
    parser.add_argument("exact", help="exact branch, e.g. results/exact/nnm1.nc")
    parser.add_argument("regularized", help="regularized branch, e.g. results/hbm/nnm1.nc")
    args = parser.parse_args(argv)
    ds = stability_comparison_dataset(read_dataset(args.exact), read_dataset(args.regularized))
    with pd.option_context("display.width", 250, "display.max_columns", 40, "display.max_colwidth", 60):
        table = stability_table(ds)
        print(table.iloc[:, :12].to_string())
        print(table.iloc[:, 12:].to_string())
        print(ds[[v for v in ds.data_vars if v.startswith("change_")]].to_dataframe().to_string())
    print(f"{ds.attrs['agreeing_orbits']} of {ds.attrs['compared_orbits']} compared orbits agree")


# --------------------------------------------------------------------------- the rules' tasks


def compare_nnm1(config, inputs, outputs):
    """Exact vs regularized NNM1 at matched energies (inputs ``exact``, ``nnm1`` = stage 1)."""
    build_comparison_dataset(config, inputs, outputs["dataset"])


def compare_regimes(config, inputs, outputs):
    """Frequency error of the regularized NNM1 per impact regime, whole branch (inputs ``exact``, ``nnm1``)."""
    build_regime_error_dataset(config, inputs, outputs)


def compare_stability(config, inputs, outputs):
    """Exact vs regularized Floquet verdicts of NNM1 per impact regime (inputs ``exact``, ``nnm1``)."""
    build_stability_comparison(config, inputs, outputs)


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (compare_nnm1, compare_regimes, compare_stability)}


if __name__ == "__main__":
    main()
