"""Datasets of the forced responses (CF/ACDD through :func:`nnmstop.netcdf.write_dataset`).

One dataset per response (a force level, a contact law). Per point: ``frequency``, ``x_amplitude``
(``max |q|`` of the first stop's DOF), ``u_amplitude`` (``max |q|`` of the first forced DOF), ``amplitude``
of every DOF, ``phase_lag`` of every DOF's fundamental behind the force, ``stable``, the multipliers
(``multiplier_real``, ``multiplier_imag``), ``regime`` and ``segment``; the located stability changes
(dimension ``change``); the attributes ``forcing_amplitude``, ``forcing_dofs``, the damping
(``damping_ratio`` and the Rayleigh coefficients) and ``contact_law`` (``piecewise_linear`` or
``regularized``).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nnmstop import fourier
from nnmstop.exact.forced import SymmetricContactProblem, non_impacting_response
from nnmstop.forced.stability_changes import KINDS, regimes
from nnmstop.hbm.forced import phase_lags, response_amplitudes
from nnmstop.models.excitation import Excitation

__all__ = [
    "canonical_order",
    "response_variables",
    "change_variables",
    "base_attributes",
    "SEGMENT_KINDS",
    "exact_dataset",
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
    x_dof, u_dof = structure.stops[0].dof, excitation.force.dofs[0]
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
    stop = excitation.structure.stops[0]
    return {
        **excitation.structure.attributes,
        **excitation.as_attrs(),
        "contact_law": contact_law,
        "frequency_range": np.array(frequency_range, dtype=float),
        "stop_dof": int(stop.dof),
        "stop_gap": float(stop.gap),
        "stop_stiffness": float(stop.stiffness),
        "stop_eta": float(stop.eta),
    }


def _exact_lags(piece, problem) -> np.ndarray:
    """Lag of each DOF's fundamental behind the force, per point of an exact piece (radians)."""
    if piece.kind == "non_impacting":
        amplitude = non_impacting_response(problem.excitation, 2 * np.pi * piece.frequency)
        return np.mod(-np.angle(amplitude), 2 * np.pi)
    samples = 2048
    lags = []
    for y in piece.unknowns:
        history = problem.time_history(y, samples)
        fundamental = (2.0 / samples) * history["q"] @ np.exp(-1j * history["theta"])
        lags.append(np.mod(-np.angle(fundamental), 2 * np.pi))
    return np.array(lags)


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

    The contact families' unknowns (``z1``, ``theta1``, contact phase duration, ``Omega``) are kept in
    ``contact_unknowns(contact_point, unknown)`` with ``contact_point_index`` into ``point``. A verdict is
    resolved where its margin exceeds ``resolution_factor`` times the multipliers' error estimate (of ``mu``).
    """
    problem = SymmetricContactProblem(excitation)
    parts, changes, offset = [], [], 0
    contact_rows, contact_index = [], []
    for k, piece in enumerate(pieces):
        half = piece.kind == "one_contact"
        multipliers, error = piece.multipliers, piece.multiplier_error
        if half:  # nu of the half-period map (the piece holds mu = nu**2)
            multipliers = np.array([problem.multipliers(y)[1] for y in piece.unknowns])
            error = 2 * np.abs(multipliers).max(axis=1) * error  # of mu = nu**2
            contact_rows.append(piece.unknowns)
            contact_index.append(offset + np.arange(len(piece.frequency)))
        variables = response_variables(
            excitation,
            piece.frequency,
            piece.amplitude,
            _exact_lags(piece, problem),
            multipliers,
            half,
            np.full(len(piece.frequency), k),
        )
        variables.update(exact_verdicts(piece.multipliers, error, resolution_factor))
        parts.append(xr.Dataset(variables))
        changes += piece.changes
        offset += len(piece.frequency)
    ds = xr.concat(parts, dim="point", data_vars="all", combine_attrs="override")
    ds["dof_label"] = dof_label_variable(excitation.structure)
    ds.update(change_variables(changes, lambda U: U[-1] / (2 * np.pi), problem.amplitudes, problem.n))
    if contact_rows:
        ds["contact_unknowns"] = (("contact_point", "unknown"), np.concatenate(contact_rows))
        ds["contact_point_index"] = ("contact_point", np.concatenate(contact_index).astype(np.int32))
    ds.attrs.update(base_attributes(excitation, "piecewise_linear", frequency_range))
    ds.attrs["stability_resolution_factor"] = float(resolution_factor)
    ds.attrs["segment_kinds"] = " ".join(p.kind for p in pieces)
    ds.attrs["segment_end_reasons"] = "; ".join(f"{k}: {p.end_reason}" for k, p in enumerate(pieces))
    ds.attrs["segment_end_checks"] = "; ".join(f"{k}: {p.end_check}" for k, p in enumerate(pieces))
    return ds


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
