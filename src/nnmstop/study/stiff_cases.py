"""Stiff and extreme cases: does each solver stay exact, converge, or say plainly that it cannot.

Three sweeps (issue 5, part 2), each case its own Snakemake job (:func:`stiff_case_parameters`):

* ``alpha x eta`` and ``beta x delta``: the exact two-impact family with its exactness checks
  (:func:`exact_checks`: residuals, periodicity by event-located integration, a confirmed end)
  and a guarded continuation of NNM1 stage 1 tried with increasing harmonics until one
  resolves the branch, compared with the exact orbits at energies of the family's increasing
  arm (:func:`stiff_branch_dataset`, :func:`exact_energies`);
* ``energy x energy_alpha``: the exact solver and an HBM orbit at energies from ``1e-6`` to
  ``1e6`` (:func:`energy_case`), or the solver's plain refusal where no two-impact orbit exists.

:func:`gather_stiff_cases` assembles the job datasets. Method notes (how the end of a family is
confirmed, the harmonics ladder): ``docs/methods/study.md``; tasks: :mod:`nnmstop.tasks.study`.
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

import numpy as np
import scipy.optimize
import xarray as xr

from nnmstop.checks.time_integration import integrate_nonsmooth
from nnmstop.compare.matching import exact_increasing_arm
from nnmstop.continuation.core import ContinuationStats, newton_correct
from nnmstop.exact.dataset import two_impact_dataset
from nnmstop.exact.family import follow_two_impact_family
from nnmstop.exact.grazing import assess_orbit
from nnmstop.exact.problem import TwoImpactProblem, first_grazing_orbit, high_energy_orbit
from nnmstop.hbm.stages import start_point
from nnmstop.models.two_dof import ModelParameters, linear_modes, stiffness_matrix
from nnmstop.settings import StageOneRun, StudySettings
from nnmstop.study.runs import (
    Status,
    case_status,
    flags,
    floats,
    match_energies,
    run_stage_one,
    texts,
)

__all__ = [
    "stiff_case_parameters",
    "exact_checks",
    "periodicity_check",
    "stiff_exact_dataset",
    "exact_energies",
    "harmonics_ladder",
    "stiff_branch_dataset",
    "energy_case",
    "energy_sweep_dataset",
    "gather_stiff_cases",
]

logger = logging.getLogger("nnmstop.study.stiff")

ENERGY_KINDS = ("linear", "family", "high_energy", "none")


# --------------------------------------------------------------------------- the cases


def stiff_case_parameters(settings: StudySettings) -> dict:
    """The settings of the stiff-case jobs, in the order the gather expects their datasets.

    ``branches``: ``(alpha, beta, delta, eta)`` of the ``alpha x eta`` and ``beta x delta``
    grids (unique, sorted); ``exact``: their ``(alpha, beta, delta)`` (unique, sorted);
    ``energy``: the ``alpha`` of each energy sweep.
    """
    stiff, model = settings.stiff_sweep(), settings.run.params
    combos = {(a, model.beta, model.delta, e) for a in stiff.alpha for e in stiff.eta}
    combos |= {(model.alpha, b, d, model.eta) for b in stiff.ratios for d in stiff.ratios}
    branches = sorted(combos)
    exact = sorted({(a, b, d) for a, b, d, _ in branches})
    return {"exact": exact, "branches": branches, "energy": list(stiff.energy_alpha)}


# --------------------------------------------------------------------------- exact solver checks


def periodicity_check(params: ModelParameters, y, samples: int = 16) -> dict:
    """Integrate the exact orbit ``y`` over one period with event location; compare.

    Returns ``periodicity_error`` (``max |z(T) - z(0)|``) and ``integration_difference``
    (largest difference from the closed form at ``samples`` times), both relative to
    the largest state component, and the integration time.
    """
    y = np.asarray(y, dtype=float)
    period = 4.0 * y[3]
    t = np.linspace(0.0, period, samples + 1)
    start = time.perf_counter()
    trajectory = integrate_nonsmooth(params, [0.0, 0.0, y[0], y[1]], t)
    seconds = time.perf_counter() - start
    exact = TwoImpactProblem(params).time_history(y, t)
    closed = np.column_stack([exact.x, exact.u, exact.xdot, exact.udot])
    scale = float(np.abs(closed).max())
    return {
        "periodicity_error": float(np.abs(trajectory.states[-1] - trajectory.states[0]).max() / scale),
        "integration_difference": float(np.abs(trajectory.states - closed).max() / scale),
        "integration_seconds": seconds,
    }


def exact_checks(params: ModelParameters, step: float, max_points: int) -> tuple:
    """Follow the exact family, confirm its end, check an orbit by integration.

    Returns ``(family, checks)``: the family (recomputed with a step ten times smaller
    when the end was not confirmed) and a dict of the checks (see the module docstring).
    """
    start = time.perf_counter()
    family = follow_two_impact_family(params, step=step, max_points=max_points)
    seconds = time.perf_counter() - start
    confirmed, note = _confirm_end(params, family)
    used_step = step
    if not confirmed:
        logger.warning("alpha = %g: %s; following the family again with step %g", params.alpha, note, step / 10)
        used_step = step / 10
        start = time.perf_counter()
        family = follow_two_impact_family(params, step=used_step, max_points=max_points)
        seconds = time.perf_counter() - start
    problem = TwoImpactProblem(params)
    residuals = np.array([np.linalg.norm(problem.residual(y)) for y in family.unknowns])
    # the residual relative to the scale of the equations (velocities times the contact frequency)
    scale = max(1.0, float(np.sqrt(1.0 + params.beta + params.alpha)) * float(np.abs(family.unknowns[:, :2]).max()))
    middle = family.unknowns[len(family) // 2]
    checks = {
        "orbits": len(family),
        "energy_min": float(family.energy.min()),
        "energy_max": float(family.energy.max()),
        "end_reason": family.end_reason,
        "end_margin": family.end_margin or "none",
        "end_confirmed": bool(confirmed),
        "end_check": note,
        "step": float(used_step),
        "max_residual": float(residuals.max()),
        "relative_residual": float(residuals.max() / scale),
        "seconds_per_orbit": seconds / len(family),
        **periodicity_check(params, middle),
    }
    return family, checks


def _confirm_end(params: ModelParameters, family) -> tuple[bool, str]:
    """Restart before the end with a step 100 times smaller; the end must be met again."""
    if not family.end_margin:
        return True, "the family did not end on a violated assumption (nothing to confirm)"
    if len(family) < 3:
        start_y, direction = family.unknowns[0], family.unknowns[-1] - family.unknowns[0]
    else:
        start_y, direction = family.unknowns[-3], family.unknowns[-2] - family.unknowns[-3]
    span = float(np.linalg.norm(family.unknowns[-1] - start_y))
    fine_step = family.step / 100.0
    points = int(min(20000, max(50, 3.0 * span / fine_step)))
    fine = follow_two_impact_family(params, step=fine_step, max_points=points, start=start_y, direction=direction)
    end_a, end_b = family.energy[-1], fine.energy[-1]
    same = fine.end_margin == family.end_margin and abs(end_b - end_a) <= 1e-6 * abs(end_a)
    if same:
        return True, f"end confirmed with step {fine_step:g} ({fine.end_margin} at energy {end_b:.9g})"
    return False, (
        f"end NOT confirmed: with step {family.step:g} the family ends at energy {end_a:.9g} ({family.end_margin}), "
        f"restarted with step {fine_step:g} it goes on to {end_b:.9g} ({fine.end_margin or fine.end_reason})"
    )


def stiff_exact_dataset(params: ModelParameters, exact) -> xr.Dataset:
    """The exact family of ``params`` with its checks as scalar variables.

    ``exact``: the continuation settings of the family (:class:`~nnmstop.exact.family.FamilySettings`).
    """
    family, checks = exact_checks(params, exact.step, exact.max_points)
    ds = two_impact_dataset(family)
    for key in (
        "relative_residual",
        "periodicity_error",
        "integration_difference",
        "integration_seconds",
        "seconds_per_orbit",
        "step",
    ):
        ds[f"check_{key}"] = ((), floats(checks[key]))
    ds["check_end_confirmed"] = ((), checks["end_confirmed"])
    ds["check_end_note"] = ((), texts(checks["end_check"]))
    return ds


# --------------------------------------------------------------------------- regularized branch


def exact_energies(exact: xr.Dataset, count: int) -> np.ndarray:
    """``count`` energies inside the exact family's increasing arm, at the log-fractions k/(count+1).

    They depend on the exact family only, so every ``eta`` of one ``alpha`` is compared at
    the same energies, away from both ends of the family (folds, where matching is
    ill-conditioned).
    """
    if int(count) != count or count < 1:
        raise ValueError(f"compare_count must be an integer >= 1, got {count!r}")
    arm = np.asarray(exact["energy"].values[exact_increasing_arm(exact)], dtype=float)
    fractions = np.arange(1, int(count) + 1) / (int(count) + 1)
    return arm[0] * (arm[-1] / arm[0]) ** fractions


def harmonics_ladder(base: StageOneRun, ladder, energy_limit: float | None, label: str) -> tuple:
    """NNM1 stage 1 of ``base`` with each ``H`` of ``ladder`` in turn until one resolves the branch.

    The ladder goes on to more harmonics only when an attempt is refused as unresolved; any
    other end (a step that fails, ``max_steps`` exhausted) is not a matter of harmonics and
    ends it. Returns the last :class:`~nnmstop.study.runs.StageRun`, the text of every attempt,
    their total wall-clock time, and the case's failure ('' when the last attempt converged).
    """
    attempts, total = [], 0.0
    for H in ladder:
        run = run_stage_one(replace(base, harmonics=H), energy_limit=energy_limit, label=f"{label}, H {H}")
        total += run.runtime
        outcome = run.failure or f"converged ({run.stats.steps} steps, {run.stats.factorizations} factorizations)"
        attempts.append(f"H={H}: {outcome}")
        if run.status != Status.UNRESOLVED:
            break
    if run.status == Status.UNRESOLVED:
        failure = "no number of harmonics tried resolves the branch: " + " | ".join(attempts)
    elif run.status == Status.CONTINUATION_ENDED:
        failure = "the continuation ends for a reason more harmonics do not address: " + attempts[-1]
    else:
        failure = ""
    return run, attempts, total, failure


def stiff_branch_dataset(settings: StudySettings, exact: xr.Dataset, alpha, beta, delta, eta) -> xr.Dataset:
    """Harmonics ladder for NNM1 stage 1 of one case (:func:`harmonics_ladder`), and its errors
    against the exact family at :func:`exact_energies`.

    Each attempt stops at the end of stage 1 or past ``study.stiff.energy_limit_factor`` times
    the highest energy of the exact family.
    """
    stiff = settings.stiff_sweep()
    energies = exact_energies(exact, stiff.compare_count) if "energy" in exact else np.array([])
    energy_limit = stiff.energy_limit_factor * float(exact["energy"].max()) if "energy" in exact else None
    params = ModelParameters(alpha=float(alpha), beta=float(beta), delta=float(delta), eta=float(eta))
    base = replace(
        settings.run, params=params, continuation=replace(settings.run.continuation, max_steps=stiff.max_steps)
    )
    label = f"NNM1 stage 1 (alpha {alpha:g}, beta {beta:g}, delta {delta:g}, eta {eta:g})"
    run, attempts, total, failure = harmonics_ladder(base, stiff.harmonics, energy_limit, label)
    errors = dict.fromkeys(
        ("relative_frequency_difference", "max_x_difference", "max_u_difference", "max_force_difference"), np.nan
    )
    relative_force = np.nan
    energy_status = np.full(energies.size, run.status, dtype=np.int8)
    if run.converged:
        matched = match_energies(exact, run.dataset, energies, settings.phase_samples, settings.end_margin)
        energy_status = matched.status
        if matched.complete:
            for key in errors:
                errors[key] = float(np.max(np.abs(matched.values[key])))
            relative_force = float(np.max(matched.values["max_force_difference"] / matched.values["force_max_exact"]))
        else:
            failure = f"converged but not compared with the exact family: {matched.failure}"
    status = case_status(run.status, energy_status)
    energy_range = (float(energies[0]), float(energies[-1])) if energies.size else (np.nan, np.nan)
    stats, converged = run.stats, run.converged
    data = {
        "status": ((), flags(status)),
        "converged": ((), converged),
        "compared": ((), status == Status.COMPUTED),
        "failure": ((), texts(failure)),
        "attempts": ((), texts(" | ".join(attempts))),
        "harmonics": ((), np.int32(run.harmonics if converged else -1)),
        "steps": ((), np.int32(stats.steps if converged else -1)),
        "factorizations": ((), np.int32(stats.factorizations if converged else -1)),
        "runtime": ((), floats(run.runtime if converged else np.nan)),
        "total_runtime": ((), floats(total)),
        "truncation": ((), floats(run.truncation)),
        "frequency_error": ((), floats(errors["relative_frequency_difference"])),
        "x_error": ((), floats(errors["max_x_difference"])),
        "u_error": ((), floats(errors["max_u_difference"])),
        "force_error": ((), floats(errors["max_force_difference"])),
        "relative_force_error": ((), floats(relative_force)),
        "compared_energy_min": ((), floats(energy_range[0])),
        "compared_energy_max": ((), floats(energy_range[1])),
    }
    ds = xr.Dataset(data)
    ds.attrs = {
        "alpha": float(alpha),
        "beta": float(beta),
        "delta": float(delta),
        "eta": float(eta),
        "harmonics_tried": ", ".join(str(h) for h in stiff.harmonics),
        "max_truncation": float(base.max_truncation),
    }
    return ds


# --------------------------------------------------------------------------- energy sweep


def _linear_amplitude(params: ModelParameters, energy: float, limit: str) -> tuple[float, np.ndarray, float]:
    """x amplitude of the first linear mode of ``limit`` with total energy ``energy``."""
    omega, shapes = linear_modes(params, limit)
    phi = shapes[:, 0]
    added = {"no_contact": 0.0, "regularized": params.eta}[limit]
    stiffness = float(phi @ stiffness_matrix(params, added) @ phi)
    return float(np.sqrt(2.0 * energy / stiffness)), phi, float(omega[0])


def _high_energy_at(params: ModelParameters, energy: float) -> tuple:
    """Exact high-energy two-impact orbit at exactly ``energy`` (brentq on its turning point), or
    None, and why there is none.

    :func:`nnmstop.exact.problem.high_energy_orbit` (Newton from the gap-0 mode, meant for turning
    points ``x_max`` of about 10 and more) finds no orbit at some ``x_max``: the bracket of the
    energy is searched among those where it finds one. No bracket, or no converged root, means
    the solver finds no two-impact orbit at this energy.
    """
    problem = TwoImpactProblem(params)
    omega, shapes = linear_modes(params, "gap_zero")
    phi = shapes[:, 0]
    k = float(phi @ stiffness_matrix(params, params.alpha) @ phi)
    guess = max(1.5, float(np.sqrt(2.0 * energy / k)) + 1.0)

    def orbit(x_max):
        try:
            return high_energy_orbit(params, x_max)
        except ValueError:  # its documented refusal: Newton from the gap-0 mode does not converge there
            return None

    def mismatch(x_max):
        y = orbit(x_max)
        return np.nan if y is None else float(np.log(problem.energy(y) / energy))

    lo, hi = guess / 2.0 + 0.5, guess * 2.0
    for _ in range(20):
        if mismatch(lo) < 0:
            break
        lo = 1.0 + (lo - 1.0) / 2.0
    for _ in range(20):
        if mismatch(hi) > 0:
            break
        hi *= 2.0
    refusal = (
        f"the high-energy solver (Newton from the gap-0 mode) finds no two-impact orbit of energy {energy:g} "
        f"for turning points x_max in [{lo:.6g}, {hi:.6g}]"
    )
    if not (mismatch(lo) < 0 < mismatch(hi)):
        return None, refusal

    def defined_mismatch(x_max):
        value = mismatch(x_max)
        if np.isnan(value):
            raise _NoOrbitHere(x_max)
        return value

    try:
        x_max, result = scipy.optimize.brentq(
            defined_mismatch, lo, hi, xtol=1e-14 * hi, rtol=1e-15, full_output=True, disp=False
        )
    except _NoOrbitHere as gap:
        return None, f"{refusal} (none at x_max = {gap.args[0]:.6g} inside the bracket)"
    y = orbit(x_max)
    if not result.converged or y is None:
        return None, f"{refusal} (no converged turning point)"
    return y, ""


class _NoOrbitHere(Exception):
    """The high-energy solver finds no orbit at this turning point (ends the root search)."""


def _hbm_from_exact(system, params: ModelParameters, y) -> np.ndarray:
    """HBM seed from an exact orbit: Fourier coefficients of x, u, the piecewise force, z."""
    samples = system.M
    t = y[3] + np.arange(samples) / samples * 4.0 * y[3]  # origin at the turning point: a cosine series
    h = TwoImpactProblem(params).time_history(y, t)
    x, u, f = (system.to_coefficients(v) for v in (h.x, h.u, h.force))
    g_t = system.to_time(f / params.alpha - x)
    z = system.to_coefficients(g_t * g_t)
    return system.pack(x, u, f, z, (2.0 * np.pi / (4.0 * y[3])) ** 2)


def _energy_run(settings: StudySettings, alpha: float):
    """The run (parameters, harmonics) of the energy sweep of one ``alpha``."""
    stiff = settings.stiff_sweep()
    run = settings.run
    params = replace(run.params, alpha=float(alpha), eta=stiff.energy_eta)
    return replace(run, params=params, harmonics=stiff.energy_harmonics)


def _exact_at_energy(params: ModelParameters, energy: float, family) -> tuple:
    """``(kind, y, note)``: the exact orbit at ``energy`` (linear mode, family, high-energy segment)
    and how it was found, or kind ``none``, ``y = None`` and why there is none."""
    problem = TwoImpactProblem(params)
    grazing = problem.energy(first_grazing_orbit(params))
    if energy < grazing:
        amplitude, phi, omega = _linear_amplitude(params, energy, "no_contact")
        y = np.array([amplitude * omega, amplitude * omega * phi[1], 0.5 * np.pi / omega, 0.5 * np.pi / omega])
        return (
            "linear",
            y,
            f"below the grazing energy {grazing:.6g}: the linear mode (x amplitude {amplitude:.3g}), no impact",
        )
    if family.energy.min() <= energy <= family.energy.max():
        i = int(np.argmin(np.abs(np.log(family.energy / energy))))
        return "family", family.unknowns[i], f"first two-impact family, nearest orbit (energy {family.energy[i]:.9g})"
    y, note = _high_energy_at(params, energy)
    if y is not None:
        check = assess_orbit(problem, y)
        if check.valid:
            return "high_energy", y, "high-energy two-impact segment, solved at exactly this energy"
        note = f"the high-energy two-impact orbit at this energy violates {', '.join(check.violated)}"
    return (
        "none",
        None,
        (
            f"{note}; outside the first two-impact family ({family.energy.min():.6g}..{family.energy.max():.6g}): the "
            "exact solver has no two-impact orbit to offer at this energy"
        ),
    )


def _hbm_at(run: StageOneRun, kind: str, y, energy: float) -> tuple:
    """The regularized orbit where the exact one is: ``(U, truncation indicator)``.

    Below grazing: the regularized linear mode of the same energy, corrected by Newton at fixed
    amplitude; else the exact orbit's Fourier series corrected by Newton. A Newton failure raises.
    """
    system, params = run.system(), run.params
    if kind == "linear":
        amplitude, _, _ = _linear_amplitude(params, energy, "regularized")
        if not amplitude < 1.0:  # cannot happen: the added stiffness eta only lowers the amplitude
            raise ValueError(f"the regularized linear mode at energy {energy:g} has x amplitude {amplitude:.3g} >= 1")
        U, _ = start_point(system, 1, amplitude)
    else:
        direction = np.zeros(system.n_unknowns)
        direction[system.slices["x"].start + 1] = 1.0
        U, _ = newton_correct(system, _hbm_from_exact(system, params, y), direction, ContinuationStats(), tol=1e-12)
    return system, U


def energy_case(settings: StudySettings, alpha: float, energy: float, family=None) -> dict:
    """Exact solver and HBM at one energy (see the module docstring).

    ``family`` is the first exact two-impact family of these parameters (followed here if None).
    Where there is no exact two-impact orbit (``exact_status`` ``NO_EXACT_ORBIT``) or the HBM
    orbit is not resolved (``hbm_status`` ``UNRESOLVED``), the values are NaN and the notes say
    why; a solver failure anywhere else raises.
    """
    run = _energy_run(settings, alpha)
    params = run.params
    problem = TwoImpactProblem(params)
    if family is None:
        family = follow_two_impact_family(params, step=settings.exact.step, max_points=settings.exact.max_points)
    kind, y, note = _exact_at_energy(params, energy, family)
    out = {
        "kind": kind,
        "exact_note": note,
        "exact_status": Status.COMPUTED,
        "exact_energy": np.nan,
        "exact_frequency": np.nan,
        "exact_residual": np.nan,
        "periodicity_error": np.nan,
        "integration_difference": np.nan,
        "hbm_status": Status.COMPUTED,
        "hbm_failure": "",
        "hbm_frequency_difference": np.nan,
        "hbm_energy_mismatch": np.nan,
        "hbm_truncation": np.nan,
    }
    if y is None:
        out.update(
            exact_status=Status.NO_EXACT_ORBIT,
            hbm_status=Status.NO_EXACT_ORBIT,
            hbm_failure="no exact two-impact orbit to compare with",
        )
        return out
    if kind == "linear":
        omega = linear_modes(params, "no_contact")[0][0]
        out.update(exact_energy=energy, exact_frequency=omega / (2 * np.pi), exact_residual=0.0)
    else:
        out.update(
            exact_energy=problem.energy(y),
            exact_frequency=1.0 / (4.0 * y[3]),
            exact_residual=float(np.linalg.norm(problem.residual(y))),
        )
    out.update({k: v for k, v in periodicity_check(params, y).items() if k != "integration_seconds"})
    system, U = _hbm_at(run, kind, y, energy)
    level = out["hbm_truncation"] = system.truncation(U)
    if level > run.max_truncation:  # no number for an unresolved orbit: only the indicator and the reason
        out["hbm_status"] = Status.UNRESOLVED
        out["hbm_failure"] = (
            f"H = {system.H} does not resolve the orbit (truncation indicator {level:.4g} > {run.max_truncation:g})"
        )
    else:
        diag = system.diagnostics(U)
        out.update(
            hbm_frequency_difference=(diag["frequency"] - out["exact_frequency"]) / out["exact_frequency"],
            hbm_energy_mismatch=(diag["energy"] - out["exact_energy"]) / out["exact_energy"],
        )
    return out


def energy_sweep_dataset(settings: StudySettings, alpha: float) -> xr.Dataset:
    """Every energy of ``study.stiff.energies`` for one ``alpha`` (dimension ``energy``)."""
    energies = np.asarray(settings.stiff_sweep().energies, dtype=float)
    run = _energy_run(settings, alpha)
    params = run.params
    family = follow_two_impact_family(params, step=settings.exact.step, max_points=settings.exact.max_points)
    rows = [energy_case(settings, float(alpha), float(e), family) for e in energies]
    col = lambda key: [r[key] for r in rows]  # noqa: E731
    e = ("energy",)
    data = {
        "kind": (e, texts(col("kind"))),
        "exact_status": (e, flags(col("exact_status"))),
        "exact_note": (e, texts(col("exact_note"))),
        "exact_energy": (e, floats(col("exact_energy"))),
        "exact_frequency": (e, floats(col("exact_frequency"))),
        "exact_residual": (e, floats(col("exact_residual"))),
        "periodicity_error": (e, floats(col("periodicity_error"))),
        "integration_difference": (e, floats(col("integration_difference"))),
        "hbm_status": (e, flags(col("hbm_status"))),
        "hbm_converged": (e, np.array(col("hbm_status")) == Status.COMPUTED),
        "hbm_failure": (e, texts(col("hbm_failure"))),
        "hbm_frequency_difference": (e, floats(col("hbm_frequency_difference"))),
        "hbm_energy_mismatch": (e, floats(col("hbm_energy_mismatch"))),
        "hbm_truncation": (e, floats(col("hbm_truncation"))),
    }
    ds = xr.Dataset(data, coords={"energy": ("energy", energies)})
    ds.attrs = {**{k: float(v) for k, v in params.as_attrs().items()}, "harmonics": int(run.harmonics)}
    return ds


# --------------------------------------------------------------------------- gather


def _stacked(cases: np.ndarray, dims: tuple, prefix: str) -> dict:
    """Every variable of the case datasets ``cases`` (an object array over the grid ``dims``) stacked
    over that grid, named ``prefix + name`` (catalogue: :func:`nnmstop.catalogue.study.over`)."""
    first = cases.flat[0]
    out = {}
    for key in first.data_vars:
        values = np.array([c[key].values for c in cases.ravel()]).reshape(cases.shape + first[key].shape)
        out[prefix + key] = (tuple(dims) + first[key].dims, texts(values) if values.dtype.kind in "OUS" else values)
    return out


def _exact_summary(family: xr.Dataset) -> xr.Dataset:
    """The checks of one exact family (:func:`stiff_exact_dataset`) as scalar variables."""
    data = {}
    for key in ("relative_residual", "periodicity_error", "integration_difference", "seconds_per_orbit", "step"):
        data[f"exact_{key}"] = ((), floats(float(family[f"check_{key}"])))
    data.update(
        {
            "exact_max_residual": ((), floats(float(family.attrs["max_residual"]))),
            "exact_orbits": ((), np.int32(family.sizes["point"])),
            "exact_energy_min": ((), floats(float(family["energy"].min()))),
            "exact_energy_max": ((), floats(float(family["energy"].max()))),
            "exact_end_reason": ((), texts(family.attrs["end_reason"])),
            "exact_end_confirmed": ((), bool(family["check_end_confirmed"])),
            "exact_end_note": ((), texts(str(family["check_end_note"].values))),
        }
    )
    return xr.Dataset(data)


def _grid(lookup, shape) -> np.ndarray:
    """An object array of ``shape`` holding ``lookup(index)`` at each index."""
    out = np.empty(shape, dtype=object)
    for index in np.ndindex(shape):
        out[index] = lookup(index)
    return out


def gather_stiff_cases(settings: StudySettings, exact: list, branches: list, energy: list) -> xr.Dataset:
    """Assemble the stiff-case datasets into ``stiff_cases`` (grids ``alpha x eta``, ``beta x delta``,
    ``energy_alpha x energy``); the variables of the ``beta x delta`` grid start with ``ratio_``, those
    of the energy sweep with ``energy_``.

    ``exact``, ``branches`` and ``energy`` are the datasets of the jobs in the order of
    :func:`stiff_case_parameters`.
    """
    stiff = settings.stiff_sweep()
    a0, b0, d0, e0 = (float(getattr(settings.run.params, k)) for k in ("alpha", "beta", "delta", "eta"))
    expected = stiff_case_parameters(settings)
    for kind, datasets in (("exact", exact), ("branches", branches), ("energy", energy)):
        if len(datasets) != len(expected[kind]):
            raise ValueError(
                f"{len(datasets)} stiff {kind} datasets given, the configuration has {len(expected[kind])} cases"
            )
    family = {key: _exact_summary(ds) for key, ds in zip(expected["exact"], exact)}
    branch = dict(zip(expected["branches"], branches))
    alphas, etas, ratios = stiff.alpha, stiff.eta, stiff.ratios
    shape, ratio_shape = (len(alphas), len(etas)), (len(ratios), len(ratios))
    data = {
        **_stacked(_grid(lambda ij: branch[(alphas[ij[0]], b0, d0, etas[ij[1]])], shape), ("alpha", "eta"), ""),
        **_stacked(_grid(lambda ij: family[(alphas[ij[0]], b0, d0)], (len(alphas),)), ("alpha",), ""),
        **_stacked(
            _grid(lambda ij: branch[(a0, ratios[ij[0]], ratios[ij[1]], e0)], ratio_shape), ("beta", "delta"), "ratio_"
        ),
        **_stacked(
            _grid(lambda ij: family[(a0, ratios[ij[0]], ratios[ij[1]])], ratio_shape), ("beta", "delta"), "ratio_"
        ),
        **_stacked(_grid(lambda i: energy[i[0]], (len(energy),)), ("energy_alpha",), "energy_"),
    }
    coords = {
        "alpha": ("alpha", np.asarray(alphas)),
        "eta": ("eta", np.asarray(etas)),
        "beta": ("beta", np.asarray(ratios)),
        "delta": ("delta", np.asarray(ratios)),
        "energy": ("energy", energy[0]["energy"].values),
        "energy_alpha": ("energy_alpha", np.asarray(stiff.energy_alpha)),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs = {
        "beta_of_alpha_eta_grid": b0,
        "delta_of_alpha_eta_grid": d0,
        "alpha_of_ratio_grid": a0,
        "eta_of_ratio_grid": e0,
        "energy_sweep_eta": float(stiff.energy_eta),
        "energy_sweep_harmonics": int(stiff.energy_harmonics),
        "harmonics_tried": ", ".join(str(h) for h in stiff.harmonics),
        "max_truncation": float(settings.run.max_truncation),
        "max_steps": int(stiff.max_steps),
        "measurement": "run times are measurements of this machine; not reproducible byte for byte",
    }
    return ds
