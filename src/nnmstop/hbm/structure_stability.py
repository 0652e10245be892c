"""Floquet multipliers of the regularized orbits of a structure with stops (any number of DOF).

The variational equation of ``M q'' + K q + sum_i gap_i f_i(q_i / gap_i) e_i = 0`` along an HBM orbit is
``M dq'' + (K + sum_i k_i(t) e_i e_i^T) dq = 0`` with ``k_i = f_i'`` the regularized contact stiffness
of stop ``i`` on the orbit. Its monodromy matrix is integrated over one period by the fourth-order
Magnus method (two Gauss points and their commutator, one matrix exponential per step), once with
``steps`` and once with ``2 steps`` steps; the difference of the largest multiplier moduli is the
integration error. Method notes: docs/methods/hbm_structure.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from nnmstop import fourier
from nnmstop.fourier import PhaseSynthesis
from nnmstop.models.two_dof import ModelParameters, regularized_contact_stiffness

__all__ = ["StructureStability", "orbit_multipliers", "structure_stability"]

_GAUSS = 0.5 - np.sqrt(3.0) / 6.0, 0.5 + np.sqrt(3.0) / 6.0


def _contact_stiffness(system, x):
    """``k_i(t)`` of every stop at the stop coordinates ``x`` (s, m)."""
    out = np.empty_like(x)
    for i, (alpha, eta) in enumerate(zip(system.alphas, system.etas)):
        out[i] = regularized_contact_stiffness(x[i], ModelParameters(alpha=float(alpha), eta=float(eta)))
    return out


def _constant_part(system):
    """``A0`` of ``A(t) = A0 - sum_i k_i(t) [0; M^-1 e_i] e_i^T`` and the columns ``M^-1 e_i``: one per structure."""
    N = system.n_dofs
    mass, stiffness = system.structure.dense_matrices()
    m_inv = np.linalg.inv(mass)
    A0 = np.zeros((2 * N, 2 * N))
    A0[:N, N:] = np.eye(N)
    A0[N:, :N] = -m_inv @ stiffness
    return A0, m_inv[:, list(system.stop_dofs)]


def orbit_multipliers(system, U, steps: int, constant_part=None) -> np.ndarray:
    """Floquet multipliers of the HBM orbit ``U`` (2N, by decreasing modulus), ``steps`` Magnus steps.

    ``constant_part``: :func:`_constant_part` of the system when the caller already has it.
    """
    N = system.n_dofs
    A0, columns = constant_part if constant_part is not None else _constant_part(system)
    blocks = system.split(U)
    Q = np.stack(blocks[:N])
    omega = float(np.sqrt(blocks[-2]))
    period = 2 * np.pi / omega
    h = period / steps
    # stop coordinates at the two Gauss points of every step, from the Fourier series
    phases = omega * h * (np.arange(steps)[:, None] + np.array(_GAUSS)[None, :])
    cos, sin = fourier.to_cos_sin(Q[list(system.stop_dofs)], system.H)
    q_stop = PhaseSynthesis(phases.ravel(), system.H).values(cos.T, sin.T).T.reshape((-1, *phases.shape))
    x = q_stop / np.asarray(system.gaps)[:, None, None]
    kc = _contact_stiffness(system, x.reshape(len(system.stop_dofs), -1)).reshape(x.shape)
    phi = np.eye(2 * N)
    for n in range(steps):
        A1, A2 = A0.copy(), A0.copy()
        for i, dof in enumerate(system.stop_dofs):
            A1[N:, dof] -= kc[i, n, 0] * columns[:, i]
            A2[N:, dof] -= kc[i, n, 1] * columns[:, i]
        omega_step = 0.5 * h * (A1 + A2) + (np.sqrt(3.0) / 12.0) * h * h * (A2 @ A1 - A1 @ A2)
        phi = expm(omega_step) @ phi
    mu = np.linalg.eigvals(phi)
    return mu[np.argsort(-np.abs(mu), kind="stable")]


@dataclass
class StructureStability:
    """Floquet verdicts of the orbits of a branch (arrays on ``point``)."""

    multipliers: np.ndarray  # (points, 2N) complex, by decreasing modulus
    error: np.ndarray  # |max|mu|(steps) - max|mu|(2 steps)|
    tolerance: float

    @property
    def max_multiplier(self) -> np.ndarray:
        return np.abs(self.multipliers[:, 0])

    @property
    def stable(self) -> np.ndarray:
        return self.max_multiplier <= 1.0 + self.tolerance

    @property
    def resolved(self) -> np.ndarray:
        """Where the margin to the threshold exceeds twice the integration error."""
        return np.abs(self.max_multiplier - 1.0 - self.tolerance) > 2.0 * self.error

    def data_vars(self) -> dict:
        one = {"units": "1"}
        dims = ("point", "multiplier")
        return {
            "multiplier_real": (
                dims,
                self.multipliers.real,
                {"long_name": "real part of the Floquet multipliers", **one},
            ),
            "multiplier_imag": (
                dims,
                self.multipliers.imag,
                {"long_name": "imaginary part of the Floquet multipliers", **one},
            ),
            "max_multiplier": (
                "point",
                self.max_multiplier,
                {"long_name": "largest modulus of the Floquet multipliers", **one},
            ),
            "stable": (
                "point",
                self.stable.astype(np.int8),
                {
                    "long_name": "1 where the orbit is stable (largest multiplier modulus within the tolerance of 1)",
                    "flag_values": np.array([0, 1], dtype=np.int8),
                    "flag_meanings": "unstable stable",
                    **one,
                    "tolerance": self.tolerance,
                },
            ),
            "stability_error": (
                "point",
                self.error,
                {"long_name": "change of the largest multiplier modulus when the Magnus steps are doubled", **one},
            ),
            "stability_resolved": (
                "point",
                self.resolved.astype(np.int8),
                {
                    "long_name": "1 where the verdict's margin exceeds twice the integration error",
                    "flag_values": np.array([0, 1], dtype=np.int8),
                    "flag_meanings": "unresolved resolved",
                    **one,
                },
            ),
        }


def structure_stability(system, U_array, steps: int = 256, tolerance: float = 1e-4) -> StructureStability:
    """Floquet multipliers of every orbit of ``U_array`` with their integration error.

    ``tolerance``: an orbit is stable when its largest multiplier modulus is at most ``1 + tolerance``.
    The trivial pair of a conservative system is a Jordan block at +1: an error ``e`` of the orbit or of the
    integration splits it by about ``sqrt(e)``, so the tolerance must exceed the square root of the orbit's
    residual (``time_residual`` of the dataset).
    """
    if steps < 4:
        raise ValueError(f"steps must be >= 4, got {steps!r}")
    if not tolerance > 0:
        raise ValueError(f"tolerance must be > 0, got {tolerance!r}")
    mu, error = [], []
    constant_part = _constant_part(system)
    for U in np.atleast_2d(U_array):
        coarse = orbit_multipliers(system, U, steps, constant_part)
        fine = orbit_multipliers(system, U, 2 * steps, constant_part)
        mu.append(fine)
        error.append(abs(abs(fine[0]) - abs(coarse[0])))
    return StructureStability(np.array(mu), np.array(error), tolerance)
