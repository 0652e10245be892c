"""The datasets of the exact orbits: the two-impact family and the exact NNM1.

:func:`two_impact_dataset` labels a two-impact family (Section 3.1, unknowns
``(xdot0, udot0, tau1, T1)``); :func:`exact_branch_dataset` appends the segments of the
continuation through the grazing transitions (:func:`nnmstop.exact.family.follow_branch`)
to it, one row per orbit with its phase sequence, impact count, validity margin and
Floquet multipliers (:func:`nnmstop.exact.stability.stability_variables`). Every variable
has ``long_name`` and ``units``; the variables are listed in ``docs/datasets.md``.
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

__all__ = ["two_impact_dataset", "two_impact_unknowns", "exact_branch_dataset", "one_stop_dataset", "one_stop_backbone"]


def two_impact_dataset(family: Family) -> xr.Dataset:
    """The two-impact family (:func:`nnmstop.exact.family.follow_two_impact_family`) as a dataset along ``point``."""
    y = np.asarray(family.unknowns)
    n = len(family)
    one = "1"

    def var(values, long_name, units, **extra):
        return ("point", np.asarray(values, dtype=float), {"long_name": long_name, "units": units, **extra})

    x_max = [a.x_max for a in family.assessments]
    u_at = [a.q_at_x_max[1] for a in family.assessments]
    margin = [a.min_margin for a in family.assessments]
    floquet = stability_variables(family.model, ["FR"] * n, np.column_stack([y[:, 2], y[:, 3] - y[:, 2]]))
    ds = xr.Dataset(
        {
            "energy": var(
                family.energy,
                "total energy of the non-smooth (piecewise-linear) model: kinetic + spring potential "
                "+ stop potential alpha/2 (|x|-1)^2, conserved along the orbit",
                one,
            ),
            "frequency": var(
                family.frequency, "frequency 1/T of the periodic orbit, in Hz of the nondimensional time", "Hz"
            ),
            "period": var(4.0 * y[:, 3], "period T = 4 T1", one),
            "x_max": var(x_max, "maximum of x over the period (x_max - 1 is the penetration into the stop)", one),
            "u_at_x_max": var(u_at, "u at the time of the maximum of x", one),
            "x_turning_point": var(
                [a.margins["final_position"] + 1.0 for a in family.assessments],
                "x(T1) where both velocities vanish (equals x_max unless x peaks earlier during contact)",
                one,
            ),
            "xdot0": var(y[:, 0], "velocity of x at x = u = 0 (t = 0)", one),
            "udot0": var(y[:, 1], "velocity of u at x = u = 0 (t = 0)", one),
            "free_flight_time": var(y[:, 2], "free-flight duration tau1 of the quarter period", one),
            "contact_time": var(y[:, 3] - y[:, 2], "contact duration T1 - tau1 of the quarter period", one),
            "residual": var(family.residual, "Euclidean norm of (x(tau1) - 1, xdot(T1), udot(T1))", one),
            "validity_margin": var(
                margin,
                "smallest margin of the assumptions of the two-impact construction "
                "(> 0 inside the family, about 0 at its ends)",
                one,
            ),
            **floquet,
        },
        coords={
            "point": ("point", np.arange(n), {"long_name": "index of the orbit along the family", "units": one}),
            "arclength": var(
                family.arclength, "pseudo-arclength in (xdot0, udot0, tau1, T1) from the first orbit", one
            ),
        },
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


def _var(values, long_name, units="1", dtype=float, **extra):
    return ("point", np.asarray(values, dtype=dtype), {"long_name": long_name, "units": units, **extra})


_LONG_NAMES = {
    "energy": (
        "total energy of the non-smooth (piecewise-linear) model: kinetic + spring potential + stop potential "
        "alpha/2 (|x|-1)^2, conserved along the orbit"
    ),
    "frequency": "frequency 1/T of the periodic orbit, in Hz of the nondimensional time",
    "period": "period T = 4 T1 (T1: quarter period, from the origin to the turning point)",
    "x_max": "maximum of x over the period (x_max - 1 is the penetration into the stop)",
    "u_at_x_max": "u at the time of the maximum of x",
    "x_turning_point": "x(T1) at the turning point, where both velocities vanish",
    "xdot0": "velocity of x at x = u = 0 (t = 0)",
    "udot0": "velocity of u at x = u = 0 (t = 0)",
    "free_flight_time": "total free-flight duration in the quarter period (tau1 for two impacts per period)",
    "contact_time": "total contact duration in the quarter period (T1 - tau1 for two impacts per period)",
    "residual": "Euclidean norm of the quarter-period equations (switching conditions, xdot(T1), udot(T1))",
    "validity_margin": (
        "smallest margin of the assumptions of the phase sequence (> 0 inside a segment, about 0 at its "
        "grazing transitions)"
    ),
}


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
        Dimension ``point``; every variable has ``long_name`` and ``units``.
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
    rows = {name: list(two_impacts[name].values) for name in _LONG_NAMES}
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
    """The labelled variables of the exact NNM1 from its columns."""
    n = len(rows["sequence"])
    data = {name: _var(rows[name], long_name) for name, long_name in _LONG_NAMES.items()}
    # "Hz" of the nondimensional time (the long name says so): a unit UDUNITS knows, as CF asks.
    data["frequency"][2]["units"] = "Hz"
    data["impacts_per_period"] = _var(
        rows["impacts"], "number of excursions of x beyond the stops (|x| > 1) per period", dtype=np.int32
    )
    data["phase_sequence"] = (
        "point",
        np.array(rows["sequence"], dtype=object),
        {
            "long_name": (
                "linear phases of the quarter period from the origin to the turning point: F free flight, "
                "R contact with the stop x = 1, L contact with the stop x = -1 (the orbit -q, half a period "
                "later, has R and L swapped)"
            ),
            "units": "1",
        },
    )
    data.update(stability_variables(model, rows["sequence"], rows["durations"]))
    data["n_phases"] = _var(
        [len(s) for s in rows["sequence"]], "number of linear phases in the quarter period", dtype=np.int32
    )
    data["segment"] = _var(
        rows["segment"], "index of the phase-sequence segment (0: the two-impact family)", dtype=np.int32
    )
    data["grazing"] = _var(
        rows["grazing"],
        "1 for an exactly computed grazing orbit (a transition between phase sequences, or the start)",
        dtype=np.int8,
    )
    data["branch_point"] = _var(
        rows["branch_point"],
        "1 where the sign of det [J; t] changed since the previous orbit (a simple bifurcation was crossed)",
        dtype=np.int8,
    )
    return xr.Dataset(
        data,
        coords={
            "point": ("point", np.arange(n), {"long_name": "index of the orbit along the branch", "units": "1"}),
            "arclength": _var(
                rows["arclength"],
                "pseudo-arclength in the unknowns (xdot0, udot0, phase durations) of each segment, accumulated "
                "from the first orbit (a length in different unknowns on each segment)",
            ),
        },
    )


def one_stop_dataset(family) -> xr.Dataset:
    """A one-stop family of any structure (:func:`nnmstop.exact.ndof.follow_one_stop_family`) along ``orbit``.

    With the energy of every linear mode (``modal_energy``) and, per orbit, the internal resonance it is in
    (:func:`nnmstop.exact.resonance.classify_resonances`: ``resonant_mode``, ``resonance_order``; 0 on the
    family's backbone). The attributes say why the family ends, how that end was confirmed and where it
    leaves its backbone.
    """
    from nnmstop.exact.resonance import classify_resonances

    problem = family.problem
    resonances = classify_resonances(family)
    one = {"units": "1"}
    ds = xr.Dataset(
        {
            "energy": ("orbit", family.energy, {"long_name": "total energy of the non-smooth model", **one}),
            "frequency": (
                "orbit",
                family.frequency,
                {"long_name": "frequency 1/T in Hz of the nondimensional time", "units": "Hz"},
            ),
            "contact_time": (
                "orbit",
                family.contact_time,
                {"long_name": "contact duration of the quarter period", **one},
            ),
            "x_max": ("orbit", family.x_max, {"long_name": "largest displacement at the stop over its gap", **one}),
            "initial_velocity": (
                ("orbit", "dof"),
                family.initial_velocity,
                {"long_name": "velocities at q = 0 (start of the orbit)", **one},
            ),
            "modal_energy": (
                ("orbit", "mode"),
                family.modal_energy,
                {
                    "long_name": "energy of each linear (free-flight) mode, b_k^2 / 2 at q = 0 (they add up to energy)",
                    **one,
                },
            ),
            "resonant_mode": (
                "orbit",
                resonances.mode.astype(np.int32),
                {
                    "long_name": "linear mode in internal resonance with the orbit (takes most of the energy growth, "
                    "at one harmonic); 0 on the backbone",
                    **one,
                },
            ),
            "resonance_order": (
                "orbit",
                resonances.order.astype(np.int32),
                {
                    "long_name": "harmonic n of the orbit at which the resonant mode moves (an n:1 resonance); "
                    "0 on the backbone",
                    **one,
                },
            ),
        },
        coords={
            "orbit": ("orbit", np.arange(len(family)), {"long_name": "index of the orbit along the family", **one}),
            "dof": ("dof", np.arange(problem.n), {"long_name": "index of the degree of freedom", **one}),
            "mode": ("mode", np.arange(1, problem.n + 1), {"long_name": "linear (free-flight) mode number", **one}),
            "mode_frequency": (
                "mode",
                problem.free.omega / (2.0 * np.pi),
                {
                    "long_name": "linear frequency of the mode without contact, in Hz of the nondimensional time",
                    "units": "Hz",
                },
            ),
        },
    )
    ds.attrs = {
        "start": family.start,
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
