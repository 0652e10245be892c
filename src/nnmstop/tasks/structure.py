"""Tasks of any structure beyond its branches: exact one-impact family, comparison, frequency-energy figures.

They read the sections a rule passes in the shape of the top-level configuration (``structure``,
``exact``, ``compare_count``, ``figures``, ``metadata``); the tube's rules pass its own section so shaped
(:func:`nnmstop.tasks.tube.tube_config`). ``structure_exact``: the exact family of orbits with one impact
per stop side per period (:mod:`nnmstop.exact.ndof`, from the grazing orbit of the first linear mode);
``structure_compare``: exact against regularized NNM1 at matched energies
(:mod:`nnmstop.compare.structure_branches`); ``structure_figure``: the figures of
:mod:`nnmstop.figures.structure`.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nnmstop.netcdf import read_dataset, write_dataset
from nnmstop.tasks.hbm import structure_from_config

__all__ = ["exact_family_dataset", "structure_exact", "structure_compare", "structure_figure", "study_figure"]


def exact_family_dataset(structure, family) -> xr.Dataset:
    """Labelled dataset of a one-stop exact family (:func:`nnmstop.exact.ndof.follow_one_stop_family`)."""
    one = {"units": "1"}
    ds = xr.Dataset(
        {
            "energy": ("orbit", family.energy, {"long_name": "total energy of the non-smooth model", **one}),
            "frequency": (
                "orbit",
                family.frequency,
                {"long_name": "frequency 1/T in Hz of the nondimensional time", "units": "Hz"},
            ),
            "contact_time": (
                "orbit",
                family.contact_time,
                {"long_name": "contact duration of the quarter period", **one},
            ),
            "x_max": ("orbit", family.x_max, {"long_name": "largest displacement at the stop over its gap", **one}),
            "initial_velocity": (
                ("orbit", "dof"),
                family.initial_velocity,
                {"long_name": "velocities at q = 0 (start of the orbit)", **one},
            ),
        },
        coords={
            "orbit": ("orbit", np.arange(len(family)), {"long_name": "index of the orbit along the family", **one}),
            "dof": ("dof", np.arange(structure.n_dofs), {"long_name": "index of the degree of freedom", **one}),
            "dof_label": (
                "dof",
                np.array(structure.dof_labels, dtype=str),
                {"long_name": "name of the degree of freedom", **one},
            ),
        },
    )
    ds.attrs = {
        **structure.attributes,
        "dofs": structure.n_dofs,
        "stops": len(structure.stops),
        "mode": 1,
        "start": family.start,
        "end_reason": family.end_reason,
    }
    return ds


def structure_exact(config, inputs, outputs, keywords: str = ""):
    """Exact NNM1 of the non-smooth structure with one impact per stop side per period."""
    from nnmstop.exact.ndof import follow_one_stop_family

    structure = structure_from_config(config)
    family = follow_one_stop_family(structure, step=config["exact"]["step"], max_points=config["exact"]["max_points"])
    write_dataset(
        exact_family_dataset(structure, family),
        outputs["dataset"],
        title=f"Exact NNM1 of the {structure.n_dofs}-DOF structure with a bilateral stop",
        summary="Exact periodic orbits of the non-smooth (piecewise-linear) structure with one impact on each side "
        "of its stop per period, from the grazing orbit of its first linear mode; closed-form phases (matrix "
        f"exponentials). The family ends because {family.end_reason}.",
        keywords=keywords,
        metadata=config.get("metadata"),
    )


def structure_compare(config, inputs, outputs, keywords: str = ""):
    """Exact against regularized NNM1 at matched energies."""
    from nnmstop.compare.structure_branches import compare_at_energies

    exact = read_dataset(inputs["exact"])
    regularized = read_dataset(inputs["nnm1"])
    ds = compare_at_energies(
        exact.energy.values,
        exact.frequency.values,
        regularized.energy.values,
        regularized.frequency.values,
        config["compare_count"],
        segment=regularized.segment.values,
    )
    ds.attrs = {**structure_from_config(config).attributes, "harmonics": regularized.attrs["harmonics"]}
    write_dataset(
        ds,
        outputs["dataset"],
        title="Exact against regularized NNM1 of the structure",
        summary="Frequencies of the exact non-smooth and the regularized NNM1 where each branch first reaches "
        "log-spaced energies of their common range.",
        keywords=keywords,
        metadata=config.get("metadata"),
    )


def structure_figure(config, inputs, outputs, figure: str):
    """``<prefix>_<figure>.{pdf,png}`` from the structure's datasets (:mod:`nnmstop.figures.structure`)."""
    from nnmstop.figures.structure import draw_structure_figure

    data = {k: read_dataset(v) for k, v in inputs.items()}
    draw_structure_figure(figure, data, config["figures"], outputs["pdf"])


def study_figure(config, inputs, outputs):
    """The tube study's figure: NNM1 backbones (physical units) over gap and stop stiffness."""
    from nnmstop.figures.structure import draw_study_figure

    cases = [read_dataset(path) for path in inputs["cases"]]
    draw_study_figure(cases, config["tube"]["figures"], outputs["pdf"])
