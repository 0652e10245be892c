"""NNM branches of a structure with stops (a finite-element tube, or any :class:`Structure`).

Map: :func:`continue_structure_nnm` starts from a linear mode at small amplitude and follows the
regularized NNM by the ANM until an energy limit or the truncation limit;
:func:`structure_branch_dataset` assembles the labelled dataset (Fourier coefficients of every
degree of freedom and stop force, energy, frequency, impacts per stop, residuals, located branch
points and folds, Floquet stability). The paper's 2-DOF branches keep their own stages and datasets
(:mod:`nnmstop.hbm.stages`); both run the same harmonic-balance system and continuation.
"""

from __future__ import annotations

import logging

import numpy as np
import xarray as xr

from nnmstop.continuation.anm import ANMSettings, continue_anm
from nnmstop.continuation.core import Branch, ContinuationError, ContinuationStats, newton_correct, relative_residual
from nnmstop.hbm.bifurcation import locate_flagged_branch_points
from nnmstop.hbm.dataset import energy_folds, located_branch_point_variables, located_fold_variables
from nnmstop.hbm.structure_stability import StructureStability
from nnmstop.hbm.system import HarmonicBalanceSystem, impacts_per_period
from nnmstop.netcdf import flag_variable

logger = logging.getLogger("nnmstop.hbm.structure_branch")

__all__ = ["structure_start_point", "continue_structure_nnm", "structure_branch_dataset"]


def structure_start_point(system: HarmonicBalanceSystem, mode: int, amplitude: float, tol: float = 1e-12):
    """A point of NNM ``mode`` at small amplitude and the direction of growing amplitude.

    The linear mode of the regularized structure, with the first stop's coordinate
    ``x_1 = amplitude cos(theta)``, corrected by Newton with that harmonic held fixed.
    """
    if not (np.isfinite(amplitude) and 0 < amplitude < 1):
        raise ValueError(f"start amplitude must lie in (0, 1) (inside the gap), got {amplitude!r}")
    U0 = system.linear_mode_guess(mode, amplitude)
    direction = np.zeros(system.n_unknowns)
    direction[system.phase_dof * system.nc + 1] = 1.0
    U0, _ = newton_correct(system, U0, direction, ContinuationStats(), tol=tol)
    return U0, direction


def continue_structure_nnm(
    system: HarmonicBalanceSystem,
    mode: int,
    start_amplitude: float,
    energy_max: float,
    max_truncation: float,
    settings: ANMSettings,
    label: str = "NNM",
) -> Branch:
    """Follow NNM ``mode`` of ``system``'s structure from small amplitude up to ``energy_max``.

    The branch ends at the first point above ``energy_max``, or, keeping the points before it,
    at the first point whose truncation indicator exceeds ``max_truncation`` (the orbit needs more
    harmonics than ``system.H``): ``branch.end_reason`` says which.
    """
    if not energy_max > 0:
        raise ValueError(f"energy_max must be > 0, got {energy_max!r}")
    if not 0 < max_truncation < 1:
        raise ValueError(f"max_truncation must lie in (0, 1), got {max_truncation!r}")
    # the start needs the accuracy the continuation asks of every point (its Newton threshold): on fine meshes
    # the round-off floor of the residual (stiffness spread ~ N**4) lies above a fixed 1e-12
    U0, direction = structure_start_point(system, mode, start_amplitude, tol=settings.newton_threshold)

    def stop(U, diagnostics):
        if diagnostics["truncation"] > max_truncation:
            return f"truncation {diagnostics['truncation']:.3g} above {max_truncation:g} at E = "
            f"{diagnostics['energy']:.6g}"
        if diagnostics["energy"] > energy_max:
            return f"energy above {energy_max:g}"
        return ""

    branch = continue_anm(system, U0, direction, stop, settings, label=label)
    if branch.end_reason.startswith("truncation"):
        # the offending point is not resolved by H harmonics: drop it, keep the branch before it
        for key in ("points", "step", "diagnostics"):
            del getattr(branch, key)[-1:]
        branch.branch_points = [i for i in branch.branch_points if i < len(branch.points) - 1]
    if len(branch.points) < 3:
        raise ContinuationError(f"{label}: only {len(branch.points)} resolved points ({branch.end_reason})")
    return branch


def _per_stop_impacts(system: HarmonicBalanceSystem, U) -> np.ndarray:
    history = system.time_history(U, max(16 * system.H, 512))
    x = np.reshape(history["x"], (system.n_stops, -1))
    return np.array([impacts_per_period(x_i) for x_i in x], dtype=np.int32)


def structure_branch_dataset(
    system: HarmonicBalanceSystem,
    branch: Branch,
    settings: ANMSettings,
    stability: StructureStability,
    attrs: dict | None = None,
    dof_labels=None,
    node_coordinates=None,
) -> xr.Dataset:
    """Labelled dataset of a branch of :func:`continue_structure_nnm`.

    Variables on ``point``: ``omega_squared``, ``energy``, ``frequency``, ``period``, ``x_max`` (largest
    coordinate of the first stop over gap), ``impacts_per_period`` (all stops) and ``stop_impacts``
    (per stop), residuals, truncation, branch-point and fold flags, Floquet stability; Fourier
    coefficients ``q_cos``/``q_sin`` (point, dof, harmonic) and ``f_cos``/``f_sin`` (point, stop,
    harmonic). ``attrs``: global attributes to add (structure, mode, settings).
    """
    U = np.array(branch.points)
    H = system.H
    diags = [d if d is not None else system.diagnostics(u) for u, d in zip(U, branch.diagnostics)]
    if not all(np.isfinite(d["energy"]) for d in diags):
        raise ContinuationError("non-finite energy in the branch")
    blocks = system.split(U)
    N, s = system.n_dofs, system.n_stops
    Q, F = np.stack(blocks[:N], axis=1), np.stack(blocks[N : N + s], axis=1)
    lam, nu = blocks[-2], blocks[-1]

    def col(key):
        return np.array([d[key] for d in diags])

    def cos_sin(c):
        full = system.to_full(c)
        cos = np.concatenate([full[..., :1], full[..., 1 : H + 1]], axis=-1)
        sin = np.concatenate([np.zeros(full.shape[:-1] + (1,)), full[..., H + 1 :]], axis=-1)
        return cos, sin

    q_cos, q_sin = cos_sin(Q)
    f_cos, f_sin = cos_sin(F)
    one = {"units": "1"}
    energy = col("energy")
    branch_point = np.zeros(len(U), dtype=bool)
    branch_point[branch.branch_points] = True
    data = {
        "q_cos": (
            ("point", "dof", "harmonic"),
            q_cos,
            {"long_name": "cosine Fourier coefficients of the degrees of freedom", **one},
        ),
        "q_sin": (
            ("point", "dof", "harmonic"),
            q_sin,
            {"long_name": "sine Fourier coefficients of the degrees of freedom", **one},
        ),
        "f_cos": (
            ("point", "stop", "harmonic"),
            f_cos,
            {"long_name": "cosine Fourier coefficients of the regularized stop forces", **one},
        ),
        "f_sin": (
            ("point", "stop", "harmonic"),
            f_sin,
            {"long_name": "sine Fourier coefficients of the regularized stop forces", **one},
        ),
        "omega_squared": (
            "point",
            lam,
            {"long_name": "squared angular frequency (unknown lambda of the HBM system)", **one},
        ),
        "unfolding": ("point", nu, {"long_name": "unfolding parameter nu (zero on periodic orbits)", **one}),
        "energy": (
            "point",
            energy,
            {"long_name": "total energy of the regularized model, mean over the period", **one},
        ),
        "frequency": (
            "point",
            col("frequency"),
            {"long_name": "frequency omega/(2 pi) in Hz of the nondimensional time", "units": "Hz"},
        ),
        "period": (
            "point",
            2 * np.pi / np.sqrt(lam),
            {"long_name": "period of the orbit in nondimensional time", **one},
        ),
        "x_max": ("point", col("x_max"), {"long_name": "largest displacement at the first stop over its gap", **one}),
        "impacts_per_period": (
            "point",
            col("impacts_per_period").astype(np.int32),
            {"long_name": "excursions beyond the gaps per period, all stops", **one},
        ),
        "stop_impacts": (
            ("point", "stop"),
            np.array([_per_stop_impacts(system, u) for u in U]),
            {"long_name": "excursions beyond the gap per period at each stop", **one},
        ),
        "algebraic_residual": (
            "point",
            np.array([relative_residual(system, p) for p in U]),
            {"long_name": "norm of the HBM residual relative to the norm of the unknowns", **one},
        ),
        "time_residual": (
            "point",
            col("time_residual"),
            {
                "long_name": "largest residual in time of the equations of the stop degrees of freedom relative "
                "to the largest restoring force",
                **one,
            },
        ),
        "truncation": (
            "point",
            col("truncation"),
            {"long_name": "share of the mean square of x'' or f carried by the top tenth of the harmonics", **one},
        ),
        "step": (
            "point",
            np.asarray(branch.step, dtype=np.int32),
            {"long_name": "index of the ANM step that produced the point", **one},
        ),
        "branch_point": flag_variable(
            "point",
            branch_point,
            "1 where a simple branch point (sign change of det [J; t^T]) lies within the ANM step that ends at "
            "this point",
            "regular branch_point",
        ),
        "energy_fold": flag_variable(
            "point", energy_folds(energy), "1 where the energy has a local extremum along the branch", "regular fold"
        ),
    }
    located, unlocated = [], []
    for i in branch.branch_points:
        try:
            located += locate_flagged_branch_points(system, U, branch.step, [i], settings)
        except (ValueError, ContinuationError) as err:
            # kept as a flagged step without a located point; the count goes into the attributes
            logger.warning("branch point flagged at point %d not located: %s", i, err)
            unlocated.append(i)
    data.update(located_branch_point_variables(system, located))
    data.update(located_fold_variables(U, energy, col("frequency")))
    data.update(stability.data_vars())
    coords = {
        "point": np.arange(len(U)),
        "dof": np.arange(system.n_dofs),
        "stop": np.arange(system.n_stops),
        "harmonic": np.arange(H + 1),
        "multiplier": np.arange(stability.multipliers.shape[1]),
    }
    ds = xr.Dataset(data, coords=coords)
    ds["point"].attrs = {"long_name": "index of the point along the branch", **one}
    ds["dof"].attrs = {"long_name": "index of the degree of freedom", **one}
    ds["stop"].attrs = {"long_name": "index of the stop", **one}
    ds["harmonic"].attrs = {"long_name": "harmonic number k (0 is the mean)", **one}
    ds["multiplier"].attrs = {"long_name": "index of the Floquet multiplier, by decreasing modulus", **one}
    if dof_labels is not None:
        ds["dof_label"] = (
            "dof",
            np.array(dof_labels, dtype=str),
            {
                "long_name": "degree of freedom: w<node> displacement over gap, theta<node> rotation over gap/length",
                **one,
            },
        )
    if node_coordinates is not None:
        ds = ds.assign_coords(node=np.arange(len(node_coordinates)))
        ds["node"].attrs = {"long_name": "index of the finite-element node", **one}
        ds["node_coordinate"] = (
            "node",
            np.asarray(node_coordinates, float),
            {"long_name": "position of the node along the tube over its length", **one},
        )
    stats = branch.stats
    ds.attrs = {
        **(attrs or {}),
        "harmonics": H,
        "time_samples": system.M,
        "basis": system.basis,
        "order": settings.order,
        "tolerance": settings.tolerance,
        "pade": int(settings.pade),
        "end_reason": branch.end_reason,
        "anm_steps": stats.steps,
        "factorizations": stats.factorizations,
        "unlocated_branch_points": len(unlocated),
    }
    return ds
