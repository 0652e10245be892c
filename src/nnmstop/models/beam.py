"""Euler-Bernoulli beam of Hermite cubic elements with bilateral elastic stops at nodes.

:class:`Beam` holds the physical description (length, ``EI``, ``rho A``, elements, end conditions, stops, and
whether it bends in one plane or in two: ``planes``);
:func:`beam_structure` assembles banded sparse mass and stiffness matrices on the (transverse displacement,
rotation) degrees of freedom of the nodes (of each plane), removes the constrained ones and returns the
nondimensional
:class:`~nnmstop.models.structure.Structure` (length unit the gap of the first stop, time unit the inverse
of the first linear no-contact angular frequency, see docs/methods/beam.md).
:func:`euler_bernoulli_frequencies` gives the analytical frequencies of the continuous beam, the
independent reference of the mesh-convergence test. :func:`default_tube_parameters` is the default scene:
a tube clamped at its foot, free at its top, guided by a support plate with a clearance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
import scipy.sparse

from nnmstop.models.structure import Stop, Structure, generalized_modes, linear_frequencies, normal_modes

__all__ = [
    "BOUNDARY_CONDITIONS",
    "BeamStop",
    "Beam",
    "element_matrices",
    "assemble_free_beam",
    "beam_structure",
    "beam_scales",
    "beam_deflection",
    "mode_frequencies",
    "euler_bernoulli_frequencies",
    "rigid_body_modes",
    "default_tube_parameters",
    "tube_plates_parameters",
    "linear_frequencies",
    "normal_modes",
]

#: End conditions and the local degrees of freedom (0: displacement, 1: rotation) each one removes.
BOUNDARY_CONDITIONS = {"clamped": (0, 1), "pinned": (0,), "free": ()}

#: A stop position is on a node when it is within this fraction of the length of it.
NODE_TOLERANCE = 1e-9
#: The kinds of stop a beam takes at its nodes (``circular`` needs a beam bending in two planes).
BEAM_STOP_KINDS = ("bilateral", "one_sided", "circular")
#: Labels of the (displacement, rotation) DOFs of each plane: ``w``, ``theta`` in the first, ``v``, ``psi`` in the
#: second (a beam bending in two planes).
PLANE_LABELS = (("w", "theta"), ("v", "psi"))


def _positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class BeamStop:
    """An elastic stop at a node of the beam (physical units): bilateral, one-sided with ``side``, or circular.

    Give either ``node`` (index from the left end, 0..n_elements) or ``position`` (distance from the left
    end), which must fall on a node. ``gap`` is a length, ``stiffness`` and ``eta`` are forces per unit
    transverse displacement (``0 < eta < stiffness``). ``kind`` is ``"bilateral"`` (default) or ``"one_sided"``
    (:class:`~nnmstop.models.contact.OneSidedStop`, with ``side``: ``"positive"`` or ``"negative"``), acting on
    the displacement of the first plane; two one-sided stops at one node make unequal gaps. ``"circular"``: a
    circular clearance of radius ``gap`` and radial ``stiffness`` on the node's displacements in both planes
    (:class:`~nnmstop.models.contact.CircularStop`; a beam bending in two planes, ``Beam.planes = 2``). Relative
    stops need a structure given by its matrices.
    """

    gap: float
    stiffness: float
    eta: float
    node: int | None = None
    position: float | None = None
    kind: str = "bilateral"
    side: str | None = None

    def __post_init__(self):
        if self.kind not in BEAM_STOP_KINDS:
            raise ValueError(
                f"beam stop kind must be one of {BEAM_STOP_KINDS}, got {self.kind!r} (relative stops need a structure "
                "given by its matrices)"
            )
        if self.kind in ("bilateral", "circular") and self.side is not None:
            raise ValueError(f"stop key 'side' is not allowed for a {self.kind} beam stop, got side={self.side!r}")
        if self.kind == "one_sided" and self.side not in ("positive", "negative"):
            raise ValueError(f"a one_sided beam stop needs the key 'side' (positive or negative), got {self.side!r}")
        for name in ("gap", "stiffness", "eta"):
            object.__setattr__(self, name, _positive(f"stop {name}", getattr(self, name)))
        if self.kind == "one_sided" and 2 * self.eta >= self.stiffness:
            raise ValueError(
                f"stop eta of a one-sided stop must be smaller than half its stiffness, got eta={self.eta!r} "
                f">= stiffness/2={0.5 * self.stiffness!r}"
            )
        if self.eta >= self.stiffness:
            raise ValueError(
                f"stop eta must be smaller than its stiffness (0 < eta < stiffness), got eta={self.eta!r} "
                f">= stiffness={self.stiffness!r}"
            )
        if (self.node is None) == (self.position is None):
            raise ValueError(
                f"give a stop either a node or a position, got node={self.node!r}, position={self.position!r}"
            )


@dataclass(frozen=True)
class Beam:
    """Physical description of an Euler-Bernoulli beam with stops.

    Parameters
    ----------
    length, bending_stiffness, mass_per_length : float
        ``L``, ``EI`` and ``rho A`` (> 0), in any consistent units.
    n_elements : int
        Number of equal Hermite cubic elements (>= 1).
    left, right : {"clamped", "pinned", "free"}
        End conditions at ``s = 0`` and ``s = L``.
    stops : sequence of BeamStop
        At least one, on distinct nodes that are not fixed transversally.
    planes : {1, 2}
        Bending in one transverse plane, or in two (the same section in both: an isotropic beam, the DOFs of the
        second plane after those of the first); a circular clearance needs two.
    """

    length: float
    bending_stiffness: float
    mass_per_length: float
    n_elements: int
    left: str = "clamped"
    right: str = "free"
    stops: tuple = ()
    planes: int = 1

    def __post_init__(self):
        for name in ("length", "bending_stiffness", "mass_per_length"):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))
        if (
            isinstance(self.n_elements, bool)
            or not isinstance(self.n_elements, (int, np.integer))
            or self.n_elements < 1
        ):
            raise ValueError(f"n_elements must be an integer >= 1, got {self.n_elements!r}")
        object.__setattr__(self, "n_elements", int(self.n_elements))
        for side in ("left", "right"):
            if getattr(self, side) not in BOUNDARY_CONDITIONS:
                raise ValueError(
                    f"{side} boundary condition must be one of {sorted(BOUNDARY_CONDITIONS)}, "
                    f"got {getattr(self, side)!r}"
                )
        if self.planes not in (1, 2) or isinstance(self.planes, bool):
            raise ValueError(f"planes must be 1 or 2 (bending in one transverse plane or in two), got {self.planes!r}")
        stops = tuple(self.stops)
        if not stops:
            raise ValueError("a beam needs at least one stop, got none")
        if self.planes == 1 and any(s.kind == "circular" for s in stops):
            raise ValueError("a circular stop needs a beam bending in two planes (planes: 2), this one has planes: 1")
        object.__setattr__(self, "stops", stops)
        nodes = self.stop_nodes
        shared = [n for n in set(nodes) if nodes.count(n) > 1]
        if any(any(s.kind != "one_sided" for s, n in zip(stops, nodes) if n == node) for node in shared):
            raise ValueError(
                f"stops must be at distinct nodes, got nodes {nodes} (only one-sided stops may share a node: unequal "
                "gaps)"
            )
        fixed = {0: self.left, self.n_elements: self.right}
        for node in nodes:
            if node in fixed and fixed[node] != "free":
                raise ValueError(f"a stop at node {node} would act on a {fixed[node]} end, whose displacement is 0")

    @property
    def node_coordinates(self) -> np.ndarray:
        """Positions of the ``n_elements + 1`` nodes from the left end."""
        return np.linspace(0.0, self.length, self.n_elements + 1)

    def node_of(self, stop: BeamStop) -> int:
        """Node index of ``stop``; a position off the mesh is a ValueError naming it."""
        if stop.node is not None:
            if (
                isinstance(stop.node, bool)
                or not isinstance(stop.node, (int, np.integer))
                or not 0 <= stop.node <= self.n_elements
            ):
                raise ValueError(f"stop node must be an integer in [0, {self.n_elements}], got {stop.node!r}")
            return int(stop.node)
        position = stop.position
        if not isinstance(position, (int, float, np.integer, np.floating)) or not 0 <= position <= self.length:
            raise ValueError(f"stop position must be a number in [0, {self.length}], got {position!r}")
        h = self.length / self.n_elements
        node = int(round(position / h))
        if abs(node * h - position) > NODE_TOLERANCE * self.length:
            raise ValueError(
                f"stop position {position!r} is not on a node of the mesh ({self.n_elements} elements of length "
                f"{h!r}; nearest node {node} at {node * h!r})"
            )
        return node

    @property
    def stop_nodes(self) -> tuple:
        """Node index of each stop."""
        return tuple(self.node_of(s) for s in self.stops)

    @classmethod
    def from_parameters(cls, parameters: dict) -> Beam:
        """Build from a dict shaped like :func:`default_tube_parameters` (missing or unknown keys are named)."""
        keys = ("length", "bending_stiffness", "mass_per_length", "n_elements", "left", "right", "stops")
        missing = [k for k in keys if k not in parameters]
        unknown = sorted(set(parameters) - set(keys) - {"planes"})  # planes: optional (default 1)
        if missing or unknown:
            raise ValueError(
                f"beam parameters: missing keys {missing}, unknown keys {unknown}; expected {list(keys)} "
                "and optionally 'planes'"
            )
        stop_keys = {"gap", "stiffness", "eta", "node", "position", "kind", "side"}
        for stop in parameters["stops"]:
            if not isinstance(stop, dict) or set(stop) - stop_keys:
                raise ValueError(f"each stop must be a dict with keys among {sorted(stop_keys)}, got {stop!r}")
        stops = tuple(BeamStop(**stop) for stop in parameters["stops"])
        return cls(**{k: parameters[k] for k in keys[:-1]}, stops=stops, planes=parameters.get("planes", 1))


def element_matrices(h: float, bending_stiffness: float, mass_per_length: float):
    """Stiffness and consistent mass matrices of a Hermite cubic element of length ``h``.

    Local degrees of freedom ``(w_1, theta_1, w_2, theta_2)``.
    """
    k = (
        bending_stiffness
        / h**3
        * np.array(
            [
                [12.0, 6 * h, -12.0, 6 * h],
                [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                [-12.0, -6 * h, 12.0, -6 * h],
                [6 * h, 2 * h * h, -6 * h, 4 * h * h],
            ]
        )
    )
    m = (
        mass_per_length
        * h
        / 420.0
        * np.array(
            [
                [156.0, 22 * h, 54.0, -13 * h],
                [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                [54.0, 13 * h, 156.0, -22 * h],
                [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
            ]
        )
    )
    return k, m


def element_root(h: float, bending_stiffness: float) -> np.ndarray:
    """The ``2 x 4`` stiffness root ``G_e`` of a Hermite element (:func:`element_matrices`' ``k = G_e^T G_e``).

    Its rows are the curvatures at the element's two ends, ``w'' = B_e (w_1, theta_1, w_2, theta_2)``,
    weighted by the upper Cholesky factor of the linear curvature's energy ``EI h / 6 [[2, 1], [1, 2]]``
    (:mod:`nnmstop.models.stiffness_root`).
    """
    curvatures = np.array([[-6.0, -4.0 * h, 6.0, -2.0 * h], [6.0, 2.0 * h, -6.0, 4.0 * h]]) / h**2
    weight = np.sqrt(bending_stiffness * h / 6.0) * np.array([[np.sqrt(2.0), np.sqrt(0.5)], [0.0, np.sqrt(1.5)]])
    return weight @ curvatures


def assemble_free_beam(length: float, bending_stiffness: float, mass_per_length: float, n_elements: int):
    """Sparse (CSR, bandwidth 3) stiffness and mass of the unconstrained beam, DOFs ``(w_i, theta_i)``."""
    k_e, m_e = element_matrices(length / n_elements, bending_stiffness, mass_per_length)
    first = 2 * np.arange(n_elements)
    dofs = first[:, None] + np.arange(4)[None, :]  # element e couples DOFs 2e .. 2e+3
    rows = np.repeat(dofs, 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 4)).ravel()
    n = 2 * (n_elements + 1)
    stiffness = scipy.sparse.csr_matrix((np.tile(k_e.ravel(), n_elements), (rows, cols)), shape=(n, n))
    mass = scipy.sparse.csr_matrix((np.tile(m_e.ravel(), n_elements), (rows, cols)), shape=(n, n))
    return stiffness, mass


def free_beam_root(length: float, bending_stiffness: float, n_elements: int):
    """Sparse (CSR) stiffness root ``G`` (``2 n_elements x 2 (n_elements + 1)``) of the unconstrained beam:
    ``G^T G`` is :func:`assemble_free_beam`'s stiffness, two rows of :func:`element_root` per element."""
    g_e = element_root(length / n_elements, bending_stiffness)
    rows = np.repeat(2 * np.arange(n_elements)[:, None] + np.arange(2)[None, :], 4, axis=1).ravel()
    cols = np.tile(2 * np.arange(n_elements)[:, None] + np.arange(4)[None, :], (1, 2)).ravel()
    return scipy.sparse.csr_matrix(
        (np.tile(g_e.ravel(), n_elements), (rows, cols)), shape=(2 * n_elements, 2 * (n_elements + 1))
    )


def _kept_dofs(beam: Beam) -> np.ndarray:
    removed = [2 * 0 + j for j in BOUNDARY_CONDITIONS[beam.left]]
    removed += [2 * beam.n_elements + j for j in BOUNDARY_CONDITIONS[beam.right]]
    return np.setdiff1d(np.arange(2 * (beam.n_elements + 1)), removed)


def _constrained(beam: Beam, length: float, bending_stiffness: float, mass_per_length: float):
    """Stiffness, mass, stiffness root and kept DOFs of the beam with its end conditions."""
    stiffness, mass = assemble_free_beam(length, bending_stiffness, mass_per_length, beam.n_elements)
    root = free_beam_root(length, bending_stiffness, beam.n_elements)
    kept = _kept_dofs(beam)
    return stiffness[kept][:, kept].tocsr(), mass[kept][:, kept].tocsr(), root[:, kept].tocsr(), kept


def beam_scales(beam: Beam) -> dict:
    """Physical units of the nondimensional model of :func:`beam_structure`.

    Returns
    -------
    dict
        ``length`` (the gap of the first stop), ``angular_frequency`` (first linear no-contact angular
        frequency of the finite-element model, rigid-body modes left out, rad per physical time unit: the
        nondimensional time is
        ``angular_frequency * t``), ``stiffness`` (``EI / L**3``, the unit of stop stiffness and eta),
        ``rotation`` (``gap / L``, the unit of rotations) and ``position`` (``L``, unit of the node
        coordinates).
    """
    unit_k, unit_m, unit_root, _ = _constrained(beam, 1.0, 1.0, 1.0)
    rigid = rigid_body_modes(beam.left, beam.right)
    # a held beam solves through its stiffness root (fine meshes: docs/reduction.md)
    root = unit_root if rigid == 0 else None
    lam1 = generalized_modes(unit_m, unit_k, rigid + 1, root=root)[0][rigid] ** 2  # first flexible eigenvalue
    length, ei, rho_a = beam.length, beam.bending_stiffness, beam.mass_per_length
    return {
        "length": beam.stops[0].gap,
        "angular_frequency": float(np.sqrt(lam1 * ei / (rho_a * length**4))),
        "stiffness": ei / length**3,
        "rotation": beam.stops[0].gap / length,
        "position": length,
        "first_eigenvalue_unit_beam": float(lam1),
    }


def beam_structure(beam: Beam) -> Structure:
    """The nondimensional :class:`Structure` of ``beam`` (docs/methods/beam.md).

    Displacements are divided by the gap ``e`` of the first stop, rotations by ``e / L``, time is
    multiplied by the first linear no-contact angular frequency ``omega_1`` of the finite-element model and
    forces are divided by ``e EI / L**3``. The stiffness matrix is then that of the unit beam
    (``L = EI = 1``), the mass matrix that of the unit beam times ``lambda_1`` (its first eigenvalue), so the
    first linear angular frequency is exactly 1. Stop stiffness and eta become ``K L**3 / EI``, gaps
    ``gap / e``. Degrees of freedom are the (displacement, rotation) pairs of the nodes left after the end
    conditions, labelled ``w<i>`` and ``theta<i>``; the stop degrees of freedom are the displacements of the
    stop nodes. A beam bending in two planes has those of the second plane after them, ``v<i>`` and ``psi<i>``
    (the same matrices: an isotropic section); when every stop is a circular clearance the structure is invariant
    under the rotations about the beam's axis, which turn each pair (``w<i>``, ``v<i>``), (``theta<i>``,
    ``psi<i>``) together (``Structure.rotation_pairs``).
    """
    unit_k, unit_m, unit_root, kept = _constrained(beam, 1.0, 1.0, 1.0)
    scales = beam_scales(beam)
    position = {int(d): i for i, d in enumerate(kept)}
    n = len(kept)
    stops = []
    for stop, node in zip(beam.stops, beam.stop_nodes):
        law = {"kind": stop.kind, "side": stop.side} if stop.kind == "one_sided" else {}
        where = {"dof": position[2 * node]}
        if stop.kind == "circular":
            law, where = {"kind": "circular"}, {"dofs": [position[2 * node], n + position[2 * node]]}
        stops.append(
            Stop(
                **where,
                gap=stop.gap / scales["length"],
                stiffness=stop.stiffness / scales["stiffness"],
                eta=stop.eta / scales["stiffness"],
                **law,
            )
        )
    mass, stiffness = unit_m * scales["first_eigenvalue_unit_beam"], unit_k
    labels = [PLANE_LABELS[0][d % 2] + str(d // 2) for d in kept]
    nodes = [int(d) // 2 for d in kept]
    pairs = None
    root = unit_root if rigid_body_modes(beam.left, beam.right) == 0 else None
    if beam.planes == 2:
        mass, stiffness = (scipy.sparse.block_diag([a, a], format="csr") for a in (mass, stiffness))
        root = None if root is None else scipy.sparse.block_diag([root, root], format="csr")
        labels += [PLANE_LABELS[1][d % 2] + str(d // 2) for d in kept]
        nodes += nodes
        if all(stop.kind == "circular" for stop in beam.stops):
            pairs = tuple((i, n + i) for i in range(n))
    return Structure(
        mass=mass,
        stiffness=stiffness,
        stops=tuple(stops),
        dof_labels=tuple(labels),
        node_coordinates=beam.node_coordinates / beam.length,
        dof_nodes=tuple(nodes),
        attributes=beam_attributes(beam, scales, stops[0]),
        rotation_pairs=pairs,
        stiffness_root=root,
    )


#: Analytical (Euler-Bernoulli) linear frequencies recorded in a beam's attributes.
EULER_BERNOULLI_MODES = 10


def beam_attributes(beam: Beam, scales: dict, first_stop: Stop) -> dict:
    """Global attributes describing a beam: its physical data, stops and the units of its nondimensional model."""
    return {
        "structure": "beam",
        "length_m": beam.length,
        "bending_stiffness_N_m2": beam.bending_stiffness,
        "mass_per_length_kg_per_m": beam.mass_per_length,
        "elements": beam.n_elements,
        "left_end": beam.left,
        "right_end": beam.right,
        **({"planes": 2} if beam.planes == 2 else {}),
        "stop_nodes": np.array(beam.stop_nodes, dtype=np.int32),
        "stop_gap_m": np.array([s.gap for s in beam.stops]),
        "stop_stiffness_N_per_m": np.array([s.stiffness for s in beam.stops]),
        "stop_eta_N_per_m": np.array([s.eta for s in beam.stops]),
        **(
            {"stop_kinds": " ".join(f"{s.kind}:{s.side}" if s.kind == "one_sided" else s.kind for s in beam.stops)}
            if any(s.kind != "bilateral" for s in beam.stops)
            else {}
        ),
        "alpha": float(first_stop.stiffness),
        "eta": float(first_stop.eta),
        "length_unit_m": scales["length"],
        "angular_frequency_unit_rad_per_s": scales["angular_frequency"],
        # the continuous beam's linear frequencies, rigid-body modes left out, in Hz of the nondimensional time
        "euler_bernoulli_frequency": euler_bernoulli_frequencies(
            beam.left, beam.right, EULER_BERNOULLI_MODES, beam.length, beam.bending_stiffness, beam.mass_per_length
        )
        / (2 * np.pi * scales["angular_frequency"]),
    }


def beam_deflection(structure: Structure, q, s, plane: int = 1) -> np.ndarray:
    """Transverse displacement along the beam from degree-of-freedom vectors, by the Hermite shape functions.

    Parameters
    ----------
    structure : Structure
        From :func:`beam_structure` (uses its ``dof_labels``, ``dof_nodes`` and ``node_coordinates``).
    q : array_like, shape (..., N)
        Degree-of-freedom vectors (nondimensional: displacements over the gap, rotations over gap / L).
    s : array_like, shape (m,)
        Nondimensional positions ``s / L`` in ``[0, 1]``.
    plane : {1, 2}
        The displacement in the first plane (``w``, DOFs ``w<i>``, ``theta<i>``) or in the second (``v``, DOFs
        ``v<i>``, ``psi<i>``) of a beam bending in two.

    Returns
    -------
    ndarray, shape (..., m)
        Nondimensional displacement ``w / gap`` (``v / gap``) at ``s`` (constrained degrees of freedom are 0).
    """
    if plane not in (1, 2):
        raise ValueError(f"plane must be 1 or 2, got {plane!r}")
    displacement, rotation = PLANE_LABELS[plane - 1]
    if structure.dof_labels is None or structure.dof_nodes is None or structure.node_coordinates is None:
        raise ValueError("beam_deflection needs a structure from beam_structure (labels, nodes and coordinates)")
    nodes = structure.node_coordinates
    q = np.asarray(q, dtype=float)
    s = np.asarray(s, dtype=float)
    if q.shape[-1] != structure.n_dofs:
        raise ValueError(f"q must have {structure.n_dofs} degrees of freedom on its last axis, got shape {q.shape}")
    if s.ndim != 1 or np.any(s < nodes[0]) or np.any(s > nodes[-1]):
        raise ValueError(f"s must be a 1-D array of positions in [{nodes[0]}, {nodes[-1]}]")
    nodal = np.zeros(q.shape[:-1] + (len(nodes), 2))  # (w, theta) at every node, 0 where constrained
    for k, (label, node) in enumerate(zip(structure.dof_labels, structure.dof_nodes)):
        name = label.rstrip("0123456789")
        if name in (displacement, rotation):
            nodal[..., node, 0 if name == displacement else 1] = q[..., k]
    element = np.clip(np.searchsorted(nodes, s, side="right") - 1, 0, len(nodes) - 2)
    h = nodes[element + 1] - nodes[element]
    xi = (s - nodes[element]) / h
    shape = np.stack(
        [1 - 3 * xi**2 + 2 * xi**3, h * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, h * (xi**3 - xi**2)]
    )
    left, right = nodal[..., element, :], nodal[..., element + 1, :]
    return shape[0] * left[..., 0] + shape[1] * left[..., 1] + shape[2] * right[..., 0] + shape[3] * right[..., 1]


# --------------------------------------------------------------------------- analytical frequencies


def _clamped_free(x):
    return np.cos(x) + 1.0 / np.cosh(x)  # cos cosh + 1 = 0, divided by cosh


def _clamped_clamped(x):
    return np.cos(x) - 1.0 / np.cosh(x)  # cos cosh - 1 = 0, divided by cosh


def _clamped_pinned(x):
    return np.sin(x) - np.cos(x) * np.tanh(x)  # tan = tanh, times cos


# For each pair of end conditions: characteristic function of beta L, the bracket of its n-th positive root
# (n = 1, 2, ...), and the number of rigid-body modes (frequency 0) that the roots leave out.
_CHARACTERISTIC = {
    frozenset(["clamped", "free"]): (_clamped_free, lambda n: ((n - 1) * np.pi, n * np.pi), 0),
    frozenset(["clamped"]): (_clamped_clamped, lambda n: (n * np.pi, (n + 1) * np.pi), 0),
    frozenset(["free"]): (_clamped_clamped, lambda n: (n * np.pi, (n + 1) * np.pi), 2),
    frozenset(["pinned"]): (None, None, 0),
    frozenset(["clamped", "pinned"]): (_clamped_pinned, lambda n: (n * np.pi, (n + 0.5) * np.pi), 0),
    frozenset(["pinned", "free"]): (_clamped_pinned, lambda n: (n * np.pi, (n + 0.5) * np.pi), 1),
}


def rigid_body_modes(left_bc: str, right_bc: str) -> int:
    """Number of rigid-body (zero-frequency) modes of a beam with these end conditions: 2 free-free, 1 pinned-free."""
    return _CHARACTERISTIC[frozenset([left_bc, right_bc])][2]


def euler_bernoulli_frequencies(
    left_bc: str, right_bc: str, n_modes: int, length: float, EI: float, rhoA: float
) -> np.ndarray:
    """Angular frequencies of the continuous Euler-Bernoulli beam, from the characteristic equations.

    ``omega_n = (beta_n L)**2 sqrt(EI / (rhoA L**4))`` with ``beta_n L`` the n-th positive root of

    * clamped-free: ``cos x cosh x + 1 = 0``;
    * clamped-clamped and free-free: ``cos x cosh x - 1 = 0``;
    * pinned-pinned: ``sin x = 0`` (``x = n pi``);
    * clamped-pinned and pinned-free: ``tan x = tanh x``.

    The equations are divided by ``cosh x`` before the root search (Brent's method on brackets of width
    at most ``pi`` that hold exactly one root), which keeps them well scaled for high modes. Rigid-body modes
    (two for free-free, one for pinned-free) are **not** included: mode 1 is the first flexible mode.
    The order of the two ends does not matter.

    Returns
    -------
    ndarray, shape (n_modes,)
        Increasing angular frequencies (rad per time unit of ``EI`` and ``rhoA``).
    """
    for name, bc in (("left_bc", left_bc), ("right_bc", right_bc)):
        if bc not in BOUNDARY_CONDITIONS:
            raise ValueError(f"{name} must be one of {sorted(BOUNDARY_CONDITIONS)}, got {bc!r}")
    if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) or n_modes < 1:
        raise ValueError(f"n_modes must be an integer >= 1, got {n_modes!r}")
    length, EI, rhoA = (_positive(n, v) for n, v in (("length", length), ("EI", EI), ("rhoA", rhoA)))
    fun, bracket, _ = _CHARACTERISTIC[frozenset([left_bc, right_bc])]
    n = np.arange(1, n_modes + 1)
    if fun is None:
        roots = n * np.pi
    else:
        roots = np.array([scipy.optimize.brentq(fun, *bracket(k), xtol=1e-15, rtol=4 * np.finfo(float).eps) for k in n])
    return roots**2 * np.sqrt(EI / (rhoA * length**4))


def mode_frequencies(beam: Beam, n_modes: int) -> dict:
    """Linear (no-contact) frequencies of the first ``n_modes`` flexible modes, FE and analytical, in Hz of the
    nondimensional time of :func:`beam_structure` (mode 1 of the FE model is ``1 / (2 pi)``).

    For dataset attributes: ``{"fe": ..., "euler_bernoulli": ...}``, arrays of shape ``(n_modes,)``; the
    analytical ones are those of the continuous beam with the same end conditions, rigid-body modes left out.
    """
    rigid = rigid_body_modes(beam.left, beam.right)
    structure = beam_structure(beam)
    fe = linear_frequencies(structure, rigid + n_modes)[rigid:]
    exact = (
        euler_bernoulli_frequencies(
            beam.left, beam.right, n_modes, beam.length, beam.bending_stiffness, beam.mass_per_length
        )
        / beam_scales(beam)["angular_frequency"]
    )
    return {"fe": fe / (2 * np.pi), "euler_bernoulli": exact / (2 * np.pi)}


# --------------------------------------------------------------------------- default scene


def default_tube_parameters() -> dict:
    """The default scene: a steam-generator tube span clamped at its foot, free at its top, guided by a plate.

    Physical values (SI) of a 19.05 mm x 1.09 mm alloy tube filled with water: ``EI`` about 500 N m^2,
    ``rho A`` about 0.7 kg/m, over 1 m, 10 elements. The support plate at 0.6 m (node 6) leaves a radial
    clearance of 0.2 mm; its stiffness is 30 times the static stiffness of the cantilever at the plate
    (``3 EI / a**3``), as ``alpha = 30`` in the paper; eta is 1/300 of it (``eta / alpha`` of the paper).
    In the nondimensional model this gives ``alpha = 30 * 3 / 0.6**3 = 416.7`` and ``eta = 1.389``.
    """
    length, ei, plate = 1.0, 500.0, 0.6
    stiffness = 30.0 * 3.0 * ei / plate**3
    return {
        "length": length,
        "bending_stiffness": ei,
        "mass_per_length": 0.7,
        "n_elements": 10,
        "left": "clamped",
        "right": "free",
        "stops": [{"position": plate, "gap": 2e-4, "stiffness": stiffness, "eta": stiffness / 300.0}],
    }


def tube_plates_parameters(n_elements: int = 100) -> dict:
    """A tube on three support plates: the scene of ``tube_plates`` (config/config.yaml) at any mesh size.

    The tube of :func:`default_tube_parameters` (19.05 mm x 1.09 mm, water-filled: ``EI = 500 N m^2``,
    ``rho A = 0.7 kg/m``, 1 m) clamped at its foot and pinned at its top (the U-bend's support), through three
    plates at 0.5, 0.25 and 0.75 m, each a bilateral stop with a radial clearance of 0.2 mm, stiffness 3 times
    the cantilever's static stiffness at the plate (``9 EI / a**3``) and eta = stiffness / 300. The middle
    plate comes first: NNM1 moves it most, and the first stop carries the branch's amplitude and phase.
    ``n_elements`` must be a multiple of 4 (plates on nodes).
    """
    if isinstance(n_elements, bool) or not isinstance(n_elements, (int, np.integer)) or n_elements % 4:
        raise ValueError(f"n_elements must be a multiple of 4 (plates at L/4, L/2, 3L/4 on nodes), got {n_elements!r}")
    ei = 500.0
    stops = [
        {"position": a, "gap": 2e-4, "stiffness": 9.0 * ei / a**3, "eta": 9.0 * ei / a**3 / 300.0}
        for a in (0.5, 0.25, 0.75)
    ]
    return {
        "length": 1.0,
        "bending_stiffness": ei,
        "mass_per_length": 0.7,
        "n_elements": int(n_elements),
        "left": "clamped",
        "right": "pinned",
        "stops": stops,
    }
