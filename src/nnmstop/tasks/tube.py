"""Tasks of the finite-element tube (workflow/rules/tube.smk): the tasks of any structure, on the ``tube`` section.

The tube is a structure like any other: its stages, branches and datasets come from the HBM tasks
(:mod:`nnmstop.tasks.hbm`, which the rules call with :func:`tube_config`, the ``tube`` section shaped as
the top-level sections), its exact one-impact family, comparison and figures from the structure tasks
(:mod:`nnmstop.tasks.structure`). What is the tube's own: its keywords and its parameter study over the
gap and the stop stiffness (:func:`study_case_config`, one case per job); the tube in a circular hole at its plates
(:func:`circular_hole_config`, when ``tube.circular_hole`` is configured).
"""

from __future__ import annotations

import copy
import functools

from nnmstop.netcdf import write_dataset
from nnmstop.tasks import hbm, structure
from nnmstop.tasks.manifest import dataset_manifest

__all__ = ["KEYWORDS", "tube_config", "circular_hole_config", "in_circular_holes", "study_case_config", "TASKS"]

KEYWORDS = "finite element, Euler-Bernoulli beam, steam-generator tube, support plate"


def tube_config(config: dict) -> dict:
    """The ``tube`` section as the sections the structure and HBM tasks read (``structure``, ``hbm``, ...).

    ``tube.anm`` and ``tube.stability`` replace keys of the top-level ``anm`` and ``stability`` sections."""
    tube = config["tube"]
    return {
        "structure": {"kind": "beam", "beam": tube["structure"]},
        "hbm": tube["hbm"],
        "anm": {**config["anm"], **tube.get("anm", {})},
        "stability": {**config.get("stability", {}), **tube.get("stability", {})},
        "branches": tube["branches"],
        "exact": tube["exact"],
        "compare_count": tube["compare_count"],
        "figures": tube["figures"],
        "metadata": config.get("metadata", {}),
    }


def circular_hole_config(config: dict) -> dict:
    """:func:`tube_config` for the tube in a circular hole at each plate (``tube.circular_hole``).

    The beam bends in two planes (``planes: 2``, an isotropic section) and each stop of ``tube.structure`` becomes a
    circular clearance of the same gap (the hole's radial clearance), radial stiffness and ``eta``; the branches
    are those of ``tube.circular_hole`` (``motion: whirl`` for the whirling ones) and its ``hbm`` keys replace those
    of ``tube.hbm``. Only bilateral stops have a circular counterpart: a one-sided stop is refused by name.

    Examples
    --------
    >>> tube = {"structure": {"stops": [{"gap": 1e-4, "stiffness": 1e4, "eta": 30.0}]}, "hbm": {"harmonics": 8},
    ...         "branches": {}, "exact": {}, "compare_count": 2, "figures": {}, "study": {},
    ...         "circular_hole": {"hbm": {"harmonics": 6}, "branches": {"whirl1": {"mode": 1}}}}
    >>> case = circular_hole_config({"anm": {}, "tube": tube})
    >>> case["structure"]["beam"]["planes"], case["structure"]["beam"]["stops"][0]["kind"], case["hbm"]["harmonics"]
    (2, 'circular', 6)
    """
    hole = config["tube"].get("circular_hole")
    if hole is None:
        raise ValueError("tube.circular_hole is not configured: the tube's holes are its planar stops (tube.structure)")
    case = tube_config(config)
    return {
        **case,
        "structure": {"kind": "beam", "beam": in_circular_holes(case["structure"]["beam"], "tube")},
        "hbm": {**case["hbm"], **hole.get("hbm", {})},
        "branches": hole["branches"],
    }


def in_circular_holes(beam: dict, section: str) -> dict:
    """The beam parameters ``beam`` (of ``<section>.structure``) bending in two planes in a circular hole at each
    plate: a copy with ``planes: 2`` and each bilateral stop a circular clearance of the same gap (the hole's radial
    clearance), radial stiffness and ``eta``. Only bilateral stops have a circular counterpart: another kind is
    refused by name.

    Examples
    --------
    >>> holes = in_circular_holes({"stops": [{"gap": 1e-4, "stiffness": 1e4, "eta": 30.0}]}, "tube")
    >>> holes["planes"], holes["stops"][0]["kind"]
    (2, 'circular')
    """
    beam = copy.deepcopy(beam)
    for i, stop in enumerate(beam["stops"]):
        kind = stop.get("kind", "bilateral")
        if kind != "bilateral":
            raise ValueError(
                f"{section}.circular_hole turns each bilateral stop of {section}.structure into a circular clearance "
                f"of the same gap: {section}.structure.stops[{i}] is {kind!r}, which has no circular counterpart"
            )
        stop["kind"] = "circular"
    beam["planes"] = 2
    return beam


def study_case_config(config: dict, gap: float, factor: float) -> dict:
    """:func:`tube_config` for one case of ``tube.study``: NNM1 only, first stop's gap and stiffness replaced.

    The stiffness is ``factor x 3 EI / a**3`` (the cantilever's static stiffness at the stop, ``a`` its
    position), eta = stiffness / 300 (the paper's eta / alpha); NNM1 runs up to ``tube.study.energy_max``.
    """
    from nnmstop.models.beam import Beam

    case = tube_config(config)
    beam = copy.deepcopy(case["structure"]["beam"])
    position = Beam.from_parameters(copy.deepcopy(beam))
    a = position.node_coordinates[position.stop_nodes[0]]
    stiffness = factor * 3.0 * beam["bending_stiffness"] / a**3
    beam["stops"][0].update(gap=float(gap), stiffness=float(stiffness), eta=float(stiffness / 300.0))
    energy_max = float(config["tube"]["study"]["energy_max"])
    nnm1 = dict(case["branches"]["nnm1"], stages=[{"name": "backbone", "until": {"energy_above": energy_max}}])
    return {**case, "structure": {"kind": "beam", "beam": beam}, "branches": {"nnm1": nnm1}}


def tube_study_case(config, inputs, outputs, gap, factor):
    """NNM1 of the tube for one (gap, stop stiffness factor) of ``tube.study``."""
    case = study_case_config(config, float(gap), float(factor))
    ds = hbm.build_stage(case, "nnm1", 1)
    ds.attrs.update(study_gap_m=float(gap), study_stiffness_factor=float(factor))
    write_dataset(
        ds,
        outputs["dataset"],
        title=f"Tube NNM1, gap {gap} m, stop stiffness factor {factor}",
        summary="One case of the tube's parameter study over gap and stop stiffness.",
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
        kind="nnm_branch",
    )


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run): the tasks of any structure with
#: the tube's keywords, and its study.
TASKS = {
    "tube_stage": functools.partial(hbm.hbm_stage, keywords=KEYWORDS),
    "tube_branch": functools.partial(hbm.hbm_branch, keywords=KEYWORDS),
    "tube_exact": functools.partial(structure.structure_exact, keywords=KEYWORDS),
    "tube_compare": functools.partial(structure.structure_compare, keywords=KEYWORDS),
    "tube_figure": structure.structure_figure,
    "tube_study_case": tube_study_case,
    "tube_study": structure.study_figure,
    "tube_circular_stage": functools.partial(hbm.hbm_stage, keywords=KEYWORDS + ", circular clearance, whirl, wear"),
    "tube_circular_branch": functools.partial(hbm.hbm_branch, keywords=KEYWORDS + ", circular clearance, whirl, wear"),
    "tube_circular_figure": structure.structure_figure,
    "tube_manifest": dataset_manifest,
}
