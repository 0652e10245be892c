"""Tasks of the finite-element tube (workflow/rules/tube.smk): the tasks of any structure, on the ``tube`` section.

The tube is a structure like any other: its stages, branches and datasets come from the HBM tasks
(:mod:`nnmstop.tasks.hbm`, which the rules call with :func:`tube_config`, the ``tube`` section shaped as
the top-level sections), its exact one-impact family, comparison and figures from the structure tasks
(:mod:`nnmstop.tasks.structure`). What is the tube's own: its keywords and its parameter study over the
gap and the stop stiffness (:func:`study_case_config`, one case per job).
"""

from __future__ import annotations

import copy
import functools

from nnmstop.netcdf import write_dataset
from nnmstop.tasks import hbm, structure

__all__ = ["KEYWORDS", "tube_config", "study_case_config", "TASKS"]

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
}
