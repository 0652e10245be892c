"""A structure of one's own: mass and stiffness matrices read from files, and a list of stops.

:func:`load_matrix` reads a Matrix Market file (``.mtx``, :func:`scipy.io.mmread`) or a ``.npz`` archive
(one saved by :func:`scipy.sparse.save_npz`, or by :func:`numpy.savez` with a single array);
:func:`matrix_structure` builds the :class:`~nnmstop.models.structure.Structure` and says, naming the
file, what is wrong: not square, sizes that differ, not symmetric, a mass that is not positive
definite, a stop off the model, a structure free to move as a rigid body without touching a stop.
The matrices are the nondimensional ones (``docs/structures.md`` says how to make them so).

For example, the 3-DOF chain of ``examples/three_dof_chain``:

>>> import numpy as np, scipy.io, tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> scipy.io.mmwrite(folder / "M.mtx", np.eye(3))
>>> scipy.io.mmwrite(folder / "K.mtx", np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 1]]))
>>> chain = matrix_structure(folder / "M.mtx", folder / "K.mtx", [{"dof": 0, "gap": 1.0, "stiffness": 30.0,
...                                                                  "eta": 0.1}])
>>> chain.n_dofs, chain.attributes["structure"]
(3, 'matrices')
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse

from nnmstop.models.structure import Stop, Structure, check_grounded, check_matrix

__all__ = ["MATRIX_SUFFIXES", "load_matrix", "matrix_structure"]

MATRIX_SUFFIXES = (".mtx", ".npz")


def _from_npz(path: Path):
    with np.load(path, allow_pickle=False) as archive:
        keys = sorted(archive.files)
        if "format" in keys and "shape" in keys:
            return scipy.sparse.load_npz(path)
        if len(keys) != 1:
            raise ValueError(
                f"{path}: a .npz matrix file must hold one array (numpy.savez) or a scipy.sparse matrix "
                f"(scipy.sparse.save_npz); it holds {keys}"
            )
        return np.array(archive[keys[0]])


def load_matrix(path) -> np.ndarray | scipy.sparse.csr_matrix:
    """A real square matrix from a ``.mtx`` or ``.npz`` file (dense array or CSR).

    Raises
    ------
    ValueError
        Naming the file: missing, of another kind, unreadable, not a real square matrix, not finite.
    """
    path = Path(path)
    if path.suffix not in MATRIX_SUFFIXES:
        raise ValueError(f"{path}: a matrix file must end in one of {MATRIX_SUFFIXES}")
    if not path.is_file():
        raise ValueError(f"{path}: no such matrix file")
    try:
        matrix = scipy.io.mmread(path) if path.suffix == ".mtx" else _from_npz(path)
    except (OSError, ValueError, TypeError, KeyError) as err:
        raise ValueError(f"{path}: cannot read the matrix ({err})") from None
    matrix = scipy.sparse.csr_matrix(matrix) if scipy.sparse.issparse(matrix) else np.asarray(matrix)
    values = matrix.data if scipy.sparse.issparse(matrix) else matrix
    if np.iscomplexobj(values) or not np.issubdtype(values.dtype, np.number):
        raise ValueError(f"{path}: the matrix must be real, got entries of type {values.dtype}")
    if matrix.ndim != 2 or matrix.shape[0] != matrix.shape[1] or matrix.shape[0] == 0:
        raise ValueError(f"{path}: the matrix must be square and non-empty, got shape {matrix.shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{path}: the matrix holds NaN or infinite entries")
    return matrix.astype(float)


def _stops(entries, n: int, where: str) -> tuple:
    stops = []
    for k, entry in enumerate(entries):
        try:
            stop = Stop(**entry) if isinstance(entry, dict) else entry
        except (TypeError, ValueError) as err:
            raise ValueError(f"{where}: stop {k}: {err}") from None
        if not isinstance(stop, Stop):
            raise ValueError(f"{where}: stop {k} must be a mapping of dof, gap, stiffness, eta, got {entry!r}")
        for dof in stop.dofs:
            if dof >= n:
                raise ValueError(
                    f"{where}: stop {k} acts on dof {dof}, off the model of {n} degrees of freedom (0..{n - 1})"
                )
        stops.append(stop)
    if not stops:
        raise ValueError(f"{where}: give at least one stop")
    return tuple(stops)


def matrix_structure(mass, stiffness, stops, dof_labels=None) -> Structure:
    """The :class:`Structure` of the matrices in the files ``mass`` and ``stiffness`` with ``stops``.

    Parameters
    ----------
    mass, stiffness : path-like
        ``.mtx`` or ``.npz`` files (:func:`load_matrix`), nondimensional, symmetric, same size;
        ``mass`` positive definite.
    stops : sequence of dict or Stop
        Each with ``dof`` (0-based), ``gap``, ``stiffness`` and ``eta``, and optionally ``kind`` (``bilateral``,
        ``one_sided`` with ``side``, ``relative`` or ``circular`` with ``dofs``; :mod:`nnmstop.models.contact`).
    dof_labels : sequence of str, optional
        A name for each degree of freedom.

    Raises
    ------
    ValueError
        Naming the file and what is wrong with it, or the stop.
    """
    mass_path, stiffness_path = Path(mass), Path(stiffness)
    matrices = {}
    for name, path in (("mass", mass_path), ("stiffness", stiffness_path)):
        matrices[name] = load_matrix(path)
    if matrices["mass"].shape != matrices["stiffness"].shape:
        raise ValueError(
            f"{stiffness_path}: the stiffness matrix is {matrices['stiffness'].shape}, the mass matrix "
            f"{mass_path} is {matrices['mass'].shape}: they must have the same size"
        )
    n = matrices["mass"].shape[0]
    stop_list = _stops(stops, n, f"stops of {mass_path.name}/{stiffness_path.name}")
    for name, path in (("mass", mass_path), ("stiffness", stiffness_path)):
        try:
            check_matrix(f"the {name} matrix", matrices[name], positive_definite=name == "mass")
        except ValueError as err:
            raise ValueError(f"{path}: {err}") from None
    attributes = {"structure": "matrices", "mass_file": mass_path.name, "stiffness_file": stiffness_path.name}
    structure = Structure(matrices["mass"], matrices["stiffness"], stop_list, dof_labels, attributes=attributes)
    check_grounded(structure, f"{mass_path.name}/{stiffness_path.name}")
    return structure
