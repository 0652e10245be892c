"""The maps of the ``atlas:`` section of the configuration (validated by ``config_schema.yaml``).

Light on imports where the workflow plans jobs (:func:`map_names`, :func:`slice_values`, :func:`curve_kinds`);
:func:`atlas_maps` builds the :class:`~nnmstop.bifurcation_atlas.build.AtlasMap` of each map: the oscillator of
``model``, the tube of ``tube.structure`` or the configuration's own structure (``structure:``), damped and forced
as the map says or, where it does not, as the forced scene of ``forced`` says (``forced.damping``,
``forced.force.dofs``; ``forced.tube.force_dofs`` and ``forced.tube.amplitude`` for the tube).
"""

from __future__ import annotations

import numpy as np

__all__ = ["map_names", "slice_values", "curve_kinds", "map_excitation", "atlas_maps", "find_map", "STRUCTURES"]

#: Structures an atlas map can take from the configuration.
STRUCTURES = ("oscillator", "tube", "structure")


def map_names(config: dict) -> list:
    """Names of the configured maps (none without an ``atlas`` section)."""
    return list(config.get("atlas", {}).get("maps", {}))


def slice_values(spec: dict) -> list:
    """The second parameter's values of a map's slices: ``slices: {from, to, count}`` evenly spaced."""
    slices = spec["slices"]
    return [float(v) for v in np.linspace(float(slices["from"]), float(slices["to"]), int(slices["count"]))]


def curve_kinds(spec: dict) -> list:
    """The curve kinds of a map (one job each)."""
    return list(spec["kinds"])


def _structure(config: dict, name: str):
    import copy

    from nnmstop.models.structure import two_dof_structure
    from nnmstop.models.two_dof import ModelParameters

    if name == "oscillator":
        return two_dof_structure(ModelParameters.from_config(config["model"]))
    if name == "structure":  # the configuration's own structure (structure:, the paper's oscillator without it)
        from nnmstop.settings import structure_from_config

        return structure_from_config(config)
    if "tube" not in config:
        raise ValueError("an atlas map of the tube needs the `tube` section (its structure)")
    from nnmstop.models.beam import Beam, beam_structure

    return beam_structure(Beam.from_parameters(copy.deepcopy(config["tube"]["structure"])))


def map_excitation(config: dict, name: str, spec: dict):
    """The excitation of the map ``name`` (structure, damping, force DOFs and amplitude; see the module docstring)."""
    from nnmstop.forced.scenes import _damping, _dof_indices
    from nnmstop.models.excitation import Excitation, HarmonicForce

    key = f"atlas.maps.{name}"
    structure = _structure(config, spec["structure"])
    forced = config.get("forced", {})
    damping_spec = spec.get("damping", forced.get("damping"))
    if damping_spec is None:
        raise ValueError(f"{key}: give `damping` (or a `forced.damping` section)")
    if spec["structure"] in ("oscillator", "structure"):
        dofs = spec.get("force_dofs", forced.get("force", {}).get("dofs"))
        amplitude = spec.get("force", 1.0)
    else:
        dofs = spec.get("force_dofs", forced.get("tube", {}).get("force_dofs"))
        amplitude = spec.get("force", forced.get("tube", {}).get("amplitude", 1.0))
    if dofs is None:
        raise ValueError(f"{key}: give `force_dofs` (or the forced scene's force DOFs)")
    indices = _dof_indices(structure, dofs, f"{key}.force_dofs")
    return Excitation(structure, _damping(structure, damping_spec), HarmonicForce(float(amplitude), tuple(indices)))


def atlas_maps(config: dict) -> dict:
    """``name -> AtlasMap`` of every configured map (ValueError naming the offending key)."""
    from nnmstop.bifurcation_atlas.build import AtlasMap
    from nnmstop.bifurcation_atlas.curves import CurveSettings
    from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings
    from nnmstop.forced.responses import ExactSettings

    section = config["atlas"]
    out = {}
    for name, spec in section["maps"].items():
        exact = {**section["exact"], **spec.get("exact", {})}
        curve = {**section["curve"], **spec.get("curve", {})}
        regularized = spec.get("regularized")
        out[name] = AtlasMap(
            name=name,
            excitation=map_excitation(config, name, spec),
            plane=spec["plane"],
            frequency_range=tuple(float(v) for v in spec["frequency_range"]),
            second_range=tuple(float(v) for v in spec["range"]),
            slices=tuple(slice_values(spec)),
            seeds=tuple(float(v) for v in spec["seeds"]),
            checks=tuple(float(v) for v in spec["checks"]),
            kinds=tuple(curve_kinds(spec)),
            exact=ExactSettings(
                PseudoArclengthSettings(
                    tolerance=float(exact["tolerance"]),
                    initial_step=float(exact["initial_step"]),
                    max_step=max(float(exact["max_step"]), float(exact["initial_step"])),
                ),
                int(exact["frequency_samples"]),
            ),
            curve=CurveSettings(
                step=float(curve["step"]),
                tolerance=float(curve["tolerance"]),
                segment_points=int(curve["segment_points"]),
                max_points=int(curve["max_points"]),
                max_frequency_step=float(curve.get("max_frequency_step", CurveSettings.max_frequency_step)),
                max_log_second_step=float(curve.get("max_log_second_step", CurveSettings.max_log_second_step)),
            ),
            grid=int(section["frequency_samples"]),
            check_tolerance=float(section["check_tolerance"]),
            regularized=None if regularized is None else dict(regularized),
        )
    return out


def find_map(config: dict, name: str):
    maps = atlas_maps(config)
    if name not in maps:
        raise ValueError(f"no atlas map named {name!r}; the configuration has {sorted(maps)}")
    return maps[name]
