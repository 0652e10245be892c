"""Tasks of the exact orbits: read the configuration and files, compute, write the datasets.

``exact_two_impacts`` (:func:`build_two_impact_dataset`, ``results/exact/nnm1_two_impacts.nc``)
and ``exact_nnm1`` (:func:`build_multi_impact_dataset`, ``results/exact/nnm1.nc``), called
through :mod:`nnmstop.pipeline.run`. The numerics live in :mod:`nnmstop.exact`.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop.exact.dataset import exact_branch_dataset, two_impact_dataset, two_impact_unknowns
from nnmstop.exact.family import FamilySettings, follow_branch, follow_two_impact_family
from nnmstop.models.two_dof import ModelParameters
from nnmstop.netcdf import write_dataset

__all__ = ["build_two_impact_dataset", "build_multi_impact_dataset"]

logger = logging.getLogger(__name__)


def build_two_impact_dataset(config: dict, output_path: str | Path) -> Path:
    """Compute the exact two-impact NNM1 family and write it to NetCDF.

    Called by the Snakemake rule ``exact_two_impacts``.

    Parameters
    ----------
    config : dict
        With the ``model`` (alpha, beta, delta, eta) and ``exact`` (step, max_points)
        sections of ``config/config.yaml``.
    output_path : str or Path
        NetCDF file to write (atomically, through :func:`nnmstop.netcdf.write_dataset`).

    Returns
    -------
    Path
        The written file.
    """
    for key in ("model", "exact"):
        if key not in config:
            raise ValueError(f"config lacks the section {key!r}")
    params = ModelParameters.from_config(config["model"])
    exact = config["exact"]
    family = follow_two_impact_family(params, step=float(exact["step"]), max_points=int(exact["max_points"]))
    ds = two_impact_dataset(family)
    summary = (
        "Exact periodic orbits of the non-smooth 2-DOF oscillator with a bilateral elastic stop "
        "(Eqs. 3-4), one impact on each stop per period, built in closed form from the quarter "
        "period (Section 3.1) and followed by pseudo-arclength continuation from the grazing "
        f"orbit. The family ends because {family.end_reason}."
    )
    path = write_dataset(
        ds,
        output_path,
        kind="two_impact_family",
        title="NNM1 of the non-smooth system: two impacts per period (exact)",
        summary=summary,
        keywords="exact solution, piecewise linear",
        metadata=config.get("metadata"),
    )
    logger.info("wrote %s (%d orbits)", path, len(family))
    return path


def build_multi_impact_dataset(config: dict, two_impact_path: str | Path, output_path: str | Path) -> Path:
    """Continue the exact NNM1 past the two-impact family and write the whole branch.

    Called by the Snakemake rule ``exact_nnm1``. Reads the two-impact family (rule
    ``exact_two_impacts``), continues from its last orbit through every grazing
    transition (:func:`nnmstop.exact.family.follow_branch`) and writes the two-impact points unchanged
    followed by the continuation.

    The dataset records the segments and why each one ends in its ``segment_*`` attributes.

    Parameters
    ----------
    config : dict
        With the ``model`` and ``exact_multi`` sections.
    two_impact_path : str or Path
        NetCDF of the two-impact family.
    output_path : str or Path
        NetCDF file to write (atomically).

    Returns
    -------
    Path
    """
    for key in ("model", "exact_multi"):
        if key not in config:
            raise ValueError(f"config lacks the section {key!r}")
    params = ModelParameters.from_config(config["model"])
    settings = FamilySettings.from_config(config["exact_multi"])
    with xr.open_dataset(two_impact_path) as ds:
        two = ds.load()
    for name in ("alpha", "beta", "delta"):
        if not np.isclose(float(two.attrs[name]), getattr(params, name), rtol=1e-14, atol=0):
            raise ValueError(
                f"{two_impact_path}: {name} = {two.attrs[name]} differs from the configuration "
                f"({getattr(params, name)}); "
                "rebuild the two-impact dataset"
            )
    if two.attrs.get("end_margin") != "opposite_stop":
        logger.warning("the two-impact family ends on %r, not on the opposite stop", two.attrs.get("end_margin"))
    y = two_impact_unknowns(two)
    if len(y) < 2:
        raise ValueError(f"{two_impact_path} holds fewer than two orbits")
    segments = follow_branch(params, "FR", y[-1], y[-1] - y[-2], settings)
    ds = exact_branch_dataset(two, segments, params)
    summary = (
        "Exact NNM1 of the non-smooth 2-DOF oscillator with a bilateral elastic stop (Eqs. 3-4) with any number "
        "of impacts per period: symmetric orbits built in closed form from the quarter period as sequences of "
        "linear phases (free flight, contact with either stop) whose switching times are exact event times, "
        "followed by pseudo-arclength continuation through the grazing transitions where impacts appear or "
        f"disappear. The first {two.sizes['point']} points are results/exact/nnm1_two_impacts.nc unchanged. "
        f"The branch ends: {ds.attrs['end_reason']}."
    )
    path = write_dataset(
        ds,
        output_path,
        kind="exact_nnm1",
        title="NNM1 of the non-smooth system: all impact regimes (exact)",
        summary=summary,
        keywords="exact solution, piecewise linear, grazing bifurcation",
        metadata=config.get("metadata"),
    )
    logger.info("wrote %s (%d orbits, %d segments)", path, ds.sizes["point"], ds.attrs["segments"])
    return path


# --------------------------------------------------------------------------- the rules' tasks


def exact_two_impacts(config, inputs, outputs):
    """Exact two-impact NNM1 family of the non-smooth system (Section 3.1)."""
    build_two_impact_dataset(config, outputs["dataset"])


def exact_nnm1(config, inputs, outputs):
    """Exact NNM1 with any number of impacts per period, continued from the two-impact family."""
    build_multi_impact_dataset(config, inputs["two_impacts"], outputs["dataset"])


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (exact_two_impacts, exact_nnm1)}
