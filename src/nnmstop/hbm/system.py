r"""Harmonic balance of a structure with bilateral elastic stops (regularized contact).

``M q'' + K q + sum_i gap_i f_i e_{d_i} = 0``, and at each stop ``i``, in its own coordinate
``x_i = q_{d_i} / gap_i``, the quadratic recast of the regularized contact law (Eq. (12) of
the paper)::

    f_i - eta_i x_i - f_i z_i = 0,        z_i = (f_i / alpha_i - x_i)**2

Every field is a truncated Fourier series in ``theta = omega t`` with coefficients
``[c_0, c_c^1..c_c^H, c_s^1..c_s^H]`` (full basis) or the cosine part only. Unknowns
``U = [q_1..q_N, f_1..f_s, z_1..z_s, lam, nu]``, ``lam = omega**2``, ``nu`` the unfolding
coefficient (fictitious damping ``mu M q'``, ``nu = mu omega``, zero on every periodic orbit);
in the full basis a phase condition ``q_{d_1}'(0) = 0`` closes the system. For the paper's
oscillator (:func:`nnmstop.models.structure.two_dof_structure`) ``U`` is ``[x, u, f, z, lam, nu]``;
nothing here depends on which structure it is.
Products are Galerkin projections computed alias-free on ``M > 3H`` samples per period.
The method, the scaling of a stop with a gap other than 1, and the linear algebra (dense LU
for small systems, sparse LU ordered by harmonic for large structures) are described in
docs/methods/hbm_structure.md.
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp
from scipy.linalg import eigh

from nnmstop import fourier
from nnmstop.continuation.linear import BorderedFactorization
from nnmstop.hbm.factorization import Channel, CondensedBorderedLU, SparseBorderedLU, StopCoupling
from nnmstop.hbm.series_cache import SeriesCache
from nnmstop.models.structure import DENSE_EIGEN_LIMIT, Structure, limit_modes
from nnmstop.models.two_dof import ModelParameters

__all__ = ["HarmonicBalanceSystem", "SeriesCache", "DENSE_MAX_UNKNOWNS", "impacts_per_period"]

# Above this many unknowns the "auto" linear algebra is sparse. The sparse LU is already as
# fast from a few hundred unknowns of a chain on (benchmarks/fe_scaling.py); the threshold
# sits above the paper's oscillator (806 unknowns at H = 100, full basis), whose results
# keep the dense LU they were made with.
DENSE_MAX_UNKNOWNS = 1500


def _dense(matrix) -> np.ndarray:
    return matrix.toarray() if sp.issparse(matrix) else np.asarray(matrix, dtype=float)


class HarmonicBalanceSystem:
    """Balanced algebraic system of the regularized NNMs of a structure with ``H`` harmonics.

    Parameters
    ----------
    structure : Structure
        Mass, stiffness and stops (:mod:`nnmstop.models.structure`); the paper's oscillator
        is ``two_dof_structure(params)``.
    harmonics : int
        Number of harmonics ``H`` (>= 1).
    time_samples : int, optional
        Samples per period for products; 0 (default) picks the smallest power of two
        above ``3H``, which makes every product alias-free.
    basis : {"cosine", "full"}
        Cosine series only (orbits symmetric under time reversal) or cosine and sine series
        with the phase condition and the unfolding term.
    linear_algebra : {"auto", "dense", "sparse"}
        Storage of the Jacobian and factorization of the bordered Jacobian; "auto" is sparse
        above :data:`DENSE_MAX_UNKNOWNS` unknowns.
    rotation : bool, optional
        Fix the rotation of a structure invariant under the rotations of a plane
        (:attr:`~nnmstop.models.structure.Structure.rotation_pairs`): the rotation phase condition and its
        unfolding term (below). Default: on for such a structure. Off, the orbits that rotation turns into time
        shifts (the whirling orbits, relative equilibria) are the ones the system can follow; on, the others.
    rotation_angle : float
        Direction (rad, from the first DOF of the reference pair) the rotation phase condition fixes.

    Notes
    -----
    With ``rotation``, the structure's rotations ``q -> exp(phi J) q`` (``J`` the rotation generator) map orbits
    to orbits: without a condition the Jacobian is singular along ``J q`` (and its angular momentum makes one
    equation redundant). The system then gets one more equation, ``-sin(a) q_i(0) + cos(a) q_j(0) = 0`` on
    the reference pair ``(i, j)`` (the first stop's, a circular clearance, or the first pair): the orbit's
    position at ``t = 0`` lies along the direction ``a`` (a section transverse to the rotation generator), and
    one more unknown ``mu``, the coefficient of the circulatory force ``mu M J q`` in the equations of motion,
    zero on every periodic orbit that is not a circle (``docs/methods/circular_clearance.md``).

    Examples
    --------
    >>> from nnmstop.models.two_dof import ModelParameters
    >>> from nnmstop.models.structure import two_dof_structure
    >>> system = HarmonicBalanceSystem(two_dof_structure(ModelParameters()), harmonics=5, basis="full")
    >>> system.n_unknowns, system.n_equations
    (46, 45)
    >>> HarmonicBalanceSystem(two_dof_structure(ModelParameters()), harmonics=5).n_unknowns  # cosine basis
    25
    """

    BASES = ("cosine", "full")
    LINEAR_ALGEBRA = ("auto", "dense", "sparse")

    def __init__(
        self,
        structure,
        harmonics: int,
        time_samples: int = 0,
        basis: str = "cosine",
        linear_algebra: str = "auto",
        rotation: bool | None = None,
        rotation_angle: float = 0.0,
    ):
        if not isinstance(structure, Structure):
            hint = (
                "; for the paper's oscillator pass two_dof_structure(params)"
                if isinstance(structure, ModelParameters)
                else ""
            )
            raise TypeError(f"structure must be a Structure, got {type(structure).__name__}{hint}")
        if not isinstance(harmonics, (int, np.integer)) or isinstance(harmonics, bool) or harmonics < 1:
            raise ValueError(f"harmonics must be an integer >= 1, got {harmonics!r}")
        if basis not in self.BASES:
            raise ValueError(f"basis must be one of {self.BASES}, got {basis!r}")
        if linear_algebra not in self.LINEAR_ALGEBRA:
            raise ValueError(f"linear_algebra must be one of {self.LINEAR_ALGEBRA}, got {linear_algebra!r}")
        if rotation is None:
            rotation = structure.rotation_pairs is not None
        if rotation and structure.rotation_pairs is None:
            raise ValueError(
                "rotation=True needs a structure invariant under rotations (Structure.rotation_pairs), this one "
                "declares none"
            )
        if not np.isfinite(rotation_angle):
            raise ValueError(f"rotation_angle must be finite, got {rotation_angle!r}")
        self.rotation = bool(rotation)
        self.rotation_angle = float(rotation_angle)
        minimum_samples = 3 * harmonics + 1
        if time_samples == 0:
            time_samples = int(2 ** np.ceil(np.log2(minimum_samples)))
        if time_samples < minimum_samples:
            raise ValueError(
                f"time_samples must be 0 (automatic) or >= 3H+1 = {minimum_samples} for alias-free "
                f"products, got {time_samples!r}"
            )
        self.structure = structure
        self.basis = basis
        self.H = int(harmonics)
        self.M = int(time_samples)
        self.nfull = 2 * self.H + 1
        self.full = basis == "full"
        # Coefficients kept per field: all of [x_0, x_c^1..x_c^H, x_s^1..x_s^H], or the
        # cosine part only (orbits symmetric under time reversal, x(-t) = x(t)).
        self.nc = self.nfull if self.full else self.H + 1
        self.k = np.arange(1, self.H + 1, dtype=float)
        nc = self.nc
        self._set_structure(structure)
        N, s, m = self.n_dofs, self.n_stops, self.n_components
        names = [f"q{j}" for j in range(N)] + [f"f{c}" for c in range(m)] + [f"z{i}" for i in range(s)]
        self.field_names = tuple(names)
        self.slices = {name: slice(i * nc, (i + 1) * nc) for i, name in enumerate(names)}
        # aliases: x, f, z of the first stop (x is the block of the first degree of freedom it reads; the first
        # cosine coefficient of its coordinate is the direction in which every branch starts)
        self.slices.update(x=self.slices[f"q{self.phase_dof}"], f=self.slices["f0"], z=self.slices["z0"])
        self.n_fields = N + m + s
        self.i_lam = self.n_fields * nc
        # The unfolding term and the phase condition exist only in the full basis: in the
        # cosine basis the phase is fixed by the symmetry and nu D x (a sine series) has
        # no component on the balanced cosine equations.
        self.i_nu = self.i_lam + 1 if self.full else None
        # the rotation's unfolding coefficient mu and its phase condition come after the time's (nu, phase)
        self.i_mu = self.i_lam + 1 + self.full if self.rotation else None
        self.n_unknowns = self.i_lam + 1 + self.full + self.rotation
        self.n_equations = self.i_lam + self.full + self.rotation
        self.i_phase_row = self.i_lam if self.full else None
        self.i_rotation_row = self.i_lam + self.full if self.rotation else None
        if linear_algebra == "auto":
            linear_algebra = "sparse" if self.n_unknowns > DENSE_MAX_UNKNOWNS else "dense"
        self.linear_algebra = linear_algebra
        self._d2 = fourier.second_derivative_factors(self.H, basis)
        # d/dtheta of full-layout coefficients as one gather and one product (fourier.derivative's numbers)
        self._derivative_order = np.concatenate([[0], np.arange(self.H + 1, 2 * self.H + 1), np.arange(1, self.H + 1)])
        self._derivative_factors = np.concatenate([[0.0], self.k, -self.k])

    def _set_structure(self, structure: Structure):
        """Matrices (CSR) and the stops' laws and coordinates (:class:`~nnmstop.models.contact.StopSet`)."""
        self.n_dofs = structure.n_dofs
        self.n_stops = len(structure.stops)
        self._mass = sp.csr_matrix(structure.mass, dtype=float)
        self._stiffness = sp.csr_matrix(structure.stiffness, dtype=float)
        for matrix in (self._mass, self._stiffness):
            matrix.eliminate_zeros()
            matrix.sort_indices()
        self.stop_dofs = np.array(structure.stop_dofs, dtype=int)  # the first DOF of each stop
        self.phase_dof = int(self.stop_dofs[0])
        stops = structure.stops
        self.gaps = np.array([float(stop.gap) for stop in stops])
        self.alphas = np.array([float(stop.stiffness) for stop in stops])
        self.etas = np.array([float(stop.eta) for stop in stops])
        # the laws: per component (a circular clearance has two) its coordinate, gap, alpha, eta and the
        # coefficient of f z in its force equation; per stop the family of its z equation
        self.contact = contact = structure.contact
        self.n_components = contact.n_components
        self._component_gaps, self._component_alphas = contact.gaps, contact.alphas
        self._component_etas = contact.etas
        self._coefficients = np.array([stops[i].recast.coefficient for i in contact.owner])
        self._squared = np.array([stop.recast.family == "squared_gap" for stop in stops])
        # every stop one component with z = g**2: the paper's and the bilateral structures' arrays and sums
        self._bilateral = bool(self._squared.all()) and self.n_components == self.n_stops
        # every stop reads one DOF of its own with sign +1 (the fast path of eta on the diagonal near rest; a
        # circular clearance reads two)
        self._one_dof_stops = (
            contact.grounded and self.n_components == self.n_stops and len(set(self.stop_dofs.tolist())) == self.n_stops
        )
        # DOFs whose equations hold a contact force, in the order the stops read them
        self._stop_rows = np.array(list(dict.fromkeys(d for stop in stops for d in stop.dofs)), dtype=int)
        # the phase condition and the amplitude of the start: the first coordinate of the first stop
        self._reference_terms = list(contact.terms[0])
        # the rotation's circulatory unfolding M J (zero without rotation: nothing added to the pattern)
        self._circulatory = sp.csr_matrix(self._mass.shape)
        if structure.rotation_pairs is not None:
            self._rotation_pair = self._reference_pair(structure)
        if self.rotation:
            self._circulatory = sp.csr_matrix(self._mass @ structure.rotation_generator)
            self._circulatory.eliminate_zeros()
        # stored entries of M, K (and M J) together: the DOF pairs (i, j) of the linear blocks
        pattern = sp.coo_matrix(abs(self._mass) + abs(self._stiffness) + abs(self._circulatory))
        self._pair_rows, self._pair_cols = pattern.row.astype(int), pattern.col.astype(int)
        self._pair_mass = np.asarray(self._mass[self._pair_rows, self._pair_cols]).ravel()
        self._pair_stiffness = np.asarray(self._stiffness[self._pair_rows, self._pair_cols]).ravel()
        self._pair_circulatory = np.asarray(self._circulatory[self._pair_rows, self._pair_cols]).ravel()
        self._set_velocity_matrix(self._mass)

    @staticmethod
    def _reference_pair(structure: Structure) -> tuple:
        """The pair of DOFs of the rotation phase condition: the first stop's when it is a circular clearance on a
        rotation pair (in the order the stop reads them), else the first rotation pair."""
        first = structure.stops[0]
        pairs = {tuple(sorted(p)) for p in structure.rotation_pairs}
        if first.kind == "circular" and tuple(sorted(first.dofs)) in pairs:
            return tuple(first.dofs)
        return tuple(structure.rotation_pairs[0])

    def _set_velocity_matrix(self, matrix):
        """The matrix ``V`` of the full basis' velocity term ``nu V D q``: ``M`` (unfolding), ``C`` (forced, damped)."""
        self._velocity = sp.csr_matrix(matrix, dtype=float)
        self._pair_velocity = np.asarray(self._velocity[self._pair_rows, self._pair_cols]).ravel()

    # ------------------------------------------------------------------ Fourier helpers

    def to_full(self, c):
        """Coefficients in the full layout ``[c_0, c_c^1..c_c^H, c_s^1..c_s^H]`` (:func:`nnmstop.fourier.to_full`)."""
        return fourier.to_full(c, self.H)

    def second_derivative(self, c):
        """``d^2/dtheta^2`` of kept-basis coefficient vectors (last axis)."""
        return np.asarray(c, dtype=float) * self._d2

    def derivative(self, c):
        """``d/dtheta`` of coefficient vectors, returned in the full layout (:func:`nnmstop.fourier.derivative`)."""
        return fourier.derivative(c, self.H)

    def to_time(self, c, samples: int | None = None):
        """Time samples on ``samples`` (default ``M``) equispaced phases of one period.

        :func:`nnmstop.fourier.to_time`; ``c`` holds kept-basis or full-layout coefficients on its last axis.
        """
        return fourier.to_time(c, self.H, self.M if samples is None else samples)

    def to_coefficients(self, samples):
        """Galerkin projection of time samples onto the kept basis (first ``H`` harmonics)."""
        return fourier.to_coefficients(samples, self.H)[..., : self.nc]

    def multiplication_matrix(self, c):
        """Matrix of ``w -> [c w]`` (projected product) in the kept basis (:func:`nnmstop.fourier.product_matrix`)."""
        return fourier.product_matrix(c, self.H)[: self.nc, : self.nc]

    # ------------------------------------------------------------------ unknown vector

    def split(self, U):
        """Views ``(q_1, .., q_N, f_1, .., f_s, z_1, .., z_s, lam, nu)`` into an unknown vector (or a stack).

        For the paper's oscillator this is ``(x, u, f, z, lam, nu)``. ``nu`` is zero in the
        cosine basis, which has no unfolding term. The rotation's unfolding coefficient is
        :meth:`rotation_unfolding`.
        """
        U = np.asarray(U)
        nc = self.nc
        nu = U[..., self.i_nu] if self.full else np.zeros(U.shape[:-1])
        blocks = tuple(U[..., b * nc : (b + 1) * nc] for b in range(self.n_fields))
        return blocks + (U[..., self.i_lam], nu)

    def rotation_unfolding(self, U):
        """The coefficient ``mu`` of the rotation's circulatory unfolding term of ``U`` (or a stack); zero without
        rotation."""
        U = np.asarray(U)
        return U[..., self.i_mu] if self.rotation else np.zeros(U.shape[:-1])

    def pack(self, *parts):
        """Unknown vector from its parts ``q_1, .., q_N, f_1, .., f_s, z_1, .., z_s, lam[, nu[, mu]]``."""
        if len(parts) not in (self.n_fields + 1, self.n_fields + 2, self.n_fields + 3):
            raise ValueError(
                f"pack takes {self.n_fields} field blocks, lam and optionally nu and mu; got {len(parts)} parts"
            )
        fields, tail = parts[: self.n_fields], list(parts[self.n_fields :]) + [0.0, 0.0]
        return np.concatenate(
            list(fields) + [[tail[0]]] + ([[tail[1]]] if self.full else []) + ([[tail[2]]] if self.rotation else [])
        )

    def _fields(self, U):
        """Blocks ``Q`` (N, nc), ``F`` (m, nc: one per stop component), ``Z`` (s, nc) and ``lam``, ``nu`` of one
        unknown vector."""
        U = np.asarray(U, dtype=float)
        N, s, m, nc = self.n_dofs, self.n_stops, self.n_components, self.nc
        Q = U[: N * nc].reshape(N, nc)
        F = U[N * nc : (N + m) * nc].reshape(m, nc)
        Z = U[(N + m) * nc : (N + m + s) * nc].reshape(s, nc)
        return Q, F, Z, U[self.i_lam], (U[self.i_nu] if self.full else 0.0)

    def stop_coordinates(self, Q):
        """Scaled coordinates ``x_c = A_c q / gap_c`` of every stop component (``q_{d_i} / gap_i`` for a stop on one
        DOF), from DOF blocks (N, ...) -> (m, ...)."""
        return self.contact.coordinates(Q)

    def reference_coordinate(self, Q):
        """The physical coordinate ``A_0 q`` of the first stop's first component (DOFs on the first axis): the
        coordinate of the phase condition and of the start amplitude."""
        Q = np.asarray(Q)
        (dof, sign), rest = self._reference_terms[0], self._reference_terms[1:]
        out = Q[dof] if sign == 1 else sign * Q[dof]
        for dof, sign in rest:
            out = out + sign * Q[dof]
        return out

    def reference_amplitude(self, U) -> float:
        """First cosine coefficient of :meth:`reference_coordinate` of the orbit ``U`` (``x_c^1`` for a stop on one
        DOF): it changes sign at an ``n:1`` internal resonance."""
        U = np.asarray(U)
        return self.reference_coordinate(U[: self.n_dofs * self.nc].reshape(self.n_dofs, self.nc)[:, 1])

    def amplitude_direction(self, mode: int | None = None) -> np.ndarray:
        """Unit-coefficient direction of the first cosine coefficient of :meth:`reference_coordinate` (``e`` at
        ``x_c^1`` for a stop on one DOF): the amplitude held fixed at a branch's start, and its initial direction.
        With ``mode``, of the stop coordinate that linear mode is normalized by (:meth:`mode_reference`: the first
        stop's unless the mode does not move it)."""
        component = 0 if mode is None else self.mode_reference(self.linear_modes()[1][:, mode - 1])[0]
        direction = np.zeros(self.n_unknowns)
        for dof, sign in self.contact.terms[component]:
            direction[dof * self.nc + 1] += sign
        return direction

    def _gap_terms(self, squares, G):
        """Per stop the right-hand side of its ``z`` equation: the sum of ``g_c**2`` (``squares``, per component) over
        its components (``squared_gap``), or its ``g`` (``linear_gap``)."""
        if self._bilateral:
            return squares
        out = np.empty((self.n_stops,) + np.shape(G)[1:])
        for i, sl in enumerate(self.contact.components):
            out[i] = squares[sl].sum(axis=0) if self._squared[i] else G[sl.start]
        return out

    # ------------------------------------------------------------------ the system

    def residual(self, U):
        """``S(U) = L(U) + Q(U, U)``, length ``n_equations``.

        A trial point far off the branch (a diverging Newton or series step) may overflow: its
        residual is then non-finite, which every caller takes as a failed correction.
        """
        Q, F, Z, lam, nu = self._fields(U)
        X = self.stop_coordinates(Q)
        G = F / self._component_alphas[:, None] - X
        m = self.n_components
        with np.errstate(over="ignore", invalid="ignore"):
            samples = self.to_time(np.concatenate([F, Z if self._bilateral else Z[self.contact.owner], G]))
            products = self.to_coefficients(np.concatenate([samples[:m] * samples[m : 2 * m], samples[2 * m :] ** 2]))
            r_q = self._mass @ (lam * (Q * self._d2)) + self._stiffness @ Q
            if self.full:
                r_q += self._velocity @ (nu * self.derivative(Q))
            if self.rotation:
                r_q += U[self.i_mu] * (self._circulatory @ Q)
        self.contact.apply(r_q, F)
        # f - eta x + c f z (c = -1 for z = g**2: Eq. (12); c = kappa for the one-sided law's z = g)
        r_f = F - self._component_etas[:, None] * X + self._coefficients[:, None] * products[:m]
        r_z = Z - self._gap_terms(products[m:], G)
        parts = [r_q.ravel(), r_f.ravel(), r_z.ravel()]
        if self.full:
            parts.append([self._closing_residual(Q, lam, nu)])
        if self.rotation:
            parts.append([self._rotation_residual(Q)])
        return np.concatenate(parts)

    def _rotation_weights(self) -> list:
        """``(dof, weight)`` of the rotation phase condition ``-sin(a) q_i(0) + cos(a) q_j(0)`` on the pair."""
        (i, j), a = self._rotation_pair, self.rotation_angle
        return [(i, -np.sin(a)), (j, np.cos(a))]

    def _rotation_residual(self, Q) -> float:
        """The rotation phase condition: the reference pair's position at ``t = 0`` along ``rotation_angle``."""
        cosines = slice(0, self.H + 1)  # q(0) is the sum of the mean and the cosine coefficients
        return sum(weight * Q[dof, cosines].sum() for dof, weight in self._rotation_weights())

    def _closing_residual(self, Q, lam, nu) -> float:
        """Last equation of the full basis: the phase condition ``c_0'(0) = 0`` on the first stop's first coordinate
        (:meth:`reference_coordinate`; ``q_{d_1}'(0) = 0`` for a stop on one DOF)."""
        return np.dot(self.k, self.reference_coordinate(Q[:, self.H + 1 :]))

    def _closing_entries(self, Q, lam, nu) -> list:
        """Jacobian entries of :meth:`_closing_residual` (one group per DOF of the coordinate)."""
        sines = np.arange(self.H + 1, 2 * self.H + 1)
        return [
            (np.full(self.H, self.i_phase_row), dof * self.nc + sines, self.k if sign == 1 else sign * self.k)
            for dof, sign in self._reference_terms
        ]

    def _linear_entries(self, Q, lam, nu, mu=0.0) -> list:
        """``(rows, columns, values)`` of the Jacobian outside the stops' blocks, in groups that never share a
        position: the linear blocks, the stop forces on their DOFs, ``-eta_c x_c`` in the force equations, the
        ``lam`` and ``nu`` columns and the closing row (and with rotation the ``mu`` column, ``mu M J`` in the linear
        blocks and the rotation row). None of them touches a ``z`` row or column."""
        N, nc, H = self.n_dofs, self.nc, self.H
        diagonal = np.arange(nc)
        groups = []
        # linear blocks of each DOF pair (i, j): diag(M_ij lam d2 + K_ij) (+ M_ij nu D1)
        pi, pj, m_ij, k_ij = self._pair_rows, self._pair_cols, self._pair_mass, self._pair_stiffness
        k_ij = k_ij + self._pair_circulatory * mu if self.rotation else k_ij
        groups.append(
            (pi[:, None] * nc + diagonal, pj[:, None] * nc + diagonal, (m_ij * lam)[:, None] * self._d2 + k_ij[:, None])
        )
        if self.full:
            velocity = self._pair_velocity
            inertial = velocity != 0.0
            pi, pj, mn = pi[inertial], pj[inertial], velocity[inertial] * nu
            cos, sin = np.arange(1, H + 1), np.arange(H + 1, 2 * H + 1)
            # D maps the sine coefficient of harmonic k to k times its cosine one, and back with -k
            groups.append((pi[:, None] * nc + cos, pj[:, None] * nc + sin, mn[:, None] * self.k))
            groups.append((pi[:, None] * nc + sin, pj[:, None] * nc + cos, mn[:, None] * -self.k))
        f0 = N * nc
        for c, (terms, gap, eta) in enumerate(zip(self.contact.terms, self._component_gaps, self._component_etas)):
            f_c = f0 + c * nc
            for dof, sign in terms:
                q_d = dof * nc
                groups.append((q_d + diagonal, f_c + diagonal, np.full(nc, gap * sign)))
                groups.append((f_c + diagonal, q_d + diagonal, np.full(nc, (-eta / gap) * sign)))
        q_rows = np.arange(N * nc)
        groups.append((q_rows, np.full(N * nc, self.i_lam), (self._mass @ (Q * self._d2)).ravel()))
        if self.full:
            groups.append((q_rows, np.full(N * nc, self.i_nu), (self._velocity @ self.derivative(Q)).ravel()))
            groups.extend(self._closing_entries(Q, lam, nu))
        if self.rotation:
            groups.append((q_rows, np.full(N * nc, self.i_mu), (self._circulatory @ Q).ravel()))
            cosines = np.arange(self.H + 1)
            for dof, weight in self._rotation_weights():
                row = np.full(self.H + 1, self.i_rotation_row)
                groups.append((row, dof * nc + cosines, np.full(self.H + 1, weight)))
        return groups

    def _jacobian_parts(self, U):
        """The Jacobian's scattered entries (:meth:`_linear_entries`) and, per stop, its blocks in ``f`` and ``z``.

        With ``c`` the coefficient of ``f z`` (:class:`~nnmstop.models.contact.Recast`) a stop's equations hold the
        multiplication matrices ``M_z``, ``M_f``, ``M_g`` of its products in dense blocks: ``(f, f) = I + c M_z``,
        ``(f, z) = c M_f`` per component; its ``z`` rows ``(z, q) = (2 / gap) M_g``, ``(z, f) = -(2 / alpha) M_g``
        (``z = sum g**2``) or ``(z, q) = 1 / gap``, ``(z, f) = -1 / alpha`` (``z = g``), and ``(z, z) = I``
        (:class:`~nnmstop.hbm.factorization.StopCoupling`).
        """
        Q, F, Z, lam, nu = self._fields(U)
        G = F / self._component_alphas[:, None] - self.stop_coordinates(Q)
        N, m, nc = self.n_dofs, self.n_components, self.nc
        couplings = []
        for i, components in enumerate(self.contact.components):
            squared = bool(self._squared[i])
            z = slice((N + m + i) * nc, (N + m + i + 1) * nc)
            Mz = self.multiplication_matrix(Z[i])
            channels = []
            for c in range(components.start, components.stop):
                Mf = self.multiplication_matrix(F[c])
                Mg = self.multiplication_matrix(G[c]) if squared else None
                gap, alpha = self._component_gaps[c], self._component_alphas[c]
                q_factor, f_factor = (2.0 / gap, -2.0 / alpha) if squared else (1.0 / gap, -1.0 / alpha)
                q_terms = tuple(
                    (slice(dof * nc, (dof + 1) * nc), q_factor if sign == 1 else q_factor * sign)
                    for dof, sign in self.contact.terms[c]
                )
                channels.append(Channel(slice((N + c) * nc, (N + c + 1) * nc), Mf, Mg, q_terms, f_factor))
            couplings.append(StopCoupling(z, Mz, float(self._coefficients[components.start]), tuple(channels)))
        return self._linear_entries(Q, lam, nu, float(self.rotation_unfolding(U))), couplings

    @staticmethod
    def _stop_blocks(couplings) -> list:
        """``(rows, columns, values)`` of every stop's equations in the force and ``z`` unknowns: dense blocks
        (rows and columns as slices), and the diagonal blocks (identities) as index arrays."""
        blocks = []
        for stop in couplings:
            z_diagonal = np.arange(stop.z.start, stop.z.stop)
            nc = len(z_diagonal)
            for channel in stop.channels:
                blocks += [
                    (channel.f, channel.f, np.eye(nc) + stop.coefficient * stop.Mz),
                    (channel.f, stop.z, stop.coefficient * channel.Mf),
                ]
                if channel.Mg is None:  # z = g: diagonal blocks
                    for q, factor in channel.q_terms:
                        blocks.append((z_diagonal, np.arange(q.start, q.stop), np.full(nc, factor)))
                    f_columns = np.arange(channel.f.start, channel.f.stop)
                    blocks.append((z_diagonal, f_columns, np.full(nc, channel.f_factor)))
                else:
                    for q, factor in channel.q_terms:
                        blocks.append((stop.z, q, factor * channel.Mg))
                    blocks.append((stop.z, channel.f, channel.f_factor * channel.Mg))
            blocks.append((z_diagonal, z_diagonal, np.ones(nc)))
        return blocks

    def jacobian(self, U, sparse: bool | None = None):
        """Jacobian ``dS/dU``, shape ``(n_equations, n_unknowns)``.

        Dense ndarray, or scipy.sparse CSR matrix with ``sparse=True``; by default as the
        system's ``linear_algebra``.
        """
        if sparse if sparse is not None else self.linear_algebra == "sparse":
            return self._sparse_jacobian(U).tocsr()
        entries, couplings = self._jacobian_parts(U)
        J = np.zeros((self.n_equations, self.n_unknowns))
        for rows, cols, values in entries:
            J[rows, cols] = values
        for rows, cols, block in self._stop_blocks(couplings):
            J[rows, cols] = block
        return J

    def _sparse_jacobian(self, U):
        entries, couplings = self._jacobian_parts(U)
        for rows, cols, values in self._stop_blocks(couplings):
            entries.append((*np.mgrid[rows, cols], values) if isinstance(rows, slice) else (rows, cols, values))
        rows, cols, values = (np.concatenate([np.ravel(g[i]) for g in entries]) for i in range(3))
        return sp.coo_matrix((values, (rows, cols)), shape=(self.n_equations, self.n_unknowns))

    def factorize_bordered(self, U, tangent):
        """LU factors of the bordered Jacobian ``[J(U); tangent^T]``.

        Returns
        -------
        CondensedBorderedLU or SparseBorderedLU
            With ``solve(rhs)`` (1-D, or 2-D with one right-hand side per column),
            ``determinant_sign()`` and ``pivot_ratio``. When the system's ``linear_algebra`` is
            "dense": the ``z`` unknowns condensed out (their equations' block is the identity), then LAPACK
            LU of what is left (:class:`~nnmstop.hbm.factorization.CondensedBorderedLU`); when it is
            "sparse": SuperLU in the order of :meth:`elimination_order`.
        """
        tangent = np.asarray(tangent, dtype=float)
        if tangent.shape != (self.n_unknowns,):
            raise ValueError(f"tangent must have shape ({self.n_unknowns},), got {tangent.shape}")
        if self.linear_algebra == "dense":
            return self._condensed_factors(U, tangent)
        return SparseBorderedLU(self._sparse_jacobian(U), tangent, self.elimination_order())

    @functools.cached_property
    def _condensed_layout(self):
        """The ``z`` unknowns (one block), the kept indices (the ``q`` and ``f`` coefficients keep theirs) and the
        kept index of every row (equations, then the bordering row) and column (-1 for ``z``)."""
        N, s, m, nc, n = self.n_dofs, self.n_stops, self.n_components, self.nc, self.n_unknowns
        z = slice((N + m) * nc, (N + m + s) * nc)
        kept = np.r_[0 : z.start, z.stop : n]
        position = np.full(n, -1)
        position[kept] = np.arange(len(kept))
        return z, kept, position

    def _condensed_factors(self, U, tangent) -> CondensedBorderedLU:
        """:class:`~nnmstop.hbm.factorization.CondensedBorderedLU` of ``[J(U); tangent^T]``.

        The kept unknowns are ``[q, f, lam(, nu)]`` and the kept rows the DOF and force equations, the closing
        row and the bordering row. With ``z_i = r_z - C_i v`` from the ``z`` rows (``C_i``: their blocks in ``q``
        and ``f``, ``M_g`` times factors, or the factors alone for ``z = g``), each force row of component ``a``
        loses ``c M_{f_a} C_i`` (for the paper's stop ``(I - M_z - (2 / alpha) M_f M_g) f +
        (-eta / gap + (2 / gap) M_f M_g) q``) and the bordering row ``sum_i t_{z_i} C_i``.
        """
        z, kept, position = self._condensed_layout
        entries, couplings = self._jacobian_parts(U)
        S = np.zeros((len(kept), len(kept)), order="F")
        for rows, cols, values in entries:
            S[position[rows], position[cols]] = values
        S[-1] = tangent[kept]
        eye = np.eye(self.nc)
        for stop in couplings:
            coefficient = stop.coefficient
            for a in stop.channels:
                S[a.f, a.f] += eye + coefficient * stop.Mz
            for a in stop.channels:
                for b in stop.channels:
                    # the force rows of a gain -c M_f(a) C(b): c M_f(a) M_g(b) times the factors of b
                    product = a.Mf if b.Mg is None else a.Mf @ b.Mg
                    S[a.f, b.f] -= (coefficient * b.f_factor) * product
                    for q, factor in b.q_terms:
                        S[a.f, q] -= (coefficient * factor) * product
            for b in stop.channels:
                t_zg = tangent[stop.z] if b.Mg is None else tangent[stop.z] @ b.Mg
                for q, factor in b.q_terms:
                    S[-1, q] -= factor * t_zg
                S[-1, b.f] -= b.f_factor * t_zg
        return CondensedBorderedLU(BorderedFactorization.of_matrix(S, overwrite=True), z, couplings, tangent)

    def elimination_order(self):
        """Order of the unknowns (and of the equations alike) for the sparse LU.

        Per harmonic, the coefficients of the DOFs without a stop are coupled only by the
        banded ``K - k^2 lam M`` (and ``nu`` between the cosine and sine of one harmonic):
        they come first, harmonic by harmonic, each harmonic's DOFs in their own (banded)
        order. The stop DOFs, forces and ``z``, which couple all harmonics, come after them,
        and ``lam``, ``nu`` (dense columns) and the phase and bordering rows last.
        """
        N, nc, H = self.n_dofs, self.nc, self.H
        free = np.setdiff1d(np.arange(N), self._stop_rows)
        harmonic = np.concatenate([[0], np.arange(1, H + 1), np.arange(1, H + 1)])[:nc]
        # per harmonic, DOF by DOF, its cosine and sine together (nu M couples them DOF-wise):
        # block-banded with the mesh's bandwidth
        interior = np.concatenate([(free[:, None] * nc + np.flatnonzero(harmonic == h)).ravel() for h in range(H + 1)])
        stop_blocks = (self._stop_rows[:, None] * nc + np.arange(nc)).ravel()
        rest = np.arange(N * nc, self.n_unknowns)
        return np.concatenate([interior, stop_blocks, rest])

    def series_cache(self, order: int) -> SeriesCache:
        """Empty :class:`SeriesCache` for the terms ``U_0 .. U_order`` of one ANM series."""
        return SeriesCache(self, order)

    def series_products(self, series, p: int, cache: SeriesCache | None = None):
        """``sum_{r=1}^{p-1} Q(U_r, U_{p-r})``: the right-hand side of ANM order ``p``.

        Parameters
        ----------
        series : ndarray or list
            Terms ``U_0, U_1, ...`` (at least ``p``), as the rows of an array (no copy)
            or a list of vectors.
        p : int
            Order of the right-hand side.
        cache : SeriesCache, optional
            Time samples of ``f, z, g`` of the terms already transformed. The ANM
            passes the same cache for the orders ``2 .. N`` of one series, so that each
            term is transformed once; without it every term is transformed here.

        Returns
        -------
        ndarray
            Length ``n_equations``.
        """
        out = np.zeros(self.n_equations)
        if p < 2:
            return out
        series = np.asarray(series, dtype=float)
        if cache is None:
            cache = SeriesCache(self, p - 1)
        cache.fill(series, p)
        N, s, m, nc = self.n_dofs, self.n_stops, self.n_components, self.nc
        nq = N * nc
        # sum_r lam_r M D^2 q_{p-r} = M D^2 sum_r lam_r q_{p-r} (and nu D likewise): both sums in one product
        parameters = series[1:p, self.i_lam :]  # lam_r (, nu_r)(, mu_r) for r = 1 .. p-1
        sums = (parameters.T @ series[p - 1 : 0 : -1, :nq]).reshape(-1, N, nc)
        q_out = out[:nq].reshape(N, nc)
        q_out[:] = self._mass @ (sums[0] * self._d2)
        if self.full:
            q_out += self._velocity @ (sums[1][:, self._derivative_order] * self._derivative_factors)
        if self.rotation:
            q_out += self._circulatory @ sums[1 + self.full]
        # channels (f, g | z, g) of every component: the products f z and g g in one sum over the orders
        t = cache.samples
        np.einsum("rkm,rkm->km", t[1:p, : 2 * m], t[p - 1 : 0 : -1, 2 * m :], out=cache.products)
        if self._bilateral:
            np.negative(self.to_coefficients(cache.products).ravel(), out=out[nq : nq + 2 * s * nc])
            return out
        # c f z in the force rows; -sum g g in the z rows of z = sum g**2 (z = g is linear: no term)
        products = self.to_coefficients(cache.products)
        out[nq : nq + m * nc] = (self._coefficients[:, None] * products[:m]).ravel()
        squares = -products[m:]
        rows = out[nq + m * nc : nq + (m + s) * nc].reshape(s, nc)
        for i, components in enumerate(self.contact.components):
            rows[i] = squares[components].sum(axis=0) if self._squared[i] else 0.0
        return out

    # ------------------------------------------------------------------ starting point

    def linear_modes(self, n_modes: int | None = None):
        """Angular frequencies and mode shapes of the regularized structure near rest.

        Near rest each stop adds its law's slope at rest on its coordinates, ``eta_i A_i^T A_i``
        (``gap_i f_i ~ eta_i q`` for a stop on one DOF; :attr:`~nnmstop.models.contact.Stop.stiffness_at_rest`).
        Shapes are the columns, normalized to 1 on the first stop's coordinate (:meth:`reference_coordinate`),
        or, for a mode that does not move it, on the first stop coordinate it moves (:meth:`mode_reference`).
        Every mode (dense ``eigh``) up to :data:`~nnmstop.models.structure.DENSE_EIGEN_LIMIT` DOFs; above, the
        ``n_modes`` lowest (default 6) by shift-invert Lanczos on the sparse matrices (a dense eigen-solve of a
        large model does not fit).
        """
        if self.n_dofs > DENSE_EIGEN_LIMIT:
            count = min(self.n_dofs, 6 if n_modes is None else int(n_modes))
            omega, vectors = limit_modes(self.structure, "regularized", count)
            lam = omega**2
        else:
            stiffness = _dense(self._stiffness)
            if self._one_dof_stops:
                stiffness[self.stop_dofs, self.stop_dofs] += self.etas
            else:
                stiffness += self.contact.stiffness_matrix([stop.stiffness_at_rest for stop in self.structure.stops])
            lam, vectors = eigh(stiffness, _dense(self._mass))
        if self.structure.rotation_pairs is not None:
            vectors = self._aligned_pairs(lam, vectors)
        reference = np.array([self.mode_reference(vectors[:, j])[1] for j in range(vectors.shape[1])])
        with np.errstate(divide="ignore", invalid="ignore"):  # a mode that moves no stop: not finite, refused when used
            return np.sqrt(lam), vectors / reference

    #: Relative gap of two eigenvalues below which, with rotation, their modes are one mode and its rotated copy.
    ROTATED_PAIR_TOLERANCE = 1e-8

    def _rotated_pairs(self, lam) -> list:
        """Indices ``j`` where modes ``j`` and ``j + 1`` share one eigenvalue (a mode and its copy rotated by 90
        degrees, for a structure invariant under rotations)."""
        lam = np.asarray(lam, dtype=float)
        scale = max(float(np.max(np.abs(lam))), 1e-300)
        out, j = [], 0
        while j < len(lam) - 1:
            if abs(lam[j + 1] - lam[j]) <= self.ROTATED_PAIR_TOLERANCE * scale:
                out.append(j)
                j += 2
            else:
                j += 1
        return out

    def _aligned_pairs(self, lam, vectors) -> np.ndarray:
        """The shapes of each pair of :meth:`_rotated_pairs` turned within their plane so that the first satisfies
        the rotation phase condition (its reference pair along ``rotation_angle``) and the second is across it
        (for a structure invariant under rotations, whether the system fixes them or not)."""
        vectors = np.array(vectors, dtype=float)
        for j in self._rotated_pairs(lam):
            plane = vectors[:, j : j + 2]
            r = np.array([sum(w * plane[dof, k] for dof, w in self._rotation_weights()) for k in range(2)])
            size = np.hypot(*r)
            if size > 0:
                vectors[:, j] = plane @ (np.array([r[1], -r[0]]) / size)
                vectors[:, j + 1] = plane @ (r / size)
        return vectors

    def mode_reference(self, shape):
        """``(component, value)``: the stop coordinate a mode shape is normalized by, and its value (physical).

        The first stop's first coordinate (:meth:`reference_coordinate`) unless the shape does not move it (below
        ``1e-12`` of its largest entry): then the first stop component it moves (the shape's value on it).
        """
        shape = np.asarray(shape, dtype=float)
        first = self.reference_coordinate(shape)
        scale = np.abs(shape).max()
        if abs(first) > 1e-12 * scale or scale == 0:
            return 0, first
        coordinates = self.contact.coordinates(shape) * self._component_gaps
        moved = np.flatnonzero(np.abs(coordinates) > 1e-12 * scale)
        return (int(moved[0]), float(coordinates[moved[0]])) if len(moved) else (0, first)

    def linear_mode_guess(self, mode: int, amplitude: float):
        """Unknown vector of linear mode ``mode`` (1 .. N) of the regularized structure near rest.

        The stop coordinate of :meth:`mode_reference` (the first stop's) is ``amplitude gap cos(theta)`` and the
        DOFs follow the mode shape; ``f_c = eta_c x_c`` and each stop's ``z`` (``sum (f_c/alpha - x_c)**2`` or
        ``f/alpha - x``) balanced exactly; a Newton correction makes it a point of the branch.
        """
        if not isinstance(mode, (int, np.integer)) or isinstance(mode, bool) or not 1 <= mode <= self.n_dofs:
            raise ValueError(f"mode must be an integer in 1..{self.n_dofs}, got {mode!r}")
        omega, shapes = self.linear_modes(mode)
        if self.rotation and any(j + 2 == mode for j in self._rotated_pairs(omega**2)):
            raise ValueError(
                f"mode {mode} is mode {mode - 1} turned by 90 degrees (the structure is invariant under rotations): "
                "its NNMs are those of the mode before it, turned (the rotation phase condition fixes them): use it"
            )
        shape = shapes[:, mode - 1]
        if not np.all(np.isfinite(shape)):
            raise ValueError(f"mode {mode} does not move the coordinate of any stop (first stop: DOF {self.phase_dof})")
        x = np.zeros(self.nc)
        x[1] = amplitude * self._component_gaps[self.mode_reference(shape)[0]]
        Q = shape[:, None] * x
        X = self.stop_coordinates(Q)
        F = self._component_etas[:, None] * X
        G = F / self._component_alphas[:, None] - X
        g_t = self.to_time(G)
        Z = self._gap_terms(self.to_coefficients(g_t * g_t), G)
        return self.pack(*Q, *F, *Z, omega[mode - 1] ** 2, 0.0)

    def whirl_guess(self, mode: int, amplitude: float):
        """Unknown vector of the whirling orbit of linear mode ``mode`` of a structure invariant under rotations.

        The mode's shape ``phi`` (its reference pair along ``rotation_angle``, :meth:`linear_modes`) along
        ``cos(theta)`` and the same shape turned by 90 degrees, ``J phi``, along ``sin(theta)``: the reference pair
        goes round a circle of radius ``amplitude gap`` (``x = R cos``, ``y = R sin`` for a body in a hole). The
        stops' regularized forces of that motion, ``z`` balanced exactly and ``omega**2`` the Rayleigh quotient
        with them: exact for an isotropic body in a hole; a Newton correction makes it a whirling orbit of any
        such structure. Needs the full basis (the sine series) and ``rotation`` off: a circle is turned into
        itself by a time shift, the rotation phase condition would fix it twice.
        """
        if self.structure.rotation_pairs is None:
            raise ValueError("a whirling orbit needs a structure invariant under rotations (Structure.rotation_pairs)")
        if not self.full or self.rotation:
            raise ValueError(
                "whirling orbits are computed in the full basis without the rotation phase condition "
                f"(basis='full', rotation=False), got basis={self.basis!r}, rotation={self.rotation}"
            )
        U = self.linear_mode_guess(mode, amplitude)
        Q = U[: self.n_dofs * self.nc].reshape(self.n_dofs, self.nc).copy()
        Q[:, self.H + 1] = self.structure.rotation_generator @ Q[:, 1]  # J phi along sin(theta)
        X = self.stop_coordinates(Q)
        F = self.to_coefficients(self.contact.forces(self.to_time(X)))
        G = F / self._component_alphas[:, None] - X
        g_t = self.to_time(G)
        Z = self._gap_terms(self.to_coefficients(g_t * g_t), G)
        # omega**2 of the Rayleigh quotient of the first cosine harmonic, the stops' secant stiffness included
        q1 = Q[:, 1]
        contact = np.zeros(self.n_dofs)
        self.contact.apply(contact, F[:, 1])
        lam = (q1 @ (self._stiffness @ q1) + q1 @ contact) / (q1 @ (self._mass @ q1))
        return self.pack(*Q, *F, *Z, lam, 0.0)

    # ------------------------------------------------------------------ post-processing

    def frequency_hz(self, U):
        """Frequency ``omega / (2 pi)`` in Hz of the nondimensional time."""
        return np.sqrt(self.split(U)[-2]) / (2 * np.pi)

    def time_history(self, U, samples: int = 1024):
        """Samples of one period.

        Returns a dict with ``t``, ``q`` and ``qdot`` (N, samples), per stop component its scaled coordinate ``x``
        and velocity ``xdot`` and the force ``f`` (m, samples), and per stop ``z`` (s, samples); an axis of length
        one (a single stop with one component) is dropped. For a stack of orbits ``U`` (points, n_unknowns) every
        array has the points first.
        """
        U = np.asarray(U, dtype=float)
        N, s, m, nc = self.n_dofs, self.n_stops, self.n_components, self.nc
        Q, F, Z = (
            U[..., a * nc : b * nc].reshape(U.shape[:-1] + (b - a, nc))
            for a, b in ((0, N), (N, N + m), (N + m, N + m + s))
        )
        omega = np.sqrt(U[..., self.i_lam])[..., None, None]
        fields = self.to_time(
            np.concatenate([self.to_full(Q), omega * self.derivative(Q), self.to_full(F), self.to_full(Z)], axis=-2),
            samples,
        )
        q, qdot, f, z = np.split(fields, [N, 2 * N, 2 * N + m], axis=-2)
        t = np.arange(samples) * (2 * np.pi / omega[..., 0]) / samples
        if self.contact.grounded:
            per_stop = {"x": q[..., self.stop_dofs, :], "xdot": qdot[..., self.stop_dofs, :]}
            for key in ("x", "xdot"):
                per_stop[key] = per_stop[key] / self.gaps[:, None]
        else:
            per_stop = {
                key: np.moveaxis(self.contact.coordinates(np.moveaxis(v, -2, 0)), 0, -2)
                for key, v in (("x", q), ("xdot", qdot))
            }
        per_stop.update(f=f, z=z)
        history = {"t": t, "q": q, "qdot": qdot}
        history.update({key: value[..., 0, :] if value.shape[-2] == 1 else value for key, value in per_stop.items()})
        return history

    def energy_samples(self, q, qdot):
        """Total energy of the regularized structure at each sample (columns of ``q``, ``qdot``).

        ``1/2 q'^T M q' + 1/2 q^T K q + sum_i gap_i**2 P_i(x_i)``: the stop's force on its coordinates
        is ``gap_i A_i^T f_i(A_i q / gap_i)``, whose potential is ``gap_i**2`` times that of ``f_i``.
        Also returns the true contact force of each stop component in its coordinate, (m, samples).
        """
        kinetic = 0.5 * np.sum(qdot * (self._mass @ qdot), axis=0)
        potential = 0.5 * np.sum(q * (self._stiffness @ q), axis=0)
        X = self.stop_coordinates(q)
        forces = np.empty_like(X)
        for stop, components in zip(self.structure.stops, self.contact.components):
            forces[components], contact = stop.force_and_potential(X[components])
            potential = potential + stop.gap**2 * contact
        return kinetic + potential, forces

    def diagnostics(self, U, samples: int | None = None):
        """Physical quantities and error indicators of one HBM orbit.

        Returns a dict with ``energy`` (mean over the period of the total energy of the
        regularized structure, contact potentials included), ``energy_spread`` (its relative
        variation over the period: zero for an exact orbit), ``frequency``,
        ``time_residual`` (largest residual of the equations of motion of the stop DOFs in
        time, with the true root of the cubic for each contact force, relative to the largest
        restoring force there), ``force_error`` (largest ``|f_HBM - f(x)|`` relative to ``max |f|``),
        ``impacts_per_period`` (summed over the stops) and ``stop_impacts`` (per stop), ``x_max``
        (largest coordinate of the first stop), ``q_max`` (largest value of each degree of freedom,
        length N) and ``truncation`` (:meth:`truncation`).
        """
        return self.diagnostics_many(np.asarray(U, dtype=float)[None], samples)[0]

    def diagnostics_many(self, U_array, samples: int | None = None) -> list[dict]:
        """:meth:`diagnostics` of every orbit of ``U_array`` (points, n_unknowns), computed together.

        Every quantity is a function of the time samples, so the orbits share each transform and each
        evaluation of the contact law (one call for all their samples): the same numbers as one orbit at a
        time, at a fraction of the cost for the few orbits of one continuation step.
        """
        U = np.atleast_2d(np.asarray(U_array, dtype=float))
        P, N, s, nc = len(U), self.n_dofs, self.n_stops, self.nc
        mc = self.n_components
        m = samples or max(16 * self.H, 512)
        history = self.time_history(U, m)
        q, qdot, t = history["q"], history["qdot"], history["t"]
        f_hbm = np.reshape(history["f"], (P, mc, m))
        Q = U[:, : N * nc].reshape(P, N, nc)
        qdd = self.to_time(self.to_full(U[:, self.i_lam, None, None] * Q * self._d2), m)

        def columns(a):  # (P, k, m) -> (k, P m): every sample of every orbit a column
            return np.moveaxis(a, 0, 1).reshape(a.shape[1], P * m)

        q_columns = columns(q)
        energy_t, f_true = self.energy_samples(q_columns, columns(qdot))
        # the rows of the stop DOFs: elsewhere the equations are linear and balanced exactly
        rows = self._stop_rows
        if self._bilateral and self.contact.grounded and len(rows) == s:
            contact = self.gaps[:, None] * f_true
        else:
            contact = np.zeros((N, P * m))
            self.contact.apply(contact, f_true)
            contact = contact[rows]
        restoring = (self._stiffness @ q_columns)[rows] + contact
        eq_residual = (self._mass @ columns(qdd))[rows] + restoring + self._other_forces_at_stops(U, t, columns(qdot))
        restoring, eq_residual = (a.reshape(len(rows), P, m) for a in (restoring, eq_residual))
        f_true = f_true.reshape(mc, P, m)
        energy_t = energy_t.reshape(P, m)
        f_hbm = np.moveaxis(f_hbm, 1, 0)
        x = self.stop_coordinates(np.moveaxis(q, 1, 0))  # (m, P, samples)
        out = []
        for p in range(P):
            energy = float(np.mean(energy_t[p]))
            scale = max(float(np.max(np.abs(restoring[:, p]))), 1e-300)
            force_scale = max(float(np.max(np.abs(f_true[:, p]))), 1e-300)
            stop_impacts = self.contact.impacts(x[:, p])
            out.append(
                {
                    "energy": energy,
                    "energy_spread": float((energy_t[p].max() - energy_t[p].min()) / energy),
                    "frequency": float(self.frequency_hz(U[p])),
                    "time_residual": float(np.max(np.abs(eq_residual[:, p])) / scale),
                    "force_error": float(np.max(np.abs(f_hbm[:, p] - f_true[:, p])) / force_scale),
                    "impacts_per_period": sum(stop_impacts),
                    "stop_impacts": stop_impacts,
                    "x_max": float(x[0, p].max()),
                    "q_max": q[p].max(axis=1),
                    "truncation": self.truncation(U[p]),
                }
            )
        return out

    def _other_forces_at_stops(self, U, t, qdot):
        """Terms of the equations of motion of the stop DOFs besides inertia, stiffness and contact (none here).

        ``U`` (points, n_unknowns), ``t`` (points, samples) the sampled times of each orbit, ``qdot`` (N, points
        samples) its velocities; returns (rows, points samples) or 0, the rows those of ``_stop_rows`` (the DOFs
        the stops read, in the order they read them).
        """
        return 0.0

    def truncation(self, U) -> float:
        """Truncation indicator of an orbit: :meth:`truncation_indicator` of the stop DOFs' ``q''`` and of ``f``.

        The largest over the stops and the two series; a series below ``1e-12`` of the largest of its kind is left
        out: it carries round-off only (the second component of a circular clearance on a planar orbit), whose
        spread over the harmonics means nothing.
        """
        Q, F, _, lam, _ = self._fields(U)
        indicators = []
        for series in ([lam * (Q[dof] * self._d2) for dof in self._stop_rows], list(F)):
            sizes = [np.abs(c).max() for c in series]
            indicators += [self.truncation_indicator(c) for c, size in zip(series, sizes) if size > 1e-12 * max(sizes)]
        return max(indicators, default=0.0)

    def truncation_indicator(self, c, share: float = 0.1):
        """Fraction of the mean square of series ``c`` in the top ``share`` of the harmonics."""
        H = self.H
        c = self.to_full(c)
        power = c[1 : H + 1] ** 2 + c[H + 1 :] ** 2
        # at least two harmonics: orbits with the half-wave symmetry (NNM1, NNM2) have only
        # odd harmonics, so a single top harmonic could be an even one, always zero
        top = max(2, int(np.ceil(share * H)))
        total = power.sum()
        return float(power[-top:].sum() / total) if total > 0 else 0.0


def impacts_per_period(x_samples) -> int:
    """Number of excursions beyond the stops (``x > 1`` or ``x < -1``) in one period.

    Counted on periodic samples as the number of entries into ``x > 1`` plus the
    number of entries into ``x < -1``.
    """
    x = np.asarray(x_samples, dtype=float)
    above = x > 1.0
    below = x < -1.0
    enter_above = np.count_nonzero(above & ~np.roll(above, 1))
    enter_below = np.count_nonzero(below & ~np.roll(below, 1))
    return int(enter_above + enter_below)
