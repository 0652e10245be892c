"""The datasets of the exact orbits: the two-impact family and the exact NNM1.

:func:`two_impact_dataset` labels a two-impact family (Section 3.1, unknowns
``(xdot0, udot0, tau1, T1)``); :func:`exact_branch_dataset` appends the segments of the
continuation through the grazing transitions (:func:`nnmstop.exact.family.follow_branch`)
to it, one row per orbit with its phase sequence, impact count, validity margin and
Floquet multipliers (:func:`nnmstop.exact.stability.stability_variables`);
:func:`one_stop_dataset` labels the one-stop family of any structure. Numerics and plain values
only: every variable's long name, units and flags are in :mod:`nnmstop.catalogue.exact`, which
:func:`nnmstop.netcdf.write_dataset` applies (``docs/datasets.md`` is generated from it).
Reading and writing files is the job of :mod:`nnmstop.tasks.exact`.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nnmstop.continuation.core import unit_tangent
from nnmstop.exact.family import Family
from nnmstop.exact.problem import SequenceProblem
from nnmstop.exact.stability import stability_variables
from nnmstop.models.two_dof import ModelParameters

__all__ = [
    "two_impact_dataset",
    "two_impact_unknowns",
    "exact_branch_dataset",
    "one_stop_dataset",
    "one_stop_backbone",
    "switching_dataset",
]


def two_impact_dataset(family: Family) -> xr.Dataset:
    """The two-impact family (:func:`nnmstop.exact.family.follow_two_impact_family`) as a dataset along ``point``.

    Plain values; the metadata of every variable are in :mod:`nnmstop.catalogue.exact` (kind
    ``two_impact_family``).
    """
    y = np.asarray(family.unknowns)
    n = len(family)
    floquet = stability_variables(family.model, ["FR"] * n, np.column_stack([y[:, 2], y[:, 3] - y[:, 2]]))
    ds = xr.Dataset(
        {
            "energy": _var(family.energy),
            "frequency": _var(family.frequency),
            "period": _var(4.0 * y[:, 3]),
            "x_max": _var([a.x_max for a in family.assessments]),
            "u_at_x_max": _var([a.q_at_x_max[1] for a in family.assessments]),
            "x_turning_point": _var([a.margins["final_position"] + 1.0 for a in family.assessments]),
            "xdot0": _var(y[:, 0]),
            "udot0": _var(y[:, 1]),
            "free_flight_time": _var(y[:, 2]),
            "contact_time": _var(y[:, 3] - y[:, 2]),
            "residual": _var(family.residual),
            "validity_margin": _var([a.min_margin for a in family.assessments]),
            **floquet,
        },
        coords={"point": ("point", np.arange(n)), "arclength": _var(family.arclength)},
    )
    ds.attrs = {
        **model_attributes(family.model),
        "family_start": family.start,
        "end_reason": family.end_reason,
        "end_margin": family.end_margin or "none",
        "end_check": family.end_check or "not confirmed (not asked)",
        "continuation_step": family.step,
        "max_residual": float(np.max(family.residual)),
    }
    return ds


def model_attributes(model) -> dict:
    """``alpha``, ``beta``, ``delta`` of the paper's oscillator; a 2-DOF structure's stop stiffness as ``alpha``
    and its matrices."""
    if isinstance(model, ModelParameters):
        return {"alpha": model.alpha, "beta": model.beta, "delta": model.delta}
    mass, stiffness = model.dense_matrices()
    return {
        "alpha": float(model.stops[0].stiffness),
        "mass_matrix": np.asarray(mass, dtype=float).ravel(),
        "stiffness_matrix": np.asarray(stiffness, dtype=float).ravel(),
    }


def two_impact_unknowns(ds: xr.Dataset) -> np.ndarray:
    """``(xdot0, udot0, tau1, T1 - tau1)`` of every orbit of a two-impact dataset (the FR unknowns)."""
    quarter = ds["period"].values / 4.0  # exact: a power of two
    tau1 = ds["free_flight_time"].values
    return np.column_stack([ds["xdot0"].values, ds["udot0"].values, tau1, quarter - tau1])


def _var(values, dtype=float):
    return ("point", np.asarray(values, dtype=dtype))


#: The columns of the exact NNM1 copied from the two-impact family and filled from each segment's orbits.
_COLUMNS = (
    "energy",
    "frequency",
    "period",
    "x_max",
    "u_at_x_max",
    "x_turning_point",
    "xdot0",
    "udot0",
    "free_flight_time",
    "contact_time",
    "residual",
    "validity_margin",
)


def exact_branch_dataset(two_impacts: xr.Dataset, segments: list, model) -> xr.Dataset:
    """The exact NNM1: the two-impact dataset followed by the continuation segments.

    Parameters
    ----------
    two_impacts : xarray.Dataset
        The two-impact family (:func:`two_impact_dataset`); its values are copied
        unchanged as the first points.
    segments : list of Family
        The continuation from its last orbit (:func:`nnmstop.exact.family.follow_branch`). Orbits of a first
        ``"FR"`` segment duplicate the end of ``two_impacts`` (to the bisection tolerance)
        and are left out.
    model : ModelParameters or Structure
        The paper's oscillator or a 2-DOF structure (:func:`nnmstop.exact.phases.check_sequence_model`).

    Returns
    -------
    xarray.Dataset
        Dimension ``point``; the metadata come from the catalogue (kind ``exact_nnm1``).
    """
    rows = _two_impact_rows(two_impacts, SequenceProblem(model, "FR"))
    summaries = [
        f"FR: 2 impacts per period, energy {two_impacts['energy'].values.min():.6g} to "
        f"{two_impacts['energy'].values.max():.6g}, from the grazing orbit; ends where "
        f"{two_impacts.attrs.get('end_reason', 'the two-impact family ends')} (results/exact/nnm1_two_impacts.nc)"
    ]
    index = 0
    for number, seg in enumerate(segments):
        if number == 0 and seg.sequence != "FR":
            raise ValueError(f"the continuation of the two-impact family must start with FR, got {seg.sequence}")
        index += number > 0
        added = _append_segment(rows, seg, index, first=number == 0)
        energies = np.array(rows["energy"])[np.array(rows["segment"]) == index]
        problem = seg.problem
        text = (
            f"{seg.sequence}: {problem.impacts_per_period} impacts per period, energy {energies.min():.6g} to "
            f"{energies.max():.6g} ({energies[0]:.6g} -> {energies[-1]:.6g}); ends: {seg.end_reason}"
        )
        if number == 0:
            summaries[0] = text + f" ({'starts with' if added else 'the points of'} results/exact/nnm1_two_impacts.nc)"
        else:
            summaries.append(text)
    ds = _branch_variables(rows, model)
    ds.attrs = {
        **model_attributes(model),
        "two_impact_points": two_impacts.sizes["point"],
        "segments": len(summaries),
        **{f"segment_{k}": text for k, text in enumerate(summaries)},
        **{f"segment_{k}_end_check": seg.end_check for k, seg in enumerate(segments) if seg.end_check},
        "end_reason": segments[-1].end_reason if segments else two_impacts.attrs.get("end_reason", ""),
        "max_residual": float(np.max(rows["residual"])),
    }
    return ds


def _two_impact_rows(two_impacts: xr.Dataset, fr: SequenceProblem) -> dict:
    """The columns of the branch dataset for the two-impact points (copied), with their bordered-Jacobian signs."""
    n0 = two_impacts.sizes["point"]
    y_two = two_impact_unknowns(two_impacts)
    contact = two_impacts["contact_time"].values
    rows = {name: list(two_impacts[name].values) for name in _COLUMNS}
    rows.update(
        sequence=["FR"] * n0,
        durations=[y[2:] for y in y_two],
        segment=[0] * n0,
        impacts=[2 if c > 0 else 0 for c in contact],
        grazing=[0] * n0,
        branch_point=[0],
        arclength=list(two_impacts["arclength"].values),
        last_two_impact=y_two[-1],
    )
    rows["grazing"][0] = int(contact[0] == 0.0)  # the family starts at the grazing orbit
    det = None
    for k in range(n0):  # bordered-Jacobian sign along the two-impact part too
        chord = y_two[min(k + 1, n0 - 1)] - y_two[max(k - 1, 0)]
        _, sign = unit_tangent(fr, y_two[k], chord, singular_tol=None)
        if det is not None:
            rows["branch_point"].append(int(sign != det))
        det = sign
    return rows


def _append_segment(rows: dict, seg, index: int, first: bool) -> bool:
    """Append the orbits of a continuation segment to the columns; False when none was added."""
    y_last = rows["last_two_impact"]
    keep = list(range(len(seg)))
    if first:
        # its first orbit is the last two-impact orbit; its grazing orbit, when located within
        # round-off of that orbit (the two-impact family already ended there), is not repeated
        same = 1e-9 * (1 + np.linalg.norm(y_last))
        keep = [j for j in keep[1:] if np.linalg.norm(seg.unknowns[j] - y_last) > same]
        if seg.grazing[-1] and not keep:
            rows["grazing"][-1] = 1
    problem, s_offset = seg.problem, rows["arclength"][-1]
    is_free = np.array([c == "F" for c in seg.sequence])
    for j in keep:
        y, check = seg.unknowns[j], seg.assessments[j]
        for name, value in (
            ("energy", problem.energy(y)),
            ("frequency", problem.frequency(y)),
            ("period", 4.0 * problem.quarter(y)),
            ("x_max", check.x_max),
            ("u_at_x_max", check.u_at_x_max),
            ("x_turning_point", check.x_turning),
            ("xdot0", y[0]),
            ("udot0", y[1]),
            ("free_flight_time", float(np.sum(y[2:][is_free]))),
            ("contact_time", float(np.sum(y[2:][~is_free]))),
            ("residual", seg.residual[j]),
            ("validity_margin", check.min_margin),
            ("sequence", seg.sequence),
            ("durations", y[2:]),
            ("segment", index),
            ("impacts", problem.impacts_per_period),
            ("grazing", int(seg.grazing[j])),
            ("branch_point", int(seg.branch_point[j])),
            ("arclength", s_offset + seg.arclength[j]),
        ):
            rows[name].append(value)
    return bool(keep)


def _branch_variables(rows: dict, model) -> xr.Dataset:
    """The variables of the exact NNM1 from its columns (metadata: kind ``exact_nnm1`` of the catalogue)."""
    n = len(rows["sequence"])
    data = {name: _var(rows[name]) for name in _COLUMNS}
    data["impacts_per_period"] = _var(rows["impacts"], dtype=np.int32)
    data["phase_sequence"] = ("point", np.array(rows["sequence"], dtype=object))
    data.update(stability_variables(model, rows["sequence"], rows["durations"]))
    data["n_phases"] = _var([len(s) for s in rows["sequence"]], dtype=np.int32)
    data["segment"] = _var(rows["segment"], dtype=np.int32)
    data["grazing"] = _var(rows["grazing"], dtype=np.int8)
    data["branch_point"] = _var(rows["branch_point"], dtype=np.int8)
    return xr.Dataset(data, coords={"point": ("point", np.arange(n)), "arclength": _var(rows["arclength"])})


def one_stop_dataset(family) -> xr.Dataset:
    """A one-stop family of any structure (:func:`nnmstop.exact.ndof.follow_one_stop_family`) along ``orbit``.

    With the energy of every linear mode (``modal_energy``) and, per orbit, the internal resonance it is in
    (:func:`nnmstop.exact.resonance.classify_resonances`: ``resonant_mode``, ``resonance_order``; 0 on the
    family's backbone). The attributes say why the family ends, how that end was confirmed and where it
    leaves its backbone. Metadata: kind ``one_stop_family`` of :mod:`nnmstop.catalogue.exact`.
    """
    from nnmstop.exact.resonance import classify_resonances

    problem = family.problem
    resonances = classify_resonances(family)
    ds = xr.Dataset(
        {
            "energy": ("orbit", family.energy),
            "frequency": ("orbit", family.frequency),
            "contact_time": ("orbit", family.contact_time),
            "x_max": ("orbit", family.x_max),
            "initial_velocity": (("orbit", "dof"), family.initial_velocity),
            "modal_energy": (("orbit", "mode"), family.modal_energy),
            "resonant_mode": ("orbit", resonances.mode.astype(np.int32)),
            "resonance_order": ("orbit", resonances.order.astype(np.int32)),
        },
        coords={
            "orbit": ("orbit", np.arange(len(family))),
            "dof": ("dof", np.arange(problem.n)),
            "mode": ("mode", np.arange(1, problem.n + 1)),
            "mode_frequency": ("mode", problem.free.omega / (2.0 * np.pi)),
        },
    )
    ds.attrs = {
        "start": family.start,
        "struck_stop": int(problem.structure.stops.index(problem.stop)),
        "end_reason": family.end_reason,
        "end_margin": family.end_margin or "none",
        "end_check": family.end_check or "not confirmed (not asked)",
        "internal_resonance": _resonance_summary(family, resonances),
    }
    return ds


def _resonance_summary(family, resonances) -> str:
    first = resonances.first()
    if first is None:
        return "none: every orbit is on the backbone (the energy grows in the family's own mode)"
    mode, order = int(resonances.mode[first]), int(resonances.order[first])
    frequency = family.frequency[first]
    linear = family.problem.free.omega[mode - 1] / (2 * np.pi)
    return (
        f"from orbit {first} (energy {family.energy[first]:.6g}, frequency {frequency:.8g} Hz) the family is in the "
        f"{order}:1 internal resonance with linear mode {mode} ({linear:.6g} Hz = {linear / frequency:.6f} x the "
        f"orbit's): the energy grows in "
        f"mode {mode} at the {order}th harmonic while the frequency stays locked; orbits 0 to {first - 1} "
        f"(energy {family.energy[0]:.6g} to {family.energy[first - 1]:.6g}) are the backbone"
    )


def one_stop_backbone(ds: xr.Dataset) -> xr.Dataset:
    """The orbits of a :func:`one_stop_dataset` before its first internal resonance: the family's backbone,
    the part that a regularized backbone (whose harmonics stop far below the resonant harmonic) compares with."""
    if "resonant_mode" not in ds:
        raise ValueError("the dataset has no resonant_mode variable: rebuild it with one_stop_dataset")
    resonant = np.flatnonzero(ds["resonant_mode"].values > 0)
    return ds.isel(orbit=slice(0, int(resonant[0]) if resonant.size else ds.sizes["orbit"]))


def switching_dataset(structure, family=None, reason: str = "") -> xr.Dataset:
    """A full-period family (:func:`nnmstop.exact.switching.follow_switching_family`) along ``orbit``; with no
    ``family``, the dataset of a structure that has no exact orbits, ``reason`` saying why (no orbit).

    Metadata: kind ``switching_family`` of :mod:`nnmstop.catalogue.exact`.
    """
    from nnmstop.models.structure import normal_modes

    n, s = structure.n_dofs, len(structure.stops)
    omega = normal_modes(structure)[0]
    count = 0 if family is None else len(family)
    if family is None:
        empty = np.zeros(0)
        data = {
            name: ("orbit", empty)
            for name in ("energy", "frequency", "period", "contact_time", "unfolding", "residual", "validity_margin")
        }
        data.update(
            impacts_per_period=("orbit", np.zeros(0, dtype=np.int32)),
            segment=("orbit", np.zeros(0, dtype=np.int32)),
            branch_point=("orbit", np.zeros(0, dtype=np.int8)),
            phase_sequence=("orbit", np.zeros(0, dtype=str)),
            stop_impacts=(("orbit", "stop"), np.zeros((0, s), dtype=np.int32)),
            x_max=(("orbit", "stop"), np.zeros((0, s))),
            initial_position=(("orbit", "dof"), np.zeros((0, n))),
            initial_velocity=(("orbit", "dof"), np.zeros((0, n))),
            modal_energy=(("orbit", "mode"), np.zeros((0, n))),
        )
        attrs = {"start": "none", "end_reason": reason, "end_margin": "none", "skipped": 1}
    else:
        start = family.start_state
        data = {
            "energy": ("orbit", family.energy),
            "frequency": ("orbit", family.frequency),
            "period": ("orbit", family.period),
            "contact_time": ("orbit", family.contact_time),
            "impacts_per_period": ("orbit", family.stop_impacts.sum(axis=1).astype(np.int32)),
            "stop_impacts": (("orbit", "stop"), family.stop_impacts.astype(np.int32)),
            "x_max": (("orbit", "stop"), family.x_max),
            "initial_position": (("orbit", "dof"), start[:, :n]),
            "initial_velocity": (("orbit", "dof"), start[:, n:]),
            "modal_energy": (("orbit", "mode"), family.modal_energy),
            "unfolding": ("orbit", family.unfolding),
            "residual": ("orbit", family.residual),
            "validity_margin": ("orbit", np.array([a.min_margin for a in family.assessments])),
            "segment": ("orbit", family.segment.astype(np.int32)),
            "phase_sequence": ("orbit", np.array(family.sequences, dtype=str)),
            "branch_point": ("orbit", family.branch_point.astype(np.int8)),
        }
        attrs = {
            "start": family.start,
            "end_reason": family.end_reason,
            "end_margin": family.end_margin or "none",
            "segments": len(family.problems),
            "sequences": " | ".join(p.describe_sequence() for p in family.problems),
            "continuation_step": family.step,
            "max_residual": float(np.max(family.residual)) if count else 0.0,
        }
    ds = xr.Dataset(
        data,
        coords={
            "orbit": ("orbit", np.arange(count)),
            "dof": ("dof", np.arange(n)),
            "stop": ("stop", np.arange(s)),
            "mode": ("mode", np.arange(1, n + 1)),
            "mode_frequency": ("mode", omega / (2.0 * np.pi)),
        },
    )
    ds.attrs = attrs
    return ds
