"""Datasets -> the explorer's data: the one module that knows the datasets' layout.

A branch of the explorer is one dataset of a kind listed in :data:`KINDS` (``"regularized"``: an
HBM branch, whole or switched; ``"exact"``: the exact NNM1 of the non-smooth model). Adding a kind
of branch is one entry there: a function from the opened dataset to a :class:`Branch` record.
Everything the page shows comes from the record: per-point columns with their CF ``long_name``
and ``units``, the Fourier coefficients that the page synthesizes into orbits (float32, harmonics
that vanish at float32 resolution over the whole branch dropped), the Floquet multipliers, the
located branch points and folds, and the dataset's path and SHA-256.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

__all__ = ["Branch", "ExplorerSettings", "KINDS", "read_manifest", "file_sha256", "extract_branch", "extract_atlas"]


@dataclass(frozen=True)
class ExplorerSettings:
    """Settings of the explorer (configuration section ``explorer``).

    Parameters
    ----------
    time_samples : int
        Instants per period at which the page synthesizes an orbit.
    exact_harmonics : int
        Harmonics of the cosine series that represent an exact (non-smooth) orbit.
    tube : bool
        The workflow's rule also draws the finite-element tube's regularized branches (and builds them).
    atlas : bool
        The workflow's rule also shows the maps of the bifurcation atlas (and builds them).
    """

    time_samples: int = 512
    exact_harmonics: int = 64
    tube: bool = False
    structure: object = None  # the Structure of an exact one-stop family (its orbits are rebuilt on it); not configured
    atlas: bool = False

    def __post_init__(self):
        for name in ("tube", "atlas"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"explorer.{name} must be true or false, got {getattr(self, name)!r}")
        for name in ("time_samples", "exact_harmonics"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 8:
                raise ValueError(f"explorer.{name} must be an integer >= 8, got {value!r}")

    @classmethod
    def from_config(cls, section: dict | None, structure=None) -> ExplorerSettings:
        return cls(**(section or {}), structure=structure)


@dataclass
class Branch:
    """What the page needs of one branch; arrays are numpy arrays indexed by point first."""

    kind: str
    columns: dict  # name -> array (numbers) or list of str (text), one entry per point
    meta: dict  # name -> {"long_name", "units"[, "flag_values", "flag_meanings"]}
    numbers: list  # names of the columns listed for a selected point, in order
    piece: str  # column whose changes split the curve (stage, segment)
    orbit: (
        dict  # "harmonics", "omega", "fields"/"sines": {name: coefficients (point, kept harmonic)}, "force", "labels"
    )
    multipliers: dict  # "real", "imag": (point, multiplier)
    marks: dict = field(default_factory=dict)  # "branch_points"/"folds": {"energy", "frequency"}
    attrs: dict = field(default_factory=dict)  # "model" parameters; "family": the NNM (nnm1, ...) it belongs to


def read_manifest(path) -> dict:
    """``results/MANIFEST.sha256`` as ``{relative path: sha256}`` (``sha256sum`` format)."""
    entries = {}
    for number, line in enumerate(Path(path).read_text().splitlines(), start=1):
        if not line.strip():
            continue
        digest, _, name = line.partition("  ")
        if len(digest) != 64 or not name:
            raise ValueError(f"{path}:{number}: not a sha256sum line: {line!r}")
        entries[name.strip()] = digest
    return entries


def file_sha256(path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _meta(ds: xr.Dataset, name: str) -> dict:
    attrs = ds[name].attrs
    out = {"long_name": str(attrs.get("long_name", name)), "units": str(attrs.get("units", ""))}
    if "flag_values" in attrs and "flag_meanings" in attrs:
        out["flag_values"] = [int(v) for v in np.atleast_1d(attrs["flag_values"])]
        out["flag_meanings"] = str(attrs["flag_meanings"]).split()
    return out


def _columns(ds: xr.Dataset, names) -> tuple[dict, dict]:
    columns, meta = {}, {}
    for name in names:
        if name not in ds:
            continue
        values = ds[name].values
        columns[name] = [str(v) for v in values] if values.dtype.kind in "US" else values
        meta[name] = _meta(ds, name)
    return columns, meta


def _kept_harmonics(fields: dict) -> np.ndarray:
    """Harmonics not zero at float32 resolution in some field: largest |coefficient| (cosine or sine) over
    the branch above 2^-24 times the field's largest coefficient."""
    keep = np.zeros(next(iter(fields.values()))[0].shape[1], dtype=bool)
    for cos, sin in fields.values():
        peak = np.maximum(np.abs(cos).max(axis=0), np.abs(sin).max(axis=0))
        keep |= peak > np.finfo(np.float32).eps / 2 * peak.max()
    return np.flatnonzero(keep)


def _orbit(fields: dict, omega, force: str, labels: dict) -> dict:
    """``fields``: name -> (cos, sin) over (point, harmonic); sines are carried only where some is not zero."""
    kept = _kept_harmonics(fields)
    return {
        "labels": labels,
        "harmonics": kept.astype(np.int32),
        "omega": np.asarray(omega, dtype=float),
        "fields": {name: cos[:, kept].astype(np.float32) for name, (cos, _) in fields.items()},
        "sines": {name: sin[:, kept].astype(np.float32) for name, (_, sin) in fields.items() if np.any(sin != 0.0)},
        "force": force,
    }


def _located(ds: xr.Dataset, energy: str, frequency: str) -> dict:
    if energy not in ds:
        return {"energy": np.empty(0), "frequency": np.empty(0)}
    return {"energy": ds[energy].values, "frequency": ds[frequency].values}


def _model(ds: xr.Dataset) -> dict:
    """Model parameters of the page: the attributes alpha, beta, delta, eta; the first stop's gap and stiffness."""
    model = {name: float(ds.attrs[name]) for name in ("alpha", "beta", "delta", "eta") if name in ds.attrs}
    model["gap"] = float(ds["stop_gap"].values[0]) if "stop_gap" in ds else 1.0  # 2-DOF: the gap is the unit
    if "stop_stiffness" in ds:
        model["alpha"] = float(ds["stop_stiffness"].values[0])
    return model


def _time_label(ds: xr.Dataset) -> str:
    return f"t [{ds['period'].attrs.get('units', '')}]"


def _shown_dofs(ds: xr.Dataset, labels: list) -> tuple[int, int]:
    """The degrees of freedom drawn as x and u: the first stop's (``stop_dof``, else the label ``x``, else
    ``w<node>`` of the ``stop_nodes`` attribute), and ``u``, else the last translation ``w...``, else the last
    other degree of freedom (the far end of a chain)."""
    if "stop_dof" in ds:
        x = int(ds["stop_dof"].values[0])
    elif "x" in labels:
        x = labels.index("x")
    else:
        node = int(np.atleast_1d(ds.attrs.get("stop_nodes", [-1]))[0])
        if f"w{node}" not in labels:
            raise ValueError(f"{ds.attrs.get('id')}: cannot tell the first stop's degree of freedom among {labels}")
        x = labels.index(f"w{node}")
    others = [i for i in range(len(labels)) if i != x]
    translations = [i for i in others if labels[i].startswith("w")]
    u = labels.index("u") if "u" in labels else (translations or others)[-1]
    return x, u


def _branch_fields(ds: xr.Dataset) -> tuple[dict, dict]:
    """Coefficients over (point, harmonic) of the fields x, u and f of a regularized branch, and their labels.

    Every branch dataset has ``q_cos`` over point, dof, harmonic with ``dof_label`` and ``f_cos`` over point,
    stop, harmonic: the first stop's degree of freedom is drawn as x, a second one as u, the first stop's force
    as f."""
    labels = [str(v) for v in ds["dof_label"].values]
    x, u = _shown_dofs(ds, labels)
    q_cos, q_sin = ds["q_cos"].values, ds["q_sin"].values
    fields = {
        "x": (q_cos[:, x], q_sin[:, x]),
        "u": (q_cos[:, u], q_sin[:, u]),
        "f": (ds["f_cos"].values[:, 0], ds["f_sin"].values[:, 0]),
    }
    names = {"x": labels[x], "u": labels[u], "f": "force of the first stop"}
    if "node_coordinate" in ds:  # where along the structure: the node of a w<node> label
        where = {key: re.fullmatch(r"[a-z]+(\d+)", names[key]) for key in ("x", "u")}
        for key, match in where.items():
            if match and int(match.group(1)) < ds.sizes["node"]:
                names[key] += f" at s/L = {float(ds['node_coordinate'][int(match.group(1))]):.3g}"
    return fields, {"t": _time_label(ds), **names}


REGULARIZED_NUMBERS = (
    "energy", "frequency", "x_max", "u_max", "impacts_per_period", "algebraic_residual", "time_residual",
    "truncation", "stable", "stability_reason", "max_multiplier", "stage", "segment",
    "orbit_kind", "dominant_mode", "dominant_harmonic", "tongue_harmonic",  # what the orbit is (issue 29)
)  # fmt: skip


def regularized_branch(ds: xr.Dataset, settings: ExplorerSettings) -> Branch:
    """An HBM branch: ``results/hbm/<branch>.nc``, ``results/hbm/bifurcated/<name>.nc``, ``results/tube/nnm<k>.nc``."""
    fields, labels = _branch_fields(ds)
    columns, meta = _columns(ds, REGULARIZED_NUMBERS)
    return Branch(
        kind="regularized",
        columns=columns,
        meta=meta,
        numbers=list(columns),
        piece="stage" if "stage" in ds else "segment" if "segment" in ds else "",
        orbit=_orbit(fields, np.sqrt(ds["omega_squared"].values), "coefficients", labels),
        multipliers={"real": ds["multiplier_real"].values, "imag": ds["multiplier_imag"].values},
        marks={
            "branch_points": _located(ds, "branch_point_energy", "branch_point_frequency"),
            "folds": _located(ds, "fold_energy", "fold_frequency"),
        },
        attrs={"model": _model(ds), "family": str(ds.attrs.get("branch", ds.attrs.get("id", "")))},
    )


EXACT_NUMBERS = (
    "energy", "frequency", "x_max", "impacts_per_period", "phase_sequence", "residual", "validity_margin",
    "stable", "multiplier_modulus", "segment",
)  # fmt: skip


def exact_branch(ds: xr.Dataset, settings: ExplorerSettings) -> Branch:
    """The exact NNM1 (``results/exact/nnm1.nc``): orbits rebuilt in closed form from the stored start
    velocities and phase sequences (:mod:`nnmstop.explorer.exact_orbits`)."""
    from nnmstop.exact.problem import SequenceProblem
    from nnmstop.explorer.exact_orbits import orbit_coefficients, orbit_unknowns
    from nnmstop.models.two_dof import ModelParameters

    model = _model(ds)
    params = ModelParameters(alpha=model["alpha"], beta=model["beta"], delta=model["delta"])
    sequences = ds["phase_sequence"].values if "phase_sequence" in ds else np.full(ds.sizes["point"], "FR")
    xdot0, udot0, period = (ds[name].values for name in ("xdot0", "udot0", "period"))
    problems, x, u = {}, [], []
    for sequence, a, b, T in zip(sequences, xdot0, udot0, period):
        problem = problems.setdefault(str(sequence), SequenceProblem(params, str(sequence)))
        series = orbit_coefficients(problem, orbit_unknowns(problem, a, b, T / 4.0), settings.exact_harmonics)
        x.append(series["x"])
        u.append(series["u"])
    columns, meta = _columns(ds, EXACT_NUMBERS)
    # the piecewise-linear force has no phase with multipliers stored one by one: the pair is (mu, 1/mu)
    mu = ds["multiplier_real"].values + 1j * ds["multiplier_imag"].values
    pair = np.stack([mu, 1.0 / mu], axis=1)
    return Branch(
        kind="exact",
        columns=columns,
        meta=meta,
        numbers=list(columns),
        piece="segment" if "segment" in ds else "",
        orbit=_orbit(
            {name: (np.array(c), np.zeros_like(np.array(c))) for name, c in (("x", x), ("u", u))},
            2.0 * np.pi / period,
            "piecewise_law",
            {"t": _time_label(ds), "x": "x", "u": "u", "f": "contact force (piecewise-linear law)"},
        ),
        multipliers={"real": pair.real, "imag": pair.imag},
        attrs={"model": model, "family": "nnm1"},  # the exact family starts at the first mode's grazing orbit
    )


ONE_STOP_NUMBERS = ("energy", "frequency", "x_max", "contact_time", "resonant_mode", "resonance_order")


def one_stop_branch(ds: xr.Dataset, settings: ExplorerSettings) -> Branch:
    """The exact NNM1 of a structure of one's own (``results/exact/nnm1_one_impact.nc``, one impact per side of its
    struck stop): orbits rebuilt in closed form (:mod:`nnmstop.exact.ndof`) on ``settings.structure`` from the
    stored start velocities, periods and contact times; drawn as x the struck stop's degree of freedom."""
    from nnmstop.exact.ndof import OneStopProblem, time_history
    from nnmstop.fourier import to_coefficients

    structure = settings.structure
    if structure is None:
        raise ValueError(f"{ds.attrs.get('id', 'exact family')}: the exact family of a structure needs the structure")
    struck = int(ds.attrs.get("struck_stop", 0))
    problem = OneStopProblem(structure, struck)
    labels = list(structure.dof_labels)
    x = problem.dof
    others = [i for i in range(problem.n) if i != x]
    u = next((i for i in others if i in structure.stop_dofs), others[-1] if others else x)
    period = 1.0 / ds["frequency"].values
    H = settings.exact_harmonics
    samples = 8 * H
    fields = {"x": [], "u": []}
    for v, T, contact in zip(ds["initial_velocity"].values, period, ds["contact_time"].values):
        y = problem.unknowns_from_velocity(v, T / 4.0 - contact, T / 4.0)
        t = T / 4.0 + T * np.arange(samples) / samples  # from the turning point in contact: a cosine series
        q = time_history(problem, y, t).q
        for name, dof in (("x", x), ("u", u)):
            fields[name].append(to_coefficients(q[:, dof], H)[: H + 1])  # even about the turning point: cosines
    columns, meta = _columns(ds, ONE_STOP_NUMBERS)
    stop = structure.stops[struck]
    model = {"alpha": float(stop.stiffness), "gap": float(stop.gap)}
    return Branch(
        kind="exact",
        columns=columns,
        meta=meta,
        numbers=list(columns),
        piece="",
        orbit=_orbit(
            {name: (np.array(c), np.zeros_like(np.array(c))) for name, c in fields.items()},
            2.0 * np.pi / period,
            "piecewise_law",
            {"t": "t [1]", "x": labels[x], "u": labels[u], "f": f"force of the struck stop (on {labels[x]})"},
        ),
        multipliers={"real": np.ones((len(period), 2)), "imag": np.zeros((len(period), 2))},
        attrs={"model": model, "family": "nnm1"},
    )


#: Kinds of branch the explorer draws: the function that reads a dataset of that kind.
KINDS: dict[str, Callable[[xr.Dataset, ExplorerSettings], Branch]] = {
    "regularized": regularized_branch,
    "exact": exact_branch,
    "exact_one_stop": one_stop_branch,
}


def extract_branch(kind: str, path, manifest: dict, settings: ExplorerSettings, root=".") -> dict:
    """The explorer's record of the dataset ``path`` (relative to ``root``) of kind ``kind``.

    The record holds the dataset's path, SHA-256 and identification (``id``, ``title``, ``source``).
    A dataset listed in ``manifest`` must have the listed SHA-256 (else the manifest is stale); it is read by
    the reader of every task (:func:`nnmstop.netcdf.read_dataset`).
    """
    if kind not in KINDS:
        raise ValueError(f"unknown kind of branch {kind!r}; known kinds: {sorted(KINDS)}")
    path = Path(path)
    digest = file_sha256(Path(root) / path)
    listed = manifest.get(path.as_posix())
    if listed is not None and listed != digest:
        raise ValueError(f"{path}: SHA-256 {digest} differs from the manifest's {listed}; rebuild the manifest")
    from nnmstop.netcdf import read_dataset

    ds = read_dataset(Path(root) / path)  # refuses NaN and orbits that do not satisfy their equations, naming the file
    branch = KINDS[kind](ds, settings)
    identity = {name: str(ds.attrs.get(name, "")) for name in ("id", "title", "source")}
    return {
        "kind": branch.kind,
        "path": path.as_posix(),
        "sha256": digest,
        "in_manifest": listed is not None,
        **identity,
        **branch.attrs,
        "points": len(branch.columns["energy"]),
        "columns": branch.columns,
        "meta": branch.meta,
        "numbers": branch.numbers,
        "piece": branch.piece,
        "orbit": branch.orbit,
        "multipliers": branch.multipliers,
        "marks": branch.marks,
    }


def _cell_edges(centres) -> np.ndarray:
    """Edges of the cells around ``centres`` (half way between them; the end cells as wide as their neighbours)."""
    centres = np.asarray(centres, dtype=float)
    if len(centres) == 1:
        return np.array([0.9 * centres[0], 1.1 * centres[0]])
    middle = 0.5 * (centres[1:] + centres[:-1])
    return np.concatenate([[2 * centres[0] - middle[0]], middle, [2 * centres[-1] - middle[-1]]])


def extract_atlas(path, slice_paths, manifest: dict, root=".") -> dict:
    """The explorer's record of an atlas (``results/atlas/<map>.nc``) and its slices (``slice_<k>.nc``).

    Regions as runs of equal region along each slice row (the page draws one rectangle per run); the curves
    with, at each point, the orbit's Fourier coefficients of the two kept DOFs (float32) and the multipliers;
    the codimension-two points; the slices' response points with their orbits (a click on a region shows the
    responses of the nearest slice there). A dataset listed in ``manifest`` must have the listed SHA-256.
    """
    from nnmstop.bifurcation_atlas.flags import CODIM2_KINDS, CURVE_KINDS, LAWS, REGIONS

    path = Path(path)
    digest = file_sha256(Path(root) / path)
    listed = manifest.get(path.as_posix())
    if listed is not None and listed != digest:
        raise ValueError(f"{path}: SHA-256 {digest} differs from the manifest's {listed}; rebuild the manifest")
    with xr.open_dataset(Path(root) / path) as ds:
        ds.load()
        region, grid, values = ds["region"].values, ds["grid_frequency"].values, ds["slice_value"].values
        runs = []
        edges = _cell_edges(grid)
        value_edges = _cell_edges(values)
        for k in range(len(values)):
            start = 0
            for j in range(1, len(grid) + 1):
                if j == len(grid) or region[k, j] != region[k, start]:
                    runs.append([edges[start], edges[j], value_edges[k], value_edges[k + 1], int(region[k, start])])
                    start = j
        record = {
            "kind": "atlas",
            "path": path.as_posix(),
            "sha256": digest,
            "in_manifest": listed is not None,
            "title": str(ds.attrs.get("title", "")),
            "name": str(ds.attrs.get("atlas_map", path.stem)),
            "plane": str(ds.attrs["plane"]),
            "gap": float(ds.attrs["stop_gap"]),
            "harmonics": int(ds.attrs["orbit_harmonics"]),
            "regions": {"runs": np.array(runs, dtype=np.float64), "meanings": list(REGIONS)},
            "curves": {
                "frequency": ds["frequency"].values.astype(np.float64),
                "second": ds["second"].values.astype(np.float64),
                "curve": ds["point_curve"].values.astype(np.int32),
                "kind": [CURVE_KINDS[k] for k in ds["curve_kind"].values],
                "law": [LAWS[k] for k in ds["curve_law"].values],
                "orbit": ds["orbit"].values.astype(np.float32),
                "multiplier_real": ds["multiplier_real"].values.astype(np.float32),
                "multiplier_imag": ds["multiplier_imag"].values.astype(np.float32),
            },
            "codim2": {
                "kind": [CODIM2_KINDS[k] for k in ds["codim2_kind"].values],
                "frequency": ds["codim2_frequency"].values.astype(np.float64),
                "second": ds["codim2_second"].values.astype(np.float64),
            },
        }
    responses = {name: [] for name in ("frequency", "second", "piece", "stable", "impacting", "orbit")}
    for slice_path in slice_paths:
        with xr.open_dataset(Path(root) / slice_path) as sl:
            sl.load()
            n = sl.sizes["response"]
            responses["frequency"].append(sl["response_frequency"].values)
            responses["second"].append(np.full(n, float(sl.attrs["slice_value"])))
            responses["piece"].append(sl["response_piece"].values.astype(np.int32))
            responses["stable"].append(sl["response_stable"].values.astype(np.int8))
            responses["impacting"].append(sl["response_impacting"].values.astype(np.int8))
            responses["orbit"].append(sl["response_orbit"].values.astype(np.float32))
    record["responses"] = {name: np.concatenate(parts) for name, parts in responses.items()} if slice_paths else {}
    return record
