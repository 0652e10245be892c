"""Datasets of the forced responses (CF/ACDD through :func:`nnmstop.netcdf.write_dataset`).

One dataset per response (a force level, a contact law). Per point: ``frequency``, ``x_amplitude``
(``max |q|`` of the first stop's DOF), ``u_amplitude`` (``max |q|`` of the first forced DOF), ``amplitude``
of every DOF, ``phase_lag`` of every DOF's fundamental behind the force, ``stable``, the multipliers
(``multiplier_real``, ``multiplier_imag``), ``regime`` and ``segment``; the located stability changes
(dimension ``change``); the attributes ``forcing_amplitude``, ``forcing_dofs``, the damping
(``damping_ratio`` and the Rayleigh coefficients) and ``contact_law`` (``piecewise_linear`` or
``regularized``). The orbits of an exact response are kept by their unknowns: ``contact_unknowns`` for the
half-wave families (the paper's), the switches (``switch_*``) for the full-period ones;
:func:`exact_time_history` rebuilds any stored orbit.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nnmstop import fourier
from nnmstop.exact.forced import (
    ForcedResponseProblem,
    SymmetricContactProblem,
    non_impacting_response,
    structure_contacts,
)
from nnmstop.forced.stability_changes import KINDS, regimes
from nnmstop.hbm.forced import phase_lags, response_amplitudes
from nnmstop.models.excitation import Excitation
from nnmstop.wear import WEAR_VARIABLES, orbit_wear, structure_wear

__all__ = [
    "canonical_order",
    "response_variables",
    "change_variables",
    "base_attributes",
    "SEGMENT_KINDS",
    "exact_dataset",
    "exact_time_history",
    "regularized_dataset",
    "backbone_dataset",
]

#: Kinds of the segments of an exact response (flag values of ``segment_kind``).
SEGMENT_KINDS = ("non_impacting", "one_contact")


def canonical_order(mu) -> np.ndarray:
    """Multipliers (rows) by decreasing modulus, each complex-conjugate pair with its positive imaginary part
    first: the stored order then follows the multipliers, not round-off (a pair's moduli are equal to it)."""
    mu = np.array(mu, dtype=complex)
    mu = np.take_along_axis(mu, np.argsort(-np.abs(mu), axis=-1, kind="stable"), axis=-1)
    for j in range(mu.shape[-1] - 1):
        a, b = mu[:, j], mu[:, j + 1]
        pair = np.abs(a - np.conj(b)) <= 1e-8 * np.maximum(np.abs(a), 1.0)
        swap = pair & (a.imag < b.imag)
        mu[swap, j], mu[swap, j + 1] = b[swap], a[swap]
    return mu


def response_variables(
    excitation: Excitation, frequency, amplitude, lags, multipliers, half_period: bool, segment
) -> dict:
    """Per-point variables (dimension ``point``; ``dof``, ``multiplier``) of a response (metadata: the catalogue)."""
    structure = excitation.structure
    x_dof, u_dof = structure.stop_dofs[0], excitation.force.dofs[0]
    multipliers = np.asarray(multipliers)
    mu = canonical_order(multipliers**2 if half_period else multipliers)
    stable = np.all(np.abs(mu) <= 1.0 + 1e-12, axis=1)
    amplitude = np.asarray(amplitude, dtype=float)
    return {
        "frequency": ("point", np.asarray(frequency, dtype=float)),
        "x_amplitude": ("point", amplitude[:, x_dof]),
        "u_amplitude": ("point", amplitude[:, u_dof]),
        "amplitude": (("point", "dof"), amplitude),
        "phase_lag": (("point", "dof"), np.degrees(lags)),
        "stable": ("point", stable.astype(np.int8)),
        "multiplier_real": (("point", "multiplier"), mu.real),
        "multiplier_imag": (("point", "multiplier"), mu.imag),
        "regime": ("point", regimes(multipliers, half_period)),
        "segment": ("point", np.asarray(segment, dtype=np.int32)),
    }


def dof_label_variable(structure) -> tuple:
    """The ``dof_label`` coordinate of a structure (``q0, q1, ...`` when it names none)."""
    labels = structure.dof_labels or tuple(f"q{j}" for j in range(structure.n_dofs))
    return ("dof", np.array(labels, dtype=object))


def change_variables(changes, frequency_of, amplitude_of, n_dofs: int) -> dict:
    """Located stability changes (dimension ``change``): frequency, amplitudes, kind (index in :data:`KINDS`)."""
    frequency = np.array([frequency_of(c.U) for c in changes], dtype=float)
    amplitude = np.array([amplitude_of(c.U) for c in changes], dtype=float).reshape(len(changes), n_dofs)
    kinds = np.array([KINDS.index(c.kind) for c in changes], dtype=np.int8)
    return {
        "change_frequency": ("change", frequency),
        "change_amplitude": (("change", "dof"), amplitude),
        "change_kind": ("change", kinds),
    }


def base_attributes(excitation: Excitation, contact_law: str, frequency_range) -> dict:
    """Global attributes of a response dataset."""
    if contact_law not in ("piecewise_linear", "regularized"):
        raise ValueError(f"contact_law must be 'piecewise_linear' or 'regularized', got {contact_law!r}")
    stops = excitation.structure.stops
    stop = stops[0]
    attrs = {
        **excitation.structure.attributes,  # the structure, rebuilt by the readers (nnmstop.stored_accuracy)
        **excitation.as_attrs(),
        "contact_law": contact_law,
        "frequency_range": np.array(frequency_range, dtype=float),
        "stop_dof": int(excitation.structure.stop_dofs[0]),
        "stop_gap": float(stop.gap),
        "stop_stiffness": float(stop.stiffness),
        "stop_eta": float(stop.eta),
    }
    if len(stops) > 1 or any(s.kind != "bilateral" for s in stops):
        # every stop, as the branch datasets' stop variables (the paper's datasets, one bilateral stop, keep theirs):
        # the readers rebuild the structure from them (nnmstop.stored_accuracy)
        meta = [s.metadata() for s in stops]
        attrs.update(
            stop_dof=np.array(excitation.structure.stop_dofs, dtype=np.int32),
            stop_gap=np.array([s.gap for s in stops]),
            stop_stiffness=np.array([s.stiffness for s in stops]),
            stop_eta=np.array([s.eta for s in stops]),
            stop_kinds=" ".join(m["kind"] for m in meta),  # text attribute: the kinds in the order of the stops
            stop_side=np.array([m["side"] for m in meta], dtype=np.int32),
            stop_other_dof=np.array([m["dofs"][-1] for m in meta], dtype=np.int32),
            stop_labels="; ".join(s.label for s in stops),
        )
    return attrs


def _exact_lags(piece, excitation: Excitation) -> np.ndarray:
    """Lag of each DOF's fundamental behind the force, per point of an exact piece (radians)."""
    if piece.kind == "non_impacting":
        amplitude = non_impacting_response(excitation, 2 * np.pi * piece.frequency)
        return np.mod(-np.angle(amplitude), 2 * np.pi)
    samples = 2048
    lags = []
    for y in piece.unknowns:
        history = piece.problem.time_history(y, samples)
        fundamental = (2.0 / samples) * history["q"] @ np.exp(-1j * history["theta"])
        lags.append(np.mod(-np.angle(fundamental), 2 * np.pi))
    return np.array(lags)


def _switch_variables(problem: ForcedResponseProblem, unknowns, first: int) -> dict:
    """The switches of the full-period orbits ``unknowns`` (contact points ``first``, ``first + 1``, ...)."""
    m, rows = problem.m, len(unknowns)
    phases = np.array([problem.switch_phases(y)[:m] for y in unknowns])
    return {
        "switch_state": np.array([problem.split(y)[0] for y in unknowns]),
        "switch_point": np.repeat(first + np.arange(rows), m),
        "switch_phase": np.mod(phases, 2 * np.pi).ravel(),
        "switch_contact": np.tile([s.contact for s in problem.switches], rows),
        "switch_entry": np.tile([int(s.entry) for s in problem.switches], rows),
    }


#: Samples per period of an exact orbit for its wear (:func:`nnmstop.wear.structure_wear`): the sampled peak force
#: and impact work are off by about (pi / samples)**2 relative (docs/methods/wear.md), here about 1.5e-7, below the
#: accuracy to which verify compares the exact responses' smooth quantities between builds storing other points
#: (2048 samples left about 1.5e-6 there, above it).
WEAR_SAMPLES = 8192


def _exact_wear(piece, excitation: Excitation) -> dict:
    """Wear of every orbit of an exact piece at every stop (piecewise-linear laws): zero on the non-impacting
    response, which touches no stop."""
    n_stops = len(excitation.structure.stops)
    if piece.kind == "non_impacting":
        return {name: (("point", "stop"), np.zeros((len(piece.frequency), n_stops))) for name in WEAR_VARIABLES}
    rows = []
    for y, frequency in zip(piece.unknowns, piece.frequency):
        history = piece.problem.time_history(y, WEAR_SAMPLES)
        rows.append(
            structure_wear(excitation.structure, history["q"], history["qdot"], 1.0 / frequency, law="piecewise_linear")
        )
    return {name: (("point", "stop"), np.stack([row[name] for row in rows])) for name in WEAR_VARIABLES}


def exact_verdicts(mu, error, resolution_factor: float) -> dict:
    """``multiplier_error``, ``stability_margin``, ``stability_resolved`` of exact multipliers ``mu`` (points, 2N)."""
    margin = np.abs(np.abs(np.asarray(mu)) - 1.0).min(axis=1)
    error = np.asarray(error, dtype=float)
    return {
        "multiplier_error": ("point", error),
        "stability_margin": ("point", margin),
        "stability_resolved": ("point", (margin > resolution_factor * error).astype(np.int8)),
    }


def exact_dataset(excitation: Excitation, pieces: list, frequency_range, resolution_factor: float = 2.0) -> xr.Dataset:
    """Dataset of the exact response (:func:`nnmstop.forced.responses.exact_response`), pieces one after the other.

    The orbits of the half-wave families (unknowns ``z1``, ``theta1``, contact phase duration, ``Omega``) are kept
    in ``contact_unknowns(contact_point, unknown)``, those of the full-period families by their switches
    (``switch_state(contact_point, state)`` at the first switch; ``switch_point``, ``switch_phase``,
    ``switch_contact``, ``switch_entry`` along ``switch``; the half-space contacts ``contact_stop``,
    ``contact_side``), each with ``contact_point_index`` into ``point``. A verdict is resolved where its margin
    exceeds ``resolution_factor`` times the multipliers' error estimate (of ``mu``).
    """
    parts, changes, offset, owner = [], [], 0, {}
    contact_rows, contact_index, switch_parts, contact_points = [], [], [], 0
    struck = []  # per half-wave orbit, the contact of its sequence [{c}, {}]
    for k, piece in enumerate(pieces):
        problem = piece.problem
        if piece.kind == "one_contact" and problem is None:  # a piece built without its problem: the paper's
            problem = piece.problem = SymmetricContactProblem(excitation)
        half = piece.kind == "one_contact" and problem.half_wave
        multipliers, error = piece.multipliers, piece.multiplier_error
        if half:  # nu of the half-period map (the piece holds mu = nu**2)
            multipliers = np.array([problem.multipliers(y)[1] for y in piece.unknowns])
            error = 2 * np.abs(multipliers).max(axis=1) * error  # of mu = nu**2
            contact_rows.append(piece.unknowns)
            struck.append(np.full(len(piece.unknowns), _half_wave_contact(problem), dtype=np.int32))
        elif piece.kind == "one_contact":
            switch_parts.append(_switch_variables(problem, piece.unknowns, contact_points))
        if piece.kind == "one_contact":
            contact_index.append(offset + np.arange(len(piece.frequency)))
            contact_points += len(piece.frequency)
        variables = response_variables(
            excitation,
            piece.frequency,
            piece.amplitude,
            _exact_lags(piece, excitation),
            multipliers,
            half,
            np.full(len(piece.frequency), k),
        )
        variables.update(exact_verdicts(piece.multipliers, error, resolution_factor))
        variables.update(_exact_wear(piece, excitation))
        parts.append(xr.Dataset(variables))
        changes += piece.changes
        owner.update({id(c.U): problem for c in piece.changes})
        offset += len(piece.frequency)
    ds = xr.concat(parts, dim="point", data_vars="all", combine_attrs="override")
    ds["dof_label"] = dof_label_variable(excitation.structure)
    n = excitation.structure.n_dofs
    ds.update(change_variables(changes, lambda U: U[-1] / (2 * np.pi), lambda U: owner[id(U)].amplitudes(U), n))
    if contact_index:
        if contact_rows and switch_parts:
            raise ValueError("an exact response mixes half-wave and full-period families: store them apart")
        if contact_rows:
            ds["contact_unknowns"] = (("contact_point", "unknown"), np.concatenate(contact_rows))
            if len(excitation.structure.stops) > 1:  # which stop's contact each orbit strikes
                ds["contact_struck"] = ("contact_point", np.concatenate(struck))
        else:
            switches = {key: np.concatenate([part[key] for part in switch_parts]) for key in switch_parts[0]}
            ds["switch_state"] = (("contact_point", "state"), switches.pop("switch_state"))
            ds["switch_point"] = ("switch", switches["switch_point"].astype(np.int32))
            ds["switch_phase"] = ("switch", switches["switch_phase"])
            ds["switch_contact"] = ("switch", switches["switch_contact"].astype(np.int32))
            ds["switch_entry"] = ("switch", switches["switch_entry"].astype(np.int8))
            contacts = structure_contacts(excitation.structure)
            ds["contact_stop"] = ("contact", np.array([c.stop for c in contacts], dtype=np.int32))
            ds["contact_side"] = ("contact", np.array([c.side for c in contacts], dtype=np.int8))
        ds["contact_point_index"] = ("contact_point", np.concatenate(contact_index).astype(np.int32))
    ds.attrs.update(base_attributes(excitation, "piecewise_linear", frequency_range))
    ds.attrs["stability_resolution_factor"] = float(resolution_factor)
    ds.attrs["segment_kinds"] = " ".join(p.kind for p in pieces)
    ds.attrs["segment_end_reasons"] = "; ".join(f"{k}: {p.end_reason}" for k, p in enumerate(pieces))
    ds.attrs["segment_end_checks"] = "; ".join(f"{k}: {p.end_check}" for k, p in enumerate(pieces))
    if switch_parts:
        ds.attrs["segment_sequences"] = "; ".join(
            f"{k}: {p.problem.describe()}" for k, p in enumerate(pieces) if p.kind == "one_contact"
        )
    return ds


def _half_wave_contact(problem) -> int:
    """The contact ``c`` of a half-wave problem of sequence ``[{c}, {}]`` (one contact per half period)."""
    sequence = problem.sequence
    if len(sequence) != 2 or len(sequence[0]) != 1 or sequence[1]:
        raise ValueError(f"a half-wave family stores one contact per half period, got {problem.describe()}")
    return int(next(iter(sequence[0])))


def exact_time_history(ds: xr.Dataset, excitation: Excitation, contact_point: int, samples: int = 1024) -> dict:
    """One period of the stored exact orbit ``contact_point`` of an exact response dataset of ``excitation``
    (:meth:`~nnmstop.exact.forced.ForcedResponseProblem.time_history`), from either layout."""
    problem, y = stored_contact_orbit(ds, excitation, contact_point)
    return problem.time_history(y, samples)


def stored_contact_orbit(ds: xr.Dataset, excitation: Excitation, contact_point: int):
    """The problem and the unknowns of the stored exact orbit ``contact_point`` of an exact response dataset of
    ``excitation``, from either layout (the half-wave ``contact_unknowns``, the full-period switches)."""
    if "contact_unknowns" in ds:
        y = np.asarray(ds["contact_unknowns"].values[contact_point], float)
        if "contact_struck" in ds:  # several stops: the contact its half-wave sequence strikes
            contact = int(ds["contact_struck"].values[contact_point])
            return ForcedResponseProblem(excitation, [{contact}, set()], half_wave=True), y
        return SymmetricContactProblem(excitation), y
    pick = ds["switch_point"].values == contact_point
    contacts = [int(c) for c in ds["switch_contact"].values[pick]]
    entry = ds["switch_entry"].values[pick].astype(bool)
    # active before the first switch: the contacts whose first switch leaves them
    active, sequence = {c for c in set(contacts) if not entry[contacts.index(c)]}, []
    for c, enters in zip(contacts, entry):
        active = active | {c} if enters else active - {c}
        sequence.append(set(active))
    problem = ForcedResponseProblem(excitation, sequence)
    phases = ds["switch_phase"].values[pick]
    durations = np.mod(np.diff(phases), 2 * np.pi)
    omega = 2 * np.pi * float(ds["frequency"].values[ds["contact_point_index"].values[contact_point]])
    y = np.concatenate([ds["switch_state"].values[contact_point], [phases[0]], durations, [omega]])
    return problem, y


def regularized_dataset(system, branch, multipliers, half_period: bool, changes, frequency_range) -> xr.Dataset:
    """Dataset of the regularized response: per-point variables, the Fourier coefficients of ``q``, ``f`` and
    ``z`` (``<field>_cos``/``<field>_sin``), ``truncation`` and ``time_residual``, and the located changes."""
    U = np.asarray(branch.points)
    excitation = system.excitation
    amplitude = response_amplitudes(system, U)
    variables = response_variables(
        excitation,
        U[:, system.i_omega] / (2 * np.pi),
        amplitude,
        phase_lags(system, U),
        multipliers,
        half_period,
        np.zeros(len(U), dtype=int),
    )
    N, s, nc, H = system.n_dofs, system.n_stops, system.nc, system.H
    if system.n_components != s:
        raise ValueError(
            "a forced response dataset holds one force per stop; a circular clearance has two components (not yet)"
        )
    Q = U[:, : N * nc].reshape(-1, N, nc)
    F = U[:, N * nc : (N + s) * nc].reshape(-1, s, nc)
    Z = U[:, (N + s) * nc : (N + 2 * s) * nc].reshape(-1, s, nc)
    for name, block, dim in (("q", Q, "dof"), ("f", F, "stop"), ("z", Z, "stop")):
        cos, sin = fourier.to_cos_sin(block, H)
        variables[f"{name}_cos"] = (("point", dim, "harmonic"), cos)
        variables[f"{name}_sin"] = (("point", dim, "harmonic"), sin)
    diagnostics = branch.diagnostics
    variables["truncation"] = ("point", np.array([d["truncation"] for d in diagnostics], dtype=float))
    variables["time_residual"] = ("point", np.array([d["time_residual"] for d in diagnostics], dtype=float))
    variables["step"] = ("point", np.asarray(branch.step, dtype=np.int32))
    variables.update({name: (("point", "stop"), values) for name, values in orbit_wear(system, U).items()})
    variables["dof_label"] = dof_label_variable(excitation.structure)
    ds = xr.Dataset(variables, coords={"harmonic": ("harmonic", np.arange(H + 1))})
    ds.update(change_variables(changes, system.frequency_hz, lambda V: response_amplitudes(system, V[None])[0], N))
    ds.attrs.update(base_attributes(excitation, "regularized", frequency_range))
    ds.attrs.update(
        harmonics=int(H),
        end_reason=branch.end_reason,
        anm_steps=int(branch.stats.steps),
        factorizations=int(branch.stats.factorizations),
    )
    return ds


def backbone_dataset(excitation: Excitation, backbones: dict, forces, predictions: dict) -> xr.Dataset:
    """NNM backbones (``point``, with ``backbone_mode``) and the peaks they predict (``level``, ``mode``).

    ``backbones``: mode -> (frequency Hz, amplitudes (points, N), required force); ``predictions``: mode -> one
    :func:`nnmstop.forced.backbone.predicted_peaks` entry per level (None where the backbone does not reach it:
    stored as missing values).
    """
    modes = sorted(backbones)
    frequency = np.concatenate([backbones[m][0] for m in modes])
    amplitude = np.concatenate([backbones[m][1] for m in modes])
    required = np.concatenate([backbones[m][2] for m in modes])
    which = np.concatenate([np.full(len(backbones[m][0]), m) for m in modes])
    n = excitation.structure.n_dofs
    peak_frequency = np.full((len(forces), len(modes)), np.nan)
    peak_amplitude = np.full((len(forces), len(modes), n), np.nan)
    for j, m in enumerate(modes):
        for i, found in enumerate(predictions[m]):
            if found is not None:
                peak_frequency[i, j], peak_amplitude[i, j] = found[0], found[1]
    return xr.Dataset(
        {
            "backbone_frequency": ("point", frequency),
            "backbone_amplitude": (("point", "dof"), amplitude),
            "backbone_mode": ("point", which.astype(np.int32)),
            "required_force": ("point", required),
            "forcing_amplitude": ("level", np.asarray(forces, dtype=float)),
            "mode": ("mode", np.array(modes, dtype=np.int32)),
            "predicted_frequency": (("level", "mode"), peak_frequency),
            "predicted_amplitude": (("level", "mode", "dof"), peak_amplitude),
            "dof_label": dof_label_variable(excitation.structure),
        }
    )
