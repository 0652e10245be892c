"""The one staged continuation of the regularized NNM branches of any structure, and branches switched from them.

A branch starts from its linear mode near rest (:func:`start_point`) and is continued in *stages*:
each stage starts from the last point of the previous one and ends at the first point that meets its
condition (:func:`nnmstop.hbm.criteria.stage_condition`), so a figure that needs only the low-energy
part of a branch needs only the first stages. A stage whose condition never comes ends at its energy
bound, or where the harmonics stop resolving the orbits (:class:`~nnmstop.hbm.criteria.TruncationGuard`),
with the reason stored; the stages after it are skipped with that reason
(:func:`nnmstop.hbm.dataset.skipped_stage_dataset`). A stage may pass internal resonance tongues
(:mod:`nnmstop.hbm.tongues`). :func:`continue_stage` runs one stage: continuation, location of the
flagged branch points (:mod:`nnmstop.hbm.bifurcation`), Floquet stability, then the dataset
(:mod:`nnmstop.hbm.dataset`); :func:`combine_stages` joins the stages; :func:`bifurcated_branch`
follows the curve that crosses a branch at the branch point of an ``n:1`` internal resonance, wherever
the branch has one. Everything here takes a system, settings and datasets (:class:`BranchSettings`,
:class:`BranchSpec`, :class:`BifurcationSpec`); :mod:`nnmstop.tasks.hbm` builds them from the
configuration. Method notes: ``docs/methods/hbm.md``.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace

import numpy as np
import xarray as xr

from nnmstop.continuation.anm import ANMSettings, continue_anm
from nnmstop.continuation.confirm import ContinuationEnd, EndNotConfirmed, confirm_end
from nnmstop.continuation.core import Branch, ContinuationError, ContinuationStats, newton_correct, relative_residual
from nnmstop.hbm.bifurcation import (
    branch_point_kind,
    continue_bifurcated_branch,
    locate_flagged_branch_points,
    subharmonic_share,
)
from nnmstop.hbm.criteria import (
    CRITERIA,
    StageStop,
    TongueWatch,
    TruncationGuard,
    describe_condition,
    stage_condition,
)
from nnmstop.hbm.dataset import (
    BRANCH_POINT_DIM,
    FOLD_DIM,
    IDENTITY_CHANGE_DIM,
    bifurcated_dataset,
    branch_dataset,
    coefficient_vectors,
    dataset_unknowns,
    energy_folds,
    identity_change_variables,
    is_skipped,
    labelled,
    segment_fold_variables,
    skipped_stage_dataset,
)
from nnmstop.hbm.stability import StabilitySettings, orbit_stability
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.hbm.tongues import joined_segments, over_the_tongue
from nnmstop.models.structure import check_grounded

__all__ = [
    "CRITERIA",
    "BranchSettings",
    "StageSpec",
    "BranchSpec",
    "BifurcationSpec",
    "CROSSINGS",
    "MOTIONS",
    "branch_system",
    "start_point",
    "stage_criterion",
    "TruncationGuard",
    "follow_stage",
    "confirm_truncation_end",
    "checked_start",
    "continue_stage",
    "stage_dataset",
    "combine_stages",
    "bifurcated_branch",
]

logger = logging.getLogger("nnmstop.hbm.stages")

#: A stage that ends on the truncation guard is restarted END_BACK points before its first unresolved point
#: with steps END_REFINE times shorter than those it ended with (:func:`confirm_truncation_end`).
END_REFINE = 10.0
END_BACK = 2


@dataclass(frozen=True)
class BranchSettings:
    """Numerical settings shared by every stage and bifurcated branch.

    Attributes
    ----------
    continuation : ANMSettings
        Settings of the ANM continuation (``points_per_step`` included).
    max_truncation : float
        Largest truncation indicator accepted along a branch (:class:`TruncationGuard`), in (0, 1).
    stability : StabilitySettings
        How the Floquet verdicts are computed (:func:`nnmstop.hbm.stability.orbit_stability`, any structure).
    start_tolerance : float
        Relative residual to which the start point is corrected (:func:`start_point`).
    truncation_setting : str
        Configuration key of ``max_truncation``, for messages.
    """

    continuation: ANMSettings
    max_truncation: float
    stability: StabilitySettings = field(default_factory=StabilitySettings)
    start_tolerance: float = 1e-13
    truncation_setting: str = "hbm.max_truncation"


@dataclass(frozen=True)
class StageSpec:
    """One stage: its name, its ``until`` condition (one key of :data:`CRITERIA` and its value), its bound.

    ``energy_max``: the stage ends at the first point above this energy if its condition has not come
    (None: the branch's ``energy_max``); ``pass_resonances``: internal resonance tongues the stage passes
    (:mod:`nnmstop.hbm.tongues`).
    """

    name: str
    until: dict
    energy_max: float | None = None
    pass_resonances: int = 0

    def __post_init__(self):
        describe_condition(self.until)  # refuses an unknown condition
        if not (isinstance(self.pass_resonances, (int, np.integer)) and self.pass_resonances >= 0):
            raise ValueError(
                f"stage {self.name!r}: pass_resonances must be an integer >= 0, got {self.pass_resonances!r}"
            )


#: How a branch moves: ``planar`` orbits start from a linear mode, ``whirl`` orbits from that mode whirling (a
#: structure invariant under rotations: :meth:`~nnmstop.hbm.system.HarmonicBalanceSystem.whirl_guess`).
MOTIONS = ("planar", "whirl")


@dataclass(frozen=True)
class BranchSpec:
    """A regularized NNM branch: name, mode index, start amplitude ``x_c^1``, stages and their default bound.

    ``energy_max`` bounds every stage that gives no bound of its own; ``resonance_margin`` (relative
    frequency) is how far beyond a tongue the backbone is taken up again (:mod:`nnmstop.hbm.tongues`).
    ``motion`` (:data:`MOTIONS`): ``whirl`` starts from the mode whirling, on the system of
    :func:`branch_system` (full basis, no rotation phase condition).
    """

    name: str
    mode: int
    start_amplitude: float
    stages: tuple[StageSpec, ...]
    energy_max: float = 1.5e5
    resonance_margin: float = 1e-3
    motion: str = "planar"

    def __post_init__(self):
        if self.motion not in MOTIONS:
            raise ValueError(f"branch {self.name!r}: motion must be one of {MOTIONS}, got {self.motion!r}")
        if not (np.isfinite(self.energy_max) and self.energy_max > 0):
            raise ValueError(f"branch {self.name!r}: energy_max must be finite and > 0, got {self.energy_max!r}")
        if not 0 < self.resonance_margin < 0.1:
            raise ValueError(
                f"branch {self.name!r}: resonance_margin must lie in (0, 0.1), got {self.resonance_margin!r}"
            )


#: Which branch point a switched branch starts from: an ``n:1`` internal ``resonance``, or where planar motion in a
#: circular clearance gives way to ``whirl`` (:func:`nnmstop.hbm.bifurcation.is_whirl_branch_point`).
CROSSINGS = ("resonance", "whirl")


@dataclass(frozen=True)
class BifurcationSpec:
    """The branch switched at the first ``n:1`` branch point of branch ``parent`` (``crossing="whirl"``: at its
    first branch point where planar motion gives way to whirl), wherever it lies.

    ``energy_range`` bounds the energy along the switched curve, ``switch_step`` is the first step
    along its tangent relative to ``|U*|`` (:func:`nnmstop.hbm.bifurcation.switch_branch`).
    """

    name: str
    parent: str
    resonance: int
    energy_range: tuple[float, float]
    switch_step: float
    crossing: str = "resonance"

    def __post_init__(self):
        if self.crossing not in CROSSINGS:
            raise ValueError(f"bifurcations.{self.name}: crossing must be one of {CROSSINGS}, got {self.crossing!r}")


def branch_system(system: HarmonicBalanceSystem, spec: BranchSpec) -> HarmonicBalanceSystem:
    """The system a branch is continued on: ``system`` itself, or for a whirling branch the same structure and
    harmonics in the full basis without the rotation phase condition (a circle turned is the circle shifted in
    time: one phase condition fixes both)."""
    if spec.motion == "planar" or (system.full and not system.rotation):
        return system
    return HarmonicBalanceSystem(
        system.structure, system.H, system.M, basis="full", linear_algebra=system.linear_algebra, rotation=False
    )


def start_point(system: HarmonicBalanceSystem, mode: int, amplitude: float, tol: float = 1e-13, motion="planar"):
    """A point of NNM ``mode`` at small amplitude, and the direction of growing amplitude.

    The linear mode of the regularized system (the first stop's coordinate ``x = amplitude cos(theta)``,
    :meth:`~nnmstop.hbm.system.HarmonicBalanceSystem.linear_mode_guess`; with ``motion="whirl"`` the mode
    whirling, :meth:`~nnmstop.hbm.system.HarmonicBalanceSystem.whirl_guess`) is corrected by Newton, to the
    relative residual ``tol``, with the amplitude of that coordinate held fixed
    (:meth:`~nnmstop.hbm.system.HarmonicBalanceSystem.amplitude_direction`).
    """
    if not (np.isfinite(amplitude) and 0 < amplitude < 1):
        raise ValueError(f"start amplitude must lie in (0, 1) (inside the gap), got {amplitude!r}")
    guess = system.whirl_guess if motion == "whirl" else system.linear_mode_guess
    U0 = guess(mode, amplitude)
    direction = system.amplitude_direction(mode)
    U0, _ = newton_correct(system, U0, direction, ContinuationStats(), tol=tol)
    return U0, direction


def stage_criterion(until: dict, system, mode: int):
    """A stage's condition as a stop criterion ``stop(U, diagnostics) -> reason`` on ``system``.

    See :func:`nnmstop.hbm.criteria.stage_condition` for the conditions.
    """
    condition = stage_condition(until, system.structure, mode)
    return lambda U, d: condition(U, d, system)


def _branch_stability(system, U, settings: StabilitySettings, time_residual):
    started = time.perf_counter()
    stability = orbit_stability(system, U, settings, time_residual=time_residual)
    # Wall time in the log only (datasets stay byte-reproducible); benchmarks/cold_build.py reads it.
    logger.info("stability of %d points in %.2f s (%s)", len(U), time.perf_counter() - started, settings.method)
    return stability


def _locate(system, U, branch: Branch, continuation) -> tuple[list, int]:
    """The flagged branch points located one by one; those that cannot be are counted, not fatal.

    Not every flagged step holds a simple branch point: where the continuation jumped between two close
    curves the determinant changes sign without one, and the least-norm Newton finds no point there.
    """
    located, unlocated = [], 0
    for i in branch.branch_points:
        try:
            located += locate_flagged_branch_points(system, U, branch.step, [i], continuation)
        except (ValueError, ContinuationError) as err:
            logger.warning("branch point flagged at point %d not located: %s", i, err)
            unlocated += 1
    return located, unlocated


def stage_dataset(
    system, branch: Branch, stage: int, settings: BranchSettings, labels: dict, located=None
) -> xr.Dataset:
    """Dataset of a continued branch: branch points located, stability computed, then assembled.

    ``located``: the located branch points (:func:`nnmstop.hbm.bifurcation.locate_flagged_branch_points`);
    by default the flagged steps of ``branch`` are located here (``[]`` skips the location).
    ``labels``: global attributes naming the branch (:func:`nnmstop.hbm.dataset.branch_dataset`).
    """
    U = np.array(branch.points)
    branch.diagnostics = [d if d is not None else system.diagnostics(u) for u, d in zip(U, branch.diagnostics)]
    unlocated = 0
    if located is None:
        located, unlocated = _locate(system, U, branch, settings.continuation)
    time_residual = np.array([d["time_residual"] for d in branch.diagnostics])
    stability = _branch_stability(system, U, settings.stability, time_residual)
    return branch_dataset(system, branch, stage, located, stability, settings.continuation, labels, unlocated)


def _follow(system, U, direction, stop: StageStop, settings: BranchSettings, label: str, restart_stop=None) -> Branch:
    """One segment of a stage; a point the harmonics do not resolve ends it, is confirmed, and is dropped.

    ``restart_stop()``: a fresh stop criterion of the segment, for the restart that confirms a truncation
    end (:func:`confirm_truncation_end`); ``end_check`` says how the end was checked.
    """
    branch = continue_anm(system, U, direction, stop, settings.continuation, label=label)
    branch.end_check = f"located: {stop.ended_by} reached at a stored point (the stage's own end, nothing to confirm)"
    if stop.ended_by == "truncation":
        if restart_stop is not None:
            branch.end_check = confirm_truncation_end(system, branch, settings, restart_stop, label)
        for key in ("points", "step", "diagnostics", "arclength"):
            del getattr(branch, key)[-1:]
        branch.branch_points = [i for i in branch.branch_points if i < len(branch.points)]
    return branch


def _step_lengths(branch: Branch) -> np.ndarray:
    """Length (path parameter) of the continuation step that produced each point (0 for the start point)."""
    arclength, steps = np.asarray(branch.arclength, dtype=float), np.asarray(branch.step)
    lengths = np.zeros(len(steps))
    for s in np.unique(steps[steps > 0]):
        before = arclength[np.flatnonzero(steps < s)[-1]]
        lengths[steps == s] = arclength[np.flatnonzero(steps == s)[-1]] - before
    return lengths


def _truncation_end(branch: Branch, ended_by: str, step: float) -> ContinuationEnd:
    """The end of a stage's segment as :func:`~nnmstop.continuation.confirm.confirm_end` compares it.

    A truncation end is an event of the curve (the indicator crossing its limit) known to the last stored
    spacing (the first unresolved point, not located between it and the last resolved one).
    """
    end = ContinuationEnd.of_branch(branch, step)
    return replace(end, event="truncation" if ended_by == "truncation" else "")


def confirm_truncation_end(system, branch: Branch, settings: BranchSettings, restart_stop, label: str) -> str:
    """Confirm that a stage ends where its harmonics stop resolving the orbits, not where a long step left the curve.

    The segment is restarted :data:`END_BACK` points before its first unresolved point with ANM steps at
    most ``1 / END_REFINE`` of the steps it ended with (``ANMSettings.max_step``); the restart must end on
    the truncation guard too, within the two runs' stored spacings of the first end
    (:func:`nnmstop.continuation.confirm.confirm_end`).

    Raises
    ------
    EndNotConfirmed
        Naming the stage, both ends and what to change.
    """
    back = min(END_BACK, len(branch.points) - 1)
    step = float(np.max(_step_lengths(branch)[-back:])) if back > 0 else 0.0

    def restart(U, direction, fine_step):
        stop = restart_stop()
        finer = replace(settings.continuation, max_step=fine_step)
        again = continue_anm(system, U, direction, stop, finer, label=f"{label} (end check)")
        return _truncation_end(again, stop.ended_by, fine_step)

    end = _truncation_end(branch, "truncation", step)
    try:
        message = confirm_end(end, restart, step, refine=END_REFINE, back=back, label=label)
    except EndNotConfirmed as err:
        raise EndNotConfirmed(
            f"{err}. The steps were too long where it ended: rebuild with a smaller anm.tolerance "
            f"(shorter steps); if the restart went on past the first end, the harmonics resolve the orbits "
            f"there and {settings.truncation_setting} is not what ends the branch"
        ) from err
    logger.info("%s: %s", label, message)
    return message


def follow_stage(system, settings: BranchSettings, spec: BranchSpec, stage: int = 1, start=None) -> Branch:
    """The continued stage ``stage`` of ``spec``: its segments over the tongues it passes, joined.

    ``start``: the start point and direction ``(U0, direction)``; by default the start point of the branch
    (:func:`start_point`). The returned branch has ``segment`` (of every point), ``resonances`` (the tongues
    passed, :class:`~nnmstop.hbm.tongues.PassedResonance`) and ``ended_by`` (``"condition"``, ``"bound"``
    or ``"truncation"``: the unresolved point is dropped).
    """
    if start is None:
        check_grounded(system.structure, f"branch {spec.name}")
        start = start_point(system, spec.mode, spec.start_amplitude, settings.start_tolerance, spec.motion)
    U0, direction = start
    current = spec.stages[stage - 1]
    label = f"{spec.name} stage {stage} ({current.name})"
    bound = spec.energy_max if current.energy_max is None else current.energy_max
    condition = stage_condition(current.until, system.structure, spec.mode)
    segments, resonances, ended_by = [], [], ""
    for k in range(current.pass_resonances + 1):
        tongue = TongueWatch() if k < current.pass_resonances else None
        stop = StageStop(system, condition, bound, settings.max_truncation, label, tongue, settings.truncation_setting)
        name = label if current.pass_resonances == 0 else f"{label} segment {k}"

        def restart_stop(watch=tongue is not None):  # a fresh condition and tongue watch: no memory of the first run
            fresh = stage_condition(current.until, system.structure, spec.mode)
            watch = TongueWatch() if watch else None
            return StageStop(system, fresh, bound, settings.max_truncation, label, watch, settings.truncation_setting)

        segments.append(_follow(system, U0, direction, stop, settings, name, restart_stop))
        ended_by = stop.ended_by
        if ended_by != "tongue":
            break
        resonance, U0, direction = over_the_tongue(
            system, segments[-1], settings.continuation, spec.resonance_margin, name
        )
        resonances.append(resonance)
    branch = joined_segments(segments)
    branch.resonances = resonances
    branch.ended_by = ended_by
    branch.end_check = segments[-1].end_check
    return branch


def _previous_end(previous: xr.Dataset | None, spec: BranchSpec, stage: int) -> str:
    """Why stage ``stage`` is skipped (the stage before it ended without its condition), or ""."""
    if previous is None:
        raise ValueError(f"stage {stage} of {spec.name!r} needs the dataset of stage {stage - 1}")
    if is_skipped(previous):
        return str(previous.attrs["end_reason"])
    if not int(previous.attrs.get("stage_condition_met", 1)):
        before = spec.stages[stage - 2]
        return (
            f"skipped: stage {stage - 1} ({before.name}) ended without its condition "
            f"({describe_condition(before.until)}): {previous.attrs['end_reason']}"
        )
    return ""


def checked_start(previous: xr.Dataset, system, spec: BranchSpec, stage: int, threshold: float):
    """The start of stage ``stage``: the last point of ``previous`` and the direction of its last secant.

    The start orbit is checked against what ``previous`` stores: it must be a point of the branch, its
    residual recomputed within ten times the larger of the stored one and ``threshold``.

    Raises
    ------
    ValueError
        Naming the file of ``previous`` (a corrupted or foreign file), the residuals, or the mismatch.
    """
    source = previous.encoding.get("source", f"the dataset of {spec.name} stage {stage - 1}")
    held = np.unique(previous["stage"].values)
    if previous.attrs.get("branch") != spec.name or list(held) != [stage - 1]:
        raise ValueError(
            f"{source}: stage {stage} of {spec.name} starts from stage {stage - 1} of {spec.name}, this file holds "
            f"branch {previous.attrs.get('branch')!r} stage(s) {list(held)}"
        )
    if previous.sizes["point"] < 2:
        raise ValueError(f"{source}: stage {stage - 1} holds {previous.sizes['point']} point(s), no direction to go on")
    try:
        points = dataset_unknowns(previous.isel(point=slice(-2, None)), system)
    except ValueError as err:
        raise ValueError(f"{source}: {err}") from None
    residual = relative_residual(system, points[-1])
    stored = float(previous["algebraic_residual"].values[-1])
    if not (np.all(np.isfinite(points)) and residual <= 10 * max(stored, threshold)):
        raise ValueError(
            f"{source}: its last orbit, the start of stage {stage} of {spec.name}, is not a point of the branch: "
            f"residual {residual:.3g} recomputed, {stored:.3g} stored (a corrupted file, or one made with other "
            "settings); rebuild it"
        )
    return points[-1], points[-1] - points[-2]


def continue_stage(system, settings: BranchSettings, spec: BranchSpec, stage: int, previous=None) -> xr.Dataset:
    """Continue stage ``stage`` (1-based) of the branch ``spec`` and return its dataset.

    Stage 1 starts from the linear mode; stage ``k > 1`` starts from the last point of ``previous``
    (the dataset of stage ``k - 1``), in the direction of its last secant, or is skipped (a dataset with
    no point saying why) when stage ``k - 1`` ended without its condition. The dataset's attributes
    ``stage_name``, ``stage_condition``, ``stage_condition_met``, ``stage_end`` (``condition``, ``bound`` or
    ``truncation``) and ``end_reason`` say how it ended.

    Raises
    ------
    ContinuationError
        With the branch, stage, step and energy where the continuation failed.
    """
    if not 1 <= stage <= len(spec.stages):
        raise ValueError(f"stage must be in 1..{len(spec.stages)} for branch {spec.name!r}, got {stage!r}")
    system = branch_system(system, spec)
    current = spec.stages[stage - 1]
    labels = {
        "branch": spec.name,
        "mode": int(spec.mode),
        "stages": len(spec.stages),
        "stage_name": current.name,
        "stage_condition": describe_condition(current.until),
        **({"motion": spec.motion} if spec.motion != "planar" else {}),
    }
    start = None
    if stage > 1:
        skipped = _previous_end(previous, spec, stage)
        if skipped:
            logger.info("%s stage %d (%s) %s", spec.name, stage, current.name, skipped)
            return skipped_stage_dataset(system, stage, labels, skipped)
        start = checked_start(previous, system, spec, stage, settings.continuation.newton_threshold)
    branch = follow_stage(system, settings, spec, stage, start)
    labels["stage_condition_met"] = int(branch.ended_by == "condition")
    labels["stage_end"] = branch.ended_by
    labels["end_check"] = branch.end_check
    return stage_dataset(system, branch, stage, settings, labels)


def _combined_segments(stages: list[xr.Dataset]) -> list[np.ndarray]:
    """Segment numbers of each stage's points on the joined branch (a stage continues the last segment)."""
    out, offset = [], 0
    for ds in stages:
        segment = ds["segment"].values + offset
        out.append(segment)
        offset = int(segment[-1])
    return out


def combine_stages(stages: list[xr.Dataset]) -> xr.Dataset:
    """Concatenate the stage datasets of a branch (the repeated start points dropped, skipped stages left out).

    Raises
    ------
    ValueError
        If no stage holds a point.
    """
    if not stages:
        raise ValueError("combine_stages needs at least one stage dataset")
    held = [ds for ds in stages if not is_skipped(ds)]
    if not held:
        raise ValueError("combine_stages: every stage dataset is empty (skipped)")
    held = [
        ds.assign(segment=(ds["segment"].dims, s, ds["segment"].attrs)) for ds, s in zip(held, _combined_segments(held))
    ]
    located = [v for v in held[0].data_vars if BRANCH_POINT_DIM in held[0][v].dims]
    folds = [v for v in held[0].data_vars if FOLD_DIM in held[0][v].dims]
    changes = [v for v in held[0].data_vars if IDENTITY_CHANGE_DIM in held[0][v].dims]
    parts = [held[0]] + [ds.isel(point=slice(1, None)) for ds in held[1:]]
    parts = [ds.drop_vars(located + folds + changes) for ds in parts]
    per_point = [v for v in parts[0].data_vars if "point" in parts[0][v].dims]
    out = xr.concat(parts, dim="point", data_vars=per_point, coords="minimal", combine_attrs="override")
    # point indices of each stage shift by the points of the stages before it (start points dropped)
    offsets = np.cumsum([0] + [ds.sizes["point"] - 1 for ds in held[:-1]])
    pieces = []
    for ds, offset in zip(held, offsets):
        piece = ds[located]
        piece["branch_point_flagged_point"] = piece["branch_point_flagged_point"] + offset
        pieces.append(piece)
    table = xr.concat(pieces, dim=BRANCH_POINT_DIM, combine_attrs="override")
    for v in located:
        table[v].attrs = held[0][v].attrs
        out[v] = table[v]
    out = out.assign_coords(point=np.arange(out.sizes["point"]))
    out["point"].attrs = held[0]["point"].attrs
    # folds at the junction of two stages are only visible on the combined branch
    segment = out["segment"].values
    out["energy_fold"].values[:] = np.concatenate(
        [energy_folds(out["energy"].values[segment == k]) for k in np.unique(segment)]
    ).astype(np.int8)
    out = out.assign(
        segment_fold_variables(coefficient_vectors(out), out["energy"].values, out["frequency"].values, segment)
    )
    out = out.assign(identity_change_variables(out, out["energy"].values, out["frequency"].values))
    return labelled(_combined_attributes(out, stages, held))


def _combined_attributes(out: xr.Dataset, stages: list[xr.Dataset], held: list[xr.Dataset]) -> xr.Dataset:
    """The joined branch's attributes: how its last continued stage ended, which stages were skipped and why."""
    out.attrs["end_reason"] = held[-1].attrs["end_reason"]
    if "end_check" in held[-1].attrs:
        out.attrs["end_check"] = held[-1].attrs["end_check"]
    skipped = [int(ds.attrs["skipped_stage"]) for ds in stages if is_skipped(ds) and "skipped_stage" in ds.attrs]
    if skipped:
        out.attrs["skipped_stages"] = np.array(skipped, dtype=np.int32)
        out.attrs["skip_reason"] = str(next(ds for ds in stages if is_skipped(ds)).attrs["end_reason"])
    for key in ("anm_steps", "factorizations", "pade_steps", "unlocated_branch_points", "passed_resonances"):
        out.attrs[key] = int(sum(int(ds.attrs.get(key, 0)) for ds in held))
    for key in ("stage_name", "stage_condition", "stage_condition_met", "stage_end"):
        out.attrs.pop(key, None)
    return out


def _parent_stage_rows(parent: xr.Dataset, flagged: int) -> tuple[xr.Dataset, int]:
    """The rows of the stage holding point ``flagged``, as that stage continued them (its start point first).

    On a joined branch a stage's start point is the last point of the stage before it; its step index is
    set back to 0, as in the stage's own dataset, so that the step holding ``flagged`` starts where it did.
    """
    stage = parent["stage"].values
    rows = np.flatnonzero(stage == stage[flagged])
    first = int(rows[0]) - 1 if rows[0] > 0 else 0
    part = parent.isel(point=slice(first, int(rows[-1]) + 1))
    steps = part["step"].values.copy()
    steps[0] = 0 if first < rows[0] else steps[0]
    return part.assign(step=(part["step"].dims, steps, part["step"].attrs)), flagged - first


def _resonance_point(system, settings: BranchSettings, spec: BifurcationSpec, parent: xr.Dataset):
    """The located ``n:1`` (or whirl) branch point of ``parent`` and the stage holding it, or the reason there is
    none."""
    resonance = parent["branch_point_resonance"].values if "branch_point_resonance" in parent else np.zeros(0)
    match = np.flatnonzero(resonance == spec.resonance)
    if spec.crossing == "whirl":
        whirl = parent["branch_point_whirl"].values if "branch_point_whirl" in parent else np.zeros_like(resonance)
        match = np.flatnonzero(whirl == 1)
    if match.size == 0:
        found = (
            [
                f"energy {e:.6g} ({branch_point_kind(int(m), bool(b))})"
                for e, m, b in zip(
                    parent["branch_point_energy"].values, resonance, parent["branch_point_symmetry_breaking"].values
                )
            ]
            if resonance.size
            else []
        )
        wanted = (
            "where planar motion gives way to whirl"
            if spec.crossing == "whirl"
            else f"of the {spec.resonance}:1 resonance (orbit of period T/{spec.resonance})"
        )
        located = "; ".join(found) if found else "none"
        reason = f"no branch point {wanted} on {spec.parent.upper()}; located: {located}"
        return None, None, reason
    flagged = int(parent["branch_point_flagged_point"].values[match[0]])
    rows, index = _parent_stage_rows(parent, flagged)
    ((_, point, _, _),) = locate_flagged_branch_points(
        system, dataset_unknowns(rows, system), rows["step"].values, [index], settings.continuation
    )
    return point, int(parent["stage"].values[flagged]), ""


def _resolved_ends(branch: Branch, limit: float) -> Branch:
    """``branch`` without the end points (either side of a switched branch) that the harmonics do not resolve.

    Each side of a switched curve ends where its energy leaves the range or at its first unresolved orbit
    (:class:`TruncationGuard` with ``end_branch``): that orbit is dropped, as a stage drops it.
    """
    first = 1 if branch.diagnostics[0]["truncation"] > limit else 0
    last = len(branch.points) - (1 if branch.diagnostics[-1]["truncation"] > limit else 0)
    out = Branch(
        stats=branch.stats, end_reason=branch.end_reason, end_tangent=branch.end_tangent, end_check=branch.end_check
    )
    for U, step, diagnostics in zip(branch.points[first:last], branch.step[first:last], branch.diagnostics[first:last]):
        out.add(U, step, diagnostics)
    out.branch_points = [i - first for i in branch.branch_points if first <= i < last]
    return out


def bifurcated_branch(system, settings: BranchSettings, spec: BifurcationSpec, parent: xr.Dataset) -> xr.Dataset:
    """Dataset of the branch that bifurcates from a regularized branch at an ``n:1`` resonance.

    ``parent`` is the whole branch ``spec.parent`` (its stages joined); its branch points were located
    and classified when its stages were built (``branch_point_resonance``). The first one of the
    ``spec.resonance:1`` resonance is located again (for ``U*``) on the steps of its stage, and the other
    curve through it is followed both ways by the ANM until its energy leaves ``spec.energy_range``
    (:func:`nnmstop.hbm.bifurcation.continue_bifurcated_branch`). Where the parent has no such branch
    point the dataset holds no point and says so (``skipped``, ``end_reason``).

    The dataset has the layout of a branch dataset, ordered along the curve through the branch point
    (``branch_point`` flags it), plus what :func:`nnmstop.hbm.dataset.bifurcated_dataset` adds.
    """
    if parent.attrs.get("branch") != spec.parent or "stage" not in parent:
        raise ValueError(
            f"bifurcations.{spec.name}: expected the branch dataset of {spec.parent}, got branch "
            f"{parent.attrs.get('branch')!r}"
        )
    n = spec.resonance if spec.crossing == "resonance" else 0
    point, stage, reason = _resonance_point(system, settings, spec, parent)
    labels = {"branch": spec.name, "parent_branch": spec.parent, "resonance": n, "switch_step": spec.switch_step}
    if point is None:
        logger.info("bifurcations.%s: %s", spec.name, reason)
        return skipped_stage_dataset(system, 0, labels, reason)
    low, high = spec.energy_range
    where = f"the {n}:1 resonance" if n else "planar motion giving way to whirl"
    label = f"{spec.name} (bifurcated from {spec.parent} at {where})"

    def out_of_range(U, d):
        return f"energy left [{low:g}, {high:g}]" if not low <= d["energy"] <= high else ""

    def guard():
        return TruncationGuard(
            system, out_of_range, settings.max_truncation, label, settings.truncation_setting, end_branch=True
        )

    def side_end(side: Branch, side_label: str) -> str:
        if side.diagnostics[-1]["truncation"] <= settings.max_truncation:
            return f"located: {side.end_reason} (the energy range's end, nothing to confirm)"
        return confirm_truncation_end(system, side, settings, guard, side_label)

    branch = _resolved_ends(
        continue_bifurcated_branch(
            system, point, guard(), settings.continuation, spec.switch_step, label, end_check=side_end
        ),
        settings.max_truncation,
    )
    ds = stage_dataset(
        system,
        branch,
        stage,
        settings,
        {"branch": spec.parent, "end_check": branch.end_check},
        located=[(branch.branch_points[0], point, n, False)],
    )
    diag = system.diagnostics(point.U)
    described = {
        "branch_point_energy": float(diag["energy"]),
        "branch_point_frequency": float(diag["frequency"]),
        "tangent_angle": point.angle,
        "singular_ratio": point.singular_ratio,
    }
    share = [subharmonic_share(system, U, n) for U in branch.points] if n else None
    return bifurcated_dataset(ds, spec.name, spec.parent, n, share, described, spec.switch_step)
