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
from nnmstop.continuation.core import ContinuationError, ContinuationStats, newton_correct
from nnmstop.exact.dataset import two_impact_dataset
from nnmstop.exact.family import follow_two_impact_family
from nnmstop.exact.grazing import assess_orbit
from nnmstop.exact.problem import TwoImpactProblem, first_grazing_orbit, high_energy_orbit
from nnmstop.hbm.stages import start_point
from nnmstop.models.two_dof import ModelParameters, linear_modes, stiffness_matrix
from nnmstop.settings import StudySettings
from nnmstop.study.runs import (
    match_energies,
    run_stage_one,
    string_variable,
    variable,
)

__all__ = [
    "stiff_case_parameters",
    "exact_checks",
    "periodicity_check",
    "stiff_exact_dataset",
    "exact_energies",
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
    for key, long_name, units in (
        ("relative_residual", "largest residual of the quarter-period equations, relative to max velocity * sqrt(1 + beta + alpha)", "1"),
        ("periodicity_error", "middle orbit integrated over one period with event location: max |z(T) - z(0)| / max |z|", "1"),
        ("integration_difference", "middle orbit: largest difference between integration and closed form / max |z|", "1"),
        ("integration_seconds", "time of that integration", "s"),
        ("seconds_per_orbit", "time per orbit of the family continuation", "s"),
        ("step", "continuation step used", "1"),
    ):
        ds[f"check_{key}"] = variable((), checks[key], long_name, units)
    ds["check_end_confirmed"] = ((), checks["end_confirmed"], {"long_name": "the end of the family was met again with a step 100 times smaller", "units": "1"})
    ds["check_end_note"] = string_variable((), checks["end_check"], "how the end of the family was confirmed")
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


def stiff_branch_dataset(settings: StudySettings, exact: xr.Dataset, alpha, beta, delta, eta) -> xr.Dataset:
    """Harmonics ladder for NNM1 stage 1 of one case, and errors against the exact family.

    The ladder goes on to more harmonics only when an attempt is refused as unresolved;
    any other failure (a step that fails, ``max_steps`` exhausted) is not a matter of
    harmonics and ends it. Each attempt stops at the end of stage 1 or past
    ``study.stiff.energy_limit_factor`` times the highest energy of the exact family.
    """
    stiff = settings.stiff_sweep()
    ladder = list(stiff.harmonics)
    energies = exact_energies(exact, stiff.compare_count) if "energy" in exact else np.array([])
    energy_limit = stiff.energy_limit_factor * float(exact["energy"].max()) if "energy" in exact else None
    params = ModelParameters(alpha=float(alpha), beta=float(beta), delta=float(delta), eta=float(eta))
    base = replace(
        settings.run, params=params, continuation=replace(settings.run.continuation, max_steps=stiff.max_steps)
    )
    attempts, run = [], None
    total = 0.0
    for H in ladder:
        run = run_stage_one(
            replace(base, harmonics=H), energy_limit=energy_limit,
            label=f"NNM1 stage 1 (alpha {alpha:g}, beta {beta:g}, delta {delta:g}, eta {eta:g}, H {H})",
        )
        total += run.runtime
        attempts.append(f"H={H}: " + (run.failure or f"converged ({run.stats.steps} steps, {run.stats.factorizations} factorizations)"))
        if run.converged or not run.extra.get("unresolved"):
            break
    converged = run.converged
    if converged:
        failure = ""
    elif run.extra.get("unresolved"):
        failure = "no number of harmonics tried resolves the branch: " + " | ".join(attempts)
    else:
        failure = "the continuation fails for a reason more harmonics do not address: " + attempts[-1]
    errors = {"relative_frequency_difference": np.nan, "max_x_difference": np.nan, "max_u_difference": np.nan, "max_force_difference": np.nan}
    relative_force = np.nan
    energy_range = (float(energies[0]), float(energies[-1])) if energies.size else (np.nan, np.nan)
    compared = False
    if converged:
        matched = match_energies(exact, run.dataset, energies, settings.phase_samples, settings.end_margin)
        if matched.complete:
            for key in errors:
                errors[key] = float(np.max(np.abs(matched.values[key])))
            relative_force = float(np.max(matched.values["max_force_difference"] / matched.values["force_max_exact"]))
            compared = True
        else:
            failure = f"converged but not compared with the exact family: {matched.failure}"
    stats = run.stats
    data = {
        "converged": ((), converged, {"long_name": "NNM1 stage 1 converged with every orbit resolved, for one of the harmonics tried", "units": "1"}),
        "compared": ((), compared, {"long_name": "converged and compared with the exact family at every chosen energy", "units": "1"}),
        "failure": string_variable((), failure, "why the case did not converge or was not compared ('' if it was)"),
        "attempts": string_variable((), " | ".join(attempts), "every number of harmonics tried, with its outcome"),
        "harmonics": ((), np.int32(run.harmonics if converged else -1), {"long_name": "smallest number of harmonics tried that resolves the branch (-1: none)", "units": "1"}),
        "steps": ((), np.int32(stats.steps if converged else -1), {"long_name": "ANM steps of the resolving run (-1: none)", "units": "1"}),
        "factorizations": ((), np.int32(stats.factorizations if converged else -1), {"long_name": "LU factorizations of the resolving run (-1: none)", "units": "1"}),
        "runtime": variable((), run.runtime if converged else np.nan, "wall-clock time of the resolving run", "s"),
        "total_runtime": variable((), total, "wall-clock time of every attempt together", "s"),
        "truncation": variable((), run.truncation, "largest truncation indicator of the last attempt (up to its end or failure)"),
        "frequency_error": variable((), errors["relative_frequency_difference"], "largest |relative frequency error| against the exact orbits at the compared energies"),
        "x_error": variable((), errors["max_x_difference"], "largest |x_regularized - x_exact| over the period and the compared energies"),
        "u_error": variable((), errors["max_u_difference"], "largest |u_regularized - u_exact| over the period and the compared energies"),
        "force_error": variable((), errors["max_force_difference"], "largest contact-force difference over the period and the compared energies"),
        "relative_force_error": variable((), relative_force, "largest contact-force difference relative to the largest exact force"),
        "compared_energy_min": variable((), energy_range[0], "lowest compared energy (log-fraction 1/(n+1) of the exact increasing arm)"),
        "compared_energy_max": variable((), energy_range[1], "highest compared energy (log-fraction n/(n+1) of the exact increasing arm)"),
    }
    ds = xr.Dataset(data)
    ds.attrs = {"alpha": float(alpha), "beta": float(beta), "delta": float(delta), "eta": float(eta),
                "harmonics_tried": ", ".join(str(h) for h in ladder), "max_truncation": float(base.max_truncation)}
    return ds


# --------------------------------------------------------------------------- energy sweep


def _linear_amplitude(params: ModelParameters, energy: float, limit: str) -> tuple[float, np.ndarray, float]:
    """x amplitude of the first linear mode of ``limit`` with total energy ``energy``."""
    omega, shapes = linear_modes(params, limit)
    phi = shapes[:, 0]
    added = {"no_contact": 0.0, "regularized": params.eta}[limit]
    stiffness = float(phi @ stiffness_matrix(params, added) @ phi)
    return float(np.sqrt(2.0 * energy / stiffness)), phi, float(omega[0])


def _high_energy_at(params: ModelParameters, energy: float):
    """Exact high-energy two-impact orbit at exactly ``energy`` (brentq on its turning point)."""
    problem = TwoImpactProblem(params)
    omega, shapes = linear_modes(params, "gap_zero")
    phi = shapes[:, 0]
    k = float(phi @ stiffness_matrix(params, params.alpha) @ phi)
    guess = max(1.5, float(np.sqrt(2.0 * energy / k)) + 1.0)

    def mismatch(x_max):
        return np.log(problem.energy(high_energy_orbit(params, x_max)) / energy)

    lo, hi = guess / 2.0 + 0.5, guess * 2.0
    for _ in range(20):
        if mismatch(lo) < 0:
            break
        lo = 1.0 + (lo - 1.0) / 2.0
    for _ in range(20):
        if mismatch(hi) > 0:
            break
        hi *= 2.0
    x_max = scipy.optimize.brentq(mismatch, lo, hi, xtol=1e-14 * hi, rtol=1e-15)
    return high_energy_orbit(params, x_max)


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


def energy_case(settings: StudySettings, alpha: float, energy: float, family=None) -> dict:
    """Exact solver and HBM at one energy (see the module docstring); never raises for numerics.

    ``family`` is the first exact two-impact family of these parameters (followed here if None).
    """
    run = _energy_run(settings, alpha)
    params = run.params
    problem = TwoImpactProblem(params)
    out = {"kind": "none", "exact_energy": np.nan, "exact_frequency": np.nan, "exact_residual": np.nan,
           "periodicity_error": np.nan, "integration_difference": np.nan, "exact_note": "",
           "hbm_converged": False, "hbm_failure": "", "hbm_frequency_difference": np.nan,
           "hbm_energy_mismatch": np.nan, "hbm_truncation": np.nan}
    grazing = problem.energy(first_grazing_orbit(params))
    y = None
    if family is None:
        family = follow_two_impact_family(params, step=settings.exact.step, max_points=settings.exact.max_points)
    if energy < grazing:
        amplitude, phi, omega = _linear_amplitude(params, energy, "no_contact")
        out.update(kind="linear", exact_energy=energy, exact_frequency=omega / (2 * np.pi), exact_residual=0.0,
                   exact_note=f"below the grazing energy {grazing:.6g}: the linear mode (x amplitude {amplitude:.3g}), no impact")
        y = np.array([amplitude * omega, amplitude * omega * phi[1], 0.5 * np.pi / omega, 0.5 * np.pi / omega])
    elif family.energy.min() <= energy <= family.energy.max():
        i = int(np.argmin(np.abs(np.log(family.energy / energy))))
        y = family.unknowns[i]
        out.update(kind="family", exact_note=f"first two-impact family, nearest orbit (energy {family.energy[i]:.9g})")
    else:
        try:
            y = _high_energy_at(params, energy)
            check = assess_orbit(problem, y)
            if check.valid:
                out.update(kind="high_energy", exact_note="high-energy two-impact segment, solved at exactly this energy")
            else:
                out["exact_note"] = f"the high-energy two-impact orbit at this energy violates {', '.join(check.violated)}"
                y = None
        except (ValueError, RuntimeError) as err:
            out["exact_note"] = f"no high-energy two-impact orbit found: {err}"
            y = None
        if y is None:
            out["exact_note"] += (
                f"; outside the first two-impact family ({family.energy.min():.6g}..{family.energy.max():.6g}): no "
                "two-impact orbit at this energy (multi-impact regime); the exact solver refuses"
            )
    if y is None:
        out["hbm_failure"] = "no exact two-impact orbit to compare with"
        return out
    if out["kind"] != "linear":
        out.update(exact_energy=problem.energy(y), exact_frequency=1.0 / (4.0 * y[3]),
                   exact_residual=float(np.linalg.norm(problem.residual(y))))
    out.update({k: v for k, v in periodicity_check(params, y).items() if k != "integration_seconds"})
    # the regularized orbit at the same place
    system = run.system()
    try:
        if out["kind"] == "linear":
            amplitude, _, _ = _linear_amplitude(params, energy, "regularized")
            if not amplitude < 1.0:
                raise ContinuationError(f"the regularized linear mode at energy {energy:g} has x amplitude {amplitude:.3g} >= 1")
            U, _ = start_point(system, 1, amplitude)
        else:
            direction = np.zeros(system.n_unknowns)
            direction[system.slices["x"].start + 1] = 1.0
            U, _ = newton_correct(system, _hbm_from_exact(system, params, y), direction, ContinuationStats(), tol=1e-12)
        level = system.truncation(U)
        out["hbm_truncation"] = level
        limit = run.max_truncation
        if level > limit:  # no number for an unresolved orbit: only the indicator and the reason
            out["hbm_failure"] = f"H = {system.H} does not resolve the orbit (truncation indicator {level:.4g} > {limit:g})"
        else:
            diag = system.diagnostics(U)
            out.update(hbm_converged=True,
                       hbm_frequency_difference=(diag["frequency"] - out["exact_frequency"]) / out["exact_frequency"],
                       hbm_energy_mismatch=(diag["energy"] - out["exact_energy"]) / out["exact_energy"])
    except (ContinuationError, np.linalg.LinAlgError, ValueError) as err:
        out["hbm_failure"] = f"HBM orbit not found: {err}"
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
        "kind": string_variable(e, col("kind"), f"exact orbit used: one of {', '.join(ENERGY_KINDS)} (none: no two-impact orbit)"),
        "exact_note": string_variable(e, col("exact_note"), "how the exact orbit was found, or why there is none"),
        "exact_energy": variable(e, col("exact_energy"), "energy of the exact orbit"),
        "exact_frequency": variable(e, col("exact_frequency"), "frequency of the exact orbit", "Hz"),
        "exact_residual": variable(e, col("exact_residual"), "norm of the quarter-period equations of the exact orbit"),
        "periodicity_error": variable(e, col("periodicity_error"), "event-located integration over one period: max |z(T) - z(0)| / max |z|"),
        "integration_difference": variable(e, col("integration_difference"), "largest difference between integration and closed form / max |z|"),
        "hbm_converged": (e, np.array(col("hbm_converged"), dtype=bool), {"long_name": "an HBM orbit of the regularized model was found there and is resolved", "units": "1"}),
        "hbm_failure": string_variable(e, col("hbm_failure"), "why there is no resolved HBM orbit ('' if there is)"),
        "hbm_frequency_difference": variable(e, col("hbm_frequency_difference"), "(HBM frequency - exact frequency) / exact frequency"),
        "hbm_energy_mismatch": variable(e, col("hbm_energy_mismatch"), "(HBM energy - exact energy) / exact energy (the HBM orbit keeps the x amplitude)"),
        "hbm_truncation": variable(e, col("hbm_truncation"), "truncation indicator of the HBM orbit"),
    }
    ds = xr.Dataset(data, coords={"energy": ("energy", energies, {"long_name": "requested total energy", "units": "1"})})
    ds.attrs = {**{k: float(v) for k, v in params.as_attrs().items()}, "harmonics": int(run.harmonics)}
    return ds


# --------------------------------------------------------------------------- gather


def gather_stiff_cases(settings: StudySettings, exact: list, branches: list, energy: list) -> xr.Dataset:
    """Assemble the stiff-case datasets into ``stiff_cases`` (grids ``alpha x eta``, ``beta x delta``, ``energy``).

    ``exact``, ``branches`` and ``energy`` are the datasets of the jobs in the order of
    :func:`stiff_case_parameters`.
    """
    stiff = settings.stiff_sweep()
    model = settings.run.params
    alphas, etas, ratios, energy_alphas = list(stiff.alpha), list(stiff.eta), list(stiff.ratios), list(stiff.energy_alpha)
    expected = stiff_case_parameters(settings)
    for kind, datasets in (("exact", exact), ("branches", branches), ("energy", energy)):
        if len(datasets) != len(expected[kind]):
            raise ValueError(f"{len(datasets)} stiff {kind} datasets given, the configuration has {len(expected[kind])} cases")
    exact = dict(zip(expected["exact"], exact))
    branches = dict(zip(expected["branches"], branches))

    def branch(a, b, d, e):
        return branches[(float(a), float(b), float(d), float(e))]

    def fam(a, b, d):
        return exact[(float(a), float(b), float(d))]

    b0, d0, a0, e0 = model.beta, model.delta, model.alpha, model.eta
    branch_scalars = ("runtime", "total_runtime", "truncation", "frequency_error", "x_error", "u_error", "force_error", "relative_force_error", "compared_energy_min", "compared_energy_max")
    branch_ints = ("harmonics", "steps", "factorizations")
    exact_scalars = ("check_relative_residual", "check_periodicity_error", "check_integration_difference", "check_seconds_per_orbit", "check_step")
    data = {}

    def put_branch(prefix, dims, grid):
        shape = tuple(len(v) for v in grid.values())
        cases = np.empty(shape, dtype=object)
        for idx in np.ndindex(shape):
            cases[idx] = grid_case(grid, idx)
        get = lambda key, cast: np.vectorize(lambda c: cast(c[key].values), otypes=[object])(cases)  # noqa: E731
        data[f"{prefix}converged"] = (dims, get("converged", bool).astype(bool), {"long_name": "NNM1 stage 1 converged with every orbit resolved for one of the harmonics tried", "units": "1"})
        data[f"{prefix}compared"] = (dims, get("compared", bool).astype(bool), {"long_name": "converged and compared with the exact family at every chosen energy", "units": "1"})
        data[f"{prefix}failure"] = string_variable(dims, get("failure", str).astype(str), "why the case did not converge or was not compared ('' if it was)")
        data[f"{prefix}attempts"] = string_variable(dims, get("attempts", str).astype(str), "every number of harmonics tried, with its outcome")
        for key in branch_ints:
            src = next(iter(branches.values()))[key]
            data[f"{prefix}{key}"] = (dims, get(key, int).astype(np.int32), dict(src.attrs))
        for key in branch_scalars:
            src = next(iter(branches.values()))[key]
            values = get(key, float).astype(float)
            data[f"{prefix}{key}"] = variable(dims, values, src.attrs["long_name"], src.attrs["units"])

    def grid_case(grid, idx):
        values = {name: vals[i] for (name, vals), i in zip(grid.items(), idx)}
        return branch(values.get("alpha", a0), values.get("beta", b0), values.get("delta", d0), values.get("eta", e0))

    put_branch("", ("alpha", "eta"), {"alpha": alphas, "eta": etas})
    put_branch("ratio_", ("beta", "delta"), {"beta": ratios, "delta": ratios})

    def put_exact(prefix, dims, cases):
        shape = cases.shape
        for key in exact_scalars:
            src = next(iter(exact.values()))[key]
            values = np.array([float(c[key]) for c in cases.ravel()]).reshape(shape)
            data[f"{prefix}{key.replace('check_', 'exact_')}"] = variable(dims, values, "exact solver: " + src.attrs["long_name"], src.attrs["units"])
        data[f"{prefix}exact_max_residual"] = variable(dims, np.array([float(c.attrs["max_residual"]) for c in cases.ravel()]).reshape(shape), "exact solver: largest residual norm of the quarter-period equations")
        data[f"{prefix}exact_orbits"] = (dims, np.array([c.sizes["point"] for c in cases.ravel()], dtype=np.int32).reshape(shape), {"long_name": "exact solver: orbits of the two-impact family", "units": "1"})
        data[f"{prefix}exact_energy_min"] = variable(dims, np.array([float(c["energy"].min()) for c in cases.ravel()]).reshape(shape), "exact solver: lowest energy of the two-impact family")
        data[f"{prefix}exact_energy_max"] = variable(dims, np.array([float(c["energy"].max()) for c in cases.ravel()]).reshape(shape), "exact solver: highest energy of the two-impact family")
        data[f"{prefix}exact_end_reason"] = string_variable(dims, np.array([c.attrs["end_reason"] for c in cases.ravel()]).reshape(shape), "exact solver: why the two-impact family ends")
        data[f"{prefix}exact_end_confirmed"] = (dims, np.array([bool(c["check_end_confirmed"]) for c in cases.ravel()]).reshape(shape), {"long_name": "exact solver: the family end was met again with a step 100 times smaller (else recomputed with a 10 times smaller step)", "units": "1"})
        data[f"{prefix}exact_end_note"] = string_variable(dims, np.array([str(c["check_end_note"].values) for c in cases.ravel()]).reshape(shape), "exact solver: how the family end was checked")

    alpha_cases = np.empty(len(alphas), dtype=object)
    for i, a in enumerate(alphas):
        alpha_cases[i] = fam(a, b0, d0)
    put_exact("", ("alpha",), alpha_cases)
    ratio_cases = np.empty((len(ratios), len(ratios)), dtype=object)
    for i, b in enumerate(ratios):
        for j, d in enumerate(ratios):
            ratio_cases[i, j] = fam(a0, b, d)
    put_exact("ratio_", ("beta", "delta"), ratio_cases)

    # energy sweep: (energy, energy_alpha)
    dims = ("energy", "energy_alpha")
    for key in energy[0].data_vars:
        values = np.stack([ds[key].values for ds in energy], axis=-1)
        attrs = dict(energy[0][key].attrs)
        if values.dtype.kind in "US" or values.dtype == object:
            data[f"energy_{key}"] = string_variable(dims, values.astype(str), attrs["long_name"])
        elif values.dtype == bool:
            data[f"energy_{key}"] = (dims, values, attrs)
        else:
            attrs.pop("_FillValue", None)
            data[f"energy_{key}"] = variable(dims, values, attrs.pop("long_name"), attrs.pop("units"))
    coords = {
        "alpha": ("alpha", np.asarray(alphas), {"long_name": "stop stiffness ratio alpha = K/k1", "units": "1"}),
        "eta": ("eta", np.asarray(etas), {"long_name": "regularization parameter eta", "units": "1"}),
        "beta": ("beta", np.asarray(ratios), {"long_name": "coupling stiffness ratio beta = k2/k1 (ratio sweep)", "units": "1"}),
        "delta": ("delta", np.asarray(ratios), {"long_name": "mass ratio delta = m2/m1 (ratio sweep)", "units": "1"}),
        "energy": ("energy", energy[0]["energy"].values, {"long_name": "requested total energy (energy sweep)", "units": "1"}),
        "energy_alpha": ("energy_alpha", np.asarray(energy_alphas), {"long_name": "alpha of the energy sweep", "units": "1"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs = {
        "beta_of_alpha_eta_grid": b0, "delta_of_alpha_eta_grid": d0,
        "alpha_of_ratio_grid": a0, "eta_of_ratio_grid": e0,
        "energy_sweep_eta": float(stiff.energy_eta), "energy_sweep_harmonics": int(stiff.energy_harmonics),
        "harmonics_tried": ", ".join(str(h) for h in stiff.harmonics),
        "max_truncation": float(settings.run.max_truncation), "max_steps": int(stiff.max_steps),
        "measurement": "run times are measurements of this machine; not reproducible byte for byte",
    }
    return ds


