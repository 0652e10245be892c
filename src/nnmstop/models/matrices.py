"""A structure of one's own: mass and stiffness matrices read from files, and a list of stops.

:func:`load_matrix` reads a Matrix Market file (``.mtx``, :func:`scipy.io.mmread`) or a ``.npz`` archive
(one saved by :func:`scipy.sparse.save_npz`, or by :func:`numpy.savez` with a single array). It reads the
header first (:func:`scipy.io.mminfo`, the arrays' ``.npy`` headers) and refuses, before allocating
anything, a dense matrix above :data:`MAX_DENSE_SIZE` rows and a sparse one larger than half the memory
available; a ``MemoryError`` names the file. :func:`matrix_structure` builds the
:class:`~nnmstop.models.structure.Structure` and says, naming the file, what is wrong: not square, sizes
that differ, not symmetric, a mass that is not positive definite, a stiffness that is indefinite, a
structure held only by its stops (a singular stiffness: a rigid-body motion in free flight, where the
non-smooth model has no linear mode) or free to move as a rigid body without touching a stop. The
structure records each matrix's path (as the configuration gives it, from the working directory) and
SHA-256 (``mass_file``, ``mass_sha256``, ...), so that a dataset names the matrices it was computed with.
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

import hashlib
import os
import zipfile
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse

from nnmstop.models.structure import Stop, Structure, check_grounded, check_matrix

__all__ = ["MATRIX_SUFFIXES", "MAX_DENSE_SIZE", "load_matrix", "matrix_structure", "recorded_path"]

MATRIX_SUFFIXES = (".mtx", ".npz")
#: Largest number of rows of a matrix stored dense (200 MB of doubles); a larger one must be stored sparse.
MAX_DENSE_SIZE = 5000
#: Bytes of memory per stored entry of a sparse matrix while it is read and converted (COO then CSR).
_BYTES_PER_ENTRY = 48


def _available_memory() -> int | None:
    """Bytes of physical memory available now (None where the system does not say)."""
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def _npy_header(handle) -> tuple:
    version = np.lib.format.read_magic(handle)
    read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
    shape, _, dtype = read(handle)
    return tuple(shape), dtype


def _declared_size(path: Path) -> tuple[tuple, int, bool]:
    """(shape, stored entries, dense) from the file's header, without reading its values."""
    if path.suffix == ".mtx":
        rows, cols, entries, layout, _, symmetry = scipy.io.mminfo(path)
        dense = layout == "array"
        stored = rows * cols if dense else entries * (2 if symmetry != "general" else 1)
        return (rows, cols), stored, dense
    with zipfile.ZipFile(path) as archive:
        headers = {}
        for name in archive.namelist():
            with archive.open(name) as handle:
                headers[name.removesuffix(".npy")] = _npy_header(handle)
        if "format" in headers and "shape" in headers:  # scipy.sparse.save_npz
            with np.load(path, allow_pickle=False) as arrays:
                shape = tuple(int(v) for v in arrays["shape"])
            return shape, int(np.prod(headers["data"][0])), False
        if len(headers) == 1:
            shape = next(iter(headers.values()))[0]
            return shape, int(np.prod(shape)), True
    return (), 0, True  # read below, which names what the archive holds


def _check_size(path: Path) -> None:
    """Refuse, from the header alone, a matrix too large to read (see the module docstring)."""
    try:
        shape, stored, dense = _declared_size(path)
    except (OSError, ValueError, TypeError, KeyError, zipfile.BadZipFile) as err:
        raise ValueError(f"{path}: cannot read the matrix's header ({err})") from None
    if len(shape) == 2 and dense and max(shape) > MAX_DENSE_SIZE:
        raise ValueError(
            f"{path}: the header declares a dense {shape[0]} x {shape[1]} matrix, above the limit of "
            f"{MAX_DENSE_SIZE} rows for a dense matrix ({8 * shape[0] * shape[1] / 2**30:.3g} GiB); store it sparse "
            "(Matrix Market coordinate format, or scipy.sparse.save_npz)"
        )
    available = _available_memory()
    needed = _BYTES_PER_ENTRY * stored + 16 * (shape[0] if shape else 0)
    if available is not None and needed > available // 2:
        raise ValueError(
            f"{path}: the header declares a {shape[0]} x {shape[1]} matrix of {stored} entries, about "
            f"{needed / 2**30:.3g} GiB to read, more than half the memory available ({available / 2**30:.3g} GiB)"
        )


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
        Naming the file: missing, of another kind, unreadable, too large (from its header), not a real
        square matrix, not finite.
    """
    path = Path(path)
    if path.suffix not in MATRIX_SUFFIXES:
        raise ValueError(f"{path}: a matrix file must end in one of {MATRIX_SUFFIXES}")
    if not path.is_file():
        raise ValueError(f"{path}: no such matrix file")
    _check_size(path)
    try:
        matrix = scipy.io.mmread(path) if path.suffix == ".mtx" else _from_npz(path)
    except MemoryError:
        raise ValueError(f"{path}: not enough memory to read the matrix") from None
    except (OSError, ValueError, TypeError, KeyError, zipfile.BadZipFile) as err:
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
    _check_not_indefinite(stiffness_path, matrices["stiffness"])
    attributes = {"structure": "matrices"}
    for name, path in (("mass", mass_path), ("stiffness", stiffness_path)):
        attributes[f"{name}_file"] = recorded_path(path)
        attributes[f"{name}_sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
    structure = Structure(matrices["mass"], matrices["stiffness"], stop_list, dof_labels, attributes=attributes)
    check_grounded(structure, f"{mass_path.name}/{stiffness_path.name}")
    try:
        check_matrix("the stiffness matrix", matrices["stiffness"], positive_definite=True)
    except ValueError:
        raise ValueError(
            f"{stiffness_path}: the stiffness matrix is singular: the structure is held only by its stops (a rigid-"
            "body motion in free flight, between contacts, where the non-smooth model has no linear mode); "
            "support it (a grounding spring, a clamped or pinned end)"
        ) from None
    return structure


def _check_not_indefinite(path: Path, stiffness) -> None:
    """Refuse a stiffness matrix with a negative eigenvalue (round-off of a singular one allowed)."""
    dense_scale = abs(stiffness).max()
    scale = float(dense_scale if np.isscalar(dense_scale) else dense_scale.max()) or 1.0
    n = stiffness.shape[0]
    identity = scipy.sparse.identity(n, format="csr") if scipy.sparse.issparse(stiffness) else np.eye(n)
    shifted = stiffness + 1e-9 * scale * identity
    try:
        check_matrix("the stiffness matrix", shifted, positive_definite=True)
    except ValueError:
        raise ValueError(
            f"{path}: the stiffness matrix is indefinite (a negative eigenvalue: the structure at rest is unstable); "
            "a stiffness matrix must be positive definite"
        ) from None


def recorded_path(path) -> str:
    """How a dataset records a matrix file: the path as the configuration gives it when relative (from the
    working directory), relative to the working directory when it lies below it, else absolute."""
    path = Path(path)
    if not path.is_absolute():
        return path.as_posix()
    try:
        return path.relative_to(Path.cwd()).as_posix()
    except ValueError:
        return path.as_posix()
