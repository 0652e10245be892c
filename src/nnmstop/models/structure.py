"""The structure as a parameter of the engines: mass, stiffness and the degrees of freedom that meet a stop.

A :class:`Structure` describes ``M q'' + K q + sum_s gap_s A_s^T f_s(A_s q / gap_s) = 0`` in nondimensional
form: symmetric ``M`` (positive definite) and ``K`` (dense or scipy.sparse), and one or more stops
(:class:`~nnmstop.models.contact.Stop`: bilateral, one-sided, relative or circular, :mod:`nnmstop.models.contact`),
each reading its coordinates ``A_s q`` with its gap, stiffness ``alpha`` and regularization ``eta``. The paper's
oscillator is :func:`two_dof_structure`; a finite-element beam is built by :mod:`nnmstop.models.beam`.
:func:`normal_modes` solves the generalized eigenproblem of the linear (no-contact) structure, densely for
small models and by shift-invert Lanczos for large sparse ones; :func:`limit_modes` the linear limits of any
structure (no contact, regularized near rest, gap 0).
A structure carries ``attributes``: what describes it in a dataset's global attributes (the paper's
``alpha``, ``beta``, ``delta``, ``eta``; a beam's length and units; the files of a user's matrices).
Physics that exists only for the paper's oscillator takes a structure through
:func:`two_dof_parameters`, which says clearly which structures it does not support.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from nnmstop.models.contact import BilateralStop, Stop, StopSet
from nnmstop.models.stiffness_root import RootSolver, check_root
from nnmstop.models.two_dof import ModelParameters, mass_matrix, stiffness_matrix

__all__ = [
    "Stop",
    "Structure",
    "two_dof_structure",
    "two_dof_parameters",
    "generalized_modes",
    "normal_modes",
    "linear_frequencies",
    "LINEAR_LIMITS",
    "limit_stiffness",
    "limit_modes",
    "check_matrix",
    "check_grounded",
]

#: Relative asymmetry ``max|A - A^T| / max|A|`` accepted as round-off.
SYMMETRY_TOLERANCE = 1e-12
#: Largest model solved by dense ``eigh`` in :func:`normal_modes`; sparse shift-invert above.
DENSE_EIGEN_LIMIT = 400


def _check_shared_dofs(stops) -> None:
    """Stops may share a degree of freedom only when they are all one-sided stops on it (unequal gaps, stops in
    series): a bilateral, relative or circular stop reads degrees of freedom no other stop reads."""
    readers = {}
    for k, stop in enumerate(stops):
        for dof in stop.dofs:
            readers.setdefault(dof, []).append(k)
    for dof, ks in readers.items():
        if len(ks) > 1 and not all(stops[k].kind == "one_sided" for k in ks):
            kinds = ", ".join(stops[k].kind for k in ks)
            listed = [list(stop.dofs) if len(stop.dofs) > 1 else stop.dofs[0] for stop in stops]
            raise ValueError(
                f"stops must act on distinct degrees of freedom, got dofs {listed}: stops {ks} ({kinds}) act on "
                f"degree of freedom {dof}; only one-sided stops may share one (unequal gaps: two one-sided stops)"
            )


def _square_matrix(name: str, matrix):
    """Float CSR or dense copy of ``matrix``, checked square, finite and symmetric."""
    if scipy.sparse.issparse(matrix):
        matrix = scipy.sparse.csr_matrix(matrix, dtype=float)
        values = matrix.data
    else:
        matrix = np.array(matrix, dtype=float)
        values = matrix
    if matrix.ndim != 2 or matrix.shape[0] != matrix.shape[1] or matrix.shape[0] == 0:
        raise ValueError(f"{name} must be a non-empty square matrix, got shape {matrix.shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{name} must be finite")
    scale = np.abs(values).max() if values.size else 0.0
    asym = abs(matrix - matrix.T)
    asym = asym.max() if scipy.sparse.issparse(asym) else np.max(asym)
    if asym > SYMMETRY_TOLERANCE * scale:
        raise ValueError(
            f"{name} must be symmetric to round-off, got max|A - A^T| = {asym:.3e} for max|A| = {scale:.3e}"
        )
    return matrix


def _lower_band(matrix) -> np.ndarray:
    """Lower banded storage (rows = diagonals) of a symmetric matrix, for ``scipy.linalg.cholesky_banded``."""
    coo = scipy.sparse.coo_matrix(matrix)
    lower = coo.row >= coo.col
    rows, cols, vals = coo.row[lower], coo.col[lower], coo.data[lower]
    width = int((rows - cols).max()) if rows.size else 0
    band = np.zeros((width + 1, matrix.shape[0]))
    np.add.at(band, (rows - cols, cols), vals)
    return band


#: Largest banded storage (entries) of a sparse matrix checked by a banded Cholesky; above, by a sparse LDL^T.
BAND_ENTRIES_LIMIT = 10_000_000


def _bandwidth(matrix) -> int:
    coo = scipy.sparse.coo_matrix(matrix)
    return int(np.abs(coo.row - coo.col).max()) if coo.nnz else 0


def sparse_inertia_positive(matrix) -> bool:
    """Whether a symmetric sparse matrix is positive definite, by a sparse ``L D L^T`` in a fill-reducing order.

    SuperLU factors ``P A P^T = L U`` with a symmetric ordering (minimum degree on ``A + A^T``) and the diagonal
    always taken as pivot (``diag_pivot_thresh = 0``): then ``U = D L^T`` and, by Sylvester's law of inertia,
    ``A`` is positive definite exactly when every pivot ``D`` is > 0. A zero pivot forces a row interchange
    (``perm_r != perm_c``), which an SPD matrix never needs. Time and memory follow the factor's fill: linear in
    the size for banded finite-element matrices, whatever order their DOFs come in.
    """
    matrix = scipy.sparse.csc_matrix(matrix, dtype=float)
    try:
        factor = scipy.sparse.linalg.splu(
            matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
        )
    except RuntimeError:  # exactly singular
        return False
    if not np.array_equal(factor.perm_r, factor.perm_c):
        return False
    return bool(np.all(factor.U.diagonal() > 0))


def _is_positive_definite(matrix) -> bool:
    """Banded Cholesky for dense or narrow-band matrices, :func:`sparse_inertia_positive` for wide sparse ones."""
    if scipy.sparse.issparse(matrix) and (_bandwidth(matrix) + 1) * matrix.shape[0] > BAND_ENTRIES_LIMIT:
        return sparse_inertia_positive(matrix)
    try:
        scipy.linalg.cholesky_banded(_lower_band(matrix), lower=True)
    except np.linalg.LinAlgError:
        return False
    return True


def _check_positive_definite(name: str, matrix) -> None:
    if not _is_positive_definite(matrix):
        raise ValueError(f"{name} must be positive definite (its Cholesky factorization fails)")


def check_matrix(name: str, matrix, positive_definite: bool = False):
    """``matrix`` as float CSR or dense, checked square, finite, symmetric and, if asked, positive definite.

    Raises
    ------
    ValueError
        Naming ``name`` and what is wrong.
    """
    matrix = _square_matrix(name, matrix)
    if positive_definite:
        _check_positive_definite(name, matrix)
    return matrix


def check_grounded(structure: Structure, where: str = "the structure") -> None:
    """Refuse a structure that can move as a rigid body without touching a stop.

    Its regularized linear limit near rest, ``K + sum_s eta_s A_s^T A_s`` (:func:`limit_stiffness`), must be
    positive definite: otherwise a zero-frequency mode (e.g. a beam free at both ends) leaves the NNMs
    undefined and every Newton solve singular.

    Raises
    ------
    ValueError
        Naming ``where``.
    """
    try:
        _check_positive_definite("K + sum eta e e^T", limit_stiffness(structure, "regularized"))
    except ValueError:
        raise ValueError(
            f"{where}: the stiffness near rest (K plus each stop's eta on its coordinates) is singular or "
            "not positive definite: the structure can move as a rigid body without touching a stop (a beam free "
            "at both ends, an unsupported chain); support it (a clamped or pinned end, a grounding spring)"
        ) from None


@dataclass(frozen=True, eq=False)
class Structure:
    """Mass, stiffness and stops of ``M q'' + K q + sum_s gap_s A_s^T f_s(A_s q / gap_s) = 0`` (nondimensional).

    Parameters
    ----------
    mass, stiffness : ndarray or scipy.sparse matrix, shape (N, N)
        Symmetric to round-off; ``mass`` positive definite. Sparse input is kept as CSR.
    stops : sequence of Stop
        At least one (:mod:`nnmstop.models.contact`), on degrees of freedom in ``[0, N)``; stops act on distinct
        degrees of freedom except one-sided stops, which may share theirs (unequal gaps).
    dof_labels : sequence of str, optional
        A name for each degree of freedom (``N`` of them), for datasets.
    node_coordinates : array_like, optional
        Coordinates of the mesh nodes (finite-element models), for datasets.
    dof_nodes : sequence of int, optional
        Node index of each degree of freedom (``N`` of them), into ``node_coordinates``.
    attributes : mapping, optional
        What describes the structure in a dataset's global attributes (names to numbers, strings or
        1-D arrays): ``structure`` names its kind (``"two_dof"``, ``"beam"``, ``"matrices"``), and e.g.
        the paper's ``alpha``, ``beta``, ``delta``, ``eta``. Nothing in the engines reads them.
    reduction : nnmstop.models.reduction.Reduction, optional
        Set on a reduced structure (:func:`nnmstop.models.reduction.craig_bampton`): the recovery matrix back
        to the full model's DOFs and what the reduction kept. Nothing in the engines reads it.
    rotation_pairs : sequence of (int, int), optional
        Declares the structure invariant under the rotations of a plane (an isotropic structure in a circular
        hole): rotating every pair ``(q_i, q_j)`` by one angle leaves ``M``, ``K`` and the stops unchanged. Its
        NNMs then come in circles of rotated orbits, which the harmonic balance fixes by a rotation phase
        condition (:mod:`nnmstop.hbm.system`, ``docs/methods/circular_clearance.md``). Checked: ``M`` and ``K``
        commute with the rotation generator :attr:`rotation_generator` to round-off, every stop that reads a
        rotated DOF is a circular clearance on one of the pairs.
    stiffness_root : scipy.sparse matrix, shape (m, N), optional
        ``G`` with ``K = G^T G`` (:mod:`nnmstop.models.stiffness_root`: the element strains), for a held
        structure (no rigid-body mode). Where it is given, the linear modes and the reduction solve through
        it, losing the condition of ``G`` instead of that of ``K`` (its square): what keeps a fine beam mesh
        accurate. Checked: ``G^T G`` equals ``K`` to round-off.

    Examples
    --------
    The 3-DOF grounded chain with one stop on its first mass:

    >>> import numpy as np
    >>> chain = Structure(np.eye(3), [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]],
    ...                   [Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)])
    >>> chain.n_dofs, chain.stop_dofs, chain.dof_labels
    (3, (0,), ('q0', 'q1', 'q2'))
    """

    mass: object
    stiffness: object
    stops: tuple
    dof_labels: tuple | None = None
    node_coordinates: np.ndarray | None = None
    dof_nodes: tuple | None = None
    attributes: dict | None = None
    reduction: object | None = None
    rotation_pairs: tuple | None = None
    stiffness_root: object | None = None

    def __post_init__(self):
        mass = _square_matrix("mass", self.mass)
        stiffness = _square_matrix("stiffness", self.stiffness)
        if mass.shape != stiffness.shape:
            raise ValueError(f"mass and stiffness must have the same shape, got {mass.shape} and {stiffness.shape}")
        _check_positive_definite("mass", mass)
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "stiffness", stiffness)
        n = mass.shape[0]
        stops = (self.stops,) if isinstance(self.stops, Stop) else tuple(self.stops)
        if not stops:
            raise ValueError("a structure needs at least one stop, got none")
        for stop in stops:
            if not isinstance(stop, Stop):
                raise TypeError(f"stops must be Stop instances, got {stop!r}")
            for dof in stop.dofs:
                if dof >= n:
                    raise ValueError(f"stop dof {dof} is out of range for {n} degrees of freedom (0..{n - 1})")
        _check_shared_dofs(stops)
        object.__setattr__(self, "stops", stops)
        labels = tuple(f"q{j}" for j in range(n)) if self.dof_labels is None else tuple(map(str, self.dof_labels))
        if len(labels) != n or len(set(labels)) != n:
            raise ValueError(f"dof_labels must give the {n} degrees of freedom distinct names, got {labels}")
        object.__setattr__(self, "dof_labels", labels)
        object.__setattr__(self, "attributes", dict(self.attributes or {}))
        if self.node_coordinates is not None:
            coords = np.array(self.node_coordinates, dtype=float)
            if coords.ndim != 1 or not np.all(np.isfinite(coords)):
                raise ValueError(f"node_coordinates must be a finite 1-D array, got shape {coords.shape}")
            coords.setflags(write=False)
            object.__setattr__(self, "node_coordinates", coords)
        if self.dof_nodes is not None:
            nodes = tuple(int(k) for k in self.dof_nodes)
            n_nodes = None if self.node_coordinates is None else len(self.node_coordinates)
            if len(nodes) != n or (n_nodes is not None and any(not 0 <= k < n_nodes for k in nodes)):
                raise ValueError(f"dof_nodes must give a valid node index for each of the {n} degrees of freedom")
            object.__setattr__(self, "dof_nodes", nodes)
        if self.reduction is not None and self.reduction.recovery.shape[1] != n:
            raise ValueError(
                f"the reduction's recovery matrix has {self.reduction.recovery.shape[1]} columns, not the {n} DOFs"
            )
        if self.rotation_pairs is not None:
            object.__setattr__(self, "rotation_pairs", _checked_rotation_pairs(self, self.rotation_pairs))
        if self.stiffness_root is not None:
            object.__setattr__(self, "stiffness_root", check_root(self.stiffness_root, stiffness))

    @property
    def n_dofs(self) -> int:
        """Number of degrees of freedom ``N``."""
        return self.mass.shape[0]

    @property
    def stop_dofs(self) -> tuple:
        """The (first) degree of freedom each stop reads, in the order of ``stops``."""
        return tuple(s.dofs[0] for s in self.stops)

    @functools.cached_property
    def contact(self) -> StopSet:
        """The stops as the engines see them (:class:`~nnmstop.models.contact.StopSet`)."""
        return StopSet(self.stops, self.n_dofs)

    @functools.cached_property
    def rotation_generator(self):
        """The generator ``J`` of the rotations declared by :attr:`rotation_pairs` (sparse CSR, ``(N, N)``), None
        without them: ``J q`` is ``(-q_j, q_i)`` on each pair ``(i, j)`` and 0 elsewhere, the velocity of the DOFs
        under a rotation of unit angular speed."""
        if self.rotation_pairs is None:
            return None
        return _rotation_matrix(self.rotation_pairs, self.n_dofs)

    @property
    def is_sparse(self) -> bool:
        """Whether the matrices are stored sparse."""
        return scipy.sparse.issparse(self.mass)

    def dense_matrices(self) -> tuple:
        """``(M, K)`` as dense arrays (copies)."""
        return tuple(a.toarray() if scipy.sparse.issparse(a) else a.copy() for a in (self.mass, self.stiffness))


def _rotation_matrix(pairs, n: int):
    rows, cols, vals = [], [], []
    for i, j in pairs:
        rows += [i, j]
        cols += [j, i]
        vals += [-1.0, 1.0]
    return scipy.sparse.csr_matrix((vals, (rows, cols)), shape=(n, n))


def _checked_rotation_pairs(structure: Structure, pairs) -> tuple:
    """``pairs`` as a tuple of int pairs, checked against the structure (see ``Structure.rotation_pairs``)."""
    n = structure.n_dofs
    try:
        pairs = tuple((int(i), int(j)) for i, j in pairs)
    except (TypeError, ValueError):
        raise ValueError(
            f"rotation_pairs must be a sequence of pairs of degrees of freedom [i, j], got {pairs!r}"
        ) from None
    flat = [d for pair in pairs for d in pair]
    if not pairs or any(not 0 <= d < n for d in flat) or len(set(flat)) != len(flat):
        raise ValueError(
            f"rotation_pairs must pair distinct degrees of freedom in 0..{n - 1}, each at most once, got {list(pairs)}"
        )
    J = _rotation_matrix(pairs, n)
    for name, symbol, matrix in (("mass", "M", structure.mass), ("stiffness", "K", structure.stiffness)):
        commutator = J @ matrix - matrix @ J
        commutator = abs(scipy.sparse.csr_matrix(commutator)).max()
        scale = abs(scipy.sparse.csr_matrix(matrix)).max()
        if commutator > 1e-10 * scale:
            raise ValueError(
                f"rotation_pairs {list(pairs)}: the {name} matrix is not invariant under their rotations "
                f"(max |J {symbol} - {symbol} J| = {commutator:.3e} for max |{symbol}| = {scale:.3e}): the structure "
                "is not isotropic in those planes"
            )
    rotated = set(flat)
    for k, stop in enumerate(structure.stops):
        if not rotated.intersection(stop.dofs):
            continue
        if stop.kind != "circular" or tuple(sorted(stop.dofs)) not in {tuple(sorted(p)) for p in pairs}:
            raise ValueError(
                f"rotation_pairs {list(pairs)}: stop {k} ({stop.label}) is not invariant under their rotations: a stop "
                "on rotated degrees of freedom must be a circular clearance on one of the pairs"
            )
    return pairs


def two_dof_structure(params: ModelParameters | None = None) -> Structure:
    """The paper's oscillator (Eqs. 3-4) as a :class:`Structure`.

    ``q = (x, u)``, ``M = diag(1, delta)``, ``K = [[1 + beta, -beta], [-beta, beta]]`` and one stop on ``x``
    with gap 1, stiffness ``alpha`` and regularization ``eta``. ``params`` defaults to the paper's values
    (alpha = 30, beta = 1, delta = 1, eta = 0.1); they become the structure's ``attributes``.

    Examples
    --------
    >>> s = two_dof_structure(ModelParameters(alpha=10.0))
    >>> s.dof_labels, s.stops[0].stiffness, s.attributes["structure"]
    (('x', 'u'), 10.0, 'two_dof')
    """
    params = ModelParameters() if params is None else params
    stop = Stop(dof=0, gap=1.0, stiffness=params.alpha, eta=params.eta)
    attributes = {"structure": "two_dof", **params.as_attrs()}
    return Structure(
        mass_matrix(params), stiffness_matrix(params), (stop,), dof_labels=("x", "u"), attributes=attributes
    )


def _dense(matrix) -> np.ndarray:
    return matrix.toarray() if scipy.sparse.issparse(matrix) else np.asarray(matrix, dtype=float)


def two_dof_parameters(structure: Structure, purpose: str = "this method") -> ModelParameters:
    """The :class:`ModelParameters` of a structure that is the paper's oscillator, for 2-DOF-only physics.

    The closed-form exact multi-impact family and the comparisons built on it exist only for the
    oscillator of :func:`two_dof_structure`: two degrees of freedom, ``M = diag(1, delta)``,
    ``K = [[1 + beta, -beta], [-beta, beta]]``, one stop on the first with gap 1.

    Raises
    ------
    ValueError
        Naming ``purpose`` and what the structure has instead.
    """
    if not isinstance(structure, Structure):
        raise TypeError(f"structure must be a Structure, got {type(structure).__name__}")
    stop = structure.stops[0]
    shape = f"{structure.n_dofs} degrees of freedom and {len(structure.stops)} stop(s)"
    if (
        structure.n_dofs == 2
        and len(structure.stops) == 1
        and isinstance(stop, BilateralStop)
        and stop.dof == 0
        and stop.gap == 1.0
    ):
        mass, stiffness = _dense(structure.mass), _dense(structure.stiffness)
        beta, delta = float(stiffness[1, 1]), float(mass[1, 1])
        if beta > 0 and delta > 0:
            params = ModelParameters(alpha=stop.stiffness, beta=beta, delta=delta, eta=stop.eta)
            if np.array_equal(mass, mass_matrix(params)) and np.array_equal(stiffness, stiffness_matrix(params)):
                return params
        shape += " whose matrices are not those of the paper's oscillator"
    raise ValueError(
        f"{purpose} exists only for the paper's 2-DOF oscillator (two_dof_structure: M = diag(1, delta), "
        f"K = [[1 + beta, -beta], [-beta, beta]], one stop on x with gap 1); this structure has {shape}"
    )


def generalized_modes(mass, stiffness, n_modes: int, root=None):
    """The ``n_modes`` lowest solutions of ``K phi = omega**2 M phi`` (``M``, ``K`` dense or sparse, symmetric).

    Both paths solve for the largest ``1 / (lambda - sigma)`` (``sigma = 0``, or a small negative shift when
    ``K`` is singular): dense ``eigh`` up to :data:`DENSE_EIGEN_LIMIT` degrees of freedom, shift-invert Lanczos
    (``eigsh``) on sparse matrices above. With ``root`` (``K = G^T G``, positive definite), the sparse path
    inverts through :class:`~nnmstop.models.stiffness_root.RootSolver` and each ``omega**2`` is the Rayleigh
    quotient ``|G phi|^2`` of its mass-normalized shape (no cancellation).

    Returns
    -------
    omega : ndarray, shape (n_modes,)
        Increasing angular frequencies (rad per unit time); rigid-body modes give 0 up to round-off.
    shapes : ndarray, shape (N, n_modes)
        Mass-normalized mode shapes (``Phi^T M Phi = I``).
    """
    n = mass.shape[0]
    if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) or not 1 <= n_modes <= n:
        raise ValueError(f"n_modes must be an integer in [1, {n}], got {n_modes!r}")
    # Solve the inverse problem M phi = mu (K - sigma M) phi for its largest mu = 1 / (lambda - sigma): the
    # round-off on the low lambda is then relative to lambda itself, not to the largest eigenvalue as in a
    # direct solve (which loses about lambda_max / lambda_1 in relative accuracy: 1e-5 at 400 beam DOFs).
    # sigma = 0 when K is positive definite, a small negative shift when it has rigid-body modes.
    if root is not None or _is_positive_definite(stiffness):
        sigma = 0.0
    else:
        diag_k = stiffness.diagonal() if scipy.sparse.issparse(stiffness) else np.diag(stiffness)
        diag_m = mass.diagonal() if scipy.sparse.issparse(mass) else np.diag(mass)
        sigma = -1e-6 * np.abs(diag_k).max() / diag_m.max()
    sparse = scipy.sparse.issparse(mass) and scipy.sparse.issparse(stiffness)
    inverse = None
    if not sparse or n <= DENSE_EIGEN_LIMIT or n_modes >= n - 1:
        mass, stiffness = (a.toarray() if scipy.sparse.issparse(a) else np.asarray(a) for a in (mass, stiffness))
        mu, shapes = scipy.linalg.eigh(mass, stiffness - sigma * mass, subset_by_index=[n - n_modes, n - 1])
        mu, shapes = mu[::-1], shapes[:, ::-1]
        lam = sigma + 1.0 / mu
    else:
        mass, stiffness = scipy.sparse.csc_matrix(mass), scipy.sparse.csc_matrix(stiffness)
        if root is not None:  # the eigenvalues below become the Rayleigh quotients |G phi|^2
            inverse = scipy.sparse.linalg.LinearOperator((n, n), matvec=RootSolver(root).solve, dtype=float)
        # a fixed start vector: the same Lanczos run, hence the same signs of the modes, on every call
        lam, shapes = scipy.sparse.linalg.eigsh(
            stiffness, k=n_modes, M=mass, sigma=sigma, which="LM", v0=np.ones(n), OPinv=inverse
        )
        order = np.argsort(lam)
        lam, shapes = lam[order], shapes[:, order]
    shapes = shapes / np.sqrt(np.einsum("ij,ij->j", shapes, mass @ shapes))
    if inverse is not None:
        strains = root @ shapes
        lam = np.einsum("ij,ij->j", strains, strains)
    # Rigid-body modes have eigenvalue 0 up to round-off of the order of eps ||K|| ||M^-1||; clip the
    # negative ones.
    return np.sqrt(np.maximum(lam, 0.0)), shapes


def _mode_count(structure: Structure, n_modes) -> int:
    if n_modes is not None:
        return n_modes
    # every mode of a model solved densely; a large sparse model would need them all dense
    return structure.n_dofs if structure.n_dofs <= DENSE_EIGEN_LIMIT else min(6, structure.n_dofs)


def normal_modes(structure: Structure, n_modes: int | None = None):
    """The ``n_modes`` lowest linear (no-contact) modes of ``structure``, see :func:`generalized_modes`.

    ``n_modes`` defaults to every mode up to :data:`DENSE_EIGEN_LIMIT` degrees of freedom, the six
    lowest above.

    Examples
    --------
    >>> omega, shapes = normal_modes(two_dof_structure())
    >>> [round(float(w), 3) for w in omega], shapes.shape
    ([0.618, 1.618], (2, 2))
    """
    return generalized_modes(
        structure.mass, structure.stiffness, _mode_count(structure, n_modes), root=structure.stiffness_root
    )


def linear_frequencies(structure: Structure, n_modes: int | None = None) -> np.ndarray:
    """Angular frequencies (rad per unit time) of the lowest linear modes, see :func:`normal_modes`."""
    return normal_modes(structure, n_modes)[0]


#: The linear limits of a structure with stops (:func:`limit_modes`).
LINEAR_LIMITS = ("no_contact", "regularized", "gap_zero")


def limit_stiffness(structure: Structure, limit: str):
    """Stiffness matrix of a linear limit of ``structure`` (same storage as ``structure.stiffness``).

    ``"no_contact"``: ``K`` (every gap infinite); ``"regularized"``: ``K + sum_s k_s A_s^T A_s`` with each law's
    slope at rest ``k_s`` (:attr:`~nnmstop.models.contact.Stop.stiffness_at_rest`, ``eta_s``), the regularized
    structure near rest; ``"gap_zero"``: ``K + sum_s alpha_s A_s^T A_s``, every stop always engaged (the force of a
    stop is ``alpha_s (q - gap_s sgn q)``, of slope ``alpha_s`` whatever the gap). For a one-sided stop the gap-0
    structure is bilinear, not linear: this limit is its contact side (orbits that stay in contact), not the
    high-energy asymptote of its NNMs.
    """
    if limit not in LINEAR_LIMITS:
        raise ValueError(f"limit must be one of {LINEAR_LIMITS}, got {limit!r}")
    added = {
        "no_contact": [0.0 for _ in structure.stops],
        "regularized": [stop.stiffness_at_rest for stop in structure.stops],
        "gap_zero": [stop.engaged_stiffness for stop in structure.stops],
    }[limit]
    values, rows, cols = structure.contact.limit_entries(added)
    matrix = scipy.sparse.csr_matrix((values, (rows, cols)), shape=structure.stiffness.shape)
    if scipy.sparse.issparse(structure.stiffness):
        return (structure.stiffness + matrix).tocsr()
    return structure.stiffness + matrix.toarray()


def limit_modes(structure: Structure, limit: str = "no_contact", n_modes: int | None = None):
    """Angular frequencies and mass-normalized shapes of a linear limit of ``structure``.

    See :func:`limit_stiffness` for the limits and :func:`normal_modes` for ``n_modes``.

    Examples
    --------
    The paper's gap-0 modes (stop always engaged), 0.984 and 5.660 rad:

    >>> omega, _ = limit_modes(two_dof_structure(), "gap_zero")
    >>> [round(float(w), 3) for w in omega]
    [0.984, 5.66]
    """
    return generalized_modes(structure.mass, limit_stiffness(structure, limit), _mode_count(structure, n_modes))
