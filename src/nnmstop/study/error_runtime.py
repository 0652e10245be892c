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
from nnmstop.netcdf import check_up_to_date
from nnmstop.settings import StageOneRun, StudySettings
from nnmstop.study.runs import (
    ERROR_KEYS,
    Status,
    case_status,
    flags,
    floats,
    hbm_orbit_differences,
    match_energies,
    path_error,
    run_stage_one,
    texts,
)

__all__ = [
    "sweep_cases",
    "case_run",
    "error_case_dataset",
    "reference_dataset",
    "exact_cost_dataset",
    "gather_error_vs_runtime",
]


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
    return replace(run, harmonics=int(harmonics), params=replace(run.params, eta=float(eta)), continuation=continuation)


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
    n_unknowns = case.system().n_unknowns
    failure = run.failure
    energy_status = np.full(energies.size, run.status, dtype=np.int8)
    values = {key: np.full(energies.size, np.nan) for key in ERROR_KEYS}
    orbits = np.full((energies.size, n_unknowns), np.nan)
    t_exact = t_reg = time_residual = path_residual = path_frequency = np.nan
    if run.converged:
        matched = match_energies(exact, run.dataset, energies, settings.phase_samples, settings.end_margin)
        values, t_exact, t_reg = matched.values, matched.exact_seconds_per_orbit, matched.regularized_seconds_per_orbit
        orbits = _orbit_matrix(matched.orbits, n_unknowns)
        energy_status = matched.status
        failure = matched.failure and f"not compared over the whole study range: {matched.failure}"
        time_residual = float(run.dataset["time_residual"].max())
        path_residual, path_frequency = path_error(case.system(), run.dataset)
    status = case_status(run.status, energy_status)
    stats = run.stats
    count = (lambda name: getattr(stats, name)) if stats is not None else (lambda name: -1)
    e = ("energy",)
    data = {
        "status": ((), flags(status)),
        "energy_status": (e, flags(energy_status)),
        "converged": ((), status not in (Status.UNRESOLVED, Status.CONTINUATION_ENDED)),
        "compared": ((), status == Status.COMPUTED),
        "failure": ((), texts(failure)),
        "runtime": ((), floats(run.runtime)),
        "cpu_time": ((), floats(run.cpu_time)),
        "load_average": ((), floats(load)),
        "steps": ((), np.int32(count("steps"))),
        "factorizations": ((), np.int32(count("factorizations"))),
        "newton_iterations": ((), np.int32(count("newton_iterations"))),
        "truncation": ((), floats(run.truncation)),
        "time_residual": ((), floats(time_residual)),
        "path_residual": ((), floats(path_residual)),
        "path_frequency_error": ((), floats(path_frequency)),
        "exact_seconds_per_orbit": ((), floats(t_exact)),
        "regularized_seconds_per_orbit": ((), floats(t_reg)),
        "orbit": (("energy", "unknown"), floats(orbits)),
    }
    for key in ERROR_KEYS:
        data[key] = (e, floats(values[key]))
    ds = xr.Dataset(
        data,
        coords={
            "energy": ("energy", energies),
            "unknown": ("unknown", np.arange(n_unknowns)),
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
    energy_status = np.full(energies.size, seed.status, dtype=np.int8)
    failure = seed.failure and f"seed continuation ended early: {seed.failure}"
    if seed.converged:
        matched = match_energies(
            exact, _pad_harmonics(seed.dataset, H_ref), energies, settings.phase_samples, settings.end_margin
        )
        values, energy_status, failure = matched.values, matched.status, matched.failure
        orbits = _orbit_matrix(matched.orbits, n_unknowns)
        levels = np.array([np.nan if U is None else matched.system.truncation(U) for U in matched.orbits])
        # an orbit its harmonics do not resolve gives no number, only its indicator
        unresolved = np.isfinite(levels) & (levels > seed_run.max_truncation)
        if unresolved.any():
            energy_status[unresolved] = Status.UNRESOLVED
            for key in values:
                values[key][unresolved] = np.nan
            orbits[unresolved] = np.nan
            failure = failure or (
                f"the reference with H_ref = {H_ref} harmonics is not resolved itself at energy "
                f"{energies[unresolved][0]:g} (truncation indicator {levels[unresolved][0]:.3g} > "
                f"{seed_run.max_truncation:g}); raise study.error_runtime.reference_harmonics"
            )
    status = case_status(seed.status, energy_status)
    runtime = time.perf_counter() - start
    e = ("energy",)
    data = {
        "status": ((), flags(status)),
        "energy_status": (e, flags(energy_status)),
        "converged": ((), status == Status.COMPUTED),
        "failure": ((), texts(failure)),
        "runtime": ((), floats(runtime)),
        "load_average": ((), floats(load)),
        "truncation": (e, floats(levels)),
        "orbit": (("energy", "unknown"), floats(orbits)),
    }
    for key in ERROR_KEYS:
        data[key] = (e, floats(values[key]))
    ds = xr.Dataset(
        data,
        coords={
            "energy": ("energy", energies),
            "unknown": ("unknown", np.arange(n_unknowns)),
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
        "family_seconds_per_orbit": ((), floats(min(family_times) / n)),
        "family_orbits": ((), np.int32(n)),
        "family_seconds": ((), floats(min(family_times))),
        "time_history_seconds": ((), floats(min(history_times))),
        "max_residual": ((), floats(float(family.residual.max()))),
        "load_average": ((), floats(load)),
    }
    ds = xr.Dataset(data)
    ds.attrs = {**params.as_attrs(), "repeats": int(repeats), "measurement": "run times measured on this machine"}
    return ds


# --------------------------------------------------------------------------- gather


def _check_case(ds: xr.Dataset, label: str, settings: StudySettings, expect: dict) -> None:
    """Refuse a case dataset computed with other settings (a stale file)."""
    check_up_to_date(ds, expect, source=label)
    energies = np.asarray(settings.energies, dtype=float)
    if ds.sizes.get("energy") != energies.size or not np.allclose(ds["energy"].values, energies, rtol=1e-12, atol=0):
        raise ValueError(
            f"{label}: computed at the energies {ds['energy'].values.tolist()}, the configuration asks for "
            f"{energies.tolist()}"
        )


def _system(settings: StudySettings, harmonics: int, eta: float) -> HarmonicBalanceSystem:
    return case_run(settings, harmonics, eta).system()


def _max_abs(values, axis=-1):
    values = np.abs(np.asarray(values, dtype=float))
    with np.errstate(invalid="ignore"):
        out = np.max(values, axis=axis)
    return out


def _grid(shape, fill=np.nan, dtype=float):
    return np.full(shape, fill, dtype=dtype)


def _references(settings: StudySettings, references: list) -> dict:
    """The reference of each ``eta`` (checked), its per-energy errors against exact and its status."""
    sweep, run = settings.sweep(), settings.run
    base = {k: getattr(run.params, k) for k in ("alpha", "beta", "delta")}
    for eta, ds in zip(sweep.eta, references):
        _check_case(
            ds, f"reference of eta = {eta:g}", settings, {**base, "eta": eta, "harmonics": sweep.reference_harmonics}
        )
    levels = [r["truncation"].values for r in references]
    return {
        "datasets": references,
        "status": np.array([int(r["status"]) for r in references], dtype=np.int8),
        "energy_status": np.array([r["energy_status"].values for r in references], dtype=np.int8),
        "failure": [str(r["failure"].values) for r in references],
        "runtime": np.array([float(r["runtime"]) for r in references]),
        "truncation": np.array([np.max(v[np.isfinite(v)]) if np.isfinite(v).any() else np.nan for v in levels]),
        "values": {key: np.array([r[key].values for r in references]) for key in ERROR_KEYS},
    }


_CASE_SCALARS = (
    "runtime",
    "cpu_time",
    "load_average",
    "truncation",
    "time_residual",
    "path_residual",
    "path_frequency_error",
    "exact_seconds_per_orbit",
    "regularized_seconds_per_orbit",
)
_CASE_COUNTS = ("steps", "factorizations", "newton_iterations")


def _cases(settings: StudySettings, cases: list, refs: dict) -> dict:
    """The (H, eta) grid: each case's scalars, status, per-energy errors, and the truncation part
    (the orbit with H against the reference orbit of the same eta, at each energy both have)."""
    sweep, run = settings.sweep(), settings.run
    Hs, etas, nE = sweep.harmonics, sweep.eta, len(settings.energies)
    shape = (len(Hs), len(etas))
    out = {
        "scalars": {k: _grid(shape) for k in _CASE_SCALARS},
        "counts": {k: _grid(shape, -1, np.int32) for k in _CASE_COUNTS},
        "status": _grid(shape, 0, np.int8),
        "energy_status": _grid(shape + (nE,), 0, np.int8),
        "failure": np.full(shape, "", dtype=object),
        "per_energy": {key: _grid(shape + (nE,)) for key in ERROR_KEYS},
        "truncation_part": {key: _grid(shape + (nE,)) for key in ERROR_KEYS if key != "force_max_exact"},
    }
    base = {k: getattr(run.params, k) for k in ("alpha", "beta", "delta")}
    expect = {**base, "order": run.continuation.order, "tolerance": run.continuation.tolerance}
    datasets = iter(cases)
    for j, eta in enumerate(etas):
        ref_system = _system(settings, sweep.reference_harmonics, eta)
        reference = refs["datasets"][j]
        for i, H in enumerate(Hs):
            ds = next(datasets)
            _check_case(ds, f"case H = {H}, eta = {eta:g}", settings, {**expect, "eta": eta, "harmonics": H})
            out["status"][i, j], out["failure"][i, j] = int(ds["status"]), str(ds["failure"].values)
            out["energy_status"][i, j] = ds["energy_status"].values
            for key in _CASE_SCALARS:
                out["scalars"][key][i, j] = float(ds[key])
            for key in _CASE_COUNTS:
                out["counts"][key][i, j] = int(ds[key])
            for key in ERROR_KEYS:
                out["per_energy"][key][i, j] = ds[key].values
            system = _system(settings, H, eta)
            both = (ds["energy_status"].values == Status.COMPUTED) & (
                reference["energy_status"].values == Status.COMPUTED
            )
            for k in np.flatnonzero(both):
                U, U_ref = ds["orbit"].values[k], reference["orbit"].values[k]
                diff = hbm_orbit_differences(system, U, ref_system, U_ref, settings.phase_samples)
                for key in out["truncation_part"]:
                    out["truncation_part"][key][i, j, k] = diff[key]
    return out


def _anm_cases(settings: StudySettings, anm_cases: list) -> dict:
    """The (order, tolerance) grid at ``anm_harmonics`` and ``model.eta``."""
    sweep, run = settings.sweep(), settings.run
    shape = (len(sweep.anm_orders), len(sweep.anm_tolerances))
    scalars = (
        "runtime",
        "cpu_time",
        "load_average",
        "path_residual",
        "path_frequency_error",
        "time_residual",
        "truncation",
    )
    out = {
        "scalars": {k: _grid(shape) for k in scalars},
        "counts": {k: _grid(shape, -1, np.int32) for k in _CASE_COUNTS},
        "errors": {key: _grid(shape) for key in ("relative_frequency_difference", "max_x_difference")},
        "status": _grid(shape, 0, np.int8),
        "failure": np.full(shape, "", dtype=object),
    }
    base = {k: getattr(run.params, k) for k in ("alpha", "beta", "delta", "eta")}
    datasets = iter(anm_cases)
    for i, order in enumerate(sweep.anm_orders):
        for j, tol in enumerate(sweep.anm_tolerances):
            ds = next(datasets)
            expect = {**base, "harmonics": sweep.anm_harmonics, "order": order, "tolerance": tol}
            _check_case(ds, f"ANM case order {order}, tolerance {tol:g}", settings, expect)
            out["status"][i, j], out["failure"][i, j] = int(ds["status"]), str(ds["failure"].values)
            for key in scalars:
                out["scalars"][key][i, j] = float(ds[key])
            for key in _CASE_COUNTS:
                out["counts"][key][i, j] = int(ds[key])
            if int(ds["status"]) == Status.COMPUTED:
                for key in out["errors"]:
                    out["errors"][key][i, j] = _max_abs(ds[key].values)
    return out


def gather_error_vs_runtime(
    settings: StudySettings, cases: list, anm_cases: list, references: list, exact_cost: xr.Dataset
) -> xr.Dataset:
    """Assemble the sweep datasets into ``error_vs_runtime`` (see the module docstring).

    ``cases``, ``anm_cases`` and ``references`` are the datasets of the sweep jobs in the
    order of :func:`sweep_cases`; ``exact_cost`` the dataset of :func:`exact_cost_dataset`.
    Each is checked against the setting it stands for (a stale file is refused).
    """
    expected = sweep_cases(settings)
    given = {"cases": list(cases), "anm_cases": list(anm_cases), "references": list(references)}
    for kind, datasets in given.items():
        if len(datasets) != len(expected[kind]):
            raise ValueError(
                f"{len(datasets)} {kind} datasets given, the configuration's sweep has {len(expected[kind])}"
            )
    refs = _references(settings, given["references"])
    grid = _cases(settings, given["cases"], refs)
    anm = _anm_cases(settings, given["anm_cases"])
    compared = grid["status"] == Status.COMPUTED
    if not compared.any():
        raise ValueError("no setting of the sweep was compared at every study energy: nothing to summarize")
    ds = xr.Dataset(
        {
            **_case_variables(grid),
            **_split_variables(settings, grid, refs),
            **_anm_variables(anm),
            **_exact_cost_variables(grid, exact_cost),
        },
        coords=_coordinates(settings),
    )
    ds.attrs = _gather_attrs(settings)
    return ds


def _summary(values, status):
    """Largest |value| over the energies, where every energy was compared (NaN elsewhere)."""
    return np.where(status == Status.COMPUTED, _max_abs(values), np.nan)


def _run_variables(dims: tuple, grid: dict, prefix: str = "", label: str = "") -> dict:
    """What every grid of settings stores about its runs: status, failure, times and counts, residuals
    (names ``prefix + name``, long names ``label + long name``)."""
    status, scalars, counts = grid["status"], grid["scalars"], grid["counts"]
    ended = np.isin(status, (Status.UNRESOLVED, Status.CONTINUATION_ENDED))
    data = {
        "status": (dims, flags(status)),
        "converged": (dims, ~ended),
        "compared": (dims, status == Status.COMPUTED),
        "failure": (dims, texts(grid["failure"].astype(str))),
        "runtime": (dims, floats(scalars["runtime"])),
        "cpu_time": (dims, floats(scalars["cpu_time"])),
        "load_average": (dims, floats(scalars["load_average"])),
        "truncation": (dims, floats(scalars["truncation"])),
        "time_residual": (dims, floats(scalars["time_residual"])),
        "path_residual": (dims, floats(scalars["path_residual"])),
        "path_frequency_error": (dims, floats(scalars["path_frequency_error"])),
    }
    for key in _CASE_COUNTS:
        data[key] = (dims, counts[key])
    return {prefix + name: value for name, value in data.items()}


def _case_variables(grid: dict) -> dict:
    hz, he = ("harmonics", "eta"), ("harmonics", "eta", "energy")
    status, per_energy = grid["status"], grid["per_energy"]
    relative_force = per_energy["max_force_difference"] / per_energy["force_max_exact"]
    data = {
        **_run_variables(hz, grid),
        "energy_status": (he, flags(grid["energy_status"])),
        "regularized_seconds_per_orbit": (hz, floats(grid["scalars"]["regularized_seconds_per_orbit"])),
        "frequency_error": (hz, floats(_summary(per_energy["relative_frequency_difference"], status))),
        "x_error": (hz, floats(_summary(per_energy["max_x_difference"], status))),
        "u_error": (hz, floats(_summary(per_energy["max_u_difference"], status))),
        "force_error": (hz, floats(_summary(per_energy["max_force_difference"], status))),
        "relative_force_error": (hz, floats(_summary(relative_force, status))),
    }
    for key in ERROR_KEYS:
        data[f"{key}_at_energy"] = (he, floats(per_energy[key]))
    return data


def _split_variables(settings: StudySettings, grid: dict, refs: dict) -> dict:
    """The regularization part (reference against exact, per eta) and the truncation part (H against
    the reference, per H and eta)."""
    hz, he, ee = ("harmonics", "eta"), ("harmonics", "eta", "energy"), ("eta", "energy")
    sweep = settings.sweep()
    # the setting's own reason first, else its reference's
    split_status = np.where(grid["status"] != Status.COMPUTED, grid["status"], refs["status"][None, :])
    data = {
        "reference_status": (("eta",), flags(refs["status"])),
        "reference_energy_status": (ee, flags(refs["energy_status"])),
        "reference_converged": (("eta",), refs["status"] == Status.COMPUTED),
        "reference_failure": (("eta",), texts(refs["failure"])),
        "reference_runtime": (("eta",), floats(refs["runtime"])),
        "reference_truncation": (("eta",), floats(refs["truncation"])),
        "reference_ratio": (("harmonics",), sweep.reference_harmonics / np.asarray(sweep.harmonics, dtype=float)),
        "split_status": (hz, flags(split_status)),
    }
    names = {
        "relative_frequency_difference": "frequency",
        "max_x_difference": "x",
        "max_u_difference": "u",
        "max_force_difference": "force",
    }
    for key, short in names.items():
        data[f"{short}_error_regularization"] = (("eta",), floats(_summary(refs["values"][key], refs["status"])))
        data[f"{short}_error_truncation"] = (hz, floats(_summary(grid["truncation_part"][key], split_status)))
        data[f"{key}_regularization_at_energy"] = (ee, floats(refs["values"][key]))
        data[f"{key}_truncation_at_energy"] = (he, floats(grid["truncation_part"][key]))
    return data


def _anm_variables(anm: dict) -> dict:
    ot = ("order", "tolerance")
    return {
        **_run_variables(ot, anm, "anm_", "ANM sweep: "),
        "anm_frequency_error": (ot, floats(anm["errors"]["relative_frequency_difference"])),
        "anm_x_error": (ot, floats(anm["errors"]["max_x_difference"])),
    }


def _exact_cost_variables(grid: dict, cost: xr.Dataset) -> dict:
    per_orbit = grid["scalars"]["exact_seconds_per_orbit"]
    return {
        "exact_seconds_per_orbit": ((), floats(np.median(per_orbit[np.isfinite(per_orbit)]))),
        "exact_family_seconds_per_orbit": ((), floats(float(cost["family_seconds_per_orbit"]))),
        "exact_time_history_seconds": ((), floats(float(cost["time_history_seconds"]))),
        "exact_max_residual": ((), floats(float(cost["max_residual"]))),
    }


def _coordinates(settings: StudySettings) -> dict:
    sweep = settings.sweep()
    return {
        "harmonics": ("harmonics", np.asarray(sweep.harmonics, dtype=np.int32)),
        "eta": ("eta", np.asarray(sweep.eta)),
        "energy": ("energy", np.asarray(settings.energies)),
        "order": ("order", np.asarray(sweep.anm_orders, dtype=np.int32)),
        "tolerance": ("tolerance", np.asarray(sweep.anm_tolerances)),
    }


def _gather_attrs(settings: StudySettings) -> dict:
    sweep, run = settings.sweep(), settings.run
    return {
        **{k: float(getattr(run.params, k)) for k in ("alpha", "beta", "delta")},
        "anm_sweep_eta": float(run.params.eta),
        "anm_sweep_harmonics": int(sweep.anm_harmonics),
        "sweep_order": int(run.continuation.order),
        "sweep_tolerance": float(run.continuation.tolerance),
        "reference_harmonics": int(sweep.reference_harmonics),
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
