"""Tasks of the tube on several support plates (workflow/rules/tube_plates.smk), reduced onto the plates' DOFs.

The ``tube_plates`` section is shaped as the top-level sections (:func:`plates_config`): a beam with a
``reduction`` that :func:`nnmstop.settings.structure_from_config` applies (Craig-Bampton onto the DOFs the stops
read, :mod:`nnmstop.models.reduction`), so its stages, branches and figures are the HBM and structure tasks of
any structure. What is its own: the forced response of the reduced tube (:func:`plates_forced_dataset`, the
forced DOFs joining the reduction's boundary) and its figure.
"""

from __future__ import annotations

import copy
import functools

from nnmstop.netcdf import read_dataset
from nnmstop.tasks import hbm, structure
from nnmstop.tasks.manifest import dataset_manifest
from nnmstop.tasks.tube import KEYWORDS

__all__ = ["PLATES_KEYWORDS", "plates_config", "plates_circular_config", "plates_forced_dataset", "TASKS"]

PLATES_KEYWORDS = KEYWORDS + ", support plates, Craig-Bampton reduction, component-mode synthesis"
CIRCULAR_WORDS = ", circular clearance, whirl, wear"


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


#: Keys of ``tube_plates.circular_hole`` (``branches`` required) and of its ``structure`` (what a modest mesh changes).
CIRCULAR_KEYS = ("structure", "reduction", "hbm", "anm", "branches", "figures")
CIRCULAR_STRUCTURE_KEYS = ("n_elements",)


def plates_circular_config(config: dict) -> dict:
    """:func:`plates_config` for the tube on plates in a circular hole at each plate (``tube_plates.circular_hole``).

    The beam bends in two planes and each plate's bilateral stop becomes a circular clearance of the same radial gap,
    stiffness and ``eta`` (:func:`nnmstop.tasks.tube.in_circular_holes`); Craig-Bampton reduces it onto both
    transverse DOFs of each plate and ``reduction.modes`` fixed-interface modes, which come in pairs turned by the
    rotations about the tube's axis (an even count: twice the one-plane tube's for the same basis in each plane). The
    section's ``structure`` (``n_elements``), ``reduction``, ``hbm``, ``anm`` and ``figures`` keys replace those of
    ``tube_plates``; its branches are planar (``nnm<k>``) or whirling (``whirl<k>``, ``motion: whirl``).

    Examples
    --------
    >>> plates = {"structure": {"n_elements": 40, "stops": [{"position": 0.5, "gap": 1e-4, "stiffness": 1e4,
    ...           "eta": 30.0}]}, "reduction": {"modes": 8}, "hbm": {"harmonics": 30}, "branches": {}, "figures": {},
    ...           "circular_hole": {"structure": {"n_elements": 12}, "reduction": {"modes": 6},
    ...                             "hbm": {"harmonics": 10}, "branches": {"whirl1": {"mode": 1, "motion": "whirl"}}}}
    >>> case = plates_circular_config({"anm": {}, "tube_plates": plates})
    >>> beam = case["structure"]["beam"]
    >>> beam["planes"], beam["n_elements"], beam["stops"][0]["kind"], case["hbm"]["harmonics"]
    (2, 12, 'circular', 10)
    >>> case["structure"]["reduction"]
    {'modes': 6}
    """
    from nnmstop.tasks.tube import in_circular_holes

    hole = config["tube_plates"].get("circular_hole")
    if hole is None:
        raise ValueError(
            "tube_plates.circular_hole is not configured: the plates are the bilateral stops of tube_plates"
        )
    for where, keys, allowed in (
        ("tube_plates.circular_hole", hole, CIRCULAR_KEYS),
        ("tube_plates.circular_hole.structure", hole.get("structure", {}), CIRCULAR_STRUCTURE_KEYS),
    ):
        unknown = sorted(set(keys) - set(allowed))
        if unknown:
            raise ValueError(f"{where}: unknown keys {unknown}; allowed: {list(allowed)}")
    if "branches" not in hole:
        raise ValueError("tube_plates.circular_hole: 'branches' is required (planar nnm<k> and whirling whirl<k>)")
    case = plates_config(config)
    beam = {**case["structure"]["beam"], **hole.get("structure", {})}
    reduction = {**case["structure"]["reduction"], **hole.get("reduction", {})}
    return {
        **case,
        "structure": {"kind": "beam", "beam": in_circular_holes(beam, "tube_plates"), "reduction": reduction},
        "hbm": {**case["hbm"], **hole.get("hbm", {})},
        "anm": {**case["anm"], **hole.get("anm", {})},
        "branches": hole["branches"],
        "figures": {**case["figures"], **hole.get("figures", {})},
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


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {
    "tube_plates_stage": functools.partial(hbm.hbm_stage, keywords=PLATES_KEYWORDS),
    "tube_plates_branch": functools.partial(hbm.hbm_branch, keywords=PLATES_KEYWORDS),
    "tube_plates_figure": structure.structure_figure,
    "tube_plates_forced": tube_plates_forced,
    "tube_plates_forced_figure": tube_plates_forced_figure,
    "tube_plates_circular_stage": functools.partial(hbm.hbm_stage, keywords=PLATES_KEYWORDS + CIRCULAR_WORDS),
    "tube_plates_circular_branch": functools.partial(hbm.hbm_branch, keywords=PLATES_KEYWORDS + CIRCULAR_WORDS),
    "tube_plates_circular_figure": structure.structure_figure,
    "tube_plates_manifest": dataset_manifest,
}
