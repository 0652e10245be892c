"""The forced scenes of the configuration: an excitation (structure, damping, force) and a frequency range each.

The structure is the configuration's own (``structure``: the paper's oscillator of ``model``, a beam, or matrices
from files; :func:`nnmstop.settings.structure_from_config`), forced on the degrees of freedom of ``forced.force``
(by their labels); the tube of ``tube`` has a scene of its own (``forced.tube``). The configuration's validation
builds the scenes to name bad values.
"""

from __future__ import annotations

from dataclasses import dataclass

from nnmstop.models.excitation import Damping, Excitation, HarmonicForce
from nnmstop.models.structure import Structure

__all__ = [
    "Scene",
    "WHICH",
    "scene_name",
    "forced_scenes",
    "exact_response_gap",
    "find_scene",
    "prediction_excitations",
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


def exact_response_gap(scene: Scene) -> str:
    """Why the exact (non-smooth) response of ``scene`` is not computed, or "" where it is: the exact forced solver
    (:mod:`nnmstop.exact.forced`) strikes one stop and checks the others only along its contact families, not
    along the non-impacting response and its grazings, so a structure with several stops is not covered; nor is
    the tube's scene (regularized only: each exact orbit's lags and multipliers are costly on a fine mesh)."""
    if scene.name.startswith("tube_"):
        return "the tube's forced response is regularized only"
    stops = len(scene.excitation.structure.stops)
    if stops > 1:
        return (
            f"the exact forced solver covers structures with one stop; this one has {stops} (regularized responses "
            "only)"
        )
    return ""


def find_scene(config: dict, name: str) -> Scene:
    for scene in forced_scenes(config):
        if scene.name == name:
            return scene
    raise ValueError(f"no forced scene named {name!r}; the configuration has {[s.name for s in forced_scenes(config)]}")
