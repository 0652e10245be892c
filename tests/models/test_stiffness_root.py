"""The stiffness root ``K = G^T G`` (nnmstop.models.stiffness_root) and what it keeps accurate on fine meshes.

Independent facts: the clamped-pinned Euler-Bernoulli beam's first eigenvalue ``beta^4`` with
``tan(beta) = tanh(beta)``; a dense solve of a small model; the assembled-stiffness reduction of the same model;
a converged coarse mesh (Hermite elements converge as ``h^4``, so 800 elements are exact to about 1e-10 on the
lowest modes while a mesh 25 times finer only adds round-off).
"""

import dataclasses

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
import scipy.sparse

from nnmstop.models.beam import (
    Beam,
    BeamStop,
    assemble_free_beam,
    beam_scales,
    beam_structure,
    free_beam_root,
    tube_plates_parameters,
)
from nnmstop.models.reduction import craig_bampton
from nnmstop.models.stiffness_root import RootSolver, check_root
from nnmstop.models.structure import Stop, Structure, generalized_modes

pytestmark = pytest.mark.numerics


def _clamped_pinned_betas(n: int = 3) -> np.ndarray:
    """The first ``n`` roots of ``tan(beta) = tanh(beta)`` (one in each ``((k + 1) pi, (k + 1.5) pi)``)."""
    return np.array(
        [
            scipy.optimize.brentq(lambda b: np.tan(b) - np.tanh(b), (k + 1.1) * np.pi, (k + 1.45) * np.pi, xtol=1e-15)
            for k in range(n)
        ]
    )


def _clamped_pinned_eigenvalue() -> float:
    return _clamped_pinned_betas(1)[0] ** 4


def test_root_squares_to_the_assembled_stiffness_and_solves_like_it():
    k, _ = assemble_free_beam(2.0, 3.0, 1.0, 6)
    root = free_beam_root(2.0, 3.0, 6)
    np.testing.assert_allclose((root.T @ root).toarray(), k.toarray(), rtol=0, atol=1e-12 * abs(k).max())
    kept = np.arange(3, 14)  # clamped left end (w0, theta0) and w1 held: a held structure
    b = np.linspace(-1.0, 2.0, len(kept))
    expected = np.linalg.solve(k[kept][:, kept].toarray(), b)
    np.testing.assert_allclose(RootSolver(root[:, kept]).solve(b), expected, rtol=1e-10)


@pytest.mark.parametrize("n_elements", [2_000, 40_000])
def test_first_eigenvalue_of_a_fine_beam_mesh_is_the_closed_form(n_elements):
    """At 40,000 elements the assembled stiffness spans ~1e19: its factorization gives no correct digit of the
    lowest eigenvalue; through the root it keeps ten."""
    beam = Beam(1.0, 1.0, 1.0, n_elements, left="clamped", right="pinned", stops=(BeamStop(1.0, 30.0, 0.1, node=5),))
    lam1 = beam_scales(beam)["first_eigenvalue_unit_beam"]
    assert lam1 == pytest.approx(_clamped_pinned_eigenvalue(), rel=1e-9)


def test_reduction_through_the_root_equals_the_assembled_one_on_a_coarse_mesh():
    plates = beam_structure(Beam.from_parameters(tube_plates_parameters(40)))
    assembled = craig_bampton(dataclasses.replace(plates, stiffness_root=None), 6)
    rooted = craig_bampton(plates, 6)
    np.testing.assert_allclose(
        rooted.stiffness, assembled.stiffness, rtol=0, atol=1e-10 * abs(assembled.stiffness).max()
    )
    np.testing.assert_allclose(rooted.mass, assembled.mass, rtol=0, atol=1e-12 * abs(assembled.mass).max())


def test_reduced_tube_on_a_fine_mesh_equals_the_converged_coarse_one():
    """80,000 DOFs reduced onto the three plates and 24 modes: the reduced linear frequencies are those of the
    800-element mesh (converged) to 1e-8; round-off no longer grows with the mesh."""

    def reduced_frequencies(n_elements):
        reduced = craig_bampton(beam_structure(Beam.from_parameters(tube_plates_parameters(n_elements))), 24)
        return np.sqrt(scipy.linalg.eigh(reduced.stiffness, reduced.mass, eigvals_only=True)[:12])

    np.testing.assert_allclose(reduced_frequencies(40_000), reduced_frequencies(800), rtol=1e-8)


def test_a_root_that_is_not_the_stiffness_or_a_free_interior_is_refused():
    k, m = assemble_free_beam(1.0, 1.0, 1.0, 8)
    root = free_beam_root(1.0, 1.0, 8)
    stop = Stop(dof=8, gap=1.0, stiffness=30.0, eta=0.1)
    with pytest.raises(ValueError, match="not the root of this stiffness"):
        Structure(m, 2.0 * k, [stop], stiffness_root=root)
    with pytest.raises(ValueError, match="must have the 18 columns"):
        check_root(root[:, :-1], k)
    free = Structure(m, k, [stop], stiffness_root=root)  # free-free: rigid-body modes, the interior moves
    with pytest.raises(ValueError, match="singular when the boundary is held"):
        craig_bampton(free, 2)
    assert scipy.sparse.issparse(free.stiffness_root)


def test_modes_through_the_root_are_rayleigh_quotients_and_the_closed_form():
    """Nondimensional time: omega_k = (beta_k / beta_1)^2. The assembled sparse path is already off by ~1e-7
    at 600 elements (round-off growing as the mesh's fourth power); the root keeps ~1e-10."""
    beam = Beam(1.0, 1.0, 1.0, 600, left="clamped", right="pinned", stops=(BeamStop(1.0, 30.0, 0.1, node=5),))
    structure = beam_structure(beam)
    with_root, shapes = generalized_modes(structure.mass, structure.stiffness, 3, root=structure.stiffness_root)
    strains = structure.stiffness_root @ shapes
    np.testing.assert_allclose(with_root**2, np.einsum("ij,ij->j", strains, strains), rtol=1e-14)
    betas = _clamped_pinned_betas(3)
    np.testing.assert_allclose(with_root, (betas / betas[0]) ** 2, rtol=1e-9)
