"""The forced scenes of the configuration: an excitation (structure, damping, force) and a frequency range each.

The structure is the configuration's own (``structure``: the paper's oscillator of ``model``, a beam, or matrices
from files; :func:`nnmstop.settings.structure_from_config`), forced on the degrees of freedom of ``forced.force``
(by their labels); the tube of ``tube`` has a scene of its own (``forced.tube``). The configuration's validation
builds the scenes to name bad values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnmstop.models.excitation import Damping, Excitation, HarmonicForce, linear_response
from nnmstop.models.structure import Structure

__all__ = [
    "Scene",
    "WHICH",
    "scene_name",
    "forced_scenes",
    "exact_response_gap",
    "find_scene",
    "prediction_excitations",
    "check_forced_section",
]


@dataclass(frozen=True)
class Scene:
    """One forced response to compute: its name (file stem), excitation, frequency range (Hz), ``H``, the points
    stored per ANM step and the settings of its Floquet multipliers (``steps``, ``max_steps``, ``tolerance``)."""

    name: str
    excitation: Excitation
    frequency_range: tuple
    harmonics: int
    points_per_step: int
    stability: dict


def scene_name(amplitude: float, prefix: str = "") -> str:
    """File stem of the response at force amplitude ``amplitude``: ``F0.05``, ``tube_F0.5``."""
    return f"{prefix}F{float(amplitude):g}".replace("e+", "e")


def _dof_indices(structure: Structure, dofs, key: str) -> list:
    """DOF indices from labels (or indices); an unknown label or an index off the model is named."""
    labels = list(structure.dof_labels or [])
    out = []
    for dof in dofs:
        if isinstance(dof, str):
            if dof not in labels:
                shown = labels if len(labels) <= 12 else labels[:6] + ["..."] + labels[-6:]
                raise ValueError(f"{key}: force dof {dof!r} is not a degree of freedom of the model ({shown})")
            out.append(labels.index(dof))
        elif not 0 <= int(dof) < structure.n_dofs:
            raise ValueError(f"{key}: force dof {dof} is off the model (0..{structure.n_dofs - 1})")
        else:
            out.append(int(dof))
    return out


def _damping(structure: Structure, spec: dict) -> Damping:
    if "ratios" in spec:
        return Damping.from_modal_ratios(structure, spec["ratios"], spec["modes"])
    return Damping(float(spec["mass_coefficient"]), float(spec["stiffness_coefficient"]))


def _frequency_range(spec, key: str) -> tuple:
    low, high = (float(v) for v in spec)
    if not low < high:
        raise ValueError(
            f"{key}: the frequency range [{low:g}, {high:g}] Hz is empty (its low end must be below its high end)"
        )
    return low, high


#: Which scenes :func:`forced_scenes` returns.
WHICH = ("structure", "tube", "all")


def _structure(config: dict) -> Structure:
    """The configuration's structure (its ``structure`` section; the paper's oscillator of ``model`` without it)."""
    from nnmstop.settings import structure_from_config

    return structure_from_config(config)


def forced_scenes(config: dict, which: str = "all") -> list:
    """The scenes of the ``forced`` section: one per force amplitude on the configuration's structure
    (``structure``, :func:`_structure`), and with ``forced.tube`` (and ``tube``) one for the tube. ``which``:
    "structure", "tube" or "all"."""
    if which not in WHICH:
        raise ValueError(f"which must be one of {WHICH}, got {which!r}")
    forced = config["forced"]
    scenes = []
    if which in ("structure", "all"):
        structure = _structure(config)
        damping = _damping(structure, forced["damping"])
        dofs = _dof_indices(structure, forced["force"]["dofs"], "forced.force.dofs")
        frequency_range = _frequency_range(forced["frequency_range"], "forced.frequency_range")
        for amplitude in forced["force"]["amplitudes"]:
            excitation = Excitation(structure, damping, HarmonicForce(float(amplitude), tuple(dofs)))
            scenes.append(
                Scene(
                    scene_name(amplitude),
                    excitation,
                    frequency_range,
                    int(forced["harmonics"]),
                    int(forced["points_per_step"]),
                    dict(forced["stability"]),
                )
            )
    if which in ("tube", "all") and "tube" in forced and "tube" in config:
        scenes.append(_tube_scene(config))
    names = [scene.name for scene in scenes]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        amplitudes = [a for a in forced["force"]["amplitudes"] if scene_name(a) in repeated]
        raise ValueError(
            f"forced.force.amplitudes: {amplitudes} give the same scene name {repeated[0]!r} (file names keep 6 "
            "significant digits): one response would overwrite the other; give amplitudes that differ within "
            "6 significant digits"
        )
    return scenes


def _tube_scene(config: dict) -> Scene:
    import copy

    from nnmstop.models.beam import Beam, beam_structure

    spec = config["forced"]["tube"]
    structure = beam_structure(Beam.from_parameters(copy.deepcopy(config["tube"]["structure"])))
    dofs = _dof_indices(structure, spec["force_dofs"], "forced.tube.force_dofs")
    damping = _damping(structure, config["forced"]["damping"])
    excitation = Excitation(structure, damping, HarmonicForce(float(spec["amplitude"]), tuple(dofs)))
    frequency_range = _frequency_range(spec["frequency_range"], "forced.tube.frequency_range")
    forced = config["forced"]
    return Scene(
        scene_name(spec["amplitude"], "tube_"),
        excitation,
        frequency_range,
        int(spec["harmonics"]),
        int(spec.get("points_per_step", forced["points_per_step"])),
        dict(spec.get("stability", forced["stability"])),
    )


def prediction_excitations(config: dict) -> tuple:
    """The excitations of ``forced.prediction`` (the configuration's structure, damping ratio ``r`` on the damped
    modes of ``forced.damping``, ``F = force_per_ratio r`` on the forced DOFs) and its frequency window (Hz)."""
    forced, spec = config["forced"], config["forced"]["prediction"]
    structure = _structure(config)
    dofs = tuple(_dof_indices(structure, forced["force"]["dofs"], "forced.force.dofs"))
    modes = forced["damping"].get("modes", [1, 2])
    excitations = []
    for ratio in spec["ratios"]:
        damping = Damping.from_modal_ratios(structure, [float(ratio)] * len(modes), modes)
        excitations.append(Excitation(structure, damping, HarmonicForce(float(spec["force_per_ratio"]) * ratio, dofs)))
    return excitations, _frequency_range(spec["frequency_window"], "forced.prediction.frequency_window")


#: Frequencies per scene at which the linear response is compared with the gap (validation only).
_GRID = 2049


def check_forced_section(config: dict) -> None:
    """What the schema cannot say of the ``forced`` section, each refused naming its key.

    The scenes build (:func:`forced_scenes`: ranges increasing, DOFs on the model, distinct scene names);
    ``forced.tube`` needs the ``tube`` section (the tube's structure); every ``forced.figures.orbit_frequencies``
    lies inside ``forced.frequency_range``; and at every force level the linear response of the stop DOF
    stays inside the gap somewhere in the range (else the exact response has no non-impacting piece and no
    grazing to start its contact families from).

    Raises
    ------
    ValueError
        Naming the key and what is allowed.
    """
    forced = config["forced"]
    if "tube" in forced and "tube" not in config:
        raise ValueError(
            "forced.tube: the tube's forced response needs the 'tube' section (its structure); add it, or remove "
            "forced.tube"
        )
    scenes = forced_scenes(config)
    low, high = _frequency_range(forced["frequency_range"], "forced.frequency_range")
    outside = [f for f in forced.get("figures", {}).get("orbit_frequencies", []) if not low < float(f) < high]
    if outside:
        raise ValueError(
            f"forced.figures.orbit_frequencies: {outside} Hz lie outside forced.frequency_range [{low:g}, {high:g}] "
            "Hz: no response is computed there, so their panels would be empty"
        )
    for scene in scenes:
        if exact_response_gap(scene):  # no exact response to start
            continue
        stop = scene.excitation.structure.stops[0]
        omega = 2 * np.pi * np.linspace(*scene.frequency_range, _GRID)
        coordinate = stop.coordinate_matrix(scene.excitation.structure.n_dofs)[0]  # the stop's first coordinate
        amplitude = np.abs(linear_response(scene.excitation, omega) @ coordinate)
        if amplitude.min() > stop.gap:
            raise ValueError(
                f"forced.force.amplitudes: at F = {scene.excitation.force.amplitude:g} the linear response reaches "
                f"the stop over the whole range {scene.frequency_range[0]:g}..{scene.frequency_range[1]:g} Hz "
                f"(max |x| >= {amplitude.min():.3g} > gap {stop.gap:g}): the exact response has no non-impacting "
                "piece and no grazing to start from; lower the force or widen forced.frequency_range"
            )


def exact_response_gap(scene: Scene) -> str:
    """Why the exact (non-smooth) response of ``scene`` is not computed, or "" where it is: a stop whose law is
    not piecewise linear (a circular clearance: the regularized path only), or the tube's scene (regularized only:
    each exact orbit's lags and multipliers are costly on a fine mesh)."""
    if scene.name.startswith("tube_"):
        return "the tube's forced response is regularized only"
    for stop in scene.excitation.structure.stops:
        try:
            stop.contacts()
        except ValueError as err:
            return f"{err} (regularized responses only)"
    return ""


def find_scene(config: dict, name: str) -> Scene:
    for scene in forced_scenes(config):
        if scene.name == name:
            return scene
    raise ValueError(f"no forced scene named {name!r}; the configuration has {[s.name for s in forced_scenes(config)]}")
