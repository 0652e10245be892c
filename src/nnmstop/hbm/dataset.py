"""Assembly of the labelled dataset of a regularized branch (a stage, a whole branch, a bifurcated branch).

Numbers come in computed (:mod:`nnmstop.hbm.stages` runs the continuation, locates branch points,
computes stability); this module only names and describes them. Dimensions ``point`` (along the
branch) and ``harmonic`` (0..H); ``x_cos(point, harmonic)``, ``x_sin`` and likewise ``u``, ``f``, ``z``:
the Fourier coefficients of Eq. (13) (``x_cos[:, 0]`` the mean; sine coefficients zero in the cosine
basis); ``omega_squared`` and ``unfolding``; ``energy``, ``frequency``, ``period``, ``x_max``, ``u_max``,
``impacts_per_period``, ``algebraic_residual``, ``time_residual``, ``force_error``, ``energy_spread``,
``truncation``, ``step``, ``stage``; flags ``branch_point`` and ``energy_fold``; the located branch points
(dimension ``located_branch_point``) and energy folds (``located_fold``); the Floquet verdicts
(:mod:`nnmstop.hbm.stability`): ``stable``, ``multiplier_real``/``multiplier_imag(point, multiplier)``,
``max_multiplier``, ``stability_orbit_residual``, ``stability_resolved``. Bifurcated branches add
``subharmonic_share`` and attributes describing their branch point (:func:`bifurcated_dataset`).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nnmstop import fourier
from nnmstop.continuation.core import Branch, ContinuationError, relative_residual
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.netcdf import flag_variable

__all__ = [
    "BRANCH_POINT_DIM",
    "FOLD_DIM",
    "branch_dataset",
    "bifurcated_dataset",
    "summarize_bifurcated",
    "located_branch_point_variables",
    "located_fold_variables",
    "energy_folds",
    "dataset_unknowns",
    "coefficient_vectors",
]


def branch_dataset(system, branch: Branch, stage: int, located, stability, continuation, labels: dict) -> xr.Dataset:
    """Labelled dataset of a continued branch (variables in the module docstring).

    Parameters
    ----------
    system : HarmonicBalanceSystem
    branch : Branch
        The continued points, their steps, diagnostics (computed here where None) and flags.
    stage : int
        Stage number stored in the ``stage`` variable.
    located : list of (int, BranchPoint, int, bool)
        Located branch points (:func:`nnmstop.hbm.bifurcation.locate_flagged_branch_points`).
    stability : object with ``data_vars()``
        Floquet verdicts of the points (:func:`nnmstop.hbm.stability.orbit_stability`).
    continuation : ANMSettings
        Settings of the continuation, recorded as attributes.
    labels : dict
        Global attributes naming the branch: ``branch`` (required), and e.g. ``mode`` and ``stages``.

    Raises
    ------
    ContinuationError
        If an energy along the branch is not finite (no dataset is returned).
    """
    branch_name = labels["branch"]
    H = system.H
    U = np.array(branch.points)
    diags = [d if d is not None else system.diagnostics(u) for u, d in zip(U, branch.diagnostics)]
    steps, end_reason, stats = branch.step, branch.end_reason, branch.stats
    if not all(np.isfinite(d["energy"]) for d in diags):
        raise ContinuationError(f"{branch_name} stage {stage}: non-finite energy in the branch")
    x, u, f, z, lam, nu = system.split(U)
    coords = {"point": np.arange(len(U)), "harmonic": np.arange(H + 1)}

    def series(c, name, symbol):
        cos, sin = fourier.to_cos_sin(c, H)
        return {
            f"{symbol}_cos": (
                ("point", "harmonic"),
                cos,
                {"long_name": f"cosine Fourier coefficients of {name}", "units": "1"},
            ),
            f"{symbol}_sin": (
                ("point", "harmonic"),
                sin,
                {"long_name": f"sine Fourier coefficients of {name}", "units": "1"},
            ),
        }

    def col(key):
        return np.array([d[key] for d in diags])

    data = {}
    for c, name, symbol in (
        (x, "x (first mass)", "x"),
        (u, "u (second mass)", "u"),
        (f, "regularized contact force f", "f"),
        (z, "internal variable z = (f/alpha - x)^2", "z"),
    ):
        data.update(series(c, name, symbol))
    omega = np.sqrt(lam)
    data.update(
        {
            "omega_squared": (
                "point",
                lam,
                {"long_name": "squared angular frequency (unknown lambda of the HBM system)", "units": "1"},
            ),
            "unfolding": (
                "point",
                nu,
                {
                    "long_name": "unfolding parameter nu (fictitious damping times omega; zero on periodic orbits)",
                    "units": "1",
                },
            ),
            "energy": (
                "point",
                col("energy"),
                {
                    "long_name": "total energy of the regularized model (contact potential included), mean over the "
                    "period",
                    "units": "1",
                },
            ),
            "frequency": (
                "point",
                col("frequency"),
                {"long_name": "frequency omega/(2 pi) in Hz of the nondimensional time", "units": "Hz"},
            ),
            "period": (
                "point",
                2 * np.pi / omega,
                {"long_name": "period of the orbit in nondimensional time", "units": "1"},
            ),
            "x_max": (
                "point",
                col("x_max"),
                {"long_name": "largest displacement of the first mass over the period", "units": "1"},
            ),
            "u_max": (
                "point",
                col("u_max"),
                {"long_name": "largest displacement of the second mass over the period", "units": "1"},
            ),
            "impacts_per_period": (
                "point",
                col("impacts_per_period").astype(np.int32),
                {"long_name": "number of excursions of x beyond the stops (|x| > 1) per period", "units": "1"},
            ),
            "algebraic_residual": (
                "point",
                np.array([relative_residual(system, p) for p in U]),
                {
                    "long_name": "norm of the residual of the HBM algebraic system relative to the norm of the "
                    "unknowns",
                    "units": "1",
                },
            ),
            "time_residual": (
                "point",
                col("time_residual"),
                {
                    "long_name": "largest residual in time of the regularized equation of x (true cubic root for f) "
                    "relative to the largest restoring force",
                    "units": "1",
                },
            ),
            "force_error": (
                "point",
                col("force_error"),
                {
                    "long_name": "largest difference between the HBM contact force and the cubic root f(x(t)), "
                    "relative to max |f|",
                    "units": "1",
                },
            ),
            "energy_spread": (
                "point",
                col("energy_spread"),
                {
                    "long_name": "relative variation of the total energy over the period (zero for an exact orbit)",
                    "units": "1",
                },
            ),
            "truncation": (
                "point",
                col("truncation"),
                {
                    "long_name": "share of the mean square of x'' or f carried by the top tenth of the harmonics "
                    "(larger of the two)",
                    "units": "1",
                },
            ),
            "step": (
                "point",
                np.asarray(steps, dtype=np.int32),
                {"long_name": "index of the ANM step that produced the point", "units": "1"},
            ),
            "stage": (
                "point",
                np.full(len(U), stage, dtype=np.int32),
                {"long_name": "continuation stage of the point", "units": "1"},
            ),
        }
    )
    branch_point = np.zeros(len(U), dtype=bool)
    branch_point[branch.branch_points] = True
    fold = energy_folds(col("energy"))
    data.update(
        {
            "branch_point": flag_variable(
                "point",
                branch_point,
                "1 where a simple branch point of the HBM system (sign change of det [J; t^T]) lies within the ANM "
                "step that ends at this point",
                "regular branch_point",
            ),
            "energy_fold": flag_variable(
                "point", fold, "1 where the energy has a local extremum along the branch (energy fold)", "regular fold"
            ),
        }
    )
    data.update(located_branch_point_variables(system, located))
    data.update(stability.data_vars())
    coords["multiplier"] = np.arange(stability.multipliers.shape[1])
    ds = xr.Dataset(data, coords=coords)
    ds = ds.assign(located_fold_variables(coefficient_vectors(ds), col("energy"), col("frequency")))
    ds["point"].attrs = {"long_name": "index of the point along the branch", "units": "1"}
    ds["multiplier"].attrs = {
        "long_name": "index of the Floquet multiplier: 0, 1 trivial pair; 2, 3 non-trivial pair",
        "units": "1",
    }
    ds["harmonic"].attrs = {"long_name": "harmonic number k (0 is the mean)", "units": "1"}
    ds.attrs = {
        **system.params.as_attrs(),
        **labels,
        "harmonics": H,
        "time_samples": system.M,
        "basis": system.basis,
        "order": continuation.order,
        "tolerance": continuation.tolerance,
        "newton_threshold": continuation.newton_threshold,
        "pade": int(continuation.pade),
        "pade_steps": stats.pade_steps,
        "end_reason": end_reason,
        "anm_steps": stats.steps,
        "factorizations": stats.factorizations,
    }
    return ds


BRANCH_POINT_DIM = "located_branch_point"
FOLD_DIM = "located_fold"


def located_branch_point_variables(system, located) -> dict:
    """Dataset variables (dimension ``located_branch_point``) of located branch points."""
    dim = (BRANCH_POINT_DIM,)
    diags = [system.diagnostics(point.U) for _, point, _, _ in located]
    return {
        "branch_point_energy": (
            dim,
            np.array([d["energy"] for d in diags], dtype=float),
            {"long_name": "energy of the located branch point", "units": "1"},
        ),
        "branch_point_frequency": (
            dim,
            np.array([d["frequency"] for d in diags], dtype=float),
            {"long_name": "frequency of the located branch point", "units": "Hz"},
        ),
        "branch_point_resonance": (
            dim,
            np.array([n for _, _, n, _ in located], dtype=np.int32),
            {
                "long_name": "n where the orbit at the branch point has period T/n (n:1 internal resonance), else 0",
                "units": "1",
            },
        ),
        "branch_point_symmetry_breaking": flag_variable(
            dim,
            [b for _, _, _, b in located],
            "1 where the bifurcated tangent holds even harmonics only (the crossing curve breaks x(t + T/2) = -x(t))",
            "no yes",
        ),
        "branch_point_tangent_angle": (
            dim,
            np.array([p.angle for _, p, _, _ in located], dtype=float),
            {"long_name": "angle between the tangents of the two curves at the branch point", "units": "degree"},
        ),
        "branch_point_singular_ratio": (
            dim,
            np.array([p.singular_ratio for _, p, _, _ in located], dtype=float),
            {
                "long_name": "smallest over second-smallest singular value of J at the located point (zero at an exact "
                "branch point)",
                "units": "1",
            },
        ),
        "branch_point_flagged_point": (
            dim,
            np.array([i for i, _, _, _ in located], dtype=np.int32),
            {"long_name": "index of the point that ends the ANM step holding the branch point", "units": "1"},
        ),
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
        "fold_energy": (
            dim,
            np.array(e_fold, dtype=float),
            {
                "long_name": "energy at the fold (local extremum along the branch), parabola through the three nearest "
                "points",
                "units": "1",
            },
        ),
        "fold_frequency": (
            dim,
            np.array(f_fold, dtype=float),
            {"long_name": "frequency at the fold, same parabola", "units": "Hz"},
        ),
        "fold_point": (
            dim,
            np.array(index, dtype=np.int32),
            {"long_name": "index of the point of extremal energy", "units": "1"},
        ),
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
        full = fourier.from_cos_sin(ds[f"{symbol}_cos"].values, ds[f"{symbol}_sin"].values)
        parts.append(full[:, : system.nc])
    tail = [ds["omega_squared"].values[:, None]]
    if system.full:
        tail.append(ds["unfolding"].values[:, None])
    return np.concatenate(parts + tail, axis=1)


def coefficient_vectors(ds: xr.Dataset) -> np.ndarray:
    """The unknowns of every point as stored (all coefficients and omega^2), for arclengths."""
    parts = [ds[f"{s}_{kind}"].values for s in ("x", "u", "f", "z") for kind in ("cos", "sin")]
    return np.concatenate(parts + [ds["omega_squared"].values[:, None]], axis=1)


def bifurcated_dataset(
    ds: xr.Dataset, name: str, parent: str, resonance: int, subharmonic_share, branch_point: dict, switch_step: float
) -> xr.Dataset:
    """Turn the :func:`branch_dataset` of a bifurcated branch into its final layout.

    Adds ``subharmonic_share`` (one value per point, zero on orbits of period ``T/n``), relabels
    ``stage`` and ``step``, and replaces the stage attributes (``mode``, ``stages``) by those of the
    switch: ``branch`` (``name``), ``parent_branch``, ``resonance``, ``switch_step`` and
    ``branch_point`` (``branch_point_energy``, ``branch_point_frequency``, ``tangent_angle`` in
    degrees, ``singular_ratio``).
    """
    n = int(resonance)
    ds["subharmonic_share"] = (
        "point",
        np.asarray(subharmonic_share, dtype=float),
        {
            "long_name": f"share of the mean square of x and u in harmonics that are not multiples of {n} "
            f"(zero for an orbit of period T/{n})",
            "units": "1",
        },
    )
    ds["stage"].attrs["long_name"] = "stage of the parent branch from whose branch point the branch was switched"
    ds["step"].attrs["long_name"] = (
        "index of the ANM step that produced the point (negative on the side followed backwards)"
    )
    for key in ("mode", "stages"):
        ds.attrs.pop(key, None)
    ds.attrs.update(
        {"branch": name, "parent_branch": parent, "resonance": n, **branch_point, "switch_step": switch_step}
    )
    return ds


def summarize_bifurcated(ds, nnm2=None) -> str:
    """Plain-text summary of a bifurcated-branch dataset (``results/hbm/bifurcated/*.nc``).

    With ``nnm2`` (a regularized NNM2 dataset), also the relative distance of
    ``n f`` on the bifurcated branch from the NNM2 frequency at the same energy
    (NNM2 interpolated linearly in ``ln E``; its energy must increase along the branch).
    """
    n = int(ds.attrs["resonance"])
    e, f = ds["energy"].values, ds["frequency"].values
    resolved = ds["stability_resolved"] == 1
    lines = [
        f"branch {ds.attrs['branch']}: switched from {ds.attrs['parent_branch']} at its {n}:1 branch point",
        f"  branch point: energy {ds.attrs['branch_point_energy']:.6g}, frequency "
        f"{ds.attrs['branch_point_frequency']:.6g} Hz, "
        f"angle between the tangents {ds.attrs['tangent_angle']:.2f} deg, singular ratio "
        f"{ds.attrs['singular_ratio']:.2e}",
        f"  {ds.sizes['point']} points, energy {e.min():.4g} .. {e.max():.4g}, frequency {f.min():.6g} .. "
        f"{f.max():.6g} Hz, "
        f"{int(ds.attrs['anm_steps'])} ANM steps",
        f"  largest share of harmonics not multiple of {n}: {float(ds['subharmonic_share'].max()):.2e}",
        f"  stability: {int(((ds['stable'] == 1) & resolved).sum())} stable, "
        f"{int(((ds['stable'] == 0) & resolved).sum())} unstable, {int((~resolved).sum())} unresolved "
        f"of {ds.sizes['point']} points",
    ]
    if nnm2 is not None:
        e2, f2 = nnm2["energy"].values, nnm2["frequency"].values
        rising = np.all(np.diff(e2) > 0)
        if not rising:
            raise ValueError("the NNM2 dataset's energy is not increasing along the branch: cannot interpolate")
        inside = (e >= e2.min()) & (e <= e2.max())
        ref = np.interp(np.log(e[inside]), np.log(e2), f2)
        dev = np.abs(n * f[inside] - ref) / ref
        lines.append(
            f"  |{n} f - f_NNM2(E)| / f_NNM2 over {int(inside.sum())} points: max {dev.max():.2e}, median "
            f"{np.median(dev):.2e} "
            f"(NNM2 interpolated in ln E between its stored points)"
        )
    return "\n".join(lines)
