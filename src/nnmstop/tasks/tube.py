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

from nnmstop.netcdf import read_dataset, write_dataset
from nnmstop.tasks import hbm, structure

__all__ = ["KEYWORDS", "tube_config", "study_case_config", "plates_config", "plates_forced_dataset", "TASKS"]

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


PLATES_KEYWORDS = KEYWORDS + ", support plates, Craig-Bampton reduction, component-mode synthesis"


def plates_config(config: dict) -> dict:
    """The ``tube_plates`` section as the sections the structure and HBM tasks read: the beam with its
    ``reduction`` (:func:`nnmstop.settings.structure_from_config` reduces it onto the plates' DOFs)."""
    plates = config["tube_plates"]
    return {
        "structure": {"kind": "beam", "beam": plates["structure"], "reduction": plates["reduction"]},
        "hbm": plates["hbm"],
        "anm": {**config["anm"], **plates.get("anm", {})},
        "stability": {**config.get("stability", {}), **plates.get("stability", {})},
        "branches": plates["branches"],
        "figures": plates["figures"],
        "forced": plates.get("forced", {}),
        "metadata": config.get("metadata", {}),
    }


def plates_forced_dataset(config: dict):
    """The forced response of the reduced tube on plates (``tube_plates.forced``) and its scene.

    ``config`` is shaped by :func:`plates_config`. The forced DOFs join the reduction's boundary (they stay
    physical DOFs of the reduced structure); Rayleigh damping on the reduced matrices is the full model's
    ``a M + b K`` projected exactly (``T^T (a M + b K) T``), its coefficients from the reduced modes' ratios.
    """
    from nnmstop.forced.scenes import Scene, _damping, _dof_indices, _frequency_range, scene_name
    from nnmstop.models.beam import Beam, beam_structure
    from nnmstop.models.excitation import Excitation, HarmonicForce
    from nnmstop.models.reduction import reduce_structure
    from nnmstop.tasks.forced import regularized_response_dataset

    spec = config["forced"]
    full = beam_structure(Beam.from_parameters(copy.deepcopy(config["structure"]["beam"])))
    dofs = _dof_indices(full, spec["force_dofs"], "tube_plates.forced.force_dofs")
    reduction = dict(config["structure"]["reduction"])
    reduction["boundary_dofs"] = [*reduction.get("boundary_dofs", []), *dofs]
    structure = reduce_structure(full, reduction, "tube_plates.reduction")
    reduced_dofs = _dof_indices(structure, [full.dof_labels[d] for d in dofs], "tube_plates.forced.force_dofs")
    excitation = Excitation(
        structure, _damping(structure, spec["damping"]), HarmonicForce(float(spec["amplitude"]), tuple(reduced_dofs))
    )
    scene = Scene(
        scene_name(spec["amplitude"], "tube_plates_"),
        excitation,
        _frequency_range(spec["frequency_range"], "tube_plates.forced.frequency_range"),
        int(spec["harmonics"]),
        int(spec.get("points_per_step", 1)),
        dict(spec["stability"]),
    )
    forced_config = {"anm": config["anm"], "forced": {"max_truncation": spec["max_truncation"]}}
    ds = regularized_response_dataset(forced_config, scene)
    ds.attrs.update(structure.reduction.attributes())
    return ds, scene


def tube_plates_forced(config, inputs, outputs):
    """Forced response of the reduced tube on plates (regularized, harmonic balance + ANM, with stability)."""
    from nnmstop.tasks.forced import _write

    ds, scene = plates_forced_dataset(config)
    _write(ds, outputs["dataset"], scene, "regularized", config)


def tube_plates_forced_figure(config, inputs, outputs):
    """paper_figures/tube_plates_forced.{pdf,png}: the forced response of the reduced tube on plates."""
    from nnmstop.figures import forced as draw

    draw.tube_figure([read_dataset(inputs["dataset"])], outputs["pdf"], int(config["figures"]["png_dpi"]))


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
    "tube_plates_stage": functools.partial(hbm.hbm_stage, keywords=PLATES_KEYWORDS),
    "tube_plates_branch": functools.partial(hbm.hbm_branch, keywords=PLATES_KEYWORDS),
    "tube_plates_figure": structure.structure_figure,
    "tube_plates_forced": tube_plates_forced,
    "tube_plates_forced_figure": tube_plates_forced_figure,
}
