"""The variational equation of a structure with stops along its HBM orbits, for the stability methods.

A perturbation ``dq`` of an orbit of ``M q'' + K q + sum_i gap_i A_i^T f_i(A_i q / gap_i) = 0`` obeys
``M dq'' + (K + sum_i A_i^T J_i(t) A_i) dq = 0``, ``J_i = df_i/dx (x_i(t))`` the Jacobian of stop ``i``'s
regularized law along the orbit (:meth:`nnmstop.models.contact.Stop.jacobian`; a number ``k_i`` for a stop with
one coordinate, ``A_i = e_{d_i}`` for a stop on one DOF). In mass-normalized coordinates ``z = L^T dq``
(``M = L L^T``) it reads ``z'' + B(t) z = 0`` with the symmetric ``B = B_0 + sum_(a, b) J_ab w_a w_b^T`` over
the pairs of components of each stop, ``B_0 = L^-1 K L^-T``, ``w_a = L^-1 A_a^T``: the form every method here
works in (:mod:`nnmstop.hbm.monodromy`,
:mod:`nnmstop.hbm.shooting_refinement`, :mod:`nnmstop.hbm.hill`). Also the symmetry tests of orbits
(time reversal, half-wave symmetry) that decide which shortcuts apply. Method notes:
``docs/methods/monodromy.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

__all__ = [
    "Linearization",
    "stop_coefficients",
    "dof_coefficients",
    "is_reversible",
    "halfwave_symmetric",
    "is_halfwave_symmetric",
    "check_unknowns",
    "REVERSIBLE_TOL",
    "HALFWAVE_TOL",
]

# Relative size of sine coefficients below which a full-basis orbit is taken as time-reversible.
REVERSIBLE_TOL = 1e-10
# Relative size of even harmonics below which an orbit is taken as half-wave symmetric.
HALFWAVE_TOL = 1e-7


@dataclass(frozen=True, eq=False)
class Linearization:
    """The constant parts of the variational equation of a structure, mass-normalized.

    Attributes
    ----------
    n_dofs : int
    mass_factor : ndarray, shape (N, N)
        Lower Cholesky factor ``L`` of the mass matrix, ``z = L^T dq``.
    stiffness : ndarray, shape (N, N)
        ``B_0 = L^-1 K L^-T`` (symmetric).
    stop_vectors : ndarray, shape (m, N)
        ``w_a = L^-1 A_a^T`` of every stop component (``L^-1 e_{d_i}`` for a stop on one DOF).
    contact : StopSet
        The stops (:class:`~nnmstop.models.contact.StopSet`): their laws' Jacobians at the scaled coordinates.
    pairs : tuple of (int, int, int)
        ``(stop, a, b)``: the component pairs of the stops' Jacobians (``(i, i, i)`` for stops of one component).
    """

    n_dofs: int
    mass_factor: np.ndarray
    stiffness: np.ndarray
    stop_vectors: np.ndarray
    contact: object
    pairs: tuple

    @classmethod
    def of(cls, system) -> Linearization:
        """The linearization of ``system`` (a :class:`~nnmstop.hbm.system.HarmonicBalanceSystem`)."""
        mass, stiffness = system.structure.dense_matrices()
        L = np.linalg.cholesky(mass)
        half = scipy.linalg.solve_triangular(L, stiffness, lower=True)
        B0 = scipy.linalg.solve_triangular(L, half.T, lower=True)
        contact = system.structure.contact
        if contact.grounded:
            unit = np.zeros((system.n_dofs, contact.n_components))
            unit[contact.first_dofs, np.arange(contact.n_components)] = 1.0
        else:
            unit = contact.matrix().T
        w = scipy.linalg.solve_triangular(L, unit, lower=True).T
        return cls(system.n_dofs, L, 0.5 * (B0 + B0.T), w, contact, tuple(contact.pairs()))

    @property
    def n_stops(self) -> int:
        return len(self.contact)

    @property
    def stop_outer(self):
        """``w_a w_b^T`` of every pair of :attr:`pairs`, (P, N, N) (``w_i w_i^T`` per stop of one component)."""
        a = np.array([p[1] for p in self.pairs], dtype=int)
        b = np.array([p[2] for p in self.pairs], dtype=int)
        return self.stop_vectors[a][:, :, None] * self.stop_vectors[b][:, None, :]

    @property
    def outer_bound(self):
        """``|w_a|_1 |w_b|`` of every pair, (P, N): row sums of ``|w_a w_b^T|`` per unit slope."""
        a = np.array([p[1] for p in self.pairs], dtype=int)
        b = np.array([p[2] for p in self.pairs], dtype=int)
        w = np.abs(self.stop_vectors)
        return w[a].sum(axis=1)[:, None] * w[b]

    def contact_stiffness(self, x):
        """``J_ab`` of every pair at the stops' scaled coordinates ``x`` (m, ...), shape (P, ...)
        (``k_i = f_i'(x_i)`` per stop of one component)."""
        return self.contact.pair_slopes(np.asarray(x, dtype=float))

    def stiffness_at(self, k):
        """``B = B_0 + sum_p k_p w_a w_b^T`` for pair slopes ``k`` (P, ...): shape ``(..., N, N)``."""
        k = np.asarray(k, dtype=float)
        return self.stiffness + np.tensordot(np.moveaxis(k, 0, -1), self.stop_outer, axes=(-1, 0))

    def to_physical(self, matrices):
        """State-transition matrices from ``(z, z')`` to ``(dq, dq')`` coordinates (``dq = L^-T z``)."""
        N = self.n_dofs
        S = np.zeros((2 * N, 2 * N))
        S[:N, :N] = S[N:, N:] = scipy.linalg.solve_triangular(self.mass_factor, np.eye(N), lower=True).T
        S_inv = np.zeros_like(S)
        S_inv[:N, :N] = S_inv[N:, N:] = self.mass_factor.T
        return S @ matrices @ S_inv


def dof_coefficients(system, U_array):
    """Full-layout coefficients of every degree of freedom, shape (n, N, 2H+1)."""
    parts = system.split(np.asarray(U_array, dtype=float))
    return system.to_full(np.stack(parts[: system.n_dofs], axis=-2))


def stop_coefficients(system, U_array):
    """Full-layout coefficients of each stop component's scaled coordinate ``x_c = A_c q / gap_c``
    (``q_{d_i} / gap_i`` for a stop on one DOF), shape (n, m, 2H+1)."""
    q = dof_coefficients(system, U_array)
    return np.moveaxis(system.stop_coordinates(np.moveaxis(q, 1, 0)), 0, 1)


def check_unknowns(system, U):
    """``U`` as one finite unknown vector of ``system`` with ``omega**2 > 0`` (ValueError otherwise)."""
    U = np.asarray(U, dtype=float)
    if U.shape != (system.n_unknowns,):
        raise ValueError(
            f"U must be one unknown vector of length {system.n_unknowns} for this system, got shape {U.shape}"
        )
    if not np.all(np.isfinite(U)):
        raise ValueError("U must be finite")
    lam = system.split(U)[-2]
    if not lam > 0:
        raise ValueError(f"omega**2 must be > 0 on a periodic orbit, got {lam!r}")
    return U


def is_reversible(system, U) -> bool:
    """Whether an orbit is even in time (no sine content in any degree of freedom).

    Always true in the cosine basis; in the full basis, true when the sine coefficients are below
    :data:`REVERSIBLE_TOL` of the largest coefficient.
    """
    if not system.full:
        return True
    q = dof_coefficients(system, check_unknowns(system, U)[None])[0]
    scale = max(float(np.abs(q).max()), 1e-300)
    return bool(np.abs(q[:, system.H + 1 :]).max() <= REVERSIBLE_TOL * scale)


def halfwave_symmetric(system, U_array) -> np.ndarray:
    """Whether each orbit has the half-wave symmetry ``q(t + T/2) = -q(t)`` (rows of ``U_array``).

    True when the even harmonics (mean included) of every degree of freedom are below
    :data:`HALFWAVE_TOL` of its largest coefficient. Where the stop forces are odd (every law's
    :attr:`~nnmstop.models.contact.Stop.odd`) the symmetric orbits form an invariant subspace of the HBM
    system; continued branches keep it up to round-off drift (about ``2e-10`` along the paper's H = 100
    NNM1 branch). With a law that is not odd (a one-sided stop) no orbit that touches it has the symmetry, and
    none is taken as having it.
    """
    q = dof_coefficients(system, U_array)
    if not system.contact.odd:
        return np.zeros(len(q), dtype=bool)
    H = system.H
    even = np.r_[0, np.arange(2, H + 1, 2), H + np.arange(2, H + 1, 2)]
    scale = np.maximum(np.abs(q).max(axis=(-2, -1)), 1e-300)
    return np.abs(q[..., even]).max(axis=(-2, -1)) <= HALFWAVE_TOL * scale


def is_halfwave_symmetric(system, U) -> bool:
    """:func:`halfwave_symmetric` of one orbit."""
    return bool(halfwave_symmetric(system, check_unknowns(system, U)[None])[0])
