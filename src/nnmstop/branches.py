"""Regularized NNM branches: staged ANM continuation and their labelled datasets.

A branch (NNM1 or NNM2) starts from its linear mode of the regularized system near
rest and is continued in *stages*: each stage starts from the last point of the
previous one and ends at the first point that meets its ``until`` criterion, for
example ``{impacts_above: 2}`` (the first orbit with more than one excursion beyond
each stop) or ``{energy_above: 1.0e5}``. A figure that needs only the low-energy part
of a branch then needs only the first stages. The stages of a branch concatenated
give the whole branch (:func:`combine_stages`).

Dataset layout (one per stage, and one per branch)
--------------------------------------------------
dimensions ``point`` (along the branch) and ``harmonic`` (0..H);
``x_cos(point, harmonic)``, ``x_sin``, and likewise ``u``, ``f``, ``z``: the Fourier
coefficients of Eq. (13) (``x_cos[:, 0]`` is the mean ``x_0``; the sine coefficients
are zero in the cosine basis); ``omega_squared`` and ``unfolding`` (the extra unknowns);
``energy``, ``frequency``, ``period``, ``x_max``, ``u_max``, ``impacts_per_period``,
``algebraic_residual``, ``time_residual``, ``force_error``, ``energy_spread``,
``truncation``, ``step``, ``stage``, ``branch_point`` and ``energy_fold`` (flags);
Floquet stability (config ``stability.method``: the monodromy matrix, :mod:`nnmstop.monodromy`, or
Hill's method, :mod:`nnmstop.stability`): ``stable`` (flag),
``multiplier_real``/``multiplier_imag(point, multiplier)``, ``max_multiplier``,
``stability_orbit_residual``, ``stability_resolved``.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
import xarray as xr

from .anm import ANMSettings, continue_anm
from .continuation import (
    Branch,
    ContinuationError,
    ContinuationStats,
    UnresolvedBranchError,
    newton_correct,
    relative_residual,
)
from .datasets import flag_variable
from .hbm import HarmonicBalanceSystem
from .models.structure import two_dof_structure
from .model import ModelParameters, linear_modes
from .monodromy import MonodromySettings, branch_monodromy
from .stability import DEFAULT_TOL, branch_stability

__all__ = [
    "system_from_config",
    "start_point",
    "stage_criterion",
    "continue_stage",
    "branch_dataset",
    "dataset_unknowns",
    "combine_stages",
    "TruncationGuard",
    "resolved_or_error",
    "bifurcated_branch",
]

logger = logging.getLogger("nnmstop.branches")

CRITERIA = ("energy_above", "impacts_above", "impacts_at_most", "frequency_within_gap_zero")


def system_from_config(config: dict, harmonics: int | None = None, eta: float | None = None) -> HarmonicBalanceSystem:
    """The HBM system of the configuration (optionally with other ``H`` or ``eta``)."""
    model = dict(config["model"])
    if eta is not None:
        model["eta"] = eta
    params = ModelParameters.from_config(model)
    H = config["hbm"]["harmonics"] if harmonics is None else harmonics
    return HarmonicBalanceSystem(two_dof_structure(params), H, time_samples=config["hbm"]["time_samples"])


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
    (kind, value), = until.items()
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
    :class:`~nnmstop.continuation.UnresolvedBranchError`, naming the energy, the
    truncation indicator (``diagnostics["truncation"]``, see
    :meth:`nnmstop.hbm.HarmonicBalanceSystem.truncation`) and ``H``, when the indicator
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


def resolved_or_error(stop, system, max_truncation: float, label: str) -> TruncationGuard:
    """``stop`` guarded by ``hbm.max_truncation`` (:class:`TruncationGuard`)."""
    return TruncationGuard(system, stop, max_truncation, label)


def _stage_settings(config: dict) -> ANMSettings:
    return ANMSettings.from_config(config["anm"], points_per_step=config["hbm"].get("points_per_step", 1))


def continue_stage(config: dict, branch_name: str, stage: int, previous: xr.Dataset | None = None) -> xr.Dataset:
    """Continue stage ``stage`` (1-based) of ``branch_name`` and return its dataset.

    Stage 1 starts from the linear mode; stage ``k > 1`` starts from the last point
    of ``previous`` (the dataset of stage ``k - 1``), in the direction of its last
    secant.

    Raises
    ------
    ContinuationError
        With the branch, stage, step and energy where the continuation failed.
    """
    spec = config["branches"][branch_name]
    stages = spec["stages"]
    if not 1 <= stage <= len(stages):
        raise ValueError(f"stage must be in 1..{len(stages)} for branch {branch_name!r}, got {stage!r}")
    system = system_from_config(config)
    if stage == 1:
        U0, direction = start_point(system, spec["mode"], spec["start_amplitude"])
    else:
        if previous is None:
            raise ValueError(f"stage {stage} of {branch_name!r} needs the dataset of stage {stage - 1}")
        points = dataset_unknowns(previous, system)
        U0, direction = points[-1], points[-1] - points[-2]
    label = f"{branch_name} stage {stage} ({stages[stage - 1]['name']})"
    stop = resolved_or_error(stage_criterion(stages[stage - 1]["until"], system.params, spec["mode"]),
                             system, config["hbm"]["max_truncation"], label)
    branch = continue_anm(system, U0, direction, stop, _stage_settings(config), label=label)
    return branch_dataset(system, branch, stage, config, branch_name)


def branch_dataset(system, branch: Branch, stage: int, config: dict, branch_name: str, located=None) -> xr.Dataset:
    """Labelled dataset of a continued branch (see the module docstring).

    ``located``: the located branch points, as returned by
    :func:`nnmstop.bifurcation.locate_flagged_branch_points`; by default the flagged
    steps of ``branch`` are located here.
    """
    H = system.H
    U = np.array(branch.points)
    diags = [d if d is not None else system.diagnostics(u) for u, d in zip(U, branch.diagnostics)]
    steps, end_reason, stats = branch.step, branch.end_reason, branch.stats
    if not all(np.isfinite(d["energy"]) for d in diags):
        raise ContinuationError(f"{branch_name} stage {stage}: non-finite energy in the branch")
    x, u, f, z, lam, nu = system.split(U)
    coords = {"point": np.arange(len(U)), "harmonic": np.arange(H + 1)}

    def series(c, name, symbol):
        full = system.to_full(c)
        cos = np.concatenate([full[:, :1], full[:, 1 : H + 1]], axis=1)
        sin = np.concatenate([np.zeros((len(U), 1)), full[:, H + 1 :]], axis=1)
        return {
            f"{symbol}_cos": (("point", "harmonic"), cos, {"long_name": f"cosine Fourier coefficients of {name}", "units": "1"}),
            f"{symbol}_sin": (("point", "harmonic"), sin, {"long_name": f"sine Fourier coefficients of {name}", "units": "1"}),
        }

    def col(key):
        return np.array([d[key] for d in diags])

    data = {}
    for c, name, symbol in ((x, "x (first mass)", "x"), (u, "u (second mass)", "u"), (f, "regularized contact force f", "f"), (z, "internal variable z = (f/alpha - x)^2", "z")):
        data.update(series(c, name, symbol))
    omega = np.sqrt(lam)
    data.update(
        {
            "omega_squared": ("point", lam, {"long_name": "squared angular frequency (unknown lambda of the HBM system)", "units": "1"}),
            "unfolding": ("point", nu, {"long_name": "unfolding parameter nu (fictitious damping times omega; zero on periodic orbits)", "units": "1"}),
            "energy": ("point", col("energy"), {"long_name": "total energy of the regularized model (contact potential included), mean over the period", "units": "1"}),
            "frequency": ("point", col("frequency"), {"long_name": "frequency omega/(2 pi) in Hz of the nondimensional time", "units": "Hz"}),
            "period": ("point", 2 * np.pi / omega, {"long_name": "period of the orbit in nondimensional time", "units": "1"}),
            "x_max": ("point", col("x_max"), {"long_name": "largest displacement of the first mass over the period", "units": "1"}),
            "u_max": ("point", col("u_max"), {"long_name": "largest displacement of the second mass over the period", "units": "1"}),
            "impacts_per_period": ("point", col("impacts_per_period").astype(np.int32), {"long_name": "number of excursions of x beyond the stops (|x| > 1) per period", "units": "1"}),
            "algebraic_residual": ("point", np.array([relative_residual(system, p) for p in U]), {"long_name": "norm of the residual of the HBM algebraic system relative to the norm of the unknowns", "units": "1"}),
            "time_residual": ("point", col("time_residual"), {"long_name": "largest residual in time of the regularized equation of x (true cubic root for f) relative to the largest restoring force", "units": "1"}),
            "force_error": ("point", col("force_error"), {"long_name": "largest difference between the HBM contact force and the cubic root f(x(t)), relative to max |f|", "units": "1"}),
            "energy_spread": ("point", col("energy_spread"), {"long_name": "relative variation of the total energy over the period (zero for an exact orbit)", "units": "1"}),
            "truncation": ("point", col("truncation"), {"long_name": "share of the mean square of x'' or f carried by the top tenth of the harmonics (larger of the two)", "units": "1"}),
            "step": ("point", np.asarray(steps, dtype=np.int32), {"long_name": "index of the ANM step that produced the point", "units": "1"}),
            "stage": ("point", np.full(len(U), stage, dtype=np.int32), {"long_name": "continuation stage of the point", "units": "1"}),
        }
    )
    branch_point = np.zeros(len(U), dtype=bool)
    branch_point[branch.branch_points] = True
    fold = energy_folds(col("energy"))
    data.update(
        {
            "branch_point": flag_variable("point", branch_point, "1 where a simple branch point of the HBM system (sign change of det [J; t^T]) lies within the ANM step that ends at this point", "regular branch_point"),
            "energy_fold": flag_variable("point", fold, "1 where the energy has a local extremum along the branch (energy fold)", "regular fold"),
        }
    )
    if located is None:
        from .bifurcation import locate_flagged_branch_points

        located = locate_flagged_branch_points(system, U, steps, branch.branch_points, _stage_settings(config))
    data.update(located_branch_point_variables(system, located))
    # Floquet stability of every point (config stability.method)
    started = time.perf_counter()
    stability = orbit_stability(system, U, config, time_residual=col("time_residual"))
    # Wall time in the log only (datasets stay byte-reproducible); benchmarks/cold_build.py reads it.
    logger.info("stability of %d points in %.2f s (%s)", len(U), time.perf_counter() - started, config.get("stability", {}).get("method", "monodromy"))
    data.update(stability.data_vars())
    coords["multiplier"] = np.arange(stability.multipliers.shape[1])
    ds = xr.Dataset(data, coords=coords)
    ds = ds.assign(located_fold_variables(_coefficient_vectors(ds), col("energy"), col("frequency")))
    ds["point"].attrs = {"long_name": "index of the point along the branch", "units": "1"}
    ds["multiplier"].attrs = {"long_name": "index of the Floquet multiplier: 0, 1 trivial pair; 2, 3 non-trivial pair", "units": "1"}
    ds["harmonic"].attrs = {"long_name": "harmonic number k (0 is the mean)", "units": "1"}
    anm = config["anm"]
    ds.attrs = {
        **system.params.as_attrs(),
        "branch": branch_name,
        "mode": int(config["branches"][branch_name]["mode"]),
        "harmonics": H,
        "time_samples": system.M,
        "basis": system.basis,
        "order": anm["order"],
        "tolerance": anm["tolerance"],
        "newton_threshold": anm["newton_threshold"],
        "pade": int(ANMSettings.from_config(anm).pade),
        "pade_steps": stats.pade_steps,
        "stages": len(config["branches"][branch_name]["stages"]),
        "end_reason": end_reason,
        "anm_steps": stats.steps,
        "factorizations": stats.factorizations,
    }
    return ds


def orbit_stability(system, U, config: dict, time_residual=None):
    """Floquet stability of the orbits ``U`` by the method of ``config["stability"]``.

    ``method: monodromy`` (the default, also without a ``stability`` section):
    :func:`nnmstop.monodromy.branch_monodromy`; ``method: hill``:
    :func:`nnmstop.stability.branch_stability`. Both return an object whose
    ``data_vars()`` gives the dataset variables (``stable``, ``multiplier_*``,
    ``max_multiplier``, ``stability_orbit_residual``, ``stability_resolved``, and for
    the monodromy also ``stability_reason`` and the error estimates). ``time_residual``:
    the orbits' residuals of Eq. (7), if already at hand.
    """
    spec = config.get("stability", {"method": "monodromy"})
    method = spec.get("method", "monodromy")
    if method == "monodromy":
        return branch_monodromy(system, U, MonodromySettings.from_config(spec), time_residual=time_residual)
    if method == "hill":
        return branch_stability(system, U, tol=spec.get("hill_tol", DEFAULT_TOL))
    raise ValueError(f"stability.method must be 'monodromy' or 'hill', got {method!r}")


BRANCH_POINT_DIM = "located_branch_point"
FOLD_DIM = "located_fold"


def located_branch_point_variables(system, located) -> dict:
    """Dataset variables (dimension ``located_branch_point``) of located branch points."""
    dim = (BRANCH_POINT_DIM,)
    diags = [system.diagnostics(point.U) for _, point, _, _ in located]
    return {
        "branch_point_energy": (dim, np.array([d["energy"] for d in diags], dtype=float), {"long_name": "energy of the located branch point", "units": "1"}),
        "branch_point_frequency": (dim, np.array([d["frequency"] for d in diags], dtype=float), {"long_name": "frequency of the located branch point", "units": "Hz"}),
        "branch_point_resonance": (dim, np.array([n for _, _, n, _ in located], dtype=np.int32), {"long_name": "n where the orbit at the branch point has period T/n (n:1 internal resonance), else 0", "units": "1"}),
        "branch_point_symmetry_breaking": flag_variable(dim, [b for _, _, _, b in located], "1 where the bifurcated tangent holds even harmonics only (the crossing curve breaks x(t + T/2) = -x(t))", "no yes"),
        "branch_point_tangent_angle": (dim, np.array([p.angle for _, p, _, _ in located], dtype=float), {"long_name": "angle between the tangents of the two curves at the branch point", "units": "degree"}),
        "branch_point_singular_ratio": (dim, np.array([p.singular_ratio for _, p, _, _ in located], dtype=float), {"long_name": "smallest over second-smallest singular value of J at the located point (zero at an exact branch point)", "units": "1"}),
        "branch_point_flagged_point": (dim, np.array([i for i, _, _, _ in located], dtype=np.int32), {"long_name": "index of the point that ends the ANM step holding the branch point", "units": "1"}),
    }


def located_fold_variables(U, energy, frequency) -> dict:
    """Dataset variables (dimension ``located_fold``) of the energy folds of a branch.

    Each local extremum of the energy along the branch is refined by the parabola
    through it and its two neighbours in the arclength of the unknowns; the
    frequency is read on the parabola through the same three points.
    """
    U, energy, frequency = np.asarray(U, float), np.asarray(energy, float), np.asarray(frequency, float)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(U, axis=0), axis=1))])
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
        "fold_energy": (dim, np.array(e_fold, dtype=float), {"long_name": "energy at the fold (local extremum along the branch), parabola through the three nearest points", "units": "1"}),
        "fold_frequency": (dim, np.array(f_fold, dtype=float), {"long_name": "frequency at the fold, same parabola", "units": "Hz"}),
        "fold_point": (dim, np.array(index, dtype=np.int32), {"long_name": "index of the point of extremal energy", "units": "1"}),
    }


def energy_folds(energy) -> np.ndarray:
    """Boolean flags of the local extrema of the energy along a branch."""
    energy = np.asarray(energy)
    fold = np.zeros(energy.shape, dtype=bool)
    slope = np.diff(energy)
    fold[1:-1] = slope[:-1] * slope[1:] < 0
    return fold


def dataset_unknowns(ds: xr.Dataset, system: HarmonicBalanceSystem) -> np.ndarray:
    """Unknown vectors of every point of a branch dataset, for ``system``'s layout."""
    H = system.H
    if ds.sizes["harmonic"] != H + 1:
        raise ValueError(f"dataset has {ds.sizes['harmonic'] - 1} harmonics, the system {H}")
    parts = []
    for symbol in ("x", "u", "f", "z"):
        cos = ds[f"{symbol}_cos"].values
        sin = ds[f"{symbol}_sin"].values
        full = np.concatenate([cos, sin[:, 1:]], axis=1)
        parts.append(full[:, : system.nc])
    tail = [ds["omega_squared"].values[:, None]]
    if system.full:
        tail.append(ds["unfolding"].values[:, None])
    return np.concatenate(parts + tail, axis=1)


def _coefficient_vectors(ds: xr.Dataset) -> np.ndarray:
    """The unknowns of every point as stored (all coefficients and omega^2), for arclengths."""
    parts = [ds[f"{s}_{kind}"].values for s in ("x", "u", "f", "z") for kind in ("cos", "sin")]
    return np.concatenate(parts + [ds["omega_squared"].values[:, None]], axis=1)


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
        out = out.assign(located_fold_variables(_coefficient_vectors(out), out["energy"].values, out["frequency"].values))
    out.attrs["end_reason"] = stages[-1].attrs["end_reason"]
    out.attrs["anm_steps"] = int(sum(ds.attrs["anm_steps"] for ds in stages))
    out.attrs["factorizations"] = int(sum(ds.attrs["factorizations"] for ds in stages))
    out.attrs["pade_steps"] = int(sum(ds.attrs.get("pade_steps", 0) for ds in stages))
    return out


def bifurcated_branch(config: dict, name: str, parent_stage: xr.Dataset) -> xr.Dataset:
    """Dataset of the branch that bifurcates from a regularized branch (``bifurcations.<name>``).

    The flagged steps of ``parent_stage`` (the dataset of stage ``bifurcations.<name>.stage``
    of the parent branch) are searched for the branch point of the ``n:1`` internal
    resonance, classified when the stage was built (``branch_point_resonance``); the other curve
    through it is followed both ways by the ANM until its energy leaves
    ``energy_range`` (:func:`nnmstop.bifurcation.continue_bifurcated_branch`).

    The dataset has the layout of a branch dataset (module docstring), ordered along
    the curve through the branch point (``branch_point`` flags it), plus
    ``subharmonic_share`` (zero on orbits of period ``T/n``) and global attributes
    describing the branch point: ``parent_branch``, ``resonance``,
    ``branch_point_energy``, ``branch_point_frequency``, ``tangent_angle`` (degrees
    between the two tangents), ``singular_ratio``.
    """
    from .bifurcation import (
        branch_point_kind,
        continue_bifurcated_branch,
        locate_flagged_branch_points,
        subharmonic_share,
    )

    spec = config["bifurcations"][name]
    parent, n = spec["parent"], spec["resonance"]
    stages_in = np.unique(parent_stage["stage"].values) if "stage" in parent_stage else []
    if parent_stage.attrs.get("branch") != parent or list(stages_in) != [spec["stage"]]:
        raise ValueError(
            f"bifurcations.{name}: expected the dataset of {parent} stage {spec['stage']}, got branch "
            f"{parent_stage.attrs.get('branch')!r} stage(s) {list(stages_in)}"
        )
    if "branch_point_resonance" not in parent_stage:
        raise ValueError(f"bifurcations.{name}: the {parent} stage dataset has no located branch points; rebuild it")
    # the stage located and classified its branch points: only the chosen one is located again, for U*
    resonance = parent_stage["branch_point_resonance"].values
    match = np.flatnonzero(resonance == n)
    if match.size == 0:
        found = [
            f"energy {e:.6g} ({branch_point_kind(int(m), bool(b))})"
            for e, m, b in zip(parent_stage["branch_point_energy"].values, resonance,
                               parent_stage["branch_point_symmetry_breaking"].values)
        ]
        raise ValueError(
            f"no branch point of the {n}:1 resonance (orbit of period T/{n}) among the flagged steps of "
            f"{parent} stage {spec['stage']}; found: " + ("; ".join(found) if found else "none")
        )
    system = system_from_config(config)
    settings = _stage_settings(config)
    flagged = [int(parent_stage["branch_point_flagged_point"].values[match[0]])]
    ((_, point, _, _),) = locate_flagged_branch_points(
        system, dataset_unknowns(parent_stage, system), parent_stage["step"].values, flagged, settings
    )
    low, high = spec["energy_range"]
    label = f"{name} (bifurcated from {parent} at the {n}:1 resonance)"

    def out_of_range(U, d):
        return f"energy left [{low:g}, {high:g}]" if not low <= d["energy"] <= high else ""

    stop = resolved_or_error(out_of_range, system, config["hbm"]["max_truncation"], label)
    branch = continue_bifurcated_branch(system, point, stop, settings, spec["switch_step"], label)
    ds = branch_dataset(system, branch, spec["stage"], config, parent, located=[(branch.branch_points[0], point, n, False)])
    ds["subharmonic_share"] = (
        "point",
        np.array([subharmonic_share(system, U, n) for U in branch.points]),
        {"long_name": f"share of the mean square of x and u in harmonics that are not multiples of {n} "
                      f"(zero for an orbit of period T/{n})", "units": "1"},
    )
    ds["stage"].attrs["long_name"] = "stage of the parent branch from whose branch point the branch was switched"
    ds["step"].attrs["long_name"] = "index of the ANM step that produced the point (negative on the side followed backwards)"
    diag = system.diagnostics(point.U)
    for key in ("mode", "stages"):
        ds.attrs.pop(key, None)
    ds.attrs.update(
        {
            "branch": name,
            "parent_branch": parent,
            "resonance": n,
            "branch_point_energy": float(diag["energy"]),
            "branch_point_frequency": float(diag["frequency"]),
            "tangent_angle": point.angle,
            "singular_ratio": point.singular_ratio,
            "switch_step": spec["switch_step"],
        }
    )
    return ds
