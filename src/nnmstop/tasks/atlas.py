"""Tasks of the bifurcation atlas (workflow/rules/atlas.smk): configuration in, datasets and figures out.

Each slice of a map and each kind of curve is its own job, so that a cluster spreads them
(``snakemake --profile profiles/slurm atlas``):

* :func:`atlas_slice`: the exact one-parameter response at one value of the map's second parameter (the
  regularized one for a stop that is not piecewise linear), classified into regions
  (:func:`nnmstop.bifurcation_atlas.build.slice_dataset`);
* :func:`atlas_curves`: every curve of one kind through the points the seed slices locate, checked against the
  check slices (:func:`nnmstop.bifurcation_atlas.build.curves_dataset`; the regularized kinds on harmonic-balance
  responses
  computed in the job, :mod:`nnmstop.bifurcation_atlas.regularized`);
* :func:`atlas_map`: the slices and the curves in one atlas dataset;
* :func:`atlas_backbone`: the NNM backbones and the peaks they predict (``results/atlas/<map>_backbone.nc``);
* :func:`atlas_figure`: ``paper_figures/atlas_<map>.{pdf,png}``;
* :func:`atlas_docs`: ``docs/atlas_numbers.md`` and the map figures of the atlas page;
* :func:`atlas_manifest`: ``results/atlas/MANIFEST.sha256`` (verify and update_reference cover the atlas).

The numerics live in :mod:`nnmstop.bifurcation_atlas`; method note docs/methods/atlas.md, user page docs/atlas.md.
"""

from __future__ import annotations

import logging

import numpy as np

from nnmstop.netcdf import read_dataset, write_dataset

__all__ = [
    "atlas_slice",
    "atlas_curves",
    "atlas_map",
    "atlas_figure",
    "atlas_manifest",
    "atlas_backbone",
    "backbone_dataset_of",
    "TASKS",
]

logger = logging.getLogger("nnmstop.tasks.atlas")

KEYWORDS = "bifurcation atlas, two-parameter continuation, fold, Neimark-Sacker, grazing, non-smooth, forced response"


def _paths(value) -> list:
    return list(value) if isinstance(value, (list, tuple)) else [value]


def atlas_slice(config, inputs, outputs, map: str, index: str):
    """One slice of the map ``map`` (wildcards ``map``, ``index``)."""
    from nnmstop.bifurcation_atlas.build import slice_dataset
    from nnmstop.bifurcation_atlas.maps import find_map

    atlas = find_map(config, map)
    k = int(index)
    if not 0 <= k < len(atlas.slices):
        raise ValueError(f"atlas map {map!r} has {len(atlas.slices)} slices (0..{len(atlas.slices) - 1}), not {k}")
    ds = slice_dataset(atlas, k, _anm(config))
    write_dataset(
        ds,
        outputs["dataset"],
        title=f"Atlas {map}: slice {k} ({atlas.plane} = {atlas.slices[k]:g})",
        summary=(
            f"The exact periodic responses of the forced structure at {atlas.plane} = {atlas.slices[k]:g} over "
            f"{atlas.frequency_range[0]:g}..{atlas.frequency_range[1]:g} Hz, classified into the atlas' regions on a "
            "frequency grid, with the located stability changes and the ends of the one-contact families."
            if atlas.exact_responses
            else f"The regularized (harmonic-balance) periodic response of the forced structure at {atlas.plane} = "
            f"{atlas.slices[k]:g} over {atlas.frequency_range[0]:g}..{atlas.frequency_range[1]:g} Hz (its stop is "
            "not piecewise linear), classified into the atlas' regions on a frequency grid, with the located "
            "stability changes."
        ),
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
        kind="atlas_slice",
    )


def atlas_curves(config, inputs, outputs, map: str, kind: str):
    """The curves of kind ``kind`` of the map ``map``: seeded on the seed slices, checked on the check slices."""
    from nnmstop.bifurcation_atlas.build import REGULARIZED_KINDS, curves_dataset
    from nnmstop.bifurcation_atlas.maps import find_map

    atlas = find_map(config, map)
    if kind not in atlas.kinds:
        raise ValueError(f"atlas map {map!r} has no curve kind {kind!r} (its kinds: {list(atlas.kinds)})")
    regularized = None
    seeds, checks = [], []
    if kind in REGULARIZED_KINDS:
        regularized = _regularized_inputs(config, atlas, kind)
    else:
        seeds = [read_dataset(path) for path in _paths(inputs["seeds"])]
        checks = [read_dataset(path) for path in _paths(inputs["checks"])] if "checks" in inputs else []
    ds = curves_dataset(atlas, kind, seeds, checks, regularized)
    write_dataset(
        ds,
        outputs["dataset"],
        title=f"Atlas {map}: {kind} curves",
        summary=(
            f"Curves of {kind.replace('_', ' ')} points of the periodic responses followed in frequency and "
            f"{atlas.plane} (minimally augmented systems on the continuation driver), their codimension-two points "
            "and their checks against one-parameter responses."
        ),
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
        kind="atlas_curves",
    )


def _regularized_inputs(config, atlas, kind):
    """The harmonic-balance equations, seeds and checked points of a regularized kind (computed here)."""
    from nnmstop.bifurcation_atlas.regularized import regularized_inputs

    return regularized_inputs(atlas, kind, _anm(config))


def _anm(config):
    """The ANM settings of the regularized responses (slices of a circular clearance, regularized curves)."""
    from nnmstop.continuation.anm import ANMSettings

    return ANMSettings.from_config(config["anm"], points_per_step=2)


def backbone_dataset_of(config, atlas):
    """The NNM backbones of the map's structure and the peaks they predict (the layout of ``forced/backbone.nc``,
    :func:`nnmstop.forced.dataset.backbone_dataset`): the regularized NNMs
    (:func:`nnmstop.forced.backbone.nnm_backbone`) with, at each orbit, the force whose resonance peak it is
    (:func:`nnmstop.forced.backbone.required_force`), up to 1.5 times the largest force of the map. Predicted
    peaks at the map's check values (force plane) or at its force (gap plane). On the gap plane the law
    ``g f(q / g)`` makes the equations homogeneous in
    ``(q, g, F)``: the backbone orbit at the gap ``g0`` whose required force is ``F_r`` is the peak at the gap
    ``g0 F / F_r`` of the map's force ``F`` (the figure draws it so)."""
    from nnmstop.bifurcation_atlas.maps import map_excitation
    from nnmstop.continuation.anm import ANMSettings
    from nnmstop.forced.backbone import nnm_backbone, predicted_peaks, required_force
    from nnmstop.forced.dataset import backbone_dataset, base_attributes
    from nnmstop.hbm.forced import response_amplitudes

    spec = config["atlas"]["maps"][atlas.name]["backbone"]
    excitation = map_excitation(config, atlas.name, config["atlas"]["maps"][atlas.name])
    anm = ANMSettings.from_config(config["anm"], points_per_step=2)
    gap = float(excitation.structure.stops[0].gap)
    if atlas.plane == "force":
        limit, forces = 1.5 * atlas.second_range[1], list(atlas.checks)
    else:
        limit, forces = 1.5 * excitation.force.amplitude * gap / atlas.second_range[0], [excitation.force.amplitude]
    backbones, predictions = {}, {}
    for mode in spec.get("modes", [1, 2]):
        system, branch = nnm_backbone(
            excitation,
            int(mode),
            int(spec["harmonics"]),
            anm,
            float(spec["max_truncation"]),
            force_limit=limit,
            start_tolerance=float(spec.get("start_tolerance", 1e-13)),
        )
        U = np.asarray(branch.points)
        required = np.array([required_force(system, excitation, u) for u in U])
        backbones[int(mode)] = (system.frequency_hz(U), response_amplitudes(system, U), required)
        predictions[int(mode)] = predicted_peaks(system, excitation, branch, anm, forces)
    ds = backbone_dataset(excitation, backbones, forces, predictions)
    ds.attrs.update(base_attributes(excitation, "regularized", atlas.frequency_range))
    ds.attrs.update(harmonics=int(spec["harmonics"]), newton_threshold=anm.newton_threshold, atlas_map=atlas.name)
    return ds


def atlas_backbone(config, inputs, outputs, map: str):
    """The backbones of the map ``map`` and their predicted peaks (:func:`backbone_dataset_of`)."""
    from nnmstop.bifurcation_atlas.maps import find_map

    atlas = find_map(config, map)
    write_dataset(
        backbone_dataset_of(config, atlas),
        outputs["dataset"],
        title=f"Atlas {map}: NNM backbones and predicted resonance peaks",
        summary=(
            "Backbones of the regularized structure by harmonic balance + ANM, with the force amplitude whose "
            "resonance peak each NNM orbit is (damping work over the orbit = work of the force in quadrature)."
        ),
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
        kind="forced_backbone",
    )


def atlas_map(config, inputs, outputs, map: str):
    """The atlas dataset of the map ``map`` from its slices and curves."""
    from nnmstop.bifurcation_atlas.build import atlas_dataset
    from nnmstop.bifurcation_atlas.maps import find_map

    atlas = find_map(config, map)
    slices = [read_dataset(path) for path in _paths(inputs["slices"])]
    curves = [read_dataset(path) for path in _paths(inputs["curves"])]
    ds = atlas_dataset(atlas, slices, curves)
    write_dataset(
        ds,
        outputs["dataset"],
        title=f"Bifurcation atlas {map}",
        summary=(
            f"Map of the forced structure over the frequency and the {atlas.plane}: regions (no contact, impacting, "
            "coexisting responses, no stable periodic response, not covered) read from the exact one-parameter "
            "responses, the curves of grazing, folds, Neimark-Sacker points, flips and second contacts followed in "
            "two parameters (exact and regularized), their codimension-two points and checks, and the backbone's "
            "prediction of the resonance peak."
        ),
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
        kind="atlas",
    )


def atlas_figure(config, inputs, outputs, map: str):
    """``paper_figures/atlas_<map>.{pdf,png}`` from the atlas dataset (and its backbones, where it has them)."""
    from nnmstop.figures.atlas import atlas_figure as draw

    dpi = int(config["atlas"].get("png_dpi", 150))
    backbone = read_dataset(inputs["backbone"]) if "backbone" in inputs else None
    draw(read_dataset(inputs["atlas"]), outputs["pdf"], dpi, backbone=backbone)


def atlas_docs(config, inputs, outputs):
    """``docs/atlas_numbers.md`` from the atlas datasets (:mod:`nnmstop.docpages.atlas`), and the map figures
    copied into ``docs/`` (``docs/atlas_<map>.png``) for the atlas page."""
    import shutil
    from pathlib import Path

    from nnmstop.docpages.atlas import write_page

    write_page(_paths(inputs["atlas"]), outputs["numbers"])
    for figure in _paths(inputs["figures"]):
        target = Path(outputs["numbers"]).parent / Path(figure).name
        shutil.copyfile(figure, target)


def atlas_manifest(config, inputs, outputs):
    """SHA-256 manifest of the atlas datasets (:func:`nnmstop.tasks.manifest.dataset_manifest`)."""
    from nnmstop.tasks.manifest import dataset_manifest

    dataset_manifest(config, inputs, outputs)


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {
    f.__name__: f
    for f in (atlas_slice, atlas_curves, atlas_map, atlas_backbone, atlas_figure, atlas_docs, atlas_manifest)
}
