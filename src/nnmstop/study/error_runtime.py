"""Error against run time of the regularized NNM1 on its two-impact range (issue 5, part 1).

Each sweep setting -- harmonics ``H`` and regularization ``eta``, or ANM ``order`` and
``tolerance`` (:func:`sweep_cases`) -- continues NNM1 stage 1 with
:func:`nnmstop.study.runs.run_stage_one` (timed, guarded), matches its orbits with the exact
non-smooth ones at ``study.energies`` and records the frequency error, the largest
differences of ``x``, ``u`` and the contact force, and the matched orbits
(:func:`error_case_dataset`). A large-``H`` reference per ``eta`` (:func:`reference_dataset`)
splits the error into a regularization part (reference against exact) and a truncation part
(``H`` against reference); :func:`gather_error_vs_runtime` assembles the sweep, with the cost
of the exact solver (:func:`exact_cost_dataset`).

Run times are measurements of this machine (the load average is stored): exempt from
byte-identical reruns, never read by the paper's figures. Method notes (the split, what
counts as a failure): ``docs/methods/study.md``; tasks: :mod:`nnmstop.tasks.study`.
"""

from __future__ import annotations

import os
import time
from dataclasses import replace

import numpy as np
import xarray as xr

from nnmstop.exact.family import follow_two_impact_family
from nnmstop.exact.problem import TwoImpactProblem
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.two_dof import ModelParameters
from nnmstop.settings import StageOneRun, StudySettings
from nnmstop.study.runs import (
    ERROR_KEYS,
    hbm_orbit_differences,
    match_energies,
    path_error,
    run_stage_one,
    string_variable,
    variable,
)

__all__ = [
    "sweep_cases",
    "case_run",
    "error_case_dataset",
    "reference_dataset",
    "exact_cost_dataset",
    "gather_error_vs_runtime",
]

_PER_ENERGY = {
    "relative_frequency_difference": ("relative frequency difference (regularized minus exact) / exact", "1"),
    "max_x_difference": ("largest |x_regularized - x_exact| over the period", "1"),
    "max_u_difference": ("largest |u_regularized - u_exact| over the period", "1"),
    "max_force_difference": (
        "largest |f_HBM - f_piecewise(x_exact)| over the period (regularized contact force series vs the "
        "piecewise-linear law on the exact orbit)",
        "1",
    ),
    "force_max_exact": ("largest contact force over the exact orbit", "1"),
}


# --------------------------------------------------------------------------- settings


def sweep_cases(settings: StudySettings) -> dict:
    """The settings of the sweep jobs, in the order the gather expects their datasets.

    ``cases``: ``(H, eta)`` pairs (``eta`` outer); ``anm_cases``: ``(order, tolerance)``
    pairs (``order`` outer); ``references``: one ``eta`` each.
    """
    sweep = settings.sweep()
    return {
        "cases": [(H, eta) for eta in sweep.eta for H in sweep.harmonics],
        "anm_cases": [(order, tol) for order in sweep.anm_orders for tol in sweep.anm_tolerances],
        "references": list(sweep.eta),
    }


def case_run(settings: StudySettings, harmonics: int, eta: float, order=None, tolerance=None) -> StageOneRun:
    """The study's NNM1 stage-1 run with ``H``, ``eta`` and optionally another ANM ``order`` and ``tolerance``."""
    run = settings.run
    continuation = run.continuation
    if order is not None:
        continuation = replace(continuation, order=int(order))
    if tolerance is not None:
        continuation = replace(continuation, tolerance=float(tolerance))
    return replace(
        run, harmonics=int(harmonics), params=replace(run.params, eta=float(eta)), continuation=continuation
    )


def _load_average() -> float:
    try:
        return float(os.getloadavg()[0])
    except OSError:  # pragma: no cover - not available on every platform
        return float("nan")


# --------------------------------------------------------------------------- one case


def _orbit_matrix(orbits, n_unknowns: int) -> np.ndarray:
    return np.array([np.full(n_unknowns, np.nan) if U is None else U for U in orbits])


def _case_common_attrs(run: StageOneRun) -> dict:
    return {
        **run.attrs(),
        "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS", os.environ.get("OMP_NUM_THREADS", "unset")),
        "measurement": "run times measured on this machine; not reproducible byte for byte",
    }


def error_case_dataset(
    settings: StudySettings, exact: xr.Dataset, harmonics: int, eta: float, order=None, tolerance=None
) -> xr.Dataset:
    """Run one sweep setting and return its case dataset (dimension ``energy``).

    Parameters
    ----------
    settings : StudySettings
    exact : xarray.Dataset
        The exact two-impact NNM1 family (``results/exact/nnm1_two_impacts.nc``).
    harmonics, eta : int, float
        The setting; ``order`` and ``tolerance`` override the ANM settings if given.
    """
    energies = np.asarray(settings.energies, dtype=float)
    case = case_run(settings, harmonics, eta, order, tolerance)
    load = _load_average()
    label = f"NNM1 stage 1 (H = {harmonics}, eta = {eta:g}" + (
        f", order {order}, tolerance {tolerance:g})" if order is not None else ")"
    )
    run = run_stage_one(case, label=label)
    n_unknowns = 4 * (int(harmonics) + 1) + 1
    compared, failure = False, run.failure
    values = {key: np.full(energies.size, np.nan) for key in ERROR_KEYS}
    orbits = np.full((energies.size, n_unknowns), np.nan)
    t_exact = t_reg = time_residual = path_residual = path_frequency = np.nan
    if run.converged:
        matched = match_energies(exact, run.dataset, energies, settings.phase_samples, settings.end_margin)
        values, t_exact, t_reg = matched.values, matched.exact_seconds_per_orbit, matched.regularized_seconds_per_orbit
        orbits = _orbit_matrix(matched.orbits, n_unknowns)
        compared = matched.complete
        failure = matched.failure and f"not compared over the whole study range: {matched.failure}"
        time_residual = float(run.dataset["time_residual"].max())
        path_residual, path_frequency = path_error(case.system(), run.dataset)
    stats = run.stats
    count = (lambda name: getattr(stats, name)) if stats is not None else (lambda name: -1)
    e = ("energy",)
    data = {
        "converged": ((), run.converged, {"long_name": "the continuation reached the end of stage 1 with every orbit resolved", "units": "1"}),
        "compared": ((), compared, {"long_name": "converged and matched with the exact orbits at every study energy", "units": "1"}),
        "failure": string_variable((), failure, "why the setting did not converge or was not compared ('' if it was)"),
        "runtime": variable((), run.runtime, "wall-clock time of the continuation of NNM1 stage 1 (start point included)", "s"),
        "cpu_time": variable((), run.cpu_time, "CPU time of the continuation of NNM1 stage 1 (all threads)", "s"),
        "load_average": variable((), load, "1-minute load average of the machine when the job started", "1"),
        "steps": ((), np.int32(count("steps")), {"long_name": "ANM steps (-1: unknown, the run failed)", "units": "1"}),
        "factorizations": ((), np.int32(count("factorizations")), {"long_name": "LU factorizations of the bordered Jacobian (-1: unknown, the run failed)", "units": "1"}),
        "newton_iterations": ((), np.int32(count("newton_iterations")), {"long_name": "Newton corrections of step ends (-1: unknown)", "units": "1"}),
        "truncation": variable((), run.truncation, "largest truncation indicator met along the run (top share of x'' or f, at least two harmonics)"),
        "time_residual": variable((), time_residual, "largest residual in time of Eq. (7) along the branch, relative to the largest restoring force"),
        "path_residual": variable((), path_residual, "largest relative algebraic residual of the HBM system over the branch points (interior points of ANM steps included)"),
        "path_frequency_error": variable((), path_frequency, "relative frequency shift of the worst branch point (largest residual) from the HBM solution at the same amplitude"),
        "exact_seconds_per_orbit": variable((), t_exact, "mean time to solve one exact orbit at a prescribed energy (Newton on the closed form, validity checks)", "s"),
        "regularized_seconds_per_orbit": variable((), t_reg, "mean time to solve one HBM orbit at a prescribed energy (Newton from the branch)", "s"),
        "orbit": variable(("energy", "unknown"), orbits, "HBM unknown vector of the matched regularized orbit (layout of nnmstop.hbm.system, cosine basis)"),
    }
    for key, (long_name, units) in _PER_ENERGY.items():
        data[key] = variable(e, values[key], long_name, units)
    ds = xr.Dataset(
        data,
        coords={
            "energy": ("energy", energies, {"long_name": "matched total energy", "units": "1"}),
            "unknown": ("unknown", np.arange(n_unknowns), {"long_name": "index into the HBM unknown vector", "units": "1"}),
        },
    )
    ds.attrs = _case_common_attrs(case)
    return ds


# --------------------------------------------------------------------------- reference


def _pad_harmonics(branch: xr.Dataset, harmonics: int) -> xr.Dataset:
    """The branch dataset with zero Fourier coefficients up to ``harmonics`` (seeds only)."""
    H = branch.sizes["harmonic"] - 1
    out = branch.pad(harmonic=(0, harmonics - H), constant_values=0.0)
    out = out.assign_coords(harmonic=np.arange(harmonics + 1))
    out.attrs = {**branch.attrs, "harmonics": int(harmonics), "time_samples": 0}
    return out


def reference_dataset(settings: StudySettings, exact: xr.Dataset, eta: float) -> xr.Dataset:
    """Matched orbits with ``H_ref`` harmonics for one ``eta`` (see the module docstring)."""
    sweep = settings.sweep()
    energies = np.asarray(settings.energies, dtype=float)
    H_ref, H_seed = sweep.reference_harmonics, sweep.reference_seed_harmonics
    seed_run = case_run(settings, H_seed, eta)
    n_unknowns = 4 * (H_ref + 1) + 1
    load = _load_average()
    start = time.perf_counter()
    seed = run_stage_one(seed_run, label=f"reference seed (H = {H_seed}, eta = {eta:g})")
    values = {key: np.full(energies.size, np.nan) for key in ERROR_KEYS}
    orbits = np.full((energies.size, n_unknowns), np.nan)
    levels = np.full(energies.size, np.nan)
    failure = seed.failure and f"seed continuation failed: {seed.failure}"
    if seed.converged:
        matched = match_energies(
            exact, _pad_harmonics(seed.dataset, H_ref), energies, settings.phase_samples, settings.end_margin
        )
        values = matched.values
        orbits = _orbit_matrix(matched.orbits, n_unknowns)
        failure = matched.failure
        if matched.system is not None:
            levels = np.array([np.nan if U is None else matched.system.truncation(U) for U in matched.orbits])
            worst = np.nanmax(levels) if np.isfinite(levels).any() else np.nan
            if not failure and worst > seed_run.max_truncation:
                failure = (
                    f"the reference with H_ref = {H_ref} harmonics is not resolved itself (truncation indicator "
                    f"{worst:.3g} > {seed_run.max_truncation:g}); raise study.error_runtime.reference_harmonics"
                )
    runtime = time.perf_counter() - start
    ok = not failure
    data = {
        "converged": ((), ok, {"long_name": "every reference orbit was found and is resolved", "units": "1"}),
        "failure": string_variable((), failure, "why the reference is incomplete ('' if it is complete)"),
        "runtime": variable((), runtime, "wall-clock time of the reference (seed continuation and Newton at H_ref)", "s"),
        "load_average": variable((), load, "1-minute load average of the machine when the job started", "1"),
        "truncation": variable(("energy",), levels, "truncation indicator of each reference orbit"),
        "orbit": variable(("energy", "unknown"), orbits, "HBM unknown vector of the reference orbit (H_ref harmonics, cosine basis)"),
    }
    for key, (long_name, units) in _PER_ENERGY.items():
        data[key] = variable(("energy",), values[key], "reference orbit vs exact: " + long_name, units)
    ds = xr.Dataset(
        data,
        coords={
            "energy": ("energy", energies, {"long_name": "matched total energy", "units": "1"}),
            "unknown": ("unknown", np.arange(n_unknowns), {"long_name": "index into the HBM unknown vector", "units": "1"}),
        },
    )
    ds.attrs = {**_case_common_attrs(replace(seed_run, harmonics=H_ref)), "seed_harmonics": H_seed}
    return ds


# --------------------------------------------------------------------------- exact cost


def exact_cost_dataset(params: ModelParameters, exact, phase_samples: int, repeats: int = 3) -> xr.Dataset:
    """Cost of the exact solver: family continuation per orbit and time history per orbit.

    The family is followed ``repeats`` times with the settings ``exact``
    (:class:`~nnmstop.exact.family.FamilySettings`: ``step``, ``max_points``); the fastest run is
    kept (the least disturbed by other jobs). Each time history has ``phase_samples`` phases.
    """
    if int(repeats) != repeats or repeats < 1:
        raise ValueError(f"repeats must be an integer >= 1, got {repeats!r}")
    samples = int(phase_samples)
    load = _load_average()
    family_times, history_times = [], []
    for _ in range(int(repeats)):
        start = time.perf_counter()
        family = follow_two_impact_family(params, step=exact.step, max_points=exact.max_points)
        family_times.append(time.perf_counter() - start)
        y = family.unknowns[len(family) // 2]
        start = time.perf_counter()
        for _ in range(10):
            TwoImpactProblem(params).time_history(y, np.linspace(0.0, 4.0 * y[3], samples, endpoint=False))
        history_times.append((time.perf_counter() - start) / 10)
    n = len(family)
    data = {
        "family_seconds_per_orbit": variable((), min(family_times) / n, "time per orbit of the pseudo-arclength continuation of the exact family (closed form, validity checks, end location)", "s"),
        "family_orbits": ((), np.int32(n), {"long_name": "orbits of the exact family", "units": "1"}),
        "family_seconds": variable((), min(family_times), "time to follow the whole exact family (fastest of the repeats)", "s"),
        "time_history_seconds": variable((), min(history_times), f"time to evaluate one exact orbit on {samples} phases (closed form)", "s"),
        "max_residual": variable((), float(family.residual.max()), "largest residual of the quarter-period equations along the family"),
        "load_average": variable((), load, "1-minute load average of the machine when the job started", "1"),
    }
    ds = xr.Dataset(data)
    ds.attrs = {**params.as_attrs(), "repeats": int(repeats), "measurement": "run times measured on this machine"}
    return ds


# --------------------------------------------------------------------------- gather


def _check_case(ds: xr.Dataset, label: str, settings: StudySettings, expect: dict) -> None:
    """Refuse a case dataset computed with other settings (a stale file)."""
    for key, value in expect.items():
        stored = ds.attrs.get(key)
        if stored is None or not np.isclose(float(stored), float(value), rtol=1e-12, atol=0):
            raise ValueError(f"{label}: {key} = {stored!r} in the dataset but {value!r} expected (stale study file?)")
    energies = np.asarray(settings.energies, dtype=float)
    if ds.sizes.get("energy") != energies.size or not np.allclose(ds["energy"].values, energies, rtol=1e-12, atol=0):
        raise ValueError(f"{label}: computed at the energies {ds['energy'].values.tolist()}, the configuration asks for {energies.tolist()}")


def _system(settings: StudySettings, harmonics: int, eta: float) -> HarmonicBalanceSystem:
    return case_run(settings, harmonics, eta).system()


def _max_abs(values, axis=-1):
    values = np.abs(np.asarray(values, dtype=float))
    with np.errstate(invalid="ignore"):
        out = np.max(values, axis=axis)
    return out


def gather_error_vs_runtime(
    settings: StudySettings, cases: list, anm_cases: list, references: list, exact_cost: xr.Dataset
) -> xr.Dataset:
    """Assemble the sweep datasets into ``error_vs_runtime`` (see the module docstring).

    ``cases``, ``anm_cases`` and ``references`` are the datasets of the sweep jobs in the
    order of :func:`sweep_cases`; ``exact_cost`` the dataset of :func:`exact_cost_dataset`.
    Each is checked against the setting it stands for (a stale file is refused).
    """
    sweep = settings.sweep()
    Hs, etas, orders, tols = list(sweep.harmonics), list(sweep.eta), list(sweep.anm_orders), list(sweep.anm_tolerances)
    energies = np.asarray(settings.energies, dtype=float)
    nE, nH, nEta = energies.size, len(Hs), len(etas)
    H_ref = sweep.reference_harmonics
    run = settings.run
    expected = sweep_cases(settings)
    given = {"cases": list(cases), "anm_cases": list(anm_cases), "references": list(references)}
    for kind, datasets in given.items():
        if len(datasets) != len(expected[kind]):
            raise ValueError(
                f"{len(datasets)} {kind} datasets given, the configuration's sweep has {len(expected[kind])}"
            )
    base = {k: getattr(run.params, k) for k in ("alpha", "beta", "delta")}
    order, tolerance = run.continuation.order, run.continuation.tolerance

    # references (regularization part)
    refs = []
    for eta, ds in zip(etas, given["references"]):
        _check_case(ds, f"reference of eta = {eta:g}", settings, {**base, "eta": eta, "harmonics": H_ref})
        refs.append(ds)
    reg_part = {key: np.array([r[key].values for r in refs]) for key in ERROR_KEYS}

    # the (H, eta) grid
    shape = (nH, nEta)
    scalars = {k: np.full(shape, np.nan) for k in ("runtime", "cpu_time", "load_average", "truncation", "time_residual", "path_residual", "path_frequency_error", "exact_seconds_per_orbit", "regularized_seconds_per_orbit")}
    counts = {k: np.full(shape, -1, dtype=np.int32) for k in ("steps", "factorizations", "newton_iterations")}
    converged = np.zeros(shape, dtype=bool)
    compared = np.zeros(shape, dtype=bool)
    failure = np.full(shape, "", dtype=object)
    per_energy = {key: np.full(shape + (nE,), np.nan) for key in ERROR_KEYS}
    trunc_part = {key: np.full(shape + (nE,), np.nan) for key in ERROR_KEYS if key != "force_max_exact"}
    case_datasets = iter(given["cases"])
    for j, eta in enumerate(etas):
        ref_system = _system(settings, H_ref, eta)
        for i, H in enumerate(Hs):
            ds = next(case_datasets)
            _check_case(ds, f"case H = {H}, eta = {eta:g}", settings, {**base, "eta": eta, "harmonics": H, "order": order, "tolerance": tolerance})
            converged[i, j], compared[i, j] = bool(ds["converged"]), bool(ds["compared"])
            failure[i, j] = str(ds["failure"].values)
            for key in scalars:
                scalars[key][i, j] = float(ds[key])
            for key in counts:
                counts[key][i, j] = int(ds[key])
            for key in ERROR_KEYS:
                per_energy[key][i, j] = ds[key].values
            system = _system(settings, H, eta)
            for k in range(nE):
                U, U_ref = ds["orbit"].values[k], refs[j]["orbit"].values[k]
                if np.all(np.isfinite(U)) and np.all(np.isfinite(U_ref)):
                    diff = hbm_orbit_differences(system, U, ref_system, U_ref, settings.phase_samples)
                    for key in trunc_part:
                        trunc_part[key][i, j, k] = diff[key]

    # the order/tolerance grid
    ashape = (len(orders), len(tols))
    anm = {k: np.full(ashape, np.nan) for k in ("runtime", "cpu_time", "load_average", "path_residual", "path_frequency_error", "time_residual", "truncation")}
    anm_counts = {k: np.full(ashape, -1, dtype=np.int32) for k in ("steps", "factorizations", "newton_iterations")}
    anm_err = {key: np.full(ashape, np.nan) for key in ("relative_frequency_difference", "max_x_difference")}
    anm_conv = np.zeros(ashape, dtype=bool)
    anm_failure = np.full(ashape, "", dtype=object)
    anm_datasets = iter(given["anm_cases"])
    for i, anm_order in enumerate(orders):
        for j, tol in enumerate(tols):
            ds = next(anm_datasets)
            _check_case(ds, f"ANM case order {anm_order}, tolerance {tol:g}", settings, {**base, "eta": run.params.eta, "harmonics": sweep.anm_harmonics, "order": anm_order, "tolerance": tol})
            anm_conv[i, j] = bool(ds["converged"])
            anm_failure[i, j] = str(ds["failure"].values)
            for key in anm:
                anm[key][i, j] = float(ds[key])
            for key in anm_counts:
                anm_counts[key][i, j] = int(ds[key])
            if bool(ds["compared"]):
                for key in anm_err:
                    anm_err[key][i, j] = _max_abs(ds[key].values)

    cost = exact_cost

    # summaries: maxima over the energies, only where every energy was compared
    def summary(values):
        out = _max_abs(values)
        return np.where(compared, out, np.nan)

    relative_force = per_energy["max_force_difference"] / per_energy["force_max_exact"]
    hz, he = ("harmonics", "eta"), ("harmonics", "eta", "energy")
    data = {
        "converged": (hz, converged, {"long_name": "the continuation reached the end of NNM1 stage 1 with every orbit resolved", "units": "1"}),
        "compared": (hz, compared, {"long_name": "converged and matched with the exact orbits at every study energy", "units": "1"}),
        "failure": string_variable(hz, failure.astype(str), "why the setting did not converge or was not compared ('' if it was)"),
        "runtime": variable(hz, scalars["runtime"], "wall-clock time of the continuation of NNM1 stage 1", "s"),
        "cpu_time": variable(hz, scalars["cpu_time"], "CPU time of the continuation of NNM1 stage 1", "s"),
        "load_average": variable(hz, scalars["load_average"], "1-minute load average when the job started (run times are measurements)"),
        "steps": (hz, counts["steps"], {"long_name": "ANM steps (-1: unknown, the run failed)", "units": "1"}),
        "factorizations": (hz, counts["factorizations"], {"long_name": "LU factorizations of the bordered Jacobian (-1: unknown, the run failed)", "units": "1"}),
        "newton_iterations": (hz, counts["newton_iterations"], {"long_name": "Newton corrections of ANM step ends (-1: unknown)", "units": "1"}),
        "truncation": variable(hz, scalars["truncation"], "largest truncation indicator along the run (top share of x'' or f, at least two harmonics)"),
        "time_residual": variable(hz, scalars["time_residual"], "largest residual in time of Eq. (7) along the branch, relative to the largest restoring force"),
        "path_residual": variable(hz, scalars["path_residual"], "largest relative algebraic residual over the branch points (ANM interior points included)"),
        "path_frequency_error": variable(hz, scalars["path_frequency_error"], "relative frequency shift of the worst branch point from the HBM solution curve"),
        "regularized_seconds_per_orbit": variable(hz, scalars["regularized_seconds_per_orbit"], "mean time to solve one HBM orbit at a prescribed energy", "s"),
        "frequency_error": variable(hz, summary(per_energy["relative_frequency_difference"]), "largest |relative frequency error| against the exact orbits over the study energies"),
        "x_error": variable(hz, summary(per_energy["max_x_difference"]), "largest |x_regularized - x_exact| over the period and the study energies"),
        "u_error": variable(hz, summary(per_energy["max_u_difference"]), "largest |u_regularized - u_exact| over the period and the study energies"),
        "force_error": variable(hz, summary(per_energy["max_force_difference"]), "largest |f_HBM - f_piecewise(x_exact)| over the period and the study energies"),
        "relative_force_error": variable(hz, summary(relative_force), "largest contact-force error relative to the largest exact contact force, over the study energies"),
        "frequency_error_truncation": variable(hz, summary(trunc_part["relative_frequency_difference"]), "truncation part of the frequency error: largest |f_H - f_Href| / f_Href over the study energies (same eta)"),
        "x_error_truncation": variable(hz, summary(trunc_part["max_x_difference"]), "truncation part of the x error: largest |x_H - x_Href| over the period and the study energies"),
        "u_error_truncation": variable(hz, summary(trunc_part["max_u_difference"]), "truncation part of the u error: largest |u_H - u_Href|"),
        "force_error_truncation": variable(hz, summary(trunc_part["max_force_difference"]), "truncation part of the force error: largest |f_H - f_Href|"),
        "reference_ratio": (("harmonics",), np.asarray(H_ref / np.asarray(Hs, dtype=float)), {"long_name": "H_ref / H: how much larger the reference is (the truncation part is underestimated when small)", "units": "1"}),
        "frequency_error_regularization": variable(("eta",), _max_abs(reg_part["relative_frequency_difference"]), "regularization part of the frequency error: largest |relative frequency error| of the H_ref orbits against the exact ones"),
        "x_error_regularization": variable(("eta",), _max_abs(reg_part["max_x_difference"]), "regularization part of the x error (H_ref orbits against the exact ones)"),
        "u_error_regularization": variable(("eta",), _max_abs(reg_part["max_u_difference"]), "regularization part of the u error (H_ref orbits against the exact ones)"),
        "force_error_regularization": variable(("eta",), _max_abs(reg_part["max_force_difference"]), "regularization part of the contact-force error (H_ref orbits against the exact ones)"),
        "reference_converged": (("eta",), np.array([bool(r["converged"]) for r in refs]), {"long_name": "the H_ref reference of this eta is complete and resolved", "units": "1"}),
        "reference_failure": string_variable(("eta",), [str(r["failure"].values) for r in refs], "why the reference is incomplete ('' if complete)"),
        "reference_runtime": variable(("eta",), [float(r["runtime"]) for r in refs], "wall-clock time of the reference of this eta", "s"),
        "reference_truncation": variable(("eta",), [np.nanmax(r["truncation"].values) if np.isfinite(r["truncation"].values).any() else np.nan for r in refs], "largest truncation indicator of the reference orbits"),
        "anm_converged": (("order", "tolerance"), anm_conv, {"long_name": "ANM sweep: the continuation converged with every orbit resolved", "units": "1"}),
        "anm_failure": string_variable(("order", "tolerance"), anm_failure.astype(str), "ANM sweep: why the setting failed ('' if it did not)"),
        "anm_runtime": variable(("order", "tolerance"), anm["runtime"], "ANM sweep: wall-clock time of NNM1 stage 1", "s"),
        "anm_cpu_time": variable(("order", "tolerance"), anm["cpu_time"], "ANM sweep: CPU time of NNM1 stage 1", "s"),
        "anm_load_average": variable(("order", "tolerance"), anm["load_average"], "ANM sweep: 1-minute load average when the job started"),
        "anm_steps": (("order", "tolerance"), anm_counts["steps"], {"long_name": "ANM sweep: steps (-1: unknown)", "units": "1"}),
        "anm_factorizations": (("order", "tolerance"), anm_counts["factorizations"], {"long_name": "ANM sweep: LU factorizations (-1: unknown)", "units": "1"}),
        "anm_newton_iterations": (("order", "tolerance"), anm_counts["newton_iterations"], {"long_name": "ANM sweep: Newton corrections of step ends (-1: unknown)", "units": "1"}),
        "anm_path_residual": variable(("order", "tolerance"), anm["path_residual"], "ANM sweep: largest relative algebraic residual over the branch points, interior points of the steps included (accuracy of the path itself)"),
        "anm_path_frequency_error": variable(("order", "tolerance"), anm["path_frequency_error"], "ANM sweep: relative frequency shift of the worst branch point (largest residual) from the HBM solution at the same amplitude (accuracy of the drawn curve)"),
        "anm_time_residual": variable(("order", "tolerance"), anm["time_residual"], "ANM sweep: largest residual in time of Eq. (7) along the branch"),
        "anm_frequency_error": variable(("order", "tolerance"), anm_err["relative_frequency_difference"], "ANM sweep: largest |relative frequency error| against the exact orbits (Newton-corrected matched orbits)"),
        "anm_x_error": variable(("order", "tolerance"), anm_err["max_x_difference"], "ANM sweep: largest x error against the exact orbits (Newton-corrected matched orbits)"),
        "exact_seconds_per_orbit": variable((), np.nanmedian(scalars["exact_seconds_per_orbit"]) if np.isfinite(scalars["exact_seconds_per_orbit"]).any() else np.nan, "exact solver: median time to solve one orbit at a prescribed energy (Newton on the closed form, validity checks)", "s"),
        "exact_family_seconds_per_orbit": variable((), float(cost["family_seconds_per_orbit"]), "exact solver: time per orbit of the family continuation", "s"),
        "exact_time_history_seconds": variable((), float(cost["time_history_seconds"]), cost["time_history_seconds"].attrs["long_name"], "s"),
        "exact_max_residual": variable((), float(cost["max_residual"]), "exact solver: largest residual of the quarter-period equations along the family"),
    }
    for key, (long_name, units) in _PER_ENERGY.items():
        data[f"{key}_at_energy"] = variable(he, per_energy[key], long_name, units)
        if key != "force_max_exact":
            data[f"{key}_regularization_at_energy"] = variable(("eta", "energy"), reg_part[key], "regularization part (H_ref vs exact): " + long_name, units)
            data[f"{key}_truncation_at_energy"] = variable(he, trunc_part[key], "truncation part (H vs H_ref, same eta): " + long_name.replace("regularized", "H").replace("exact", "H_ref"), units)
    coords = {
        "harmonics": ("harmonics", np.asarray(Hs, dtype=np.int32), {"long_name": "number of harmonics H", "units": "1"}),
        "eta": ("eta", np.asarray(etas), {"long_name": "regularization parameter eta", "units": "1"}),
        "energy": ("energy", energies, {"long_name": "matched total energy (two-impact range of NNM1)", "units": "1"}),
        "order": ("order", np.asarray(orders, dtype=np.int32), {"long_name": "ANM series order N (ANM sweep)", "units": "1"}),
        "tolerance": ("tolerance", np.asarray(tols), {"long_name": "ANM step-length tolerance (ANM sweep)", "units": "1"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs = {
        **{k: float(v) for k, v in base.items()},
        "anm_sweep_eta": float(run.params.eta),
        "anm_sweep_harmonics": int(sweep.anm_harmonics),
        "sweep_order": int(order),
        "sweep_tolerance": float(tolerance),
        "reference_harmonics": int(H_ref),
        "reference_seed_harmonics": int(sweep.reference_seed_harmonics),
        "max_truncation": float(run.max_truncation),
        "measurement": (
            "run times are wall-clock measurements of each Snakemake job (one BLAS thread); they depend on the "
            "machine and its load and are not reproducible byte for byte"
        ),
        "error_split": (
            "regularization part = H_ref orbit vs exact orbit; truncation part = H orbit vs H_ref orbit (same eta); "
            "both at the same matched energies as the total error"
        ),
    }
    return ds


