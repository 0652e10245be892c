"""Craig-Bampton reduction onto the contact DOFs (nnmstop.models.reduction, nnmstop.hbm.reduced).

Checked against independent facts: with every interior mode kept the basis is square, so the reduced
branch is the full one (linear frequencies and an orbit at fixed amplitude to round-off); Craig-Bampton is a
Rayleigh-Ritz projection, so its linear frequencies bound the full model's from above and fall as modes are
added; the orbit errors against the full model (sparse path, Newton) fall as modes are added.
"""

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse

from nnmstop.hbm.reduced import fewer_modes, full_unknowns, orbit_at_amplitude, orbit_difference
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.beam import Beam, BeamStop, beam_structure, tube_plates_parameters
from nnmstop.models.reduction import contact_dofs, craig_bampton, recovered_rows, reduce_structure
from nnmstop.models.structure import Stop, Structure, normal_modes, sparse_inertia_positive


@pytest.fixture(scope="module")
def plates():
    return beam_structure(Beam.from_parameters(tube_plates_parameters(12)))


def test_boundary_is_the_contact_dofs_and_stops_move_onto_it(plates):
    reduced = craig_bampton(plates, 4)
    boundary = reduced.reduction.boundary
    assert list(boundary) == sorted(plates.stop_dofs)
    for full_stop, stop in zip(plates.stops, reduced.stops):
        assert boundary[stop.dof] == full_stop.dof
        assert (stop.gap, stop.stiffness, stop.eta) == (full_stop.gap, full_stop.stiffness, full_stop.eta)
    # the recovery keeps the boundary DOFs themselves
    np.testing.assert_array_equal(reduced.reduction.recovery[boundary], np.eye(len(boundary), reduced.n_dofs))
    assert reduced.dof_labels[: len(boundary)] == tuple(plates.dof_labels[d] for d in boundary)


def test_every_mode_kept_gives_the_full_linear_frequencies(plates):
    interior = plates.n_dofs - len(contact_dofs(plates))
    reduced = craig_bampton(plates, interior)
    full = normal_modes(plates, plates.n_dofs)[0]
    np.testing.assert_allclose(normal_modes(reduced, reduced.n_dofs)[0], full, rtol=1e-10)
    assert np.isinf(reduced.reduction.next_frequency)


def test_frequencies_are_upper_bounds_falling_with_the_modes(plates):
    """Rayleigh-Ritz: each reduced eigenvalue bounds the full one from above; a larger basis lowers it."""
    full = normal_modes(plates, 4)[0]
    previous = None
    for m in (1, 2, 4, 8):
        omega = normal_modes(craig_bampton(plates, m), 4)[0]
        assert np.all(omega >= full * (1 - 1e-12))
        if previous is not None:
            assert np.all(omega <= previous * (1 + 1e-12))
        previous = omega


def test_reduced_orbit_converges_to_the_full_one(plates):
    """NNM1 with the middle plate in contact (x_c^1 = 1.15), H = 5: errors against the full model fall with the
    modes kept, and vanish to round-off with every interior mode."""
    H, amplitude = 5, 1.15
    interior = plates.n_dofs - 3
    everything = HarmonicBalanceSystem(craig_bampton(plates, interior), H)
    full = HarmonicBalanceSystem(plates, H)
    # the full orbit, by Newton from the linear mode scaled to the amplitude and continued there in amplitude
    U = full.linear_mode_guess(1, 0.5)
    for a in np.linspace(0.5, amplitude, 8):
        U = orbit_at_amplitude(full, U, a)
    exact = orbit_at_amplitude(everything, _reduced_guess(everything, full, U), amplitude)
    assert max(orbit_difference(everything, exact, full, U).values()) < 1e-9
    np.testing.assert_allclose(full_unknowns(everything, full, exact), U, atol=1e-9 * np.abs(U).max())
    errors, guess, previous = [], exact, everything
    for m in (interior - 1, 8, 4, 2):
        system = HarmonicBalanceSystem(craig_bampton(plates, m), H)
        guess = orbit_at_amplitude(system, fewer_modes(previous, guess, m), amplitude)
        previous = system
        errors.append(orbit_difference(system, guess, full, U))
    for key in ("frequency", "harmonics"):
        values = [e[key] for e in errors]
        assert values == sorted(values), (key, values)
        assert values[-1] > 10 * values[0]


def _reduced_guess(system, full, U):
    """Reduced unknowns of a full orbit: boundary DOFs read off, modal coordinates by least squares on T."""
    T = system.structure.reduction.recovery
    N, nc = full.n_dofs, full.nc
    Q = U[: N * nc].reshape(N, nc)
    q = np.linalg.lstsq(T, Q, rcond=None)[0]
    return np.concatenate([q.ravel(), U[N * nc :]])


def test_refused_structures():
    free = Beam(1.0, 1.0, 1.0, 8, left="free", right="free", stops=(BeamStop(1.0, 30.0, 0.1, node=4),))
    with pytest.raises(ValueError, match="singular to double precision"):
        craig_bampton(beam_structure(free), 2)
    held = beam_structure(Beam(1.0, 1.0, 1.0, 8, stops=(BeamStop(1.0, 30.0, 0.1, node=4),)))
    with pytest.raises(ValueError, match="n_modes must be an integer"):
        craig_bampton(held, held.n_dofs)
    with pytest.raises(ValueError, match="already reduced"):
        craig_bampton(craig_bampton(held, 2), 1)
    with pytest.raises(ValueError, match="tube.reduction.*keys must be among"):
        reduce_structure(held, {"mode": 3}, "tube.reduction")
    with pytest.raises(ValueError, match="boundary_dofs: 'w99' is not a DOF label"):
        reduce_structure(held, {"modes": 3, "boundary_dofs": ["w99"]})


def test_extra_boundary_dof_stays_physical():
    held = beam_structure(Beam(1.0, 1.0, 1.0, 8, stops=(BeamStop(1.0, 30.0, 0.1, node=4),)))
    reduced = reduce_structure(held, {"modes": 3, "boundary_dofs": ["w8"]})
    assert reduced.dof_labels[:2] == ("w4", "w8")
    assert reduced.stops[0].dof == 0
    # Rayleigh damping projects exactly: T^T (a M + b K) T = a M_r + b K_r
    T = reduced.reduction.recovery
    M, K = (a.toarray() for a in (held.mass, held.stiffness))
    np.testing.assert_allclose(T.T @ K @ T, reduced.stiffness, atol=1e-9 * np.abs(K).max())
    np.testing.assert_allclose(T.T @ M @ T, reduced.mass, atol=1e-12 * np.abs(M).max())


def test_recovered_rows_of_a_large_mesh_keep_evenly_spaced_nodes_and_the_plates():
    reduced = craig_bampton(beam_structure(Beam.from_parameters(tube_plates_parameters(400))), 2)
    rows = recovered_rows(reduced.reduction, max_nodes=51)
    nodes = np.unique(np.asarray(reduced.reduction.full_dof_nodes)[rows])
    assert {100, 200, 300} <= set(nodes) and nodes[-1] == 400
    assert len(nodes) <= 51 + 3
    assert np.all(np.isin(reduced.reduction.boundary, rows))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sparse_inertia_agrees_with_the_eigenvalues(seed):
    """The sparse LDL^T verdict against dense eigenvalues, on randomly permuted (wide-band) matrices."""
    rng = np.random.default_rng(seed)
    beam = beam_structure(Beam(1.0, 1.0, 1.0, 30, stops=(BeamStop(1.0, 30.0, 0.1, node=15),)))
    order = rng.permutation(beam.n_dofs)
    K = beam.stiffness[order][:, order]
    assert sparse_inertia_positive(K)
    lowest = np.linalg.eigvalsh(K.toarray())[0]
    shifted = K - scipy.sparse.identity(K.shape[0]) * (lowest * 1.5)
    assert not sparse_inertia_positive(shifted)
    assert not sparse_inertia_positive(scipy.sparse.csr_matrix([[0.0, 1.0], [1.0, 0.0]]))  # zero pivot


def test_wide_band_matrices_are_checked_sparse(monkeypatch):
    import nnmstop.models.structure as structure_module

    monkeypatch.setattr(structure_module, "BAND_ENTRIES_LIMIT", 10)
    beam = beam_structure(Beam(1.0, 1.0, 1.0, 10, stops=(BeamStop(1.0, 30.0, 0.1, node=5),)))
    order = np.random.default_rng(3).permutation(beam.n_dofs)
    stop = Stop(dof=int(np.flatnonzero(order == beam.stop_dofs[0])[0]), gap=1.0, stiffness=30.0, eta=0.1)
    structure = Structure(beam.mass[order][:, order], beam.stiffness[order][:, order], (stop,))
    np.testing.assert_allclose(normal_modes(structure, 3)[0], normal_modes(beam, 3)[0], rtol=1e-10)
    with pytest.raises(ValueError, match="mass must be positive definite"):
        Structure(-beam.mass, beam.stiffness, (beam.stops[0],))


def test_configuration_names_the_reduction_key():
    import copy

    from nnmstop.config import ConfigError, load_config, validate_config

    config = load_config(Path(__file__).resolve().parents[2] / "config" / "config.yaml")
    bad = copy.deepcopy(config)
    bad["tube_plates"]["reduction"]["modes"] = 10_000
    with pytest.raises(ConfigError, match=r"'tube_plates.reduction'.*n_modes must be an integer in \[0, 796\]"):
        validate_config(bad)
    bad = copy.deepcopy(config)
    bad["structure"] = {"kind": "beam", "beam": tube_plates_parameters(8), "reduction": {"modes": 2, "extra": 1}}
    with pytest.raises(ConfigError, match="structure"):
        validate_config(bad)


def test_matrices_from_files_reduce_through_the_configuration(tmp_path):
    """`structure: {kind: matrices, reduction: ...}`: the 3-DOF chain onto its stop DOF and one mode."""
    from nnmstop.settings import structure_from_config

    chain = Path(__file__).resolve().parents[2] / "examples" / "three_dof_chain"
    matrices = {
        "mass": str(chain / "mass.mtx"),
        "stiffness": str(chain / "stiffness.mtx"),
        "stops": [{"dof": 0, "gap": 1.0, "stiffness": 30.0, "eta": 0.1}],
    }
    full = structure_from_config({"structure": {"kind": "matrices", "matrices": matrices}})
    reduced = structure_from_config(
        {"structure": {"kind": "matrices", "matrices": matrices, "reduction": {"modes": 1}}}
    )
    assert reduced.n_dofs == 2 and reduced.stop_dofs == (0,) and reduced.attributes["kept_modes"] == 1
    # Rayleigh-Ritz on a 3-DOF chain: the two reduced frequencies bound the two lowest full ones from above
    assert np.all(normal_modes(reduced, 2)[0] >= normal_modes(full, 2)[0] * (1 - 1e-12))
    everything = structure_from_config(
        {"structure": {"kind": "matrices", "matrices": matrices, "reduction": {"modes": 2}}}
    )
    np.testing.assert_allclose(normal_modes(everything, 3)[0], normal_modes(full, 3)[0], rtol=1e-12)


def _in_circular_holes(n_elements: int):
    from nnmstop.tasks.tube import in_circular_holes

    return beam_structure(Beam.from_parameters(in_circular_holes(tube_plates_parameters(n_elements), "tube_plates")))


def test_circular_stops_reduce_onto_both_components_with_paired_modes():
    """A tube bending in two planes in circular holes: the boundary holds both transverse DOFs of each plate, the
    modes come in pairs (u, J u) and the reduced structure stays invariant under the rotations about the axis; in
    each plane it is the one-plane tube's reduction (the same boundary and modes, the same matrices to round-off)."""
    holes, one_plane = _in_circular_holes(12), beam_structure(Beam.from_parameters(tube_plates_parameters(12)))
    reduced, planar = craig_bampton(holes, 8), craig_bampton(one_plane, 4)
    labels = reduced.dof_labels
    assert labels[:6] == ("w3", "w6", "w9", "v3", "v6", "v9")
    for full_stop, stop in zip(holes.stops, reduced.stops):
        assert [reduced.reduction.boundary[d] for d in stop.dofs] == list(full_stop.dofs)
    assert reduced.rotation_pairs == ((0, 3), (1, 4), (2, 5), (6, 7), (8, 9), (10, 11), (12, 13))
    J = reduced.rotation_generator.toarray()
    M, K = reduced.dense_matrices()
    for matrix in (M, K):  # made invariant to the last bits (averaged over the rotations)
        np.testing.assert_allclose(J @ matrix, matrix @ J, rtol=0, atol=4e-16 * np.abs(matrix).max())
    np.testing.assert_array_equal(reduced.reduction.mode_frequencies[0::2], reduced.reduction.mode_frequencies[1::2])
    # plane 1: the boundary w DOFs and the first member of each pair against the one-plane reduction
    first = [0, 1, 2, 6, 8, 10, 12]
    Mp, Kp = planar.dense_matrices()
    np.testing.assert_allclose(M[np.ix_(first, first)], Mp, rtol=0, atol=1e-12 * np.abs(Mp).max())
    np.testing.assert_allclose(K[np.ix_(first, first)], Kp, rtol=0, atol=1e-12 * np.abs(Kp).max())
    n = one_plane.n_dofs
    np.testing.assert_allclose(reduced.reduction.recovery[:n, first], planar.reduction.recovery, atol=1e-12)
    np.testing.assert_allclose(reduced.reduction.recovery[n:, first], 0.0, atol=1e-12)


def test_circular_stops_need_whole_pairs_of_modes_and_a_turned_boundary():
    holes = _in_circular_holes(12)
    with pytest.raises(ValueError, match="n_modes must be even"):
        craig_bampton(holes, 5)
    # a boundary DOF in one plane only (a forced DOF) breaks the invariance: reduced without rotation pairs
    one_sided = craig_bampton(holes, 5, boundary_dofs=[holes.dof_labels.index("w4")])
    assert one_sided.rotation_pairs is None and "w4" in one_sided.dof_labels


def test_paired_modes_do_not_depend_on_the_basis_the_eigensolver_returns(monkeypatch):
    """A degenerate pair comes out of an eigensolver as any basis of its plane, with errors that move with the BLAS
    threads: the Lanczos solve and the dense one, and the dense one's modes turned by arbitrary angles within each
    plane, give the same reduced structure to round-off."""
    from nnmstop.models import reduction

    holes = _in_circular_holes(24)
    dense = craig_bampton(holes, 8)
    original = reduction._fixed_interface_modes
    rng = np.random.default_rng(7)

    def turned(interior, m_ii, n_wanted):
        omega, phi = original(interior, m_ii, n_wanted)
        phi = phi.copy()
        for k in range(0, n_wanted - 1, 2):
            c, s = np.cos(rng.uniform(0, 2 * np.pi)), np.sin(rng.uniform(0, 2 * np.pi))
            phi[:, k : k + 2] = phi[:, k : k + 2] @ np.array([[c, -s], [s, c]]) / np.hypot(c, s)
        return omega, phi

    monkeypatch.setattr(reduction, "_fixed_interface_modes", turned)
    perturbed = craig_bampton(holes, 8)
    monkeypatch.setattr(reduction, "_fixed_interface_modes", original)
    monkeypatch.setattr(reduction, "DENSE_EIGEN_LIMIT", 0)  # shift-invert Lanczos instead
    lanczos = craig_bampton(holes, 8)
    for other in (perturbed, lanczos):
        for a, b in zip(dense.dense_matrices(), other.dense_matrices()):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(a).max())
        np.testing.assert_allclose(dense.reduction.recovery, other.reduction.recovery, rtol=0, atol=1e-11)
