"""Tasks of the forced responses (workflow/rules/forced.smk): configuration in, datasets and figures out.

``forced_exact`` (exact response of the non-smooth system at one force level), ``forced_regularized``
(harmonic-balance response at one force level, or the tube's), ``forced_figure`` (``paper_figures/forced_*``).
:func:`forced_scenes` turns the ``forced`` section into the scenes (an :class:`~nnmstop.models.excitation.Excitation`
and a frequency range each); the numerics live in :mod:`nnmstop.forced` and the modules it uses.
"""

from __future__ import annotations

import logging

import numpy as np

from nnmstop.continuation.anm import ANMSettings
from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings
from nnmstop.forced import assemble
from nnmstop.forced.assemble import point_accuracy  # noqa: F401 (the tasks' name of it)
from nnmstop.forced.backbone import nnm_backbone, predicted_peaks, required_force
from nnmstop.forced.dataset import backbone_dataset, base_attributes
from nnmstop.forced.regularized import ForcedStabilitySettings
from nnmstop.forced.responses import ExactSettings, RegularizedSettings
from nnmstop.forced.scenes import (
    Scene,
    exact_response_gap,
    find_scene,
    forced_scenes,
    prediction_excitations,
    scene_name,
)
from nnmstop.hbm.forced import response_amplitudes
from nnmstop.netcdf import read_dataset, write_dataset

__all__ = ["forced_exact", "forced_regularized", "forced_backbone", "forced_prediction", "forced_figure", "TASKS"]

logger = logging.getLogger("nnmstop.tasks.forced")

KEYWORDS = "forced response, frequency response, harmonic balance, non-smooth, Floquet stability"


# --------------------------------------------------------------------------- computations


def exact_response_dataset(config: dict, scene: Scene):
    """The exact response of ``scene`` as a dataset (:mod:`nnmstop.forced.assemble`)."""

    spec = config["forced"]["exact"]
    settings = ExactSettings(
        PseudoArclengthSettings(
            tolerance=spec["tolerance"],
            initial_step=spec["initial_step"],
            max_step=max(spec["max_step"], spec["initial_step"]),
        ),
        int(spec["frequency_samples"]),
    )
    factor = float(scene.stability["resolution_factor"])
    try:
        return assemble.exact_response_dataset(scene.excitation, scene.frequency_range, settings, factor)
    except ValueError as err:
        if "has no piece" not in str(err):
            raise
        raise ValueError(
            f"forced scene {scene.name} (forced.force.amplitudes, forced.frequency_range): {err}"
        ) from None


def regularized_response_dataset(config: dict, scene: Scene):
    """The harmonic-balance response of ``scene`` with its multipliers and located changes, as a dataset."""

    anm = ANMSettings.from_config(config["anm"], points_per_step=scene.points_per_step)
    settings = RegularizedSettings(scene.harmonics, anm, float(config["forced"]["max_truncation"]))
    stability = ForcedStabilitySettings.from_config(scene.stability)
    return assemble.regularized_response_dataset(
        scene.excitation, scene.frequency_range, settings, stability, scene.name
    )


def stop_words(structure) -> str:
    """The structure's stops in words: "bilateral elastic stops" (the paper's), "one-sided elastic stops", ..."""
    kinds = sorted({stop.kind.replace("_", "-") for stop in structure.stops})
    return f"{' and '.join(kinds)} elastic stops"


def _write(ds, path, scene: Scene, law: str, config: dict):
    what = "exact (piecewise-linear contact law)" if law == "piecewise_linear" else "regularized (harmonic balance)"
    force = scene.excitation.force
    summary = (
        f"Periodic responses of the damped structure with {stop_words(scene.excitation.structure)} to the force "
        f"{force.amplitude:g} "
        f"cos(Omega t) on DOF(s) {list(force.dofs)}, {what}, over {scene.frequency_range[0]:g}..."
        f"{scene.frequency_range[1]:g} Hz of the nondimensional time, with Floquet multipliers and the located "
        "stability changes (folds, symmetry breaking, period doubling, Neimark-Sacker)."
    )
    write_dataset(
        ds,
        path,
        title=f"Forced response {scene.name} ({law})",
        summary=summary,
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
        kind="forced_exact" if law == "piecewise_linear" else "forced_regularized",
    )
    logger.info("wrote %s (%d points)", path, ds.sizes["point"])


def _start_tolerance(config: dict) -> float:
    """The residual of a backbone's start point: ``hbm.start_tolerance`` where configured (a fine mesh's round-off
    floor), else that of :func:`nnmstop.hbm.stages.start_point`."""
    return float(config.get("hbm", {}).get("start_tolerance", 1e-13))


def backbone_prediction_dataset(config: dict):
    """NNM1 and NNM2 backbones of the regularized structure over the forced range, and the peaks they predict
    at every force level (:mod:`nnmstop.forced.backbone`)."""
    forced = config["forced"]
    scenes = forced_scenes(config, "structure")
    excitation = scenes[0].excitation
    forces = [scene.excitation.force.amplitude for scene in scenes]
    anm = ANMSettings.from_config(config["anm"], points_per_step=int(forced["points_per_step"]))
    backbones, predictions = {}, {}
    for mode in (1, 2):
        system, branch = nnm_backbone(
            excitation,
            mode,
            scenes[0].harmonics,
            anm,
            float(forced["max_truncation"]),
            force_limit=1.5 * max(forces),
            start_tolerance=_start_tolerance(config),
        )
        U = np.asarray(branch.points)
        backbones[mode] = (
            system.frequency_hz(U),
            response_amplitudes(system, U),
            np.array([required_force(system, excitation, u) for u in U]),
        )
        predictions[mode] = predicted_peaks(system, excitation, branch, anm, forces)
    ds = backbone_dataset(excitation, backbones, forces, predictions)
    ds.attrs.update(base_attributes(excitation, "regularized", scenes[0].frequency_range))
    ds.attrs["harmonics"] = int(scenes[0].harmonics)
    ds.attrs["newton_threshold"] = anm.newton_threshold
    return ds


def prediction_error_dataset(config: dict):
    """The backbone's predicted NNM1 peak against the located peak at each damping level of ``forced.prediction``."""
    import xarray as xr

    from nnmstop.forced.backbone import prediction_errors
    from nnmstop.forced.dataset import dof_label_variable

    forced = config["forced"]
    excitations, window = prediction_excitations(config)
    # the peaks are located on the ANM steps: the step ends are enough
    anm = ANMSettings.from_config(config["anm"], points_per_step=1)
    found = prediction_errors(
        excitations,
        1,
        window,
        int(forced["harmonics"]),
        anm,
        float(forced["max_truncation"]),
        start_tolerance=_start_tolerance(config),
    )
    stop = excitations[0].structure.stop_dofs[0]
    ds = xr.Dataset(
        {
            "damping_ratio": ("level", np.array([e.damping.ratios[0] for e in excitations], dtype=float)),
            "forcing_amplitude": ("level", np.array([e.force.amplitude for e in excitations], dtype=float)),
            "predicted_frequency": ("level", found["predicted_frequency"]),
            "peak_frequency": ("level", found["peak_frequency"]),
            "predicted_amplitude": (("level", "dof"), found["predicted_amplitude"]),
            "peak_amplitude": (("level", "dof"), found["peak_amplitude"]),
            "frequency_error": (
                "level",
                np.abs(found["predicted_frequency"] - found["peak_frequency"]) / found["predicted_frequency"],
            ),
            "amplitude_error": (
                "level",
                np.abs(found["predicted_amplitude"][:, stop] - found["peak_amplitude"][:, stop])
                / found["predicted_amplitude"][:, stop],
            ),
            "peak_phase_lag": (("level", "dof"), found["peak_phase_lag"]),
            "dof_label": dof_label_variable(excitations[0].structure),
        }
    )
    ds.attrs.update(base_attributes(excitations[0], "regularized", window))
    ds.attrs.update(
        harmonics=int(forced["harmonics"]),
        mode=1,
        force_per_ratio=float(forced["prediction"]["force_per_ratio"]),
        newton_threshold=anm.newton_threshold,
    )
    for name in ("damping_ratio", "rayleigh_mass_coefficient", "rayleigh_stiffness_coefficient", "forcing_amplitude"):
        ds.attrs.pop(name, None)  # per level: variables
    return ds


# --------------------------------------------------------------------------- the rules' tasks


def forced_exact(config, inputs, outputs, scene: str):
    """Exact response of the non-smooth structure at one force level (wildcard ``scene``)."""
    scene = find_scene(config, scene)
    _write(exact_response_dataset(config, scene), outputs["dataset"], scene, "piecewise_linear", config)


def forced_regularized(config, inputs, outputs, scene: str):
    """Regularized (HBM + ANM) response at one force level, or the tube's (wildcard ``scene``)."""
    scene = find_scene(config, scene)
    _write(regularized_response_dataset(config, scene), outputs["dataset"], scene, "regularized", config)


def forced_backbone(config, inputs, outputs):
    """NNM backbones and the resonance peaks they predict (energy balance)."""
    ds = backbone_prediction_dataset(config)
    summary = (
        "Backbones (NNM1, NNM2) of the regularized structure by harmonic balance + ANM over the forced frequency "
        "range, with the force amplitude whose resonance peak each NNM orbit is (damping work over the orbit = "
        "work of the force in quadrature) and the peaks predicted at each force level."
    )
    write_dataset(
        ds,
        outputs["dataset"],
        title="NNM backbones and predicted resonance peaks",
        summary=summary,
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
        kind="forced_backbone",
    )


def forced_prediction(config, inputs, outputs):
    """The backbone's prediction error against the damping (``forced.prediction``)."""
    summary = (
        "Peak of the NNM1 primary resonance predicted by the energy balance on the regularized backbone against the "
        "peak of the regularized response (harmonic balance + ANM, located on its steps) at damping ratios going "
        "to zero with the force in proportion; relative errors and the phase lag at the peak."
    )
    write_dataset(
        prediction_error_dataset(config),
        outputs["dataset"],
        title="The backbone's prediction of the resonance peak against the damping",
        summary=summary,
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
        kind="forced_prediction",
    )


def forced_figure(config, inputs, outputs, figure: str):
    """paper_figures/forced_<figure>.{pdf,png} from the datasets it draws (named inputs of the rule)."""
    from nnmstop.figures import forced as draw

    spec = config["forced"]["figures"]
    dpi = int(spec["png_dpi"])

    def read(key):
        found = inputs.get(key, [])
        paths = found if isinstance(found, (list, tuple)) else [found]
        return [read_dataset(path) for path in paths]

    no_exact = exact_response_gap(forced_scenes(config, "structure")[0])  # "" where the exact responses exist
    if figure == "frequency_response":
        draw.frequency_response_figure(
            read("exact"), read("regularized"), read("backbone")[0], outputs["pdf"], dpi, no_exact=no_exact
        )
    elif figure == "phase_lag":
        draw.phase_lag_figure(read("exact"), read("regularized"), outputs["pdf"], dpi, no_exact=no_exact)
    elif figure == "orbits":
        exact, regularized = (read("exact") or [None])[0], read("regularized")[0]
        scene = find_scene(config, scene_name(float(regularized.attrs["forcing_amplitude"])))
        draw.orbits_figure(exact, regularized, scene.excitation, spec["orbit_frequencies"], outputs["pdf"], dpi)
    elif figure == "prediction_error":
        draw.prediction_error_figure(read("prediction")[0], outputs["pdf"], dpi)
    elif figure == "tube":
        draw.tube_figure(read("regularized"), outputs["pdf"], dpi)
    else:
        raise ValueError(f"unknown forced figure {figure!r}")


def forced_manifest(config, inputs, outputs):
    """SHA-256 manifest of the forced datasets (as the paper's, :func:`nnmstop.tasks.manifest.dataset_manifest`)."""
    from nnmstop.tasks.manifest import dataset_manifest

    dataset_manifest(config, inputs, outputs)


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {
    f.__name__: f
    for f in (forced_exact, forced_regularized, forced_backbone, forced_prediction, forced_figure, forced_manifest)
}
