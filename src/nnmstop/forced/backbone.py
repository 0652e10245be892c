r"""The backbones' prediction of the resonance peaks (energy balance on the conservative NNM).

At phase resonance the force is in quadrature with the response and, over one period, the work of the
force balances the work of the damping. On an NNM orbit ``q(t) = sum_k a_k cos(k w t) + b_k sin(k w t)``
of the conservative structure the damping dissipates ``int_0^T q'^T C q' dt = (T/2) w^2 sum_k k^2
(a_k^T C a_k + b_k^T C b_k)``; the force ``F cos(w t + phi) b`` in quadrature does the work
``pi F |b^T (a_1 - i b_1)|`` (only the fundamental works). The NNM orbit is the peak of the response to

    F_required = w sum_k k^2 (a_k^T C a_k + b_k^T C b_k) / |b^T (a_1 - i b_1)|

(:func:`required_force`), exactly so for a linear mode with modal damping and to first order in the
damping otherwise. :func:`nnm_backbone` continues an NNM of the regularized structure by the ANM (the
NNM system of the package, cosine basis) until the required force exceeds a bound; :func:`predicted_peaks`
locates on its ANM steps the orbits where the required force equals each force level.
"""

from __future__ import annotations

import numpy as np

from nnmstop.continuation.anm import ANMSettings, ANMStepper, continue_anm
from nnmstop.continuation.newton import bisect_sign_change
from nnmstop.forced.responses import path_between
from nnmstop.hbm.forced import response_amplitudes
from nnmstop.hbm.stages import TruncationGuard, start_point
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.excitation import Excitation

__all__ = ["required_force", "nnm_backbone", "predicted_peaks", "locate_peak", "prediction_errors"]


def required_force(system: HarmonicBalanceSystem, excitation: Excitation, U) -> float:
    """Force amplitude whose peak response is the NNM orbit ``U`` (energy balance, see the module docstring)."""
    Q, _, _, lam, _ = system._fields(U)
    full = system.to_full(Q)  # (N, 2H + 1)
    H = system.H
    a, b = full[:, 1 : H + 1], full[:, H + 1 :]
    C = excitation.damping_matrix
    C = C.toarray() if hasattr(C, "toarray") else np.asarray(C)
    k2 = np.arange(1, H + 1) ** 2
    dissipation = np.sum(k2 * (np.einsum("ik,ij,jk->k", a, C, a) + np.einsum("ik,ij,jk->k", b, C, b)))
    pattern = excitation.force.pattern(system.n_dofs)
    work = abs(pattern @ (a[:, 0] - 1j * b[:, 0]))
    return float(np.sqrt(lam) * dissipation / work) if work > 0 else np.inf


def nnm_backbone(
    excitation: Excitation,
    mode: int,
    harmonics: int,
    settings: ANMSettings,
    max_truncation: float,
    force_limit: float,
    start_amplitude: float = 0.05,
    start_tolerance: float = 1e-13,
):
    """The regularized NNM ``mode`` from near rest until the required force exceeds ``force_limit``.

    ``start_tolerance``: relative residual of the start point (``hbm.start_tolerance``: above the round-off floor
    of a fine mesh). Returns the system (cosine basis) and the continued branch.
    """
    system = HarmonicBalanceSystem(excitation.structure, harmonics)
    U0, direction = start_point(system, mode, start_amplitude, start_tolerance)

    def beyond(U, diag):
        return f"required force above {force_limit:g}" if required_force(system, excitation, U) > force_limit else ""

    guard = TruncationGuard(system, beyond, max_truncation, f"NNM{mode} backbone", "forced.max_truncation")
    return system, continue_anm(system, U0, direction, guard, settings, label=f"NNM{mode} backbone")


def predicted_peaks(system, excitation: Excitation, branch, settings: ANMSettings, forces) -> list:
    """Per force level, the backbone orbit whose required force equals it (None where the branch does not reach it).

    The sign change of ``required_force - F`` between two points is bisected on the ANM step between them
    (to 1e-12 of its length), so the predicted orbit is a point of the backbone, not an interpolation.
    Returns ``(frequency Hz, amplitudes max |q_j|, U)`` or None per level.
    """
    U = np.asarray(branch.points)
    required = np.array([required_force(system, excitation, u) for u in U])
    stepper = ANMStepper(settings)
    out = []
    for force in forces:
        crossing = np.flatnonzero((required[:-1] - force) * (required[1:] - force) <= 0)
        if crossing.size == 0:
            out.append(None)
            continue
        i = int(crossing[0])
        path, length = path_between(system, stepper, U, i)
        found = bisect_sign_change(
            lambda a, path=path, force=force: required_force(system, excitation, path(a)) - force,
            0.0,
            length,
            tol=1e-12 * length,
            f_a=required[i] - force,
            f_b=required[i + 1] - force,
        )
        V = path(found.midpoint)
        out.append((float(system.frequency_hz(V)), response_amplitudes(system, V[None])[0], V))
    return out


def locate_peak(system, branch, settings: ANMSettings, dof: int, rel_tol: float = 1e-10):
    """The point of a response where ``max |q_dof|`` is largest, located on the ANM steps around the largest
    stored value: the sign change of its slope along the path (central differences) bisected to ``rel_tol``."""
    U = np.asarray(branch.points)
    amplitude = response_amplitudes(system, U)[:, dof]
    i = int(np.argmax(amplitude))
    stepper = ANMStepper(settings)
    for j in (i - 1, i):
        if not 0 <= j < len(U) - 1:
            continue
        path, length = path_between(system, stepper, U, j)
        h = 1e-7 * length

        def slope(a, path=path, h=h):
            ends = response_amplitudes(system, np.array([path(a - h), path(a + h)]))[:, dof]
            return ends[1] - ends[0]

        low, high = slope(h), slope(length - h)
        if low > 0 >= high:
            found = bisect_sign_change(slope, h, length - h, tol=rel_tol * length, f_a=low, f_b=high)
            return path(found.midpoint)
    return U[i]


def prediction_errors(
    excitations,
    mode: int,
    frequency_window,
    harmonics: int,
    settings: ANMSettings,
    max_truncation: float,
    start_tolerance: float = 1e-13,
) -> dict:
    """The backbone's predicted peak against the located peak of the response, for each excitation.

    ``excitations`` share the structure and differ in damping and force, with ``F`` proportional to the
    damping (Rayleigh coefficients in proportion), so that every prediction is the same backbone orbit. The NNM
    ``mode`` backbone (regularized, cosine basis) is continued once; per excitation its predicted peak
    (:func:`predicted_peaks`) and the response by harmonic balance over ``frequency_window`` (Hz) with its peak
    of the first stop's DOF located on the ANM steps (:func:`locate_peak`). Returns arrays over the
    excitations: ``predicted_frequency``, ``peak_frequency`` (Hz), ``predicted_amplitude``, ``peak_amplitude``
    (points, N) and ``peak_phase_lag`` (degrees, points, N).
    """
    from nnmstop.hbm.forced import ForcedHarmonicBalanceSystem, continue_frequency_response, phase_lags

    first = excitations[0]
    system, backbone = nnm_backbone(
        first, mode, harmonics, settings, max_truncation, 2 * first.force.amplitude, start_tolerance=start_tolerance
    )
    keys = ("predicted_frequency", "predicted_amplitude", "peak_frequency", "peak_amplitude", "peak_phase_lag")
    out = {key: [] for key in keys}
    for excitation in excitations:
        force = excitation.force.amplitude
        (prediction,) = predicted_peaks(system, excitation, backbone, settings, [force])
        if prediction is None:
            raise ValueError(f"the NNM{mode} backbone does not reach the force level {force:g}")
        forced = ForcedHarmonicBalanceSystem(excitation, harmonics)
        branch = continue_frequency_response(forced, frequency_window, settings, max_truncation)
        peak = locate_peak(forced, branch, settings, dof=excitation.structure.stop_dofs[0])
        out["predicted_frequency"].append(prediction[0])
        out["predicted_amplitude"].append(prediction[1])
        out["peak_frequency"].append(forced.frequency_hz(peak))
        out["peak_amplitude"].append(response_amplitudes(forced, peak[None])[0])
        out["peak_phase_lag"].append(np.degrees(phase_lags(forced, peak[None])[0]))
    return {key: np.array(value, dtype=float) for key, value in out.items()}
