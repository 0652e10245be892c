"""Tasks of the finite-element tube (workflow/rules/tube.smk): config and files in, datasets and figures out.

``tube_exact`` (exact one-impact-per-stop NNM1 of the non-smooth tube), ``tube_branch`` (a regularized
NNM by HBM + ANM), ``tube_compare`` (exact against regularized at matched energies), ``tube_figure``
(``paper_figures/tube_*``), ``tube_study_case`` (NNM1 for one gap and stop stiffness) and
``tube_study`` (the study gathered). The numerics live in :mod:`nnmstop.models.beam`,
:mod:`nnmstop.exact.ndof`, :mod:`nnmstop.hbm.structure_branch` and :mod:`nnmstop.compare.structure_branches`.
"""

from __future__ import annotations

import copy
import logging

import numpy as np
import xarray as xr

from nnmstop.netcdf import read_dataset, write_dataset

logger = logging.getLogger("nnmstop.tasks.tube")

KEYWORDS = "finite element, Euler-Bernoulli beam, steam-generator tube, support plate"


def tube_beam(structure_config: dict):
    """The :class:`~nnmstop.models.beam.Beam` of the config's ``tube.structure`` section."""
    from nnmstop.models.beam import Beam

    return Beam.from_parameters(copy.deepcopy(structure_config))


def _structure_attrs(beam, structure) -> dict:
    from nnmstop.models.beam import beam_scales

    scales = beam_scales(beam)
    stop = structure.stops[0]
    return {
        "length_m": beam.length,
        "bending_stiffness_N_m2": beam.bending_stiffness,
        "mass_per_length_kg_per_m": beam.mass_per_length,
        "elements": beam.n_elements,
        "left_end": beam.left,
        "right_end": beam.right,
        "dofs": structure.n_dofs,
        "stop_nodes": np.array(beam.stop_nodes, dtype=np.int32),
        "stop_gap_m": np.array([s.gap for s in beam.stops]),
        "stop_stiffness_N_per_m": np.array([s.stiffness for s in beam.stops]),
        "stop_eta_N_per_m": np.array([s.eta for s in beam.stops]),
        "alpha": float(stop.stiffness),
        "eta": float(stop.eta),
        "length_unit_m": scales["length"],
        "angular_frequency_unit_rad_per_s": scales["angular_frequency"],
    }


def _mode_attrs(beam, mode: int) -> dict:
    from nnmstop.models.beam import mode_frequencies

    freqs = mode_frequencies(beam, mode)
    return {
        "mode": int(mode),
        "linear_frequency_fe": float(freqs["fe"][mode - 1]),
        "linear_frequency_euler_bernoulli": float(freqs["euler_bernoulli"][mode - 1]),
        "linear_frequency_units": "Hz of the nondimensional time (mode 1 of the FE model: 1/(2 pi))",
    }


def tube_exact(config, inputs, outputs):
    """Exact NNM1 of the non-smooth tube with one impact per stop side per period."""
    from nnmstop.exact.ndof import follow_one_stop_family
    from nnmstop.models.beam import beam_structure

    tube = config["tube"]
    beam = tube_beam(tube["structure"])
    structure = beam_structure(beam)
    family = follow_one_stop_family(structure, step=tube["exact"]["step"], max_points=tube["exact"]["max_points"])
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
        },
    )
    ds.attrs = {
        **_structure_attrs(beam, structure),
        **_mode_attrs(beam, 1),
        "start": family.start,
        "end_reason": family.end_reason,
    }
    write_dataset(
        ds,
        outputs["dataset"],
        kind="tube_exact_family",
        title="Exact NNM1 of the finite-element tube with a bilateral stop",
        summary="Exact periodic orbits of the non-smooth (piecewise-linear) finite-element tube with one "
        "impact on each side of its stop per period, from the grazing orbit of its first linear "
        f"mode; closed-form phases (matrix exponentials). The family ends because {family.end_reason}.",
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
    )


def run_tube_branch(
    tube: dict,
    anm: dict,
    mode: int,
    start_amplitude: float,
    energy_max: float,
    label: str,
    pass_resonances: int = 0,
    stability: dict | None = None,
):
    """System, continued branch and its dataset for one NNM of the tube section ``tube``.

    ``pass_resonances``: internal resonance tongues the backbone is continued over
    (:func:`nnmstop.hbm.structure_branch.continue_structure_nnm`); ``stability``: the config's
    ``stability`` section (:func:`nnmstop.hbm.stability.orbit_stability`, as for the 2-DOF branches).
    """
    from nnmstop.continuation.anm import ANMSettings
    from nnmstop.hbm.stability import orbit_stability
    from nnmstop.hbm.structure_branch import continue_structure_nnm, structure_branch_dataset
    from nnmstop.hbm.system import HarmonicBalanceSystem
    from nnmstop.models.beam import beam_structure
    from nnmstop.settings import stability_settings

    beam = tube_beam(tube["structure"])
    structure = beam_structure(beam)
    system = HarmonicBalanceSystem(structure, tube["harmonics"])
    settings = ANMSettings.from_config({**anm, "max_steps": tube["max_steps"]}, points_per_step=tube["points_per_step"])
    branch = continue_structure_nnm(
        system,
        mode,
        start_amplitude,
        energy_max,
        tube["max_truncation"],
        settings,
        label=label,
        pass_resonances=pass_resonances,
    )
    diagnostics = [d if d is not None else system.diagnostics(u) for u, d in zip(branch.points, branch.diagnostics)]
    branch.diagnostics = diagnostics
    stability = orbit_stability(
        system,
        np.array(branch.points),
        stability_settings({"stability": stability} if stability is not None else {}),
        time_residual=np.array([d["time_residual"] for d in diagnostics]),
    )
    attrs = {**_structure_attrs(beam, structure), **_mode_attrs(beam, mode), "branch": label}
    ds = structure_branch_dataset(
        system,
        branch,
        settings,
        stability,
        attrs,
        dof_labels=structure.dof_labels,
        node_coordinates=structure.node_coordinates,
    )
    return ds


def tube_branch(config, inputs, outputs, branch: str):
    """A regularized NNM of the tube (``tube.branches.<branch>``) by HBM + ANM."""
    tube = config["tube"]
    spec = tube["branches"][branch]
    ds = run_tube_branch(
        tube,
        config["anm"],
        spec["mode"],
        spec["start_amplitude"],
        spec["energy_max"],
        branch,
        pass_resonances=spec.get("pass_resonances", 0),
        stability=config.get("stability"),
    )
    write_dataset(
        ds,
        outputs["dataset"],
        kind="structure_branch",
        title=f"Regularized {branch.upper()} of the finite-element tube",
        summary=f"Periodic orbits of the regularized finite-element tube along its {branch.upper()}, by the "
        f"harmonic balance method (H = {tube['harmonics']}) and the asymptotic numerical method, "
        f"with Floquet multipliers. End: {ds.attrs['end_reason']}.",
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
    )


def tube_compare(config, inputs, outputs):
    """Exact against regularized NNM1 of the tube at matched energies."""
    from nnmstop.compare.structure_branches import compare_at_energies

    exact = read_dataset(inputs["exact"])
    regularized = read_dataset(inputs["nnm1"])
    ds = compare_at_energies(
        exact.energy.values,
        exact.frequency.values,
        regularized.energy.values,
        regularized.frequency.values,
        config["tube"]["compare_count"],
        segment=regularized.segment.values if "segment" in regularized else None,
    )
    ds.attrs = {k: v for k, v in regularized.attrs.items() if k in ("alpha", "eta", "harmonics", "elements")}
    write_dataset(
        ds,
        outputs["dataset"],
        kind="tube_comparison",
        title="Exact against regularized NNM1 of the finite-element tube",
        summary="Frequencies of the exact non-smooth and the regularized NNM1 of the tube where each branch "
        "first reaches log-spaced energies of their common range.",
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
    )


def study_case_config(tube: dict, gap: float, factor: float) -> dict:
    """The tube section with the first stop's gap and stiffness (``factor x 3 EI / a**3``, eta = stiffness/300)."""
    case = copy.deepcopy(tube)
    beam = tube_beam(case["structure"])
    position = beam.node_coordinates[beam.stop_nodes[0]]
    stiffness = factor * 3.0 * beam.bending_stiffness / position**3
    stop = case["structure"]["stops"][0]
    stop.update(gap=float(gap), stiffness=float(stiffness), eta=float(stiffness / 300.0))
    return case


def tube_study_case(config, inputs, outputs, gap, factor):
    """NNM1 of the tube for one (gap, stop stiffness factor) of ``tube.study``."""
    tube = study_case_config(config["tube"], float(gap), float(factor))
    nnm1 = tube["branches"]["nnm1"]
    ds = run_tube_branch(
        tube,
        config["anm"],
        1,
        nnm1["start_amplitude"],
        tube["study"]["energy_max"],
        "nnm1",
        stability=config.get("stability"),
    )
    ds.attrs.update(study_gap_m=float(gap), study_stiffness_factor=float(factor))
    write_dataset(
        ds,
        outputs["dataset"],
        kind="structure_branch",
        title=f"Tube NNM1, gap {gap} m, stop stiffness factor {factor}",
        summary="One case of the tube's parameter study over gap and stop stiffness.",
        keywords=KEYWORDS,
        metadata=config.get("metadata"),
    )


def tube_figure(config, inputs, outputs, figure: str):
    """``paper_figures/tube_<name>.{pdf,png}`` from the tube datasets."""
    from nnmstop.figures.tube import draw_tube_figure

    draw_tube_figure(
        figure,
        {k: read_dataset(v) for k, v in inputs.items()},
        config["tube"]["figures"],
        outputs["pdf"],
        outputs["png"],
    )


def tube_study(config, inputs, outputs):
    """``paper_figures/tube_study.{pdf,png}``: NNM1 backbones (physical units) over gap and stop stiffness."""
    from nnmstop.figures.tube import draw_study_figure

    cases = [read_dataset(path) for path in inputs["cases"]]
    draw_study_figure(cases, config["tube"]["figures"], outputs["pdf"], outputs["png"])


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (tube_exact, tube_branch, tube_compare, tube_figure, tube_study_case, tube_study)}
