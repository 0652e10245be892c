"""Reduction of a structure onto its contact degrees of freedom (Craig-Bampton component-mode synthesis).

The stops act on a few degrees of freedom (the *contact DOFs*, :func:`contact_dofs`: every DOF a stop reads);
everywhere else the structure is linear. :func:`craig_bampton` condenses the linear part onto those DOFs plus
the lowest ``n_modes`` fixed-interface modes and returns a :class:`~nnmstop.models.structure.Structure` like
any other, whose first DOFs are the contact DOFs themselves (physical, the stops mapped onto them) and whose
last DOFs are the modal coordinates. The one harmonic-balance engine, continuation, stability, datasets and
figures run on it unchanged; its :class:`Reduction` (``structure.reduction``) carries the recovery matrix
``q_full = T q`` back to the full model's DOFs, and what the reduction kept and cost.

With ``b`` boundary (contact) DOFs and ``i`` interior DOFs, the basis is

    T = [[I, 0], [Psi, Phi]],   Psi = -K_ii^-1 K_ib (static constraint modes),
                                K_ii Phi = M_ii Phi Omega^2 (fixed-interface modes, Phi^T M_ii Phi = I),

so ``T^T K T = diag(K_bb + K_bi Psi, Omega^2)`` and ``T^T M T`` couples the boundary and the modes. The
constraint modes give the static response of the interior to the contact forces exactly (the residual
flexibility of every neglected mode at zero frequency); what the truncation leaves out is the *dynamic*
part of the neglected modes, of relative size about ``(k omega / omega_next)**2`` at harmonic ``k``, where
``omega_next`` is the first neglected fixed-interface mode. With every interior mode kept ``T`` is square
and invertible: the reduced branch is the full one, to round-off. Method notes: docs/reduction.md.

The one-time cost is one sparse factorization of ``K_ii`` (reused for the constraint modes and as the
shift-invert operator of the Lanczos eigen-solve) and ``n_modes + 1`` eigenpairs: time and memory linear in
the size of banded finite-element matrices. :attr:`Reduction.costs` records the seconds of each part.

For example, a clamped-free beam of 40 elements with one stop, reduced onto its stop DOF and 6 modes:

>>> from nnmstop.models.beam import Beam, BeamStop, beam_structure
>>> beam = Beam(1.0, 1.0, 1.0, 40, stops=(BeamStop(1.0, 30.0, 0.1, node=24),))
>>> full = beam_structure(beam)
>>> reduced = craig_bampton(full, 6)
>>> reduced.n_dofs, reduced.stop_dofs, reduced.dof_labels[:2]
(7, (0,), ('w24', 'cb1'))
>>> reduced.reduction.recovery.shape
(80, 7)
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from nnmstop.models.stiffness_root import RootSolver, energy_matrix, fixed_order_product
from nnmstop.models.structure import DENSE_EIGEN_LIMIT, Structure

__all__ = [
    "Reduction",
    "contact_dofs",
    "craig_bampton",
    "reduce_structure",
    "REDUCTION_KEYS",
    "recovered_rows",
    "RECOVERED_NODES",
]

logger = logging.getLogger("nnmstop.models.reduction")

#: Keys of a configuration's ``reduction`` section (:func:`reduce_structure`).
REDUCTION_KEYS = ("modes", "boundary_dofs")

#: Most subspace inverse-iteration steps refining the paired modes of a structure invariant under rotations.
REFINEMENT_STEPS = 200

#: Largest number of nodes whose DOFs a dataset's recovery matrix keeps (:func:`recovered_rows`).
RECOVERED_NODES = 1001


@dataclass(frozen=True, eq=False)
class Reduction:
    """How a reduced structure maps back onto the full model it was reduced from.

    Attributes
    ----------
    recovery : ndarray, shape (N_full, n)
        ``q_full = recovery @ q`` (the Craig-Bampton basis ``T``, rows in the full model's DOF order).
    boundary : ndarray of int, shape (b,)
        Full-model index of each boundary DOF (the reduced DOFs ``0 .. b-1``).
    mode_frequencies : ndarray, shape (m,)
        Angular frequencies of the kept fixed-interface modes (reduced DOFs ``b .. b+m-1``).
    next_frequency : float
        Angular frequency of the first neglected fixed-interface mode (``inf`` when every mode is kept):
        the a-priori error estimate compares the highest harmonic frequency ``H omega`` with it.
    full_dof_labels : tuple of str
        Labels of the full model's DOFs.
    full_dof_nodes : tuple of int or None
        Node of each full DOF (finite-element models).
    full_node_coordinates : ndarray or None
        Node coordinates of the full model.
    costs : dict
        One-time cost in seconds: ``factorization`` (sparse LU of ``K_ii``), ``constraint_modes``,
        ``eigensolve``, ``projection``.
    """

    recovery: np.ndarray
    boundary: np.ndarray
    mode_frequencies: np.ndarray
    next_frequency: float
    full_dof_labels: tuple
    full_dof_nodes: tuple | None = None
    full_node_coordinates: np.ndarray | None = None
    costs: dict = dataclasses.field(default_factory=dict)

    @property
    def full_dofs(self) -> int:
        """Number of DOFs of the full model."""
        return self.recovery.shape[0]

    @property
    def kept_modes(self) -> int:
        """Number of kept fixed-interface modes."""
        return len(self.mode_frequencies)

    def recover(self, q) -> np.ndarray:
        """Full-model DOFs from reduced ones, on the last axis of ``q`` (..., n) -> (..., N_full)."""
        return np.asarray(q, dtype=float) @ self.recovery.T

    def attributes(self) -> dict:
        """What a dataset records of the reduction (global attributes)."""
        return {
            "reduction": "craig_bampton",
            "full_dofs": int(self.full_dofs),
            "boundary_dofs": int(len(self.boundary)),
            "boundary_full_dofs": np.asarray(self.boundary, dtype=np.int32),  # the full model's index of each
            "kept_modes": int(self.kept_modes),
            "highest_kept_frequency": float(self.mode_frequencies[-1] / (2 * np.pi)) if self.kept_modes else 0.0,
            "first_neglected_frequency": float(self.next_frequency / (2 * np.pi)),
        }


def contact_dofs(structure: Structure) -> np.ndarray:
    """Sorted indices of every DOF a stop of ``structure`` reads (the boundary of the reduction).

    A stop that reads several DOFs (a relative stop, a circular clearance's two components) adds all of them
    (``Stop.dofs``).
    """
    dofs = []
    for stop in structure.stops:
        dofs.extend(stop.dofs)
    return np.unique(np.asarray(dofs, dtype=int))


def _count(name: str, value, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


class _InteriorStiffness:
    """What the reduction asks of ``K_ii`` (the interior held at the boundary): ``solve`` (``K_ii^-1``), the
    constraint modes ``Psi = -K_ii^-1 K_ib`` and the form ``V^T K_ii V``.

    Where the structure has a stiffness root ``G`` (``K = G^T G``), through the augmented system of ``G_i``
    (:class:`~nnmstop.models.stiffness_root.RootSolver`: ``cond(G) = sqrt(cond K)`` digits lost), the constraint
    modes as the least-squares problems ``min |G_i psi + G_b|`` and the form as sums of squares; else through a
    sparse ``L D L^T`` of ``K_ii`` in a symmetric fill-reducing order with the diagonal as pivot (no row interchange,
    which on a shuffled mesh numbering would destroy the symmetric structure and multiply the fill). An interior
    free to move is refused (ValueError).
    """

    HELD = (
        "either it is free to move (hold the structure: a clamped or pinned end; or add the free DOFs to "
        "boundary_dofs), or its stiffness is too ill-conditioned"
    )

    def __init__(self, structure: Structure, stiffness, interior, boundary):
        self.k_ii = stiffness[interior][:, interior].tocsc()
        self._k_ib = stiffness[interior][:, boundary]
        self.full_root = None if structure.stiffness_root is None else scipy.sparse.csc_matrix(structure.stiffness_root)
        if self.full_root is not None:
            self.root, self._root_b = self.full_root[:, interior], self.full_root[:, boundary]
            try:
                self._solver = RootSolver(self.root)
            except ValueError:
                raise ValueError(
                    f"the interior of the structure is singular when the boundary is held: {self.HELD}"
                ) from None
            self.solve = self._solver.solve
            return
        self.root = None
        try:
            factor = scipy.sparse.linalg.splu(
                self.k_ii, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
            )
        except RuntimeError:
            factor = None
        pivots = factor.U.diagonal() if factor is not None else np.zeros(1)
        if factor is None or pivots.min() <= 1e-13 * np.abs(pivots).max():
            ratio = pivots.min() / np.abs(pivots).max() if factor is not None else 0.0
            raise ValueError(
                "the interior of the structure (every DOF but the boundary "
                f"{[structure.dof_labels[d] for d in boundary]}) is singular to double precision when the boundary "
                f"is held (smallest pivot of K_ii {ratio:.1e} of the largest): {self.HELD} (a beam's grows as the "
                "number of elements to the fourth: give its stiffness root, Structure.stiffness_root, as beams built "
                "by the project do)"
            )
        self.solve = factor.solve

    def constraint_modes(self) -> np.ndarray:
        """``Psi = -K_ii^-1 K_ib`` (interior rows of the static constraint modes)."""
        if self.root is not None:
            return self._solver.least_squares(self._root_b.toarray())[0]
        return -self.solve(self._k_ib.toarray())

    def form(self, basis) -> np.ndarray:
        """``V^T K_ii V`` on the columns of ``basis`` (summed in one fixed order)."""
        if self.root is not None:
            return energy_matrix(self.root, basis)
        return fixed_order_product(basis, self.k_ii @ basis)

    def check_held(self, omega, m_ii) -> None:
        """Through the root an interior free to move factors (to round-off) and shows as a lowest fixed-interface
        eigenvalue at round-off: refused (ValueError)."""
        if (
            self.root is not None
            and len(omega)
            and omega[0] ** 2 <= 1e-26 * np.max(self.k_ii.diagonal() / m_ii.diagonal())
        ):
            raise ValueError(f"the interior of the structure is singular when the boundary is held: {self.HELD}")


def _fixed_interface_modes(interior: _InteriorStiffness, m_ii, n_wanted: int):
    """The ``n_wanted`` lowest ``(omega, Phi)`` of ``K_ii phi = omega^2 M_ii phi`` (through a stiffness root, each
    ``omega^2`` is the Rayleigh quotient ``|G_i phi|^2``, without cancellation)."""
    k_ii = interior.k_ii
    n = k_ii.shape[0]
    if n_wanted == 0:
        return np.zeros(0), np.zeros((n, 0))
    if n <= DENSE_EIGEN_LIMIT or n_wanted >= n - 1:
        lam, phi = scipy.linalg.eigh(k_ii.toarray(), m_ii.toarray(), subset_by_index=[0, n_wanted - 1])
    else:
        inverse = scipy.sparse.linalg.LinearOperator((n, n), matvec=interior.solve, dtype=float)
        start = np.ones(n)  # a fixed start vector: the same Lanczos run on every call
        lam, phi = scipy.sparse.linalg.eigsh(k_ii, k=n_wanted, M=m_ii, sigma=0.0, which="LM", OPinv=inverse, v0=start)
        order = np.argsort(lam)
        lam, phi = lam[order], phi[:, order]
    phi = phi / np.sqrt(np.einsum("ij,ij->j", phi, m_ii @ phi))
    if interior.root is not None:
        lam = np.diag(interior.form(phi))
    return np.sqrt(np.maximum(lam, 0.0)), phi * _mode_signs(phi)


def _mode_signs(phi) -> np.ndarray:
    """``+-1`` per column: its first entry above a hundredth of its largest made positive. An eigensolver
    returns each mode up to its sign, and the sign fixes the modal coordinates a dataset stores: a reduction
    rebuilt to check a stored orbit (:mod:`nnmstop.stored_accuracy`) must find the same ones."""
    if phi.shape[1] == 0:
        return np.ones(0)
    magnitude = np.abs(phi)
    first = np.argmax(magnitude > 0.01 * magnitude.max(axis=0), axis=0)
    return np.where(phi[first, np.arange(phi.shape[1])] < 0, -1.0, 1.0)


def _reduced_rotation_pairs(structure: Structure, boundary, n_modes: int):
    """The rotation pairs of the reduced structure (``None`` when the full one has none, or when the boundary is not
    turned into itself by the rotations, as with a forced DOF in one plane): the boundary's own pairs, then the kept
    modes two by two. An invariant structure's modes come in pairs, and a pair is kept whole or not at all."""
    if structure.rotation_pairs is None:
        return None
    position = {int(d): k for k, d in enumerate(boundary)}
    inside = [(i in position, j in position) for i, j in structure.rotation_pairs]
    if any(a != b for a, b in inside):
        return None
    if n_modes % 2:
        raise ValueError(
            f"n_modes must be even for a structure invariant under rotations (its modes come in pairs), got {n_modes}"
        )
    pairs = [(position[i], position[j]) for (i, j), (a, _) in zip(structure.rotation_pairs, inside) if a]
    b = len(boundary)
    return tuple(pairs) + tuple((b + k, b + k + 1) for k in range(0, n_modes, 2))


def _rotation_of(structure: Structure, interior) -> scipy.sparse.csr_matrix:
    """The rotation generator ``J`` restricted to the interior DOFs (closed under the rotations)."""
    return scipy.sparse.csr_matrix(structure.rotation_generator[interior][:, interior])


def _rotation_average(matrix, pairs) -> np.ndarray:
    """``matrix`` averaged over the rotations of ``pairs`` by multiples of 90 degrees: it then commutes with them."""
    quarter = np.eye(len(matrix))
    for i, j in pairs:
        quarter[[i, j], [i, j]] = 0.0
        quarter[j, i], quarter[i, j] = 1.0, -1.0
    average, turn = np.zeros_like(matrix), np.eye(len(matrix))
    for _ in range(4):
        average += turn.T @ matrix @ turn
        turn = turn @ quarter
    return 0.25 * average


def _refined_modes(phi, omega, m_ii, n_modes: int, solve, stiffness_form):
    """The ``n_modes`` lowest eigenspaces of ``phi`` refined by subspace inverse iteration with a Rayleigh-Ritz
    projection at each step (``solve``: ``K_ii^-1``; ``stiffness_form(V)``: ``V^T K_ii V``).

    Used on the paired modes of a structure invariant under rotations: a dense eigensolver returns their
    degenerate eigenspaces with errors of about ``eps`` times the stiffness' condition number, which move with the
    BLAS threads and kernels. Each step damps an error along a neglected mode by the ratio of the eigenvalues,
    slowest the last kept mode's against the first neglected one (``omega``: the solver's frequencies, one beyond
    the kept); enough steps are taken to damp it by ``1e-10``, so that the eigenspaces are the same on every CPU
    to round-off. Returns the Ritz vectors, mass-normalized, in increasing frequency.
    """
    ratio = (omega[n_modes - 1] / omega[n_modes]) ** 2 if len(omega) > n_modes else 0.0
    iterations = 3 if ratio < 1e-3 else min(REFINEMENT_STEPS, int(np.ceil(np.log(1e-10) / np.log(min(ratio, 0.99)))))
    phi = phi[:, :n_modes]
    for _ in range(iterations):  # subspace iteration, Rayleigh-Ritz at each step (keeps the columns apart)
        phi = solve(m_ii @ phi)
        phi = phi / np.sqrt(np.einsum("ij,ij->j", phi, m_ii @ phi))
        _, ritz = scipy.linalg.eigh(stiffness_form(phi), fixed_order_product(phi, m_ii @ phi))
        phi = phi @ ritz
    return phi / np.sqrt(np.einsum("ij,ij->j", phi, m_ii @ phi))


def _paired_modes(phi, m_ii, rotation, n_modes: int, stiffness_form):
    """``n_modes`` fixed-interface modes as pairs ``(u, J u)`` spanning the lowest eigenspaces of ``phi`` (refined:
    :func:`_refined_modes`).

    An eigensolver returns a degenerate pair as any basis of its plane, which moves with round-off: each plane is
    spanned here by ``u`` and ``J u`` with ``u`` the vector of the plane with the most of its norm on the first DOF
    of each rotation pair (a least-squares choice, as accurate as the plane itself: for a beam bending in two
    planes, the first plane's shape), its sign by the rule of :func:`_mode_signs`, so that the modal coordinates are
    the same on every CPU.
    """
    first = np.asarray(rotation.sum(axis=0)).ravel() > 0  # J e_i = e_j: the column of a pair's first DOF i sums to 1
    basis = []
    for k in range(phi.shape[1]):
        if len(basis) >= n_modes:
            break
        vector = phi[:, k].copy()
        for kept in basis:
            vector -= kept * (kept @ (m_ii @ vector))
        norm = np.sqrt(vector @ (m_ii @ vector))
        if norm < 0.5:  # in the span of the modes kept already (the pair's second member)
            continue
        plane = np.column_stack([vector / norm, rotation @ (vector / norm)])
        on_first = plane[first]
        _, directions = np.linalg.eigh(on_first.T @ on_first)
        u = plane @ directions[:, -1]
        u *= _mode_signs(u[:, None])[0]
        basis += [u, rotation @ u]
    if len(basis) < n_modes:
        raise ValueError(f"the fixed-interface modes do not come in {n_modes // 2} pairs turned by the rotations")
    paired = np.column_stack(basis[:n_modes])
    omega = np.sqrt(np.maximum(np.diag(stiffness_form(paired)), 0.0))
    omega = np.repeat(0.5 * (omega[0::2] + omega[1::2]), 2)
    return omega, paired


def craig_bampton(structure: Structure, n_modes: int, boundary_dofs=()) -> Structure:
    """The Craig-Bampton reduction of ``structure`` onto its contact DOFs and ``n_modes`` fixed-interface modes.

    Parameters
    ----------
    structure : Structure
        The full model (dense or sparse matrices).
    n_modes : int
        Fixed-interface modes kept, ``0`` (static, Guyan condensation) up to the number of interior DOFs
        (exact).
    boundary_dofs : sequence of int, optional
        DOFs kept physical besides the contact DOFs (a forced DOF, a DOF to be read exactly).

    Returns
    -------
    Structure
        DOFs: the boundary DOFs (labels of the full model, increasing full index), then ``cb1 .. cb<m>``; the
        stops on the boundary DOFs; ``attributes``: the full model's and :meth:`Reduction.attributes`;
        ``reduction``: the :class:`Reduction`.

    Raises
    ------
    ValueError
        For a mode count out of range, a boundary DOF off the model, or an interior that is free to move when
        the boundary is held (``K_ii`` singular).
    """
    if not isinstance(structure, Structure):
        raise TypeError(f"structure must be a Structure, got {type(structure).__name__}")
    if structure.reduction is not None:
        raise ValueError("structure is already reduced: reduce the full model")
    n = structure.n_dofs
    extra = np.asarray(list(boundary_dofs), dtype=int)
    if extra.size and (extra.min() < 0 or extra.max() >= n):
        raise ValueError(f"boundary_dofs must lie in [0, {n - 1}], got {extra.tolist()}")
    boundary = np.union1d(contact_dofs(structure), extra).astype(int)
    interior = np.setdiff1d(np.arange(n), boundary)
    n_modes = _count("n_modes", n_modes, 0, len(interior))
    stiffness = scipy.sparse.csr_matrix(structure.stiffness)
    mass = scipy.sparse.csr_matrix(structure.mass)
    costs = {}
    started = time.perf_counter()
    m_ii = mass[interior][:, interior].tocsc()
    interior_stiffness = _InteriorStiffness(structure, stiffness, interior, boundary)
    costs["factorization"] = time.perf_counter() - started
    started = time.perf_counter()
    psi = interior_stiffness.constraint_modes()
    costs["constraint_modes"] = time.perf_counter() - started
    started = time.perf_counter()
    # one more mode than kept: the first neglected frequency is the a-priori error estimate
    wanted = min(n_modes + 1, len(interior))
    omega, phi = _fixed_interface_modes(interior_stiffness, m_ii, wanted)
    interior_stiffness.check_held(omega, m_ii)
    pairs = _reduced_rotation_pairs(structure, boundary, n_modes)
    if pairs is not None:  # the modes in pairs (phi, J phi): the reduced structure stays invariant under rotations
        form = interior_stiffness.form
        refined = _refined_modes(phi, omega, m_ii, n_modes, interior_stiffness.solve, form)
        omega[:n_modes], phi[:, :n_modes] = _paired_modes(
            refined, m_ii, _rotation_of(structure, interior), n_modes, form
        )
    next_frequency = float(omega[n_modes]) if n_modes < len(omega) else np.inf
    omega, phi = omega[:n_modes], phi[:, :n_modes]
    costs["eigensolve"] = time.perf_counter() - started
    started = time.perf_counter()
    b, m = len(boundary), n_modes
    recovery = np.zeros((n, b + m))
    recovery[boundary, np.arange(b)] = 1.0
    recovery[interior, :b] = psi
    recovery[interior, b:] = phi
    reduced_mass = fixed_order_product(recovery, mass @ recovery)
    reduced_mass = 0.5 * (reduced_mass + reduced_mass.T)
    reduced_mass[b:, b:] = np.eye(m)  # Phi^T M_ii Phi, mass-normalized
    if interior_stiffness.root is not None:  # the Ritz projection (G T)^T (G T): a sum of squares, no cancellation
        reduced_stiffness = energy_matrix(interior_stiffness.full_root, recovery)
    else:
        reduced_stiffness = np.zeros((b + m, b + m))
        condensed = stiffness[boundary][:, boundary].toarray() + stiffness[boundary][:, interior] @ psi
        reduced_stiffness[:b, :b] = 0.5 * (condensed + condensed.T)
        reduced_stiffness[b:, b:] = np.diag(omega**2)
    if pairs is not None:  # invariant to round-off: made exactly so, averaged over the rotations by 90 degrees
        reduced_mass, reduced_stiffness = (_rotation_average(a, pairs) for a in (reduced_mass, reduced_stiffness))
    costs["projection"] = time.perf_counter() - started
    position = {int(d): k for k, d in enumerate(boundary)}
    reduction = Reduction(
        recovery=recovery,
        boundary=boundary,
        mode_frequencies=omega,
        next_frequency=next_frequency,
        full_dof_labels=structure.dof_labels,
        full_dof_nodes=structure.dof_nodes,
        full_node_coordinates=structure.node_coordinates,
        costs=costs,
    )
    return Structure(
        reduced_mass,
        reduced_stiffness,
        tuple(stop.on_dofs(position) for stop in structure.stops),
        dof_labels=tuple(structure.dof_labels[d] for d in boundary) + tuple(f"cb{j + 1}" for j in range(m)),
        attributes={**structure.attributes, **reduction.attributes()},
        reduction=reduction,
        rotation_pairs=pairs,
    )


def reduce_structure(structure: Structure, spec: dict | None, where: str = "reduction") -> Structure:
    """``structure`` reduced as a configuration's ``reduction`` section says (``None``: unchanged).

    ``spec``: ``modes`` (fixed-interface modes kept) and optionally ``boundary_dofs`` (labels or indices
    of DOFs kept physical besides the contact DOFs).

    Raises
    ------
    ValueError
        Naming ``where`` and the offending key or value.
    """
    if spec is None:
        return structure
    unknown = sorted(set(spec) - set(REDUCTION_KEYS))
    if unknown or "modes" not in spec:
        raise ValueError(f"{where}: keys must be among {list(REDUCTION_KEYS)} with 'modes' given, got {sorted(spec)}")
    labels = list(structure.dof_labels)
    extra = []
    for dof in spec.get("boundary_dofs", []):
        if isinstance(dof, str):
            if dof not in labels:
                raise ValueError(f"{where}.boundary_dofs: {dof!r} is not a DOF label of the structure")
            extra.append(labels.index(dof))
        else:
            extra.append(int(dof))
    try:
        reduced = craig_bampton(structure, spec["modes"], extra)
    except ValueError as err:
        raise ValueError(f"{where}: {err}") from None
    costs = reduced.reduction.costs
    logger.info(
        "%s: %d DOFs reduced onto %d boundary DOFs and %d modes (first neglected at %.4g Hz) in %.3g s "
        "(sparse LU %.3g s, constraint modes %.3g s, eigenpairs %.3g s, projection %.3g s)",
        where,
        structure.n_dofs,
        len(reduced.reduction.boundary),
        reduced.reduction.kept_modes,
        reduced.reduction.next_frequency / (2 * np.pi),
        sum(costs.values()),
        *(costs[k] for k in ("factorization", "constraint_modes", "eigensolve", "projection")),
    )
    return reduced


def recovered_rows(reduction: Reduction, max_nodes: int = RECOVERED_NODES) -> np.ndarray:
    """Full-model DOFs whose recovery a dataset keeps: all of them on small models, else a subset.

    A finite-element model with more than ``max_nodes`` nodes keeps the DOFs of evenly spaced nodes (every
    ``k``-th, the last one and the boundary DOFs' nodes): enough to draw deformed shapes by the shape
    functions between them. A model without nodes keeps at most ``2 max_nodes`` evenly spaced DOFs and the
    boundary.
    """
    n = reduction.full_dofs
    nodes = reduction.full_dof_nodes
    if nodes is None:
        if n <= 2 * max_nodes:
            return np.arange(n)
        return np.union1d(np.linspace(0, n - 1, 2 * max_nodes).astype(int), reduction.boundary)
    nodes = np.asarray(nodes)
    count = int(nodes.max()) + 1
    if count <= max_nodes:
        return np.arange(n)
    every = int(np.ceil((count - 1) / (max_nodes - 1)))
    kept = np.union1d(np.append(np.arange(0, count, every), count - 1), nodes[reduction.boundary])
    return np.flatnonzero(np.isin(nodes, kept))
