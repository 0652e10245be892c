"""Staged continuation of the regularized NNM branches, and branches switched at their branch points.

A branch (NNM1 or NNM2) starts from its linear mode near rest and is continued in *stages*: each
stage starts from the last point of the previous one and ends at the first point that meets its
``until`` criterion (:func:`stage_criterion`), so a figure that needs only the low-energy part of a
branch needs only the first stages; :func:`combine_stages` joins them. :func:`continue_stage` runs one
stage: continuation guarded against orbits the harmonics cannot resolve (:class:`TruncationGuard`),
location of the flagged branch points (:mod:`nnmstop.hbm.bifurcation`), Floquet stability
(:mod:`nnmstop.hbm.stability`), then dataset assembly (:mod:`nnmstop.hbm.dataset`).
:func:`bifurcated_branch` follows the curve that crosses a stage at the branch point of an ``n:1``
internal resonance. Everything here takes parameters and arrays (:class:`BranchSettings`,
:class:`BranchSpec`, :class:`BifurcationSpec`); :mod:`nnmstop.tasks.hbm` builds them from the
configuration. Method notes: ``docs/methods/hbm.md``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from nnmstop.continuation.anm import ANMSettings, continue_anm
from nnmstop.continuation.core import Branch, ContinuationStats, UnresolvedBranchError, newton_correct
from nnmstop.hbm.bifurcation import (
    branch_point_kind,
    continue_bifurcated_branch,
    locate_flagged_branch_points,
    subharmonic_share,
)
from nnmstop.hbm.dataset import (
    BRANCH_POINT_DIM,
    FOLD_DIM,
    bifurcated_dataset,
    branch_dataset,
    coefficient_vectors,
    dataset_unknowns,
    energy_folds,
    located_fold_variables,
)
from nnmstop.hbm.stability import StabilitySettings, orbit_stability
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.two_dof import ModelParameters, linear_modes

__all__ = [
    "CRITERIA",
    "BranchSettings",
    "StageSpec",
    "BranchSpec",
    "BifurcationSpec",
    "start_point",
    "stage_criterion",
    "TruncationGuard",
    "continue_stage",
    "stage_dataset",
    "combine_stages",
    "bifurcated_branch",
]

logger = logging.getLogger("nnmstop.hbm.stages")

CRITERIA = ("energy_above", "impacts_above", "impacts_at_most", "frequency_within_gap_zero")


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
        How the Floquet verdicts are computed.
    """

    continuation: ANMSettings
    max_truncation: float
    stability: StabilitySettings = field(default_factory=StabilitySettings)


@dataclass(frozen=True)
class StageSpec:
    """One stage: its name and its ``until`` criterion (one key of :data:`CRITERIA` and its value)."""

    name: str
    until: dict


@dataclass(frozen=True)
class BranchSpec:
    """A regularized NNM branch: name, mode index, start amplitude ``x_c^1`` and its stages."""

    name: str
    mode: int
    start_amplitude: float
    stages: tuple[StageSpec, ...]


@dataclass(frozen=True)
class BifurcationSpec:
    """A branch switched at the ``n:1`` branch point of stage ``stage`` of branch ``parent``.

    ``energy_range`` bounds the energy along the switched curve, ``switch_step`` is the first step
    along its tangent relative to ``|U*|`` (:func:`nnmstop.hbm.bifurcation.switch_branch`).
    """

    name: str
    parent: str
    resonance: int
    stage: int
    energy_range: tuple[float, float]
    switch_step: float


def start_point(system: HarmonicBalanceSystem, mode: int, amplitude: float):
    """A point of NNM ``mode`` at small amplitude, and the direction of growing amplitude.

    The linear mode of the regularized system (``x = amplitude cos(theta)``) is
    corrected by Newton with the amplitude ``x_c^1`` held fixed.
    """
    if not (np.isfinite(amplitude) and 0 < amplitude < 1):
        raise ValueError(f"start amplitude must lie in (0, 1) (inside the gap), got {amplitude!r}")
    U0 = system.linear_mode_guess(mode, amplitude)
    direction = np.zeros(system.n_unknowns)
    direction[system.slices["x"].start + 1] = 1.0
    U0, _ = newton_correct(system, U0, direction, ContinuationStats(), tol=1e-13)
    return U0, direction


def stage_criterion(until: dict, params: ModelParameters, mode: int):
    """Stop criterion ``stop(U, diagnostics) -> reason`` from a stage's ``until`` mapping.

    ``frequency_within_gap_zero: r`` stops within the relative distance ``r`` of the
    gap-0 linear mode of the same index ``mode`` as the branch.
    """
    if len(until) != 1 or next(iter(until)) not in CRITERIA:
        raise ValueError(f"a stage's 'until' must hold exactly one of {CRITERIA}, got {until!r}")
    ((kind, value),) = until.items()
    if kind == "energy_above":
        return lambda U, d: f"energy above {value:g}" if d["energy"] > value else ""
    if kind == "impacts_above":
        return lambda U, d: f"more than {value} impacts per period" if d["impacts_per_period"] > value else ""
    if kind == "impacts_at_most":
        return lambda U, d: f"at most {value} impacts per period" if d["impacts_per_period"] <= value else ""
    limit = linear_modes(params, "gap_zero")[0][mode - 1] / (2 * np.pi)

    def near_gap_zero(U, d):
        gap = abs(d["frequency"] - limit) / limit
        return f"frequency within {value:g} of the gap-0 linear mode {mode} ({limit:.6g} Hz)" if gap <= value else ""

    return near_gap_zero


@dataclass
class TruncationGuard:
    """Stop criterion wrapper that refuses orbits the harmonics do not resolve.

    Called like a stop criterion ``(U, diagnostics) -> reason``: raises
    :class:`~nnmstop.continuation.core.UnresolvedBranchError`, naming the energy, the
    truncation indicator (``diagnostics["truncation"]``, see
    :meth:`nnmstop.hbm.system.HarmonicBalanceSystem.truncation`) and ``H``, when the indicator
    exceeds ``limit``; otherwise defers to ``inner``. A continuation so guarded never
    returns a branch whose orbits its harmonics cannot represent. ``largest`` keeps the
    largest indicator seen; ``setting`` is the configuration key of ``limit``, for the
    message.
    """

    system: HarmonicBalanceSystem
    inner: Callable
    limit: float
    label: str = "NNM1"
    setting: str = "hbm.max_truncation"
    largest: float = 0.0
    points: int = 0

    def __post_init__(self):
        if not (np.isfinite(self.limit) and 0.0 < self.limit < 1.0):
            raise ValueError(f"{self.setting} must be a number in (0, 1), got {self.limit!r}")

    def __call__(self, U, diag) -> str:
        self.points += 1
        level = float(diag["truncation"])
        self.largest = max(self.largest, level)
        if level > self.limit:
            p = self.system.params
            raise UnresolvedBranchError(
                f"{self.label}: truncation indicator {level:.4g} > {self.setting} = {self.limit:g} at energy "
                f"{diag['energy']:.6g} (frequency {diag['frequency']:.6g} Hz, point {self.points - 1}): H = "
                f"{self.system.H} harmonics do not resolve the stop (alpha = {p.alpha:g}, eta = {p.eta:g}); "
                "more harmonics or a larger eta are needed"
            )
        return self.inner(U, diag)


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
    if located is None:
        located = locate_flagged_branch_points(system, U, branch.step, branch.branch_points, settings.continuation)
    started = time.perf_counter()
    time_residual = np.array([d["time_residual"] for d in branch.diagnostics])
    stability = orbit_stability(system, U, settings.stability, time_residual=time_residual)
    # Wall time in the log only (datasets stay byte-reproducible); benchmarks/cold_build.py reads it.
    logger.info(
        "stability of %d points in %.2f s (%s)", len(U), time.perf_counter() - started, settings.stability.method
    )
    return branch_dataset(system, branch, stage, located, stability, settings.continuation, labels)


def continue_stage(system, settings: BranchSettings, spec: BranchSpec, stage: int, previous=None) -> xr.Dataset:
    """Continue stage ``stage`` (1-based) of the branch ``spec`` and return its dataset.

    Stage 1 starts from the linear mode; stage ``k > 1`` starts from the last point of
    ``previous`` (the dataset of stage ``k - 1``), in the direction of its last secant.

    Raises
    ------
    ContinuationError
        With the branch, stage, step and energy where the continuation failed.
    """
    if not 1 <= stage <= len(spec.stages):
        raise ValueError(f"stage must be in 1..{len(spec.stages)} for branch {spec.name!r}, got {stage!r}")
    if stage == 1:
        U0, direction = start_point(system, spec.mode, spec.start_amplitude)
    else:
        if previous is None:
            raise ValueError(f"stage {stage} of {spec.name!r} needs the dataset of stage {stage - 1}")
        points = dataset_unknowns(previous, system)
        U0, direction = points[-1], points[-1] - points[-2]
    current = spec.stages[stage - 1]
    label = f"{spec.name} stage {stage} ({current.name})"
    stop = TruncationGuard(
        system, stage_criterion(current.until, system.params, spec.mode), settings.max_truncation, label
    )
    branch = continue_anm(system, U0, direction, stop, settings.continuation, label=label)
    labels = {"branch": spec.name, "mode": int(spec.mode), "stages": len(spec.stages)}
    return stage_dataset(system, branch, stage, settings, labels)


def combine_stages(stages: list[xr.Dataset]) -> xr.Dataset:
    """Concatenate the stage datasets of a branch (the repeated start points dropped)."""
    if not stages:
        raise ValueError("combine_stages needs at least one stage dataset")
    located = [v for v in stages[0].data_vars if BRANCH_POINT_DIM in stages[0][v].dims]
    folds = [v for v in stages[0].data_vars if FOLD_DIM in stages[0][v].dims]
    parts = [stages[0]] + [ds.isel(point=slice(1, None)) for ds in stages[1:]]
    parts = [ds.drop_vars(located + folds) for ds in parts]
    out = xr.concat(parts, dim="point", data_vars="all", coords="minimal", combine_attrs="override")
    if located:
        # point indices of each stage shift by the points of the stages before it (start points dropped)
        offsets = np.cumsum([0] + [ds.sizes["point"] - 1 for ds in stages[:-1]])
        pieces = []
        for ds, offset in zip(stages, offsets):
            piece = ds[located]
            piece["branch_point_flagged_point"] = piece["branch_point_flagged_point"] + offset
            pieces.append(piece)
        table = xr.concat(pieces, dim=BRANCH_POINT_DIM, combine_attrs="override")
        for v in located:
            table[v].attrs = stages[0][v].attrs
            out[v] = table[v]
    out = out.assign_coords(point=np.arange(out.sizes["point"]))
    out["point"].attrs = stages[0]["point"].attrs
    # folds at the junction of two stages are only visible on the combined branch
    out["energy_fold"].values[:] = energy_folds(out["energy"].values).astype(np.int8)
    if folds:
        out = out.assign(
            located_fold_variables(coefficient_vectors(out), out["energy"].values, out["frequency"].values)
        )
    out.attrs["end_reason"] = stages[-1].attrs["end_reason"]
    out.attrs["anm_steps"] = int(sum(ds.attrs["anm_steps"] for ds in stages))
    out.attrs["factorizations"] = int(sum(ds.attrs["factorizations"] for ds in stages))
    out.attrs["pade_steps"] = int(sum(ds.attrs.get("pade_steps", 0) for ds in stages))
    return out


def bifurcated_branch(system, settings: BranchSettings, spec: BifurcationSpec, parent_stage: xr.Dataset) -> xr.Dataset:
    """Dataset of the branch that bifurcates from a regularized branch at an ``n:1`` resonance.

    ``parent_stage`` is the dataset of stage ``spec.stage`` of ``spec.parent``; its branch points were
    located and classified when it was built (``branch_point_resonance``). The one of the
    ``spec.resonance:1`` resonance is located again (for ``U*``) and the other curve through it is
    followed both ways by the ANM until its energy leaves ``spec.energy_range``
    (:func:`nnmstop.hbm.bifurcation.continue_bifurcated_branch`).

    The dataset has the layout of a branch dataset, ordered along the curve through the branch point
    (``branch_point`` flags it), plus what :func:`nnmstop.hbm.dataset.bifurcated_dataset` adds.
    """
    parent, n = spec.parent, spec.resonance
    stages_in = np.unique(parent_stage["stage"].values) if "stage" in parent_stage else []
    if parent_stage.attrs.get("branch") != parent or list(stages_in) != [spec.stage]:
        raise ValueError(
            f"bifurcations.{spec.name}: expected the dataset of {parent} stage {spec.stage}, got branch "
            f"{parent_stage.attrs.get('branch')!r} stage(s) {list(stages_in)}"
        )
    if "branch_point_resonance" not in parent_stage:
        raise ValueError(
            f"bifurcations.{spec.name}: the {parent} stage dataset has no located branch points; rebuild it"
        )
    resonance = parent_stage["branch_point_resonance"].values
    match = np.flatnonzero(resonance == n)
    if match.size == 0:
        found = [
            f"energy {e:.6g} ({branch_point_kind(int(m), bool(b))})"
            for e, m, b in zip(
                parent_stage["branch_point_energy"].values,
                resonance,
                parent_stage["branch_point_symmetry_breaking"].values,
            )
        ]
        raise ValueError(
            f"no branch point of the {n}:1 resonance (orbit of period T/{n}) among the flagged steps of "
            f"{parent} stage {spec.stage}; found: " + ("; ".join(found) if found else "none")
        )
    flagged = [int(parent_stage["branch_point_flagged_point"].values[match[0]])]
    ((_, point, _, _),) = locate_flagged_branch_points(
        system, dataset_unknowns(parent_stage, system), parent_stage["step"].values, flagged, settings.continuation
    )
    low, high = spec.energy_range
    label = f"{spec.name} (bifurcated from {parent} at the {n}:1 resonance)"

    def out_of_range(U, d):
        return f"energy left [{low:g}, {high:g}]" if not low <= d["energy"] <= high else ""

    stop = TruncationGuard(system, out_of_range, settings.max_truncation, label)
    branch = continue_bifurcated_branch(system, point, stop, settings.continuation, spec.switch_step, label)
    ds = stage_dataset(
        system, branch, spec.stage, settings, {"branch": parent}, located=[(branch.branch_points[0], point, n, False)]
    )
    diag = system.diagnostics(point.U)
    described = {
        "branch_point_energy": float(diag["energy"]),
        "branch_point_frequency": float(diag["frequency"]),
        "tangent_angle": point.angle,
        "singular_ratio": point.singular_ratio,
    }
    share = [subharmonic_share(system, U, n) for U in branch.points]
    return bifurcated_dataset(ds, spec.name, parent, n, share, described, spec.switch_step)
