"""Shared pieces of the study: a guarded, timed continuation of NNM1 and matched-energy errors.

* :func:`run_stage_one` continues stage 1 of the regularized NNM1 with the engine's
  :class:`~nnmstop.hbm.stages.TruncationGuard` (the study's own ``max_truncation``), an
  optional energy limit and no branch-point location, and measures its wall-clock and CPU
  time and its cost counters; a numerical failure becomes ``StageRun.failure``, never an
  exception.
* :func:`match_energies` compares a regularized branch with the exact orbits at given
  energies through :mod:`nnmstop.compare.matching`, on the increasing-energy run chosen by
  :func:`two_impact_arm`; :func:`hbm_orbit_differences` compares two HBM orbits (``H``
  against a reference ``H``) the same way.
* :func:`variable` stores a missing value as ``FILL_VALUE`` with ``_FillValue``, so that
  readers get NaN, never a number that looks valid.

Method notes (why the guard, why the increasing run): ``docs/methods/study.md``.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from nnmstop.compare.matching import (
    EnergyMatcher,
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

__all__ = [
    "FILL_VALUE",
    "UnresolvedBranchError",
    "TruncationGuard",
    "StageRun",
    "MatchedErrors",
    "format_number",
    "run_stage_one",
    "two_impact_arm",
    "match_energies",
    "hbm_orbit_differences",
    "path_error",
    "variable",
    "string_variable",
]

logger = logging.getLogger("nnmstop.study")

#: Fill value of missing floats (netCDF default fill of doubles); read back as NaN.
FILL_VALUE = 9.969209968386869e36

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
        Branch dataset (layout of :mod:`nnmstop.hbm.dataset`); None when the run failed.
    failure : str
        Why the run failed ('' when it converged).
    runtime, cpu_time : float
        Wall-clock and CPU seconds of the continuation (start point included).
    stats : ContinuationStats or None
        Cost counters (None when the run failed: the engine does not return them then).
    truncation : float
        Largest truncation indicator (:meth:`~nnmstop.hbm.system.HarmonicBalanceSystem.truncation`) met
        along the run (up to the failure if any).
    harmonics : int
    """

    dataset: xr.Dataset | None
    failure: str
    runtime: float
    cpu_time: float
    stats: ContinuationStats | None
    truncation: float
    harmonics: int
    extra: dict = field(default_factory=dict)

    @property
    def converged(self) -> bool:
        return self.dataset is not None and not self.failure


def run_stage_one(run: StageOneRun, label: str = "NNM1 stage 1", energy_limit: float | None = None) -> StageRun:
    """Continue stage 1 of ``run.branch`` with a :class:`TruncationGuard` at ``run.max_truncation``; time it.

    ``energy_limit`` (optional) also ends the stage at the first orbit above that energy
    (past the range that will be compared), whichever comes first.

    Never raises for a numerical failure: a :class:`~nnmstop.continuation.core.ContinuationError`
    (a failed step, ``max_steps`` exhausted, an unresolved orbit), a
    :class:`numpy.linalg.LinAlgError`, or a ``ValueError``/``FloatingPointError`` escaping
    the engine (e.g. NaN reaching a linear solve) becomes ``StageRun.failure``;
    ``StageRun.extra`` says whether it was an unresolved orbit (``unresolved``).
    """
    system = run.system()
    spec = run.branch
    inner = stage_criterion(spec.stages[0].until, system.params, spec.mode)
    if energy_limit is not None:
        stage_end, limit = inner, float(energy_limit)

        def inner(U, diag):  # noqa: F811 - the stage criterion, or the energy limit first
            past = diag["energy"] > limit
            return stage_end(U, diag) or (f"energy above {limit:g} (past the compared range)" if past else "")

    guard = TruncationGuard(system, inner, run.max_truncation, label, setting="study.max_truncation")
    wall, cpu = time.perf_counter(), time.process_time()
    dataset, failure, stats = None, "", None
    try:
        U0, direction = start_point(system, spec.mode, spec.start_amplitude)
        branch = continue_anm(system, U0, direction, guard, run.continuation, label=label, progress_seconds=30.0)
        stats = branch.stats
    except (ContinuationError, np.linalg.LinAlgError) as err:
        failure = str(err) or type(err).__name__
        unresolved = isinstance(err, UnresolvedBranchError)
    except (ValueError, FloatingPointError) as err:  # the engine should have raised a ContinuationError
        failure = f"{label}: the engine raised {type(err).__name__} (no step or energy given): {err}"
        unresolved = False
    else:
        unresolved = False
    runtime, cpu_time = time.perf_counter() - wall, time.process_time() - cpu
    if not failure:
        # the study compares orbits: branch points stay flagged, not located (costly, unused here)
        labels = {"branch": spec.name, "mode": int(spec.mode), "stages": len(spec.stages)}
        dataset = stage_dataset(system, branch, 1, run.branch_settings(), labels, located=[])
    logger.info("%s, H = %d: %s in %.2f s", label, system.H, failure or "converged", runtime)
    return StageRun(dataset, failure, runtime, cpu_time, stats, guard.largest, system.H, {"unresolved": unresolved})


def path_error(system: HarmonicBalanceSystem, branch: xr.Dataset) -> tuple[float, float]:
    """How far the stored points of a branch are from the HBM solution curve.

    The point with the largest algebraic residual (interior points of ANM steps are not
    Newton-corrected by the engine) is corrected by Newton's method at fixed amplitude
    ``x_c^1`` (as :func:`nnmstop.hbm.stages.start_point` does). Returns the largest relative
    algebraic residual and the relative frequency shift of that point.
    """
    residual = np.asarray(branch["algebraic_residual"].values, dtype=float)
    k = int(np.argmax(residual))
    U = dataset_unknowns(branch, system)[k]
    direction = np.zeros(system.n_unknowns)
    direction[system.slices["x"].start + 1] = 1.0
    try:
        corrected, _ = newton_correct(system, U, direction, ContinuationStats(), tol=1e-13)
    except ContinuationError:
        return float(residual[k]), float("nan")
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

    ``values[key]`` (key in ``ERROR_KEYS``) holds one value per energy (NaN where the
    energy could not be matched); ``orbits`` the matched HBM unknown vectors (None where
    unmatched); ``failure`` the first matching failure ('' if all matched).
    """

    energies: np.ndarray
    values: dict
    orbits: list
    system: HarmonicBalanceSystem | None
    failure: str
    exact_seconds_per_orbit: float
    regularized_seconds_per_orbit: float
    range: tuple = (np.nan, np.nan)

    @property
    def complete(self) -> bool:
        return not self.failure


def match_energies(
    exact: xr.Dataset,
    branch: xr.Dataset,
    energies,
    phase_samples: int = 2048,
    end_margin: float = 0.01,
) -> MatchedErrors:
    """Match exact and regularized NNM1 orbits at ``energies`` with :mod:`nnmstop.compare.matching`.

    ``branch`` is a regularized NNM1 dataset (its :func:`two_impact_arm` is used). Energies
    that cannot be matched (outside the common range, Newton failure, an exact orbit whose
    maximum of ``x`` is not on a symmetry axis so that the phase alignment of
    :func:`nnmstop.compare.matching.orbit_differences` does not apply) get NaN and the first such
    reason is recorded; nothing is raised for them.
    """
    energies = np.asarray(energies, dtype=float)
    values = {key: np.full(energies.size, np.nan) for key in ERROR_KEYS}
    orbits: list = [None] * energies.size
    try:
        matcher = EnergyMatcher(exact, two_impact_arm(branch, exact), end_margin)
    except ValueError as err:
        return MatchedErrors(energies, values, orbits, None, f"no common two-impact range: {err}", np.nan, np.nan)
    failure = ""
    t_exact, t_reg, n_exact, n_reg = 0.0, 0.0, 0, 0
    for i, energy in enumerate(energies):
        try:
            start = time.perf_counter()
            matcher.exact_orbit(energy)
            seconds_exact = time.perf_counter() - start
            start = time.perf_counter()
            pair = matcher.match(energy)  # solves the exact orbit again (cheap), then the HBM one
            seconds_match = time.perf_counter() - start
            diff = orbit_differences(pair, matcher.system, phase_samples)
        except ValueError as err:  # outside the common range, Newton failure, no common phase alignment
            failure = failure or f"energy {energy:g}: {err}"
            continue
        t_exact += seconds_exact
        n_exact += 1
        t_reg += max(seconds_match - seconds_exact, 0.0)
        n_reg += 1
        for key in ERROR_KEYS:
            values[key][i] = diff[key]
        orbits[i] = pair.regularized
    return MatchedErrors(
        energies,
        values,
        orbits,
        matcher.system,
        failure,
        t_exact / n_exact if n_exact else np.nan,
        t_reg / n_reg if n_reg else np.nan,
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


def variable(dims, values, long_name: str, units: str = "1", dtype=float, **extra):
    """A labelled variable tuple; NaN floats become ``FILL_VALUE`` with ``_FillValue`` set."""
    values = np.asarray(values, dtype=dtype)
    attrs = {"long_name": long_name, "units": units, **extra}
    if np.issubdtype(values.dtype, np.floating):
        missing = ~np.isfinite(values)
        if missing.any():
            values = np.where(missing, FILL_VALUE, values)
        attrs["_FillValue"] = FILL_VALUE
    return (dims, values, attrs)


def string_variable(dims, values, long_name: str):
    """A labelled variable of strings (empty string: nothing to report)."""
    return (dims, np.asarray(values, dtype=str), {"long_name": long_name, "units": "1"})
