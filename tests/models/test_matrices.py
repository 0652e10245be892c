"""Structures from matrix files: the 3-DOF chain read back, and every bad input named with its file."""

from __future__ import annotations

import hashlib
import io
import zipfile

import numpy as np
import pytest
import scipy.io
import scipy.sparse

from nnmstop.config import ConfigError, load_config, validate_config
from nnmstop.models.matrices import load_matrix, matrix_structure
from nnmstop.models.structure import limit_modes, normal_modes

MASS = np.eye(3)
STIFFNESS = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
STOP = {"dof": 0, "gap": 1.0, "stiffness": 30.0, "eta": 0.1}


@pytest.fixture()
def files(tmp_path):
    scipy.io.mmwrite(tmp_path / "M.mtx", scipy.sparse.coo_matrix(MASS), symmetry="symmetric")
    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_matrix(STIFFNESS), symmetry="symmetric")
    return tmp_path


def test_the_chain_is_read_back_from_matrix_market_and_npz(files):
    chain = matrix_structure(files / "M.mtx", files / "K.mtx", [STOP], dof_labels=["x1", "x2", "x3"])
    np.testing.assert_array_equal(np.asarray(chain.dense_matrices()[1]), STIFFNESS)
    assert chain.dof_labels == ("x1", "x2", "x3") and chain.attributes["stiffness_file"] == (files / "K.mtx").as_posix()
    assert chain.attributes["stiffness_sha256"] == hashlib.sha256((files / "K.mtx").read_bytes()).hexdigest()
    np.savez(files / "K.npz", K=STIFFNESS)
    scipy.sparse.save_npz(files / "M.npz", scipy.sparse.csr_matrix(MASS))
    same = matrix_structure(files / "M.npz", files / "K.npz", [STOP])
    # closed form of the chain's linear modes: omega_k = 2 sin((2k - 1) pi / 14), k = 1..3
    expected = 2 * np.sin((2 * np.arange(1, 4) - 1) * np.pi / 14)
    np.testing.assert_allclose(normal_modes(same)[0], expected, rtol=1e-12)
    # gap 0: the stop's stiffness alpha added on x1
    gap_zero = np.sqrt(np.linalg.eigvalsh(STIFFNESS + np.diag([30.0, 0.0, 0.0])))
    np.testing.assert_allclose(limit_modes(same, "gap_zero")[0], gap_zero, rtol=1e-12)


@pytest.mark.parametrize(
    ("mass", "stiffness", "stops", "named", "message"),
    [
        (MASS, STIFFNESS + np.triu(np.ones((3, 3)), 1), [STOP], "K.mtx", "symmetric"),
        (-MASS, STIFFNESS, [STOP], "M.mtx", "positive definite"),
        (np.eye(4), STIFFNESS, [STOP], "K.mtx", r"\(3, 3\).*\(4, 4\)"),
        (MASS, STIFFNESS, [dict(STOP, dof=3)], "stop 0", r"dof 3, off the model of 3 degrees of freedom"),
        (MASS, STIFFNESS, [dict(STOP, eta=40.0)], "stop 0", "eta must be smaller"),
        (MASS, np.zeros((3, 3)), [STOP], "M.mtx/K.mtx", "rigid body without touching a stop"),
    ],
)
def test_bad_matrices_and_stops_are_named_with_their_file(tmp_path, mass, stiffness, stops, named, message):
    scipy.io.mmwrite(tmp_path / "M.mtx", np.asarray(mass))
    scipy.io.mmwrite(tmp_path / "K.mtx", np.asarray(stiffness))
    with pytest.raises(ValueError, match=rf"{named}.*{message}"):
        matrix_structure(tmp_path / "M.mtx", tmp_path / "K.mtx", stops)


def test_unreadable_files_are_named(tmp_path):
    with pytest.raises(ValueError, match=r"nowhere\.mtx: no such matrix file"):
        load_matrix(tmp_path / "nowhere.mtx")
    (tmp_path / "bad.mtx").write_text("not a matrix\n")
    with pytest.raises(ValueError, match=r"bad\.mtx: cannot read the matrix"):
        load_matrix(tmp_path / "bad.mtx")
    with pytest.raises(ValueError, match=r"M\.txt: a matrix file must end in one of"):
        load_matrix(tmp_path / "M.txt")
    np.savez(tmp_path / "two.npz", a=MASS, b=MASS)
    with pytest.raises(ValueError, match=r"two\.npz: .* one array .* holds \['a', 'b'\]"):
        load_matrix(tmp_path / "two.npz")


def test_the_configuration_names_the_structure_key(files, monkeypatch, repo_root):
    config = load_config(repo_root / "config" / "config.yaml")
    monkeypatch.chdir(files)
    config["structure"] = {"kind": "matrices", "matrices": {"mass": "M.mtx", "stiffness": "K.mtx", "stops": [STOP]}}
    # the forced scenes are built on the configured structure: the paper's `u` is none of its DOFs (issue 29)
    with pytest.raises(ConfigError, match=r"'forced'.*force dof 'u' is not a degree of freedom"):
        validate_config(config)
    config["forced"]["force"]["dofs"] = [2]
    validate_config(config)
    config["structure"]["matrices"]["stops"] = [dict(STOP, dof=5)]
    with pytest.raises(ConfigError, match=r"'structure\.matrices'.*dof 5, off the model"):
        validate_config(config)
    config["structure"]["matrices"]["stops"] = [STOP]
    config["branches"]["nnm2"]["mode"] = 4
    with pytest.raises(ConfigError, match=r"'branches\.nnm2\.mode': 4 exceeds the 3 degrees of freedom"):
        validate_config(config)


def test_a_beam_free_at_both_ends_is_refused_at_validation(repo_root):
    config = load_config(repo_root / "config" / "config.yaml")
    config["tube"]["structure"].update(left="free", right="free")
    with pytest.raises(
        ConfigError,
        match=r"'tube\.structure': a beam free at the left end and free at the right end has 2 rigid-body mode",
    ):
        validate_config(config)


def test_a_header_declaring_a_huge_dense_matrix_is_refused_before_any_allocation(tmp_path, monkeypatch, repo_root):
    """Issue 33, reproduction 6: a header of some 57 bytes declaring a dense 200000 x 200000 matrix (298 GiB) made
    every snakemake command fail with a MemoryError naming no file. The header is read first, the file named."""
    huge = tmp_path / "K.mtx"
    huge.write_text("%%MatrixMarket matrix array real general\n200000 200000\n")
    with pytest.raises(ValueError, match=r"K\.mtx: the header declares a dense 200000 x 200000 matrix, above"):
        load_matrix(huge)
    scipy.io.mmwrite(tmp_path / "M.mtx", MASS)
    config = load_config(repo_root / "config" / "config.yaml")
    monkeypatch.chdir(tmp_path)
    config["structure"] = {"kind": "matrices", "matrices": {"mass": "M.mtx", "stiffness": "K.mtx", "stops": [STOP]}}
    with pytest.raises(ConfigError, match=r"'structure\.matrices': K\.mtx: the header declares a dense"):
        validate_config(config)


def test_a_sparse_matrix_larger_than_the_memory_is_refused_from_its_header(tmp_path, monkeypatch):
    from nnmstop.models import matrices

    scipy.io.mmwrite(tmp_path / "K.mtx", scipy.sparse.coo_matrix(STIFFNESS))
    monkeypatch.setattr(matrices, "_available_memory", lambda: 1000)  # bytes
    with pytest.raises(ValueError, match=r"K\.mtx: the header declares a 3 x 3 matrix of \d+ entries, .* more than"):
        load_matrix(tmp_path / "K.mtx")
    header = io.BytesIO()  # a .npz whose array header declares 6000 x 6000 doubles (288 MB) and holds none
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (6000, 6000)})
    with zipfile.ZipFile(tmp_path / "K.npz", "w") as archive:
        archive.writestr("K.npy", header.getvalue())
    monkeypatch.setattr(matrices, "_available_memory", lambda: None)
    with pytest.raises(ValueError, match=r"K\.npz: the header declares a dense 6000 x 6000 matrix"):
        load_matrix(tmp_path / "K.npz")


@pytest.mark.parametrize(
    ("stiffness", "message"),
    [
        (np.diag([1.0, -0.5, 1.0]), r"K\.mtx: the stiffness matrix is indefinite"),
        # the chain without its grounding spring: held only by the stop on x1
        (np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]), r"K\.mtx: .* held only by its stops"),
    ],
)
def test_an_indefinite_stiffness_or_one_held_only_by_a_stop_is_refused_at_validation(
    tmp_path, monkeypatch, repo_root, stiffness, message
):
    """Issue 33, reproduction 7: these passed validation and failed later with a raw LinAlgError."""
    scipy.io.mmwrite(tmp_path / "M.mtx", MASS)
    scipy.io.mmwrite(tmp_path / "K.mtx", stiffness)
    config = load_config(repo_root / "config" / "config.yaml")
    monkeypatch.chdir(tmp_path)
    config["structure"] = {"kind": "matrices", "matrices": {"mass": "M.mtx", "stiffness": "K.mtx", "stops": [STOP]}}
    with pytest.raises(ConfigError, match=rf"'structure\.matrices': {message}"):
        validate_config(config)


def test_the_structure_records_each_matrix_path_and_sha256(files, monkeypatch):
    """Datasets of a matrix structure name the matrices they were computed with; the readers rebuild it from them
    and refuse a dataset whose matrix file changed."""
    import xarray as xr

    from nnmstop.stored_accuracy import structure_from_attributes

    monkeypatch.chdir(files)
    chain = matrix_structure("M.mtx", "K.mtx", [STOP])
    assert chain.attributes["mass_file"] == "M.mtx" and chain.attributes["stiffness_file"] == "K.mtx"
    for name in ("M", "K"):
        key = "mass" if name == "M" else "stiffness"
        assert chain.attributes[f"{key}_sha256"] == hashlib.sha256((files / f"{name}.mtx").read_bytes()).hexdigest()
    ds = xr.Dataset(
        {"stop_dof": ("stop", [0]), "stop_gap": ("stop", [1.0]), "stop_stiffness": ("stop", [30.0]),
         "stop_eta": ("stop", [0.1])},
        attrs=chain.attributes,
    )  # fmt: skip
    np.testing.assert_array_equal(np.asarray(structure_from_attributes(ds).dense_matrices()[1]), STIFFNESS)
    scipy.io.mmwrite(files / "K.mtx", 2 * STIFFNESS)
    with pytest.raises(ValueError, match=r"the stiffness matrix file K\.mtx changed since it was computed"):
        structure_from_attributes(ds)
