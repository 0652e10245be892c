"""Assembly of the labelled dataset of a regularized branch, for any structure: the generic branch schema.

Numbers come in computed (:mod:`nnmstop.hbm.stages` runs the continuation, locates branch points,
computes stability); this module only names and describes them. Dimensions ``point`` (along the
branch), ``dof`` (coordinate ``dof_label``: ``x``, ``u`` for the paper's oscillator), ``stop``,
``harmonic`` (0..H) and ``mode`` (the linear limits). Fourier coefficients ``q_cos``/``q_sin(point,
dof, harmonic)`` and ``f_cos``/``f_sin``, ``z_cos``/``z_sin(point, stop, harmonic)`` (``[..., 0]`` the
mean; sine coefficients zero in the cosine basis); ``omega_squared``, ``unfolding``, ``energy``,
``frequency``, ``period``, ``x_max`` (first stop), ``q_max(point, dof)``, ``impacts_per_period``,
``stop_impacts(point, stop)``, residuals, ``truncation``, ``step``, ``stage``, ``segment``; flags
``branch_point`` and ``energy_fold``; the located branch points (dimension ``located_branch_point``),
energy folds (``located_fold``) and resonance tongues passed (``passed_resonance``); the Floquet
verdicts (:func:`nnmstop.hbm.stability.orbit_stability`); the structure's stops (``stop_dof``,
``stop_gap``, ``stop_stiffness``, ``stop_eta``) and linear limits (``no_contact_frequency``,
``regularized_frequency``, ``gap_zero_frequency(mode)``, ``gap_zero_shape(dof, mode)``). Global
attributes: the structure's own (``Structure.attributes``: the paper's ``alpha``, ``beta``, ``delta``,
``eta``), the branch, the settings and how the stage ended. A skipped stage is a dataset with no point
that says why (:func:`skipped_stage_dataset`). Layout reference: ``docs/datasets.md``.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nnmstop import fourier
from nnmstop.catalogue import describe
from nnmstop.continuation.core import Branch, ContinuationError, relative_residual
from nnmstop.hbm.bifurcation import circular_pair, is_whirl_branch_point, swept_area
from nnmstop.hbm.identity import ORBIT_FORCE_NAMES, orbit_identity
from nnmstop.models.structure import limit_modes
from nnmstop.wear import orbit_wear

__all__ = [
    "BRANCH_POINT_DIM",
    "FOLD_DIM",
    "RESONANCE_DIM",
    "IDENTITY_CHANGE_DIM",
    "ORBIT_COEFFICIENTS",
    "orbit_variables",
    "branch_kind",
    "labelled",
    "branch_dataset",
    "skipped_stage_dataset",
    "bifurcated_dataset",
    "summarize_bifurcated",
    "located_branch_point_variables",
    "located_fold_variables",
    "segment_fold_variables",
    "passed_resonance_variables",
    "identity_variables",
    "identity_change_variables",
    "energy_folds",
    "dataset_unknowns",
    "rotation_attributes",
    "system_arguments",
    "coefficient_vectors",
    "is_skipped",
]

#: The variables that hold an orbit: the Fourier coefficients of every field and the squared angular frequency.
ORBIT_COEFFICIENTS = ("q_cos", "q_sin", "f_cos", "f_sin", "z_cos", "z_sin", "omega_squared")

BRANCH_POINT_DIM = "located_branch_point"
FOLD_DIM = "located_fold"
RESONANCE_DIM = "passed_resonance"
IDENTITY_CHANGE_DIM = "identity_change"
#: Per-point variables that make up an orbit's identity (a change of any is an identity change).
IDENTITY_CODES = ("orbit_kind", "dominant_mode", "dominant_harmonic", "tongue_harmonic")


def _var(name: str, dims, values) -> tuple:
    """A variable ``(dims, values)``; its long name, units and flags come from the catalogue (:func:`labelled`)."""
    return dims, values


def _force_blocks(system, blocks, count: int):
    """The force fields of every stop as ``f`` (its first component) and, for a structure with a stop of two
    components (the circular clearance), ``f2`` (its second; zero for stops of one), each (points, s, nc)."""
    N, s, m, nc = system.n_dofs, system.n_stops, system.n_components, system.nc
    forces = np.stack(blocks[N : N + m], axis=1) if count else np.zeros((0, m, nc))
    if m == s:
        return {"f": forces}
    first = [sl.start for sl in system.contact.components]
    second = np.zeros((len(forces), s, nc))
    for i, sl in enumerate(system.contact.components):
        if sl.stop - sl.start > 1:
            second[:, i] = forces[:, sl.start + 1]
    return {"f": forces[:, first], "f2": second}


def orbit_variables(system, U: np.ndarray) -> dict:
    """Fourier coefficients (:data:`ORBIT_COEFFICIENTS`, and ``f2`` for a structure with a circular clearance),
    omega^2, nu and the period of the points ``U``."""
    blocks = system.split(U)
    N, s, m, H = system.n_dofs, system.n_stops, system.n_components, system.H
    pairs = {
        "q": np.stack(blocks[:N], axis=1) if len(U) else np.zeros((0, N, system.nc)),
        **_force_blocks(system, blocks, len(U)),
        "z": np.stack(blocks[N + m : N + m + s], axis=1) if len(U) else np.zeros((0, s, system.nc)),
    }
    data = {}
    for symbol, where in [("q", "dof"), ("f", "stop")] + [("f2", "stop")] * ("f2" in pairs) + [("z", "stop")]:
        cos, sin = fourier.to_cos_sin(pairs[symbol], H)
        dims = ("point", where, "harmonic")
        data[f"{symbol}_cos"], data[f"{symbol}_sin"] = (
            _var(f"{symbol}_cos", dims, cos),
            _var(f"{symbol}_sin", dims, sin),
        )
    lam, nu = blocks[-2], blocks[-1]
    data["omega_squared"] = _var("omega_squared", "point", lam)
    data["unfolding"] = _var("unfolding", "point", nu)
    if system.rotation:
        data["rotation_unfolding"] = _var("rotation_unfolding", "point", system.rotation_unfolding(U))
    data["period"] = _var("period", "point", 2 * np.pi / np.sqrt(lam))
    return data


def _diagnostic_variables(system, U: np.ndarray, diagnostics: list) -> dict:
    """Energy, frequency, amplitudes, impacts and error indicators of every point."""

    def col(key, dtype=float, shape=()):
        return np.array([d[key] for d in diagnostics], dtype=dtype).reshape((len(diagnostics),) + shape)

    data = {name: _var(name, "point", col(name)) for name in ("energy", "frequency", "x_max")}
    data["q_max"] = _var("q_max", ("point", "dof"), col("q_max", shape=(system.n_dofs,)))
    data["impacts_per_period"] = _var("impacts_per_period", "point", col("impacts_per_period", np.int32))
    data["stop_impacts"] = _var("stop_impacts", ("point", "stop"), col("stop_impacts", np.int32, (system.n_stops,)))
    data["algebraic_residual"] = _var(
        "algebraic_residual", "point", np.array([relative_residual(system, p) for p in U], dtype=float)
    )
    for name in ("time_residual", "force_error", "energy_spread", "truncation"):
        data[name] = _var(name, "point", col(name))
    if circular_pair(system) is not None:
        data["swept_area"] = _var("swept_area", "point", np.array([swept_area(system, u) for u in U], dtype=float))
    wear = orbit_wear(system, U)
    data.update({name: _var(name, ("point", "stop"), values) for name, values in wear.items()})
    return data


def _path_variables(branch: Branch, stage: int, energy: np.ndarray) -> dict:
    """Step, stage, segment and the branch-point and energy-fold flags of every point."""
    n = len(branch.points)
    segment = getattr(branch, "segment", None)
    segment = np.zeros(n, dtype=np.int32) if segment is None else np.asarray(segment, dtype=np.int32)
    flagged = np.zeros(n, dtype=bool)
    flagged[branch.branch_points] = True
    folds = np.zeros(n, dtype=bool)
    for k in np.unique(segment):
        folds[segment == k] = energy_folds(energy[segment == k])
    return {
        "step": _var("step", "point", np.asarray(branch.step, dtype=np.int32)),
        "stage": _var("stage", "point", np.full(n, stage, dtype=np.int32)),
        "segment": _var("segment", "point", segment),
        "branch_point": _var("branch_point", "point", flagged.astype(np.int8)),
        "energy_fold": _var("energy_fold", "point", folds.astype(np.int8)),
    }


def _structure_variables(system) -> tuple[dict, dict]:
    """Variables and coordinates describing the structure: its stops, linear limits, labels and mesh."""
    structure = system.structure
    stops = structure.stops
    data = {
        "stop_dof": _var("stop_dof", "stop", np.array(structure.stop_dofs, dtype=np.int32)),
        "stop_gap": _var("stop_gap", "stop", np.array([s.gap for s in stops])),
        "stop_stiffness": _var("stop_stiffness", "stop", np.array([s.stiffness for s in stops])),
        "stop_eta": _var("stop_eta", "stop", np.array([s.eta for s in stops])),
    }
    data.update(stop_kind_variables(stops))
    for limit in ("no_contact", "regularized"):
        data[f"{limit}_frequency"] = _var(f"{limit}_frequency", "mode", limit_modes(structure, limit)[0] / (2 * np.pi))
    omega, shapes = limit_modes(structure, "gap_zero")
    data["gap_zero_frequency"] = _var("gap_zero_frequency", "mode", omega / (2 * np.pi))
    data["gap_zero_shape"] = _var("gap_zero_shape", ("dof", "mode"), shapes)
    coords = {
        "dof": np.arange(structure.n_dofs),
        "stop": np.arange(len(stops)),
        "harmonic": np.arange(system.H + 1),
        "mode": np.arange(1, len(omega) + 1),
        "dof_label": ("dof", np.array(structure.dof_labels, dtype=str)),
    }
    if structure.node_coordinates is not None:
        coords["node"] = np.arange(len(structure.node_coordinates))
        data["node_coordinate"] = _var("node_coordinate", "node", np.asarray(structure.node_coordinates, float))
    if structure.reduction is not None:
        recovery_data, recovery_coords = recovery_variables(structure.reduction)
        data.update(recovery_data)
        coords.update(recovery_coords)
    return data, coords


def recovery_variables(reduction) -> tuple[dict, dict]:
    """The recovery of a reduced structure's DOFs onto (a subset of) the full model's, for figures and readers.

    ``recovery(recovered_dof, dof)``: full-model DOFs ``recovered_dof_label`` from the reduced ones
    (:func:`nnmstop.models.reduction.recovered_rows` picks them: all of a small model, evenly spaced nodes of
    a large mesh); ``recovered_dof_node`` their node, ``node_coordinate`` the full mesh's nodes.
    """
    from nnmstop.models.reduction import recovered_rows

    rows = recovered_rows(reduction)
    data = {"recovery": _var("recovery", ("recovered_dof", "dof"), reduction.recovery[rows])}
    coords = {
        "recovered_dof": np.arange(len(rows)),
        "recovered_dof_label": ("recovered_dof", np.array([reduction.full_dof_labels[r] for r in rows], dtype=str)),
    }
    if reduction.full_dof_nodes is not None:
        nodes = np.asarray(reduction.full_dof_nodes, dtype=np.int32)[rows]
        data["recovered_dof_node"] = _var("recovered_dof_node", "recovered_dof", nodes)
    if reduction.full_node_coordinates is not None:
        coords["node"] = np.arange(len(reduction.full_node_coordinates))
        data["node_coordinate"] = _var("node_coordinate", "node", np.asarray(reduction.full_node_coordinates, float))
    return data, coords


def stop_kind_variables(stops) -> dict:
    """``stop_kind``, ``stop_side`` and ``stop_other_dof`` (:meth:`~nnmstop.models.contact.Stop.metadata`) when a
    stop is not the paper's bilateral stop on one DOF; nothing otherwise (the paper's datasets keep their layout)."""
    if all(s.kind == "bilateral" for s in stops):
        return {}
    meta = [s.metadata() for s in stops]
    return {
        "stop_kind": _var("stop_kind", "stop", np.array([m["kind"] for m in meta], dtype=str)),
        "stop_side": _var("stop_side", "stop", np.array([m["side"] for m in meta], dtype=np.int8)),
        "stop_other_dof": _var("stop_other_dof", "stop", np.array([m["dofs"][-1] for m in meta], dtype=np.int32)),
    }


def rotation_attributes(system) -> dict:
    """``rotation_condition`` (1 when the system fixes the rotation, :mod:`nnmstop.hbm.system`) and
    ``rotation_angle`` for a structure invariant under rotations; nothing otherwise (the other datasets keep their
    layout). Readers rebuild the system with them (:func:`system_arguments`)."""
    if system.structure.rotation_pairs is None:
        return {}
    return {"rotation_condition": int(system.rotation), "rotation_angle": float(system.rotation_angle)}


def system_arguments(attrs) -> dict:
    """The keywords of :class:`~nnmstop.hbm.system.HarmonicBalanceSystem` a branch dataset's attributes record
    besides its harmonics: ``time_samples``, ``basis`` and, for a structure invariant under rotations, whether
    the rotation was fixed (:func:`rotation_attributes`)."""
    out = {"time_samples": int(attrs["time_samples"]), "basis": str(attrs["basis"])}
    if "rotation_condition" in attrs:
        out.update(rotation=bool(int(attrs["rotation_condition"])), rotation_angle=float(attrs["rotation_angle"]))
    return out


def _attributes(system, branch: Branch, continuation, labels: dict, unlocated: int) -> dict:
    stats = branch.stats
    return {
        **system.structure.attributes,
        "dofs": system.n_dofs,
        "stops": system.n_stops,
        **labels,
        "harmonics": system.H,
        "time_samples": system.M,
        "basis": system.basis,
        **rotation_attributes(system),
        "order": continuation.order,
        "tolerance": continuation.tolerance,
        "newton_threshold": continuation.newton_threshold,
        "pade": int(continuation.pade),
        "pade_steps": stats.pade_steps,
        "end_reason": branch.end_reason,
        "anm_steps": stats.steps,
        "factorizations": stats.factorizations,
        "unlocated_branch_points": int(unlocated),
        "passed_resonances": len(getattr(branch, "resonances", [])),
    }


def branch_dataset(
    system, branch: Branch, stage: int, located, stability, continuation, labels: dict, unlocated: int = 0
) -> xr.Dataset:
    """Labelled dataset of a continued branch (variables in the module docstring).

    Parameters
    ----------
    system : HarmonicBalanceSystem
    branch : Branch
        The continued points, their steps, diagnostics (computed here where None), flags, and
        optionally ``segment`` (segment of every point) and ``resonances`` (tongues passed).
    stage : int
        Stage number stored in the ``stage`` variable.
    located : list of (int, BranchPoint, int, bool)
        Located branch points (:func:`nnmstop.hbm.bifurcation.locate_flagged_branch_points`).
    stability : object with ``data_vars()`` and ``multipliers``
        Floquet verdicts of the points (:func:`nnmstop.hbm.stability.orbit_stability`).
    continuation : ANMSettings
        Settings of the continuation, recorded as attributes.
    labels : dict
        Global attributes naming the branch: ``branch`` (required), and e.g. ``mode``, ``stages``, how the
        stage ended.
    unlocated : int
        Flagged steps whose branch point could not be located (recorded as an attribute).

    Raises
    ------
    ContinuationError
        If an energy along the branch is not finite (no dataset is returned).
    """
    U = np.array(branch.points)
    diagnostics = [d if d is not None else system.diagnostics(u) for u, d in zip(U, branch.diagnostics)]
    if not all(np.isfinite(d["energy"]) for d in diagnostics):
        raise ContinuationError(f"{labels['branch']} stage {stage}: non-finite energy in the branch")
    data = orbit_variables(system, U)
    data.update(_diagnostic_variables(system, U, diagnostics))
    energy = data["energy"][1]
    data.update(_path_variables(branch, stage, energy))
    data.update(located_branch_point_variables(system, located))
    data.update(segment_fold_variables(coefficient_vectors(data), energy, data["frequency"][1], data["segment"][1]))
    data.update(passed_resonance_variables(getattr(branch, "resonances", [])))
    data.update(identity_variables(system.structure, data))
    data.update(identity_change_variables(data, energy, data["frequency"][1]))
    data.update(stability.data_vars())
    structure_data, coords = _structure_variables(system)
    data.update(structure_data)
    coords.update(point=np.arange(len(U)), multiplier=np.arange(stability.multipliers.shape[1]))
    ds = xr.Dataset(data, coords=coords)
    ds.attrs = _attributes(system, branch, continuation, labels, unlocated)
    return labelled(ds)


def skipped_stage_dataset(system, stage: int, labels: dict, reason: str) -> xr.Dataset:
    """The dataset of a stage that was not continued: no point, the structure, the settings and ``reason``.

    A stage is skipped when the stage before it ended without its condition (at its energy bound, or
    where the harmonics stopped resolving the orbits): the scene it was meant for does not exist on this
    branch. Its attributes ``skipped = 1`` and ``end_reason`` say so; readers find ``point`` of length 0.
    """
    empty = Branch()
    empty.end_reason = reason
    data = orbit_variables(system, np.zeros((0, system.n_unknowns)))
    data.update(_path_variables(empty, stage, np.zeros(0)))
    data.update(energy=_var("energy", "point", np.zeros(0)), frequency=_var("frequency", "point", np.zeros(0)))
    data.update(impacts_per_period=_var("impacts_per_period", "point", np.zeros(0, dtype=np.int32)))
    structure_data, coords = _structure_variables(system)
    data.update(structure_data)
    coords["point"] = np.arange(0)
    ds = xr.Dataset(data, coords=coords)
    ds.attrs = {
        **system.structure.attributes,
        "dofs": system.n_dofs,
        "stops": system.n_stops,
        **labels,
        "harmonics": system.H,
        **rotation_attributes(system),
        "skipped": 1,
        "skipped_stage": int(stage),
        "stage_condition_met": 0,
        "end_reason": reason,
    }
    return labelled(ds)


def branch_kind(ds: xr.Dataset) -> str:
    """The catalogue's kind of a branch dataset: ``skipped_branch``, ``switched_branch`` or ``nnm_branch``."""
    if is_skipped(ds):
        return "skipped_branch"
    return "switched_branch" if "subharmonic_share" in ds or "parent_branch" in ds.attrs else "nnm_branch"


def labelled(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with the long names, units and flags of its kind (:func:`branch_kind`) from the variable catalogue."""
    return describe(ds, branch_kind(ds))


def is_skipped(ds: xr.Dataset) -> bool:
    """Whether ``ds`` is the dataset of a skipped stage (:func:`skipped_stage_dataset`) or holds no point."""
    return bool(int(ds.attrs.get("skipped", 0))) or ds.sizes.get("point", 0) == 0


def located_branch_point_variables(system, located) -> dict:
    """Dataset variables (dimension ``located_branch_point``) of located branch points."""
    dim = (BRANCH_POINT_DIM,)
    diags = [system.diagnostics(point.U) for _, point, _, _ in located]
    whirl = {}
    if circular_pair(system) is not None:
        flags = [not n and is_whirl_branch_point(system, point) for _, point, n, _ in located]
        whirl["branch_point_whirl"] = _var("branch_point_whirl", dim, np.array(flags, dtype=np.int8))
    return {
        **whirl,
        "branch_point_energy": _var("branch_point_energy", dim, np.array([d["energy"] for d in diags], float)),
        "branch_point_frequency": _var("branch_point_frequency", dim, np.array([d["frequency"] for d in diags], float)),
        "branch_point_resonance": _var(
            "branch_point_resonance", dim, np.array([n for _, _, n, _ in located], dtype=np.int32)
        ),
        "branch_point_symmetry_breaking": _var(
            "branch_point_symmetry_breaking", dim, np.array([b for _, _, _, b in located], dtype=np.int8)
        ),
        "branch_point_tangent_angle": _var(
            "branch_point_tangent_angle", dim, np.array([p.angle for _, p, _, _ in located], dtype=float)
        ),
        "branch_point_singular_ratio": _var(
            "branch_point_singular_ratio", dim, np.array([p.singular_ratio for _, p, _, _ in located], dtype=float)
        ),
        "branch_point_flagged_point": _var(
            "branch_point_flagged_point", dim, np.array([i for i, _, _, _ in located], dtype=np.int32)
        ),
    }


def located_fold_variables(U, energy, frequency) -> dict:
    """Dataset variables (dimension ``located_fold``) of the energy folds of one curve.

    Each local extremum of the energy along the curve is refined by the parabola through it and its
    two neighbours in the arclength of the unknowns; the frequency is read on the parabola through the
    same three points.
    """
    U, energy, frequency = np.asarray(U, float), np.asarray(energy, float), np.asarray(frequency, float)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(U, axis=0), axis=1))]) if len(U) else U[:, 0]
    index, e_fold, f_fold = [], [], []
    for i in np.flatnonzero(energy_folds(energy)):
        ds_, e_, f_ = s[i - 1 : i + 2] - s[i], energy[i - 1 : i + 2], frequency[i - 1 : i + 2]
        ce, cf = np.polyfit(ds_, e_, 2), np.polyfit(ds_, f_, 2)
        vertex = -ce[1] / (2 * ce[0]) if ce[0] != 0 else 0.0
        vertex = float(np.clip(vertex, ds_[0], ds_[2]))
        index.append(i)
        e_fold.append(float(np.polyval(ce, vertex)))
        f_fold.append(float(np.polyval(cf, vertex)))
    dim = (FOLD_DIM,)
    return {
        "fold_energy": _var("fold_energy", dim, np.array(e_fold, dtype=float)),
        "fold_frequency": _var("fold_frequency", dim, np.array(f_fold, dtype=float)),
        "fold_point": _var("fold_point", dim, np.array(index, dtype=np.int32)),
    }


def segment_fold_variables(U, energy, frequency, segment) -> dict:
    """:func:`located_fold_variables` of each segment (curves apart), point indices of the whole branch."""
    segment = np.asarray(segment)
    parts = []
    for k in np.unique(segment) if segment.size else [0]:
        index = np.flatnonzero(segment == k)
        part = located_fold_variables(np.asarray(U)[index], np.asarray(energy)[index], np.asarray(frequency)[index])
        dims, values = part["fold_point"]
        part["fold_point"] = (dims, (values + (index[0] if index.size else 0)).astype(np.int32))
        parts.append(part)
    return {
        name: (dims, np.concatenate([part[name][1] for part in parts]).astype(values.dtype))
        for name, (dims, values) in parts[0].items()
    }


def passed_resonance_variables(resonances) -> dict:
    """Dataset variables (dimension ``passed_resonance``) of the tongues passed.

    ``resonances``: :class:`~nnmstop.hbm.tongues.PassedResonance` instances.
    """
    dim = (RESONANCE_DIM,)
    return {
        "passed_resonance_frequency": _var(
            "passed_resonance_frequency", dim, np.array([r.frequency for r in resonances], dtype=float)
        ),
        "passed_resonance_energy": _var(
            "passed_resonance_energy", dim, np.array([r.energy for r in resonances], float)
        ),
        "passed_resonance_harmonic": _var(
            "passed_resonance_harmonic", dim, np.array([r.harmonic for r in resonances], dtype=np.int32)
        ),
        "passed_resonance_landing_frequency": _var(
            "passed_resonance_landing_frequency", dim, np.array([r.landing_frequency for r in resonances], float)
        ),
    }


def identity_variables(structure, data) -> dict:
    """What each orbit is, from its Fourier coefficients (:func:`nnmstop.hbm.identity.orbit_identity`).

    ``data``: the branch's variables ``name -> (dims, values)`` holding ``q_cos`` ... ``f_sin``.
    """
    dims = {"dof_dominant_harmonic": ("point", "dof"), "effective_stop_stiffness": ("point", "stop")}
    found = orbit_identity(structure, *(data[name][1] if name in data else None for name in ORBIT_FORCE_NAMES))
    return {name: _var(name, dims.get(name, "point"), values) for name, values in found.items()}


def identity_change_variables(ds, energy, frequency) -> dict:
    """Dataset variables (dimension ``identity_change``) of the points where an orbit's identity changes.

    ``ds``: a branch dataset or the mapping of its variables ``name -> (dims, values)`` with
    :data:`IDENTITY_CODES`; a change of any of them starts a new identity (:func:`nnmstop.hbm.identity.identity_runs`).
    """

    def values(name):
        item = ds[name]
        return np.asarray(item[1] if isinstance(item, tuple) else item.values)

    codes = np.column_stack([values(name) for name in IDENTITY_CODES])
    changed = np.flatnonzero(np.any(codes[1:] != codes[:-1], axis=1)) + 1 if len(codes) > 1 else np.zeros(0, int)
    dim = (IDENTITY_CHANGE_DIM,)
    return {
        "identity_change_point": _var("identity_change_point", dim, changed.astype(np.int32)),
        "identity_change_energy": _var("identity_change_energy", dim, np.asarray(energy, float)[changed]),
        "identity_change_frequency": _var("identity_change_frequency", dim, np.asarray(frequency, float)[changed]),
    }


def energy_folds(energy) -> np.ndarray:
    """Boolean flags of the local extrema of the energy along a branch."""
    energy = np.asarray(energy)
    fold = np.zeros(energy.shape, dtype=bool)
    slope = np.diff(energy)
    fold[1:-1] = slope[:-1] * slope[1:] < 0
    return fold


def dataset_unknowns(ds: xr.Dataset, system) -> np.ndarray:
    """Unknown vectors of every point of a branch dataset, for ``system``'s layout.

    Raises
    ------
    ValueError
        If the dataset's harmonics, degrees of freedom or stops are not the system's.
    """
    if ds.sizes["harmonic"] != system.H + 1:
        raise ValueError(f"dataset has {ds.sizes['harmonic'] - 1} harmonics, the system {system.H}")
    if ds.sizes["dof"] != system.n_dofs or ds.sizes["stop"] != system.n_stops:
        raise ValueError(
            f"dataset has {ds.sizes['dof']} degrees of freedom and {ds.sizes['stop']} stop(s), the system "
            f"{system.n_dofs} and {system.n_stops}"
        )
    parts = []
    full = {
        symbol: fourier.from_cos_sin(ds[f"{symbol}_cos"].values, ds[f"{symbol}_sin"].values)[..., : system.nc]
        for symbol in ("q", "f", "f2", "z")
        if f"{symbol}_cos" in ds
    }
    parts += [full["q"][:, j] for j in range(system.n_dofs)]
    for i, sl in enumerate(system.contact.components):
        parts.append(full["f"][:, i])
        if sl.stop - sl.start > 1:
            if "f2" not in full:
                raise ValueError("dataset has no f2_cos/f2_sin: the second force component of its circular clearance")
            parts.append(full["f2"][:, i])
    parts += [full["z"][:, j] for j in range(system.n_stops)]
    tail = [ds["omega_squared"].values[:, None]]
    if system.full:
        tail.append(ds["unfolding"].values[:, None])
    if system.rotation:
        if "rotation_unfolding" not in ds:
            raise ValueError("dataset has no rotation_unfolding: it was not computed with the rotation phase condition")
        tail.append(ds["rotation_unfolding"].values[:, None])
    return np.concatenate(parts + tail, axis=1)


def coefficient_vectors(ds) -> np.ndarray:
    """The unknowns of every point as stored (all coefficients and omega^2), for arclengths.

    ``ds`` is a branch dataset or the mapping of its variables ``name -> (dims, values, attrs)``.
    Each field's cosine then sine coefficients, field after field (degrees of freedom, stop forces, ``z``).
    """

    def values(name):
        item = ds[name]
        return item[1] if isinstance(item, tuple) else item.values

    parts = []
    for symbol in ("q", "f", "f2", "z"):
        if f"{symbol}_cos" not in ds:
            continue
        cos, sin = values(f"{symbol}_cos"), values(f"{symbol}_sin")
        for j in range(cos.shape[1]):
            parts += [cos[:, j], sin[:, j]]
    return np.concatenate(parts + [values("omega_squared")[:, None]], axis=1)


def bifurcated_dataset(
    ds: xr.Dataset, name: str, parent: str, resonance: int, subharmonic_share, branch_point: dict, switch_step: float
) -> xr.Dataset:
    """Turn the :func:`branch_dataset` of a bifurcated branch into its final layout.

    Adds ``subharmonic_share`` (one value per point, zero on orbits of period ``T/n``; None for a branch switched
    where planar motion gives way to whirl, ``resonance`` 0, whose ``swept_area`` says how far it goes), relabels
    ``stage`` and ``step``, and replaces the stage attributes (``mode``, ``stages``) by those of the
    switch: ``branch`` (``name``), ``parent_branch``, ``resonance``, ``switch_step`` and
    ``branch_point`` (``branch_point_energy``, ``branch_point_frequency``, ``tangent_angle`` in
    degrees, ``singular_ratio``).
    """
    n = int(resonance)
    if subharmonic_share is not None:
        ds["subharmonic_share"] = _var("subharmonic_share", "point", np.asarray(subharmonic_share, dtype=float))
    for key in ("mode", "stages"):
        ds.attrs.pop(key, None)
    ds.attrs.update(
        {"branch": name, "parent_branch": parent, "resonance": n, **branch_point, "switch_step": switch_step}
    )
    return labelled(ds)


def summarize_bifurcated(ds, nnm2=None) -> str:
    """Plain-text summary of a bifurcated-branch dataset (``results/hbm/bifurcated/*.nc``).

    With ``nnm2`` (a regularized NNM2 dataset), also the relative distance of
    ``n f`` on the bifurcated branch from the NNM2 frequency at the same energy
    (NNM2 interpolated linearly in ``ln E``; its energy must increase along the branch).
    """
    if is_skipped(ds):
        return f"branch {ds.attrs['branch']}: no point ({ds.attrs.get('end_reason', 'skipped')})"
    n = int(ds.attrs["resonance"])
    e, f = ds["energy"].values, ds["frequency"].values
    resolved = ds["stability_resolved"] == 1
    lines = [
        f"branch {ds.attrs['branch']}: switched from {ds.attrs['parent_branch']} at its {n}:1 branch point",
        f"  branch point: energy {ds.attrs['branch_point_energy']:.6g}, frequency "
        f"{ds.attrs['branch_point_frequency']:.6g} Hz, "
        f"angle between the tangents {ds.attrs['tangent_angle']:.2f} deg, singular ratio "
        f"{ds.attrs['singular_ratio']:.2e}",
        f"  {ds.sizes['point']} points, energy {e.min():.4g} .. {e.max():.4g}, frequency {f.min():.6g} .. "
        f"{f.max():.6g} Hz, "
        f"{int(ds.attrs['anm_steps'])} ANM steps",
        (
            f"  largest share of harmonics not multiple of {n}: {float(ds['subharmonic_share'].max()):.2e}"
            if "subharmonic_share" in ds
            else f"  swept area round the hole: {float(ds['swept_area'].min()):.3g} .. "
            f"{float(ds['swept_area'].max()):.3g}"
        ),
        f"  stability: {int(((ds['stable'] == 1) & resolved).sum())} stable, "
        f"{int(((ds['stable'] == 0) & resolved).sum())} unstable, {int((~resolved).sum())} unresolved "
        f"of {ds.sizes['point']} points",
    ]
    if nnm2 is not None:
        e2, f2 = nnm2["energy"].values, nnm2["frequency"].values
        rising = np.all(np.diff(e2) > 0)
        if not rising:
            raise ValueError("the NNM2 dataset's energy is not increasing along the branch: cannot interpolate")
        inside = (e >= e2.min()) & (e <= e2.max())
        ref = np.interp(np.log(e[inside]), np.log(e2), f2)
        dev = np.abs(n * f[inside] - ref) / ref
        lines.append(
            f"  |{n} f - f_NNM2(E)| / f_NNM2 over {int(inside.sum())} points: max {dev.max():.2e}, median "
            f"{np.median(dev):.2e} "
            f"(NNM2 interpolated in ln E between its stored points)"
        )
    return "\n".join(lines)
