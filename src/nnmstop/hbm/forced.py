r"""Harmonic balance of the forced, damped structure: the regularized frequency response.

``M q'' + C q' + K q + sum_i gap_i A_i^T f_i = F cos(Omega t) b`` balanced on ``H`` harmonics of
``theta = Omega t`` in the full basis. :class:`ForcedHarmonicBalanceSystem` is the NNM system
(:class:`~nnmstop.hbm.system.HarmonicBalanceSystem`, same unknown layout, same recast of the contact law,
same Jacobian, same ANM series products) with three changes:

* the velocity term of the full basis is the damping, ``Omega C D q``, where the NNM system has the
  unfolding term ``nu M D q``: the slot ``nu`` of the unknowns holds ``Omega``;
* the force ``F b`` enters the first cosine coefficients (the force fixes the phase: no phase condition);
* the closing equation is ``lam - Omega**2 = 0`` (quadratic, so the ANM applies as it is), where the NNM
  system has the phase condition.

``Omega`` is the continuation parameter: :func:`continue_frequency_response` starts from the linear
response at the lower end of a frequency range (regularized contact stiffness ``eta`` near rest) and
follows the curve by the ANM through its folds until it leaves the range, under the truncation guard
of the NNMs. Method notes: docs/forced.md.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from nnmstop import fourier
from nnmstop.continuation.anm import ANMSettings, continue_anm
from nnmstop.continuation.core import Branch, ContinuationStats, newton_correct
from nnmstop.floquet import GAUSS, check_power_of_two, magnus_monodromy, match_nearest
from nnmstop.hbm.stages import TruncationGuard
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.excitation import Excitation, linear_response

__all__ = [
    "ForcedHarmonicBalanceSystem",
    "forced_start_point",
    "continue_frequency_response",
    "series_extremes",
    "response_amplitudes",
    "phase_lags",
    "forced_multipliers",
    "stop_coordinates_at_nodes",
    "ForcedLinearization",
]

# Entries of the batched generator arrays per chunk of orbits (bounded memory: 32 MB an array).
_CHUNK_ENTRIES = 2**22


class ForcedHarmonicBalanceSystem(HarmonicBalanceSystem):
    """Balanced system of the periodic responses of period ``2 pi / Omega`` to the harmonic force.

    Unknowns ``U = [q_1..q_N, f_1..f_s, z_1..z_s, lam, Omega]`` (full basis, ``lam = Omega**2``);
    ``n_equations = n_unknowns - 1``.

    Parameters
    ----------
    excitation : Excitation
        Structure, damping and force.
    harmonics, time_samples, linear_algebra
        As for :class:`~nnmstop.hbm.system.HarmonicBalanceSystem`.

    Examples
    --------
    >>> from nnmstop.models.structure import two_dof_structure
    >>> from nnmstop.models.two_dof import ModelParameters
    >>> from nnmstop.models.excitation import Damping, Excitation, HarmonicForce
    >>> structure = two_dof_structure(ModelParameters())
    >>> excitation = Excitation(structure, Damping.from_modal_ratios(structure, [0.01, 0.01]), HarmonicForce(0.05, [1]))
    >>> system = ForcedHarmonicBalanceSystem(excitation, harmonics=5)
    >>> system.n_unknowns, system.n_equations
    (46, 45)
    """

    def __init__(self, excitation: Excitation, harmonics: int, time_samples: int = 0, linear_algebra: str = "auto"):
        if not isinstance(excitation, Excitation):
            raise TypeError(f"excitation must be an Excitation, got {type(excitation).__name__}")
        # no rotation condition: the force fixes the plane of a structure invariant under rotations (turning a
        # response does not give a response), as it fixes the time; the condition would make the system singular
        super().__init__(
            excitation.structure, harmonics, time_samples, basis="full", linear_algebra=linear_algebra, rotation=False
        )
        self.excitation = excitation
        self._set_velocity_matrix(excitation.damping_matrix)
        self.load = excitation.load
        # rows of the first cosine coefficient of every DOF, where F b enters
        self._load_rows = np.arange(self.n_dofs) * self.nc + 1
        self.i_omega = self.i_nu

    def residual(self, U):
        r = super().residual(U)
        r[self._load_rows] -= self.load
        return r

    def _closing_residual(self, Q, lam, nu) -> float:
        return lam - nu * nu

    def _closing_entries(self, Q, lam, nu) -> list:
        row = self.n_equations - 1
        return [(np.array([row, row]), np.array([self.i_lam, self.i_nu]), np.array([1.0, -2.0 * nu]))]

    def series_products(self, series, p: int, cache=None):
        out = super().series_products(series, p, cache)
        if p >= 2:
            omega = np.asarray(series, dtype=float)[1:p, self.i_nu]
            out[-1] = -np.dot(omega, omega[::-1])
        return out

    def _other_forces_at_stops(self, U, t, qdot):
        """Damping and the external force on the stop DOFs, at the sampled times ``t`` of every orbit."""
        omega = self.split(U)[-1]
        damping = (self._velocity @ qdot)[self._stop_rows]
        load = self.load[self._stop_rows]
        return damping - np.multiply.outer(load, np.cos(omega[:, None] * t)).reshape(damping.shape)

    def omega(self, U):
        """``Omega``, the angular frequency of the force (rad per unit time)."""
        return self.split(U)[-1]

    def frequency_hz(self, U):
        return self.split(U)[-1] / (2 * np.pi)

    def linear_guess(self, omega: float):
        """Unknowns of the linear response at ``omega`` with each stop's near-rest stiffness ``eta_i``.

        ``f_c = eta_c x_c`` and each stop's ``z`` balanced exactly (:meth:`linear_mode_guess`): exact for the
        linear structure, the first guess of Newton for the regularized one.
        """
        if self._one_dof_stops:
            extra = np.zeros((self.n_dofs, self.n_dofs))
            extra[self.stop_dofs, self.stop_dofs] = self.etas
        else:
            extra = self.contact.stiffness_matrix([stop.stiffness_at_rest for stop in self.structure.stops])
        amplitude = linear_response(self.excitation, omega, extra)
        Q = np.zeros((self.n_dofs, self.nc))
        Q[:, 1], Q[:, self.H + 1] = amplitude.real, -amplitude.imag
        X = self.stop_coordinates(Q)
        F = self._component_etas[:, None] * X
        G = F / self._component_alphas[:, None] - X
        g_t = self.to_time(G)
        Z = self._gap_terms(self.to_coefficients(g_t * g_t), G)
        return self.pack(*Q, *F, *Z, omega * omega, omega)


def forced_start_point(system: ForcedHarmonicBalanceSystem, frequency: float):
    """A point of the response at ``frequency`` (Hz) from the linear response, and the direction of growing
    ``Omega``: the linear guess corrected by Newton with ``Omega`` held fixed."""
    if not (np.isfinite(frequency) and frequency > 0):
        raise ValueError(f"start frequency must be finite and > 0 Hz, got {frequency!r}")
    U0 = system.linear_guess(2 * np.pi * frequency)
    direction = np.zeros(system.n_unknowns)
    direction[system.i_nu] = 1.0
    # below the ANM's series tolerance by far; the round-off floor of a large (sparse) system is near 1e-12
    U0, _ = newton_correct(system, U0, direction, ContinuationStats(), tol=1e-11)
    return U0, direction


def continue_frequency_response(
    system: ForcedHarmonicBalanceSystem,
    frequency_range,
    settings: ANMSettings,
    max_truncation: float,
    label: str = "forced response",
    setting: str = "forced.max_truncation",
) -> Branch:
    """The frequency response over ``frequency_range = (low, high)`` Hz by the ANM, through its folds.

    Starts at ``low`` and ends at the first point outside the range (``end_reason`` says which side);
    :class:`~nnmstop.hbm.stages.TruncationGuard` refuses orbits the harmonics do not resolve.
    """
    low, high = (float(v) for v in frequency_range)
    if not (0 < low < high):
        raise ValueError(f"frequency range must satisfy 0 < low < high (Hz), got [{low!r}, {high!r}]")
    U0, direction = forced_start_point(system, low)

    def outside(U, diag):
        f = diag["frequency"]
        if f > high:
            return f"frequency above {high:g} Hz"
        return f"frequency below {low:g} Hz" if f < low * (1 - 1e-12) else ""

    stop = TruncationGuard(system, outside, max_truncation, label, setting)
    return continue_anm(system, U0, direction, stop, settings, label=label)


def series_extremes(c, harmonics: int, samples: int = 0):
    """Smallest and largest value over the period of the Fourier series ``c`` (last axis, full layout).

    The extreme samples on ``max(16 H, 256)`` phases are refined by Newton on the derivative (closed form), so
    the values are exact to round-off (where an extremum is simple).
    """
    c = fourier.to_full(np.asarray(c, dtype=float), harmonics)
    H = int(harmonics)
    m = samples or max(16 * H, 256)
    values = fourier.to_time(c, H, m)
    k = np.arange(1, H + 1)
    a, b = c[..., 1 : H + 1], c[..., H + 1 :]
    out = []
    for pick in (np.argmin, np.argmax):
        theta = 2 * np.pi * pick(values, axis=-1) / m
        for _ in range(6):
            kt = np.multiply.outer(theta, k)
            d1 = np.sum(k * (-a * np.sin(kt) + b * np.cos(kt)), axis=-1)
            d2 = np.sum(-k * k * (a * np.cos(kt) + b * np.sin(kt)), axis=-1)
            theta = theta - np.where(d2 != 0, d1 / np.where(d2 != 0, d2, 1.0), 0.0)
        kt = np.multiply.outer(theta, k)
        out.append(c[..., 0] + np.sum(a * np.cos(kt) + b * np.sin(kt), axis=-1))
    return out[0], out[1]


def response_amplitudes(system: HarmonicBalanceSystem, U_array) -> np.ndarray:
    """``max |q_j|`` over the period of every DOF of every orbit, shape (points, N)."""
    Q = np.asarray(U_array, dtype=float)[:, : system.n_dofs * system.nc].reshape(-1, system.n_dofs, system.nc)
    low, high = series_extremes(Q, system.H)
    return np.maximum(-low, high)


def phase_lags(system: HarmonicBalanceSystem, U_array) -> np.ndarray:
    """Lag (radians, in ``[0, 2 pi)``) of the fundamental of every DOF behind the force ``cos(Omega t)``.

    ``q_j ~ A cos(Omega t - phi_j)``, so ``phi_j = atan2(q_s^1, q_c^1)``: ``pi / 2`` at phase resonance.
    Shape (points, N).
    """
    Q = np.asarray(U_array, dtype=float)[:, : system.n_dofs * system.nc].reshape(-1, system.n_dofs, system.nc)
    return np.mod(np.arctan2(Q[..., system.H + 1], Q[..., 1]), 2 * np.pi)


def _contact_stiffness(system: HarmonicBalanceSystem, x):
    """The stops' Jacobian entries (pairs of :meth:`~nnmstop.models.contact.StopSet.pairs`; ``f_i'(x_i)`` per stop
    of one coordinate) at the scaled coordinates ``x`` (m, ...)."""
    return system.contact.pair_slopes(x)


def stop_coordinates_at_nodes(system: HarmonicBalanceSystem, U_array, steps: int) -> np.ndarray:
    """``x_i`` of every stop at the two Gauss nodes of each of ``steps`` uniform steps over the period.

    The nodes of one kind (first or second of every step) are a uniform grid of ``steps`` phases
    ``2 pi (j + g) / steps``; on such a grid the series ``sum_k d_k exp(i k theta)`` equals the FFT of its
    coefficients shifted by ``exp(2 pi i k g / steps)`` and folded modulo ``steps`` (exact for any ``H``, no
    aliasing error). Returns shape (s, points, steps, 2).
    """
    U = np.atleast_2d(np.asarray(U_array, dtype=float))
    N, nc, H = system.n_dofs, system.nc, system.H
    Q = U[:, : N * nc].reshape(len(U), N, nc)
    X = fourier.to_full(system.stop_coordinates(np.moveaxis(Q, 0, 1)), H)  # (s, points, 2H + 1)
    k = np.arange(1, H + 1)
    d = X[..., 1 : H + 1] - 1j * X[..., H + 1 :]
    out = np.empty(X.shape[:2] + (steps, 2))
    for node, fraction in enumerate(GAUSS):
        shifted = d * np.exp(2j * np.pi * k * fraction / steps)
        folded = np.zeros(X.shape[:2] + (steps,), dtype=complex)
        for start in range(0, H, steps):  # within a block of ``steps`` harmonics the folded indices are distinct
            block = slice(start, start + steps)
            folded[..., k[block] % steps] += shifted[..., block]
        out[..., node] = X[..., :1] + steps * np.fft.ifft(folded, axis=-1).real
    return out


class ForcedLinearization:
    """The variational equation ``M dq'' + C dq' + (K + sum_i A_i^T J_i(t) A_i) dq = 0`` of a forced system.

    ``J_i`` is the Jacobian of stop ``i``'s regularized law on the orbit (``k_i e_i e_i^T`` for a stop on one
    DOF). :meth:`monodromy` gives the monodromy matrices over ``T = 2 pi / Omega`` by fourth-order Magnus steps
    (:func:`nnmstop.floquet.magnus_monodromy`), the generator at the Gauss nodes from
    :func:`stop_coordinates_at_nodes`.
    """

    def __init__(self, system: ForcedHarmonicBalanceSystem):
        mass, stiffness = system.structure.dense_matrices()
        damping = system._velocity.toarray()
        # Scaled modal coordinates q = Phi Omega^-1 s_1, qdot = Phi s_2 (Phi^T M Phi = I): a similarity, so the
        # multipliers are those of (q, qdot), but the generator's norm is of the order of the highest
        # frequency instead of its square (fewer squarings in each step's exponential; a mesh's fast modes).
        omega2, shapes = scipy.linalg.eigh(stiffness, mass)
        scale = np.where(omega2 > 0, np.sqrt(np.abs(omega2)), 1.0)
        modal_damping = shapes.T @ damping @ shapes
        self.system = system
        self.A0 = np.block([[np.zeros_like(modal_damping), np.diag(scale)], [-np.diag(omega2 / scale), -modal_damping]])
        # the stop stiffness k_i acts as -k_i e_d e_d^T on q: in (s_1, s_2) as -phi_d phi_d^T / scale_col; a pair
        # (a, b) of a stop's components as -J_ab (A_a Phi)^T (A_b Phi) / scale_col
        contact = system.contact
        coordinates = shapes[contact.first_dofs] if contact.grounded else contact.matrix() @ shapes  # (m, N)
        first = [a for _, a, _ in contact.pairs()]
        second = [b for _, _, b in contact.pairs()]
        self.rows = coordinates[first].T  # (N, P): phi_d of each stop DOF
        self.cols = coordinates[second] / scale  # (P, N)

    def monodromy(self, U_array, steps: int) -> np.ndarray:
        """Monodromy matrices (points, 2N, 2N) of the orbits ``U_array`` with ``steps`` Magnus steps."""
        U = np.atleast_2d(np.asarray(U_array, dtype=float))
        system, n = self.system, self.A0.shape[0]
        N = system.n_dofs
        out = np.empty((len(U), n, n))
        per_chunk = max(1, _CHUNK_ENTRIES // (2 * steps * n * n))
        for start in range(0, len(U), per_chunk):
            chunk = U[start : start + per_chunk]
            stiff = _contact_stiffness(system, stop_coordinates_at_nodes(system, chunk, steps))  # (s, p, steps, 2)
            A = np.broadcast_to(self.A0, stiff.shape[1:] + self.A0.shape).copy()
            for i in range(self.rows.shape[1]):
                A[..., N:, :N] -= stiff[i][..., None, None] * np.outer(self.rows[:, i], self.cols[i])
            period = 2 * np.pi / chunk[:, system.i_omega]
            out[start : start + len(chunk)] = magnus_monodromy(A, (period / steps)[:, None])
        return out

    def multipliers(self, U_array, steps: int) -> np.ndarray:
        """Floquet multipliers (points, 2N) by decreasing modulus, with ``steps`` Magnus steps."""
        mu = np.linalg.eigvals(self.monodromy(U_array, steps))
        return np.take_along_axis(mu, np.argsort(-np.abs(mu), axis=-1, kind="stable"), axis=-1)


def forced_multipliers(
    system: ForcedHarmonicBalanceSystem, U_array, steps: int = 128, max_steps: int = 2048, tol: float = 1e-8
):
    """Floquet multipliers of the forced responses ``U_array`` (points, n_unknowns), by decreasing modulus.

    The damped variational equation has no trivial multiplier (:class:`ForcedLinearization`). Each orbit with
    ``steps`` and ``2 steps`` Magnus steps, doubled where the multipliers moved by more than ``tol`` (relative to
    ``max(1, |mu|)``), up to ``max_steps``. Returns the multipliers (points, 2N) and the error estimates (points,):
    the largest change of a multiplier between the last two step counts.
    """
    check_power_of_two("steps", steps, 16)
    check_power_of_two("max_steps", max_steps, 32)
    linearization = ForcedLinearization(system)
    U = np.atleast_2d(np.asarray(U_array, dtype=float))
    coarse = linearization.multipliers(U, steps)
    multipliers, errors = coarse.copy(), np.full(len(U), np.inf)
    todo, n = np.arange(len(U)), steps
    while len(todo) and 2 * n <= max_steps:
        fine = linearization.multipliers(U[todo], 2 * n)
        errors[todo] = np.abs(fine - match_nearest(fine, coarse)).max(axis=-1)
        multipliers[todo] = fine
        again = errors[todo] > tol * np.maximum(1.0, np.abs(fine[:, 0]))
        todo, coarse, n = todo[again], fine[again], 2 * n
    return multipliers, errors
