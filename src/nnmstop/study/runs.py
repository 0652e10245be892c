"""Shared pieces of the study: a guarded, timed continuation of NNM1, matched-energy errors, and why
a value is missing.

* :func:`run_stage_one` continues stage 1 of the regularized NNM1 with the engine's
  :class:`~nnmstop.hbm.stages.TruncationGuard` (the study's own ``max_truncation``), an
  optional energy limit and no branch-point location, and measures its wall-clock and CPU
  time and its cost counters. The ends the method expects (the guard refuses an orbit: H too
  small; the engine's :class:`~nnmstop.continuation.core.ContinuationError`: ``max_steps``
  exhausted or a step it could not take) become :attr:`StageRun.status` and
  :attr:`StageRun.failure`; any other exception propagates and fails the job.
* :func:`match_energies` compares a regularized branch with the exact orbits at given
  energies through :mod:`nnmstop.compare.matching`, on the increasing-energy run chosen by
  :func:`two_impact_arm`; an energy outside the common range, or where the comparison does not
  apply (:class:`~nnmstop.compare.matching.NotComparableError`), gets its :class:`Status`;
  :func:`hbm_orbit_differences` compares two HBM orbits (``H`` against a reference ``H``) the
  same way.
* :class:`~nnmstop.study.status.Status` says why a value was not computed. The datasets hold
  plain arrays (:func:`floats`, :func:`texts`, :func:`flags`), NaN where a value was not
  computed; their metadata, and which variables give the reason of each missing value, are in
  :mod:`nnmstop.catalogue.study` (checked when written: a missing value with no reason is refused).

Method notes (why the guard, why the increasing run, what each status means):
``docs/methods/study.md``.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import xarray as xr

from nnmstop.compare.matching import (
    EnergyMatcher,
    NotComparableError,
    OutsideRangeError,
    exact_increasing_arm,
    largest_differences,
    orbit_differences,
    regularized_orbit_on_phase,
)
from nnmstop.continuation.anm import continue_anm
from nnmstop.continuation.core import ContinuationError, ContinuationStats, UnresolvedBranchError, newton_correct
from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.stages import TruncationGuard, stage_criterion, stage_dataset, start_point
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.settings import StageOneRun
from nnmstop.study.status import Status

__all__ = [
    "Status",
    "UnresolvedBranchError",
    "TruncationGuard",
    "StageRun",
    "MatchedErrors",
    "format_number",
    "run_stage_one",
    "case_status",
    "two_impact_arm",
    "match_energies",
    "hbm_orbit_differences",
    "path_error",
    "floats",
    "texts",
    "flags",
]

logger = logging.getLogger("nnmstop.study")

#: Per-energy quantities of :func:`match_energies` (keys of :class:`MatchedErrors`).
ERROR_KEYS = (
    "relative_frequency_difference",
    "max_x_difference",
    "max_u_difference",
    "max_force_difference",
    "force_max_exact",
)


# --------------------------------------------------------------------------- configuration


def format_number(value: float) -> str:
    """Compact text of a number for file names and wildcards: ``0.001``, ``1e-08``, ``1e06``."""
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"cannot format the non-finite value {value!r} for a file name")
    return f"{value:g}".replace("e+", "e")


# --------------------------------------------------------------------------- one guarded run


@dataclass
class StageRun:
    """A timed, guarded continuation of NNM1 stage 1.

    Attributes
    ----------
    dataset : xarray.Dataset or None
        Branch dataset (layout of :mod:`nnmstop.hbm.dataset`); None when the run ended early.
    status : Status
        ``COMPUTED``, ``UNRESOLVED`` (the guard refused an orbit) or ``CONTINUATION_ENDED``.
    failure : str
        Why the run ended early ('' when it reached the end of its stage): the engine's message,
        naming the step and the energy (and the truncation indicator and ``H`` for the guard).
    runtime, cpu_time : float
        Wall-clock and CPU seconds of the continuation (start point included).
    stats : ContinuationStats or None
        Cost counters (None when the run ended early: the engine does not return them then).
    truncation : float
        Largest truncation indicator (:meth:`~nnmstop.hbm.system.HarmonicBalanceSystem.truncation`) met
        along the run (up to its end).
    harmonics : int
    """

    dataset: xr.Dataset | None
    status: Status
    failure: str
    runtime: float
    cpu_time: float
    stats: ContinuationStats | None
    truncation: float
    harmonics: int

    @property
    def converged(self) -> bool:
        return self.status == Status.COMPUTED


def run_stage_one(run: StageOneRun, label: str = "NNM1 stage 1", energy_limit: float | None = None) -> StageRun:
    """Continue stage 1 of ``run.branch`` with a :class:`TruncationGuard` at ``run.max_truncation``; time it.

    ``energy_limit`` (optional) also ends the stage at the first orbit above that energy
    (past the range that will be compared), whichever comes first.

    An orbit refused by the guard (:class:`~nnmstop.continuation.core.UnresolvedBranchError`) or
    another :class:`~nnmstop.continuation.core.ContinuationError` of the engine (``max_steps``
    exhausted, a step that cannot be taken) becomes ``StageRun.status`` and ``StageRun.failure``.
    Any other exception (a bug, NaN reaching a solve outside the continuation loop) propagates.
    """
    system = run.system()
    spec = run.branch
    inner = stage_criterion(spec.stages[0].until, system, spec.mode)
    if energy_limit is not None:
        stage_end, limit = inner, float(energy_limit)

        def inner(U, diag):  # noqa: F811 - the stage criterion, or the energy limit first
            past = diag["energy"] > limit
            return stage_end(U, diag) or (f"energy above {limit:g} (past the compared range)" if past else "")

    guard = TruncationGuard(system, inner, run.max_truncation, label, setting="study.max_truncation")
    wall, cpu = time.perf_counter(), time.process_time()
    dataset, status, failure, stats = None, Status.COMPUTED, "", None
    try:
        U0, direction = start_point(system, spec.mode, spec.start_amplitude)
        branch = continue_anm(system, U0, direction, guard, run.continuation, label=label, progress_seconds=30.0)
        stats = branch.stats
    except UnresolvedBranchError as err:
        status, failure = Status.UNRESOLVED, str(err)
    except ContinuationError as err:
        status, failure = Status.CONTINUATION_ENDED, str(err)
    runtime, cpu_time = time.perf_counter() - wall, time.process_time() - cpu
    if status == Status.COMPUTED:
        # the study compares orbits: branch points stay flagged, not located (costly, unused here)
        labels = {"branch": spec.name, "mode": int(spec.mode), "stages": len(spec.stages)}
        dataset = stage_dataset(system, branch, 1, run.branch_settings(), labels, located=[])
    logger.info("%s, H = %d: %s in %.2f s", label, system.H, failure or "converged", runtime)
    return StageRun(dataset, status, failure, runtime, cpu_time, stats, guard.largest, system.H)


def case_status(run_status: Status, energy_status) -> Status:
    """The status of a case: its run's when the run ended early, else the first energy's that was not
    compared (``COMPUTED`` when every energy was)."""
    if run_status != Status.COMPUTED:
        return Status(run_status)
    missing = [Status(s) for s in np.ravel(energy_status) if s != Status.COMPUTED]
    return missing[0] if missing else Status.COMPUTED


def path_error(system: HarmonicBalanceSystem, branch: xr.Dataset) -> tuple[float, float]:
    """How far the stored points of a branch are from the HBM solution curve.

    The point with the largest algebraic residual (interior points of ANM steps are not
    Newton-corrected by the engine) is corrected by Newton's method at fixed amplitude
    ``x_c^1`` (as :func:`nnmstop.hbm.stages.start_point` does). Returns the largest relative
    algebraic residual and the relative frequency shift of that point.

    Raises
    ------
    ContinuationError
        If Newton's method does not bring that point onto the curve (the stored path is then
        not the HBM branch it claims to be).
    """
    residual = np.asarray(branch["algebraic_residual"].values, dtype=float)
    k = int(np.argmax(residual))
    U = dataset_unknowns(branch, system)[k]
    direction = np.zeros(system.n_unknowns)
    direction[system.slices["x"].start + 1] = 1.0
    corrected, _ = newton_correct(system, U, direction, ContinuationStats(), tol=1e-13)
    f_point, f_curve = float(system.frequency_hz(U)), float(system.frequency_hz(corrected))
    return float(residual[k]), abs(f_point - f_curve) / f_curve


# --------------------------------------------------------------------------- matched energies


def two_impact_arm(branch: xr.Dataset, exact: xr.Dataset | None = None) -> xr.Dataset:
    """The branch from the start of its increasing-energy run that best covers the exact family.

    Among the leading points with at most two impacts per period, the maximal runs of
    strictly increasing energy are found; the one whose energy range overlaps the
    increasing arm of the ``exact`` family (:func:`nnmstop.compare.matching.exact_increasing_arm`)
    the most, in ratio of energies, is kept (without ``exact``: the run reaching the
    highest energy). That is the run from the linear mode for a large ``eta``, and from
    the energy minimum after the grazing fold for a small one. The returned dataset
    starts there, so that :func:`nnmstop.compare.matching.regularized_monotone_part` (which takes
    the leading increasing points) selects exactly that run.

    Raises
    ------
    ValueError
        If the branch has fewer than two leading points with at most two impacts.
    """
    impacts = np.asarray(branch["impacts_per_period"].values)
    energy = np.asarray(branch["energy"].values, dtype=float)
    over = np.flatnonzero(impacts > 2)
    end = int(over[0]) if over.size else energy.size
    if end < 2:
        raise ValueError(
            f"the regularized branch has fewer than two leading orbits with at most two impacts (impacts {impacts[:3]})"
        )
    if exact is not None:
        arm = np.asarray(exact["energy"].values[exact_increasing_arm(exact)], dtype=float)
        lo, hi = float(arm[0]), float(arm[-1])
    else:
        lo, hi = 0.0, np.inf
    runs, run_start = [], 0
    for i in range(1, end + 1):
        if i == end or energy[i] <= energy[i - 1]:
            if i - 1 > run_start:
                runs.append((run_start, i - 1))
            run_start = i
    if not runs:
        raise ValueError(
            "the regularized branch has no two consecutive orbits of increasing energy with at most two impacts"
        )

    def score(run):
        first, last = run
        if exact is None:
            return energy[last]
        if energy[last] <= lo or energy[first] >= hi:
            return -np.inf
        return np.log(min(energy[last], hi) / max(energy[first], lo))

    best = max(runs, key=score)[0]
    return branch.isel(point=slice(best, None))


@dataclass
class MatchedErrors:
    """Errors of a regularized branch against the exact orbits at given energies.

    ``values[key]`` (key in ``ERROR_KEYS``) holds one value per energy (NaN where the energy
    was not compared); ``orbits`` the matched HBM unknown vectors (None where not compared);
    ``status`` one :class:`Status` per energy; ``failure`` the reason of the first energy not
    compared ('' if all were).
    """

    energies: np.ndarray
    values: dict
    orbits: list
    system: HarmonicBalanceSystem | None
    status: np.ndarray
    failure: str
    exact_seconds_per_orbit: float
    regularized_seconds_per_orbit: float
    range: tuple = (np.nan, np.nan)

    @property
    def complete(self) -> bool:
        return not np.any(self.status != Status.COMPUTED)


def _status_of(err: NotComparableError) -> Status:
    return Status.OUTSIDE_COMMON_RANGE if isinstance(err, OutsideRangeError) else Status.NOT_APPLICABLE


def match_energies(
    exact: xr.Dataset,
    branch: xr.Dataset,
    energies,
    phase_samples: int = 2048,
    end_margin: float = 0.01,
) -> MatchedErrors:
    """Match exact and regularized NNM1 orbits at ``energies`` with :mod:`nnmstop.compare.matching`.

    ``branch`` is a regularized NNM1 dataset (its :func:`two_impact_arm` is used). An energy
    outside the common range of the two (``OUTSIDE_COMMON_RANGE``), or where the comparison
    does not apply (``NOT_APPLICABLE``: an orbit whose ``x`` is not positive at its turning point
    in contact, so that the phase alignment of :func:`nnmstop.compare.matching.orbit_differences`
    is undefined) gets NaN, its status and, for the first one, the reason. Anything else (a
    Newton solve that fails inside the common range, bad input) raises.
    """
    energies = np.asarray(energies, dtype=float)
    values = {key: np.full(energies.size, np.nan) for key in ERROR_KEYS}
    orbits: list = [None] * energies.size
    status = np.full(energies.size, Status.COMPUTED, dtype=np.int8)
    try:
        matcher = EnergyMatcher(exact, two_impact_arm(branch, exact), end_margin)
    except NotComparableError as err:
        status[:] = _status_of(err)
        reason = f"no common two-impact range: {err}"
        return MatchedErrors(energies, values, orbits, None, status, reason, np.nan, np.nan)
    failure = ""
    t_exact, t_reg, n = 0.0, 0.0, 0
    for i, energy in enumerate(energies.tolist()):
        try:
            matcher.check_energy(energy)
            start = time.perf_counter()
            matcher.exact_orbit(energy)
            seconds_exact = time.perf_counter() - start
            start = time.perf_counter()
            pair = matcher.match(energy)  # solves the exact orbit again (cheap), then the HBM one
            seconds_match = time.perf_counter() - start
            diff = orbit_differences(pair, matcher.system, phase_samples)
        except NotComparableError as err:
            status[i] = _status_of(err)
            failure = failure or f"energy {energy:g}: {err}"
            continue
        t_exact += seconds_exact
        t_reg += max(seconds_match - seconds_exact, 0.0)
        n += 1
        for key in ERROR_KEYS:
            values[key][i] = diff[key]
        orbits[i] = pair.regularized
    return MatchedErrors(
        energies,
        values,
        orbits,
        matcher.system,
        status,
        failure,
        t_exact / n if n else np.nan,
        t_reg / n if n else np.nan,
        matcher.energy_range,
    )


def hbm_orbit_differences(
    system: HarmonicBalanceSystem, U, reference_system: HarmonicBalanceSystem, U_reference, phase_samples: int = 2048
) -> dict:
    """Differences between two HBM orbits (e.g. ``H`` and a much larger ``H``) at one energy.

    Same phase alignment and same maximum as :func:`nnmstop.compare.matching.orbit_differences`
    (``t/T`` of each orbit, origin at the maximum of ``x``; the largest difference on
    ``phase_samples`` phases, refined on a grid 256 times finer around it). Returns the
    frequency difference relative to the reference frequency and the largest differences
    of ``x``, ``u`` and ``f``.
    """
    n = int(phase_samples)
    phase = np.arange(n) / n
    a, shift_a = regularized_orbit_on_phase(system, U, phase)
    b, shift_b = regularized_orbit_on_phase(reference_system, U_reference, phase)
    fa, fb = float(system.frequency_hz(U)), float(reference_system.frequency_hz(U_reference))
    largest = largest_differences(
        a,
        b,
        lambda local: regularized_orbit_on_phase(system, U, local, shift_a)[0],
        lambda local: regularized_orbit_on_phase(reference_system, U_reference, local, shift_b)[0],
        ("x", "u", "f"),
    )
    return {
        "relative_frequency_difference": (fa - fb) / fb,
        "max_x_difference": largest["x"],
        "max_u_difference": largest["u"],
        "max_force_difference": largest["f"],
    }


# --------------------------------------------------------------------------- dataset variables


def floats(values) -> np.ndarray:
    """A float variable's values (NaN where not computed: the catalogue entry names the reason)."""
    return np.asarray(values, dtype=float)


def texts(values) -> np.ndarray:
    """A text variable's values (an empty string: nothing to report)."""
    return np.asarray(values, dtype=str)


def flags(values) -> np.ndarray:
    """A :class:`Status` variable's values (int8; flag meanings in the catalogue)."""
    return np.asarray(values, dtype=np.int8)
