"""The structure passed to the engines: the 2-DOF oscillator through it, eigen-solvers, validation."""

import numpy as np
import pytest
import scipy.sparse

from nnmstop.models.beam import Beam, BeamStop, beam_structure, euler_bernoulli_frequencies
from nnmstop.models.structure import (
    DENSE_EIGEN_LIMIT,
    Stop,
    Structure,
    generalized_modes,
    linear_frequencies,
    normal_modes,
    two_dof_structure,
)
from nnmstop.models.two_dof import ModelParameters, linear_modes, mass_matrix, stiffness_matrix


@pytest.mark.parametrize("params", [ModelParameters(), ModelParameters(alpha=5.0, beta=0.3, delta=2.5, eta=0.2)])
def test_two_dof_structure_is_the_paper_oscillator(params):
    structure = two_dof_structure(params)
    np.testing.assert_array_equal(structure.mass, mass_matrix(params))
    np.testing.assert_array_equal(structure.stiffness, stiffness_matrix(params))
    assert structure.n_dofs == 2 and structure.stop_dofs == (0,)
    (stop,) = structure.stops
    assert (stop.gap, stop.stiffness, stop.eta) == (1.0, params.alpha, params.eta)
    # Linear modes from the generic solver against the 2-DOF closed form, shapes normalized to x = 1.
    omega, shapes = normal_modes(structure, 2)
    omega_ref, shapes_ref = linear_modes(params, "no_contact")
    np.testing.assert_allclose(omega, omega_ref, rtol=1e-14)
    np.testing.assert_allclose(shapes / shapes[0], shapes_ref, rtol=1e-13)
    np.testing.assert_allclose(shapes.T @ structure.mass @ shapes, np.eye(2), atol=1e-14)


def test_stop_forces_are_the_piecewise_law_scaled_by_the_gap():
    stop = Stop(dof=0, gap=0.5, stiffness=10.0, eta=0.1)
    x = np.array([-2.0, -0.5, 0.1, 0.5, 0.75])
    np.testing.assert_allclose(stop.piecewise_force(x), [-15.0, 0.0, 0.0, 0.0, 2.5])
    # the potential is the integral of the force (trapezoid on a fine grid, second order)
    s = np.linspace(0.0, 1.3, 20001)
    integral = np.sum(0.5 * (stop.piecewise_force(s[1:]) + stop.piecewise_force(s[:-1])) * np.diff(s))
    assert abs(integral - stop.piecewise_potential(1.3)) < 1e-7


def _rounding_bound(stiffness, shapes, omega):
    """First-order bound on the relative change of each eigenvalue when every entry of K is rounded:
    eps |phi|^T |K| |phi| / lambda (mass-normalized phi). Large for the low modes of a fine mesh, where the
    stiffness entries ~ 1/h^3 cancel in phi^T K phi."""
    return np.finfo(float).eps * np.einsum("ij,ik,kj->j", np.abs(shapes), np.abs(stiffness), np.abs(shapes)) / omega**2


@pytest.mark.parametrize("n_elements", [150, DENSE_EIGEN_LIMIT // 2 + 2])
def test_eigen_solvers_agree_with_each_other_and_the_continuous_beam(n_elements):
    beam = Beam(1.0, 1.0, 1.0, n_elements, "clamped", "free", stops=(BeamStop(1.0, 2.0, 1.0, node=3),))
    structure = beam_structure(beam)
    mass, stiffness = structure.dense_matrices()
    dense, shapes = generalized_modes(mass, stiffness, 4)  # LAPACK on the inverse problem
    # The tolerance is the rounding of K itself (no solver can beat it); omega errors are half the lambda ones.
    bound = _rounding_bound(stiffness, shapes, dense)
    sparse = linear_frequencies(structure, 4)  # ARPACK shift-invert above DENSE_EIGEN_LIMIT, else the same LAPACK
    assert np.all(np.abs(sparse / dense - 1) <= bound)
    # With >= 150 elements the h^4 discretization error of these modes is below 1e-10, so the frequency ratios are
    # those of the continuous cantilever. A direct solve K phi = lambda M phi would miss this by
    # eps lambda_max / lambda_1 ~ 1e-5.
    exact = euler_bernoulli_frequencies("clamped", "free", 4, 1.0, 1.0, 1.0)
    assert np.all(np.abs(dense / dense[0] / (exact / exact[0]) - 1) <= 1e-10 + bound + bound[0])


def _spd(n=3):
    return np.eye(n) * 2.0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"dof": 0, "gap": -1.0, "stiffness": 30.0, "eta": 0.1}, r"gap must be > 0, got -1\.0"),
        ({"dof": 0, "gap": 1.0, "stiffness": 30.0, "eta": 30.0}, r"eta=30\.0 >= alpha=30\.0"),
        ({"dof": 0, "gap": 1.0, "stiffness": -3.0, "eta": 0.1}, r"stiffness must be > 0, got -3\.0"),
        ({"dof": -1, "gap": 1.0, "stiffness": 30.0, "eta": 0.1}, r"dof must be >= 0, got -1"),
        ({"dof": 0, "gap": float("nan"), "stiffness": 30.0, "eta": 0.1}, r"gap must be finite, got nan"),
    ],
)
def test_stop_validation_names_the_value(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Stop(**kwargs)


def test_structure_validation_names_the_value():
    stop = Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)
    with pytest.raises(ValueError, match=r"stop dof 3 is out of range for 3 degrees of freedom"):
        Structure(_spd(), _spd(), (Stop(3, 1.0, 30.0, 0.1),))
    asymmetric = _spd() + np.diag([1.0, 1.0], 1)
    with pytest.raises(
        ValueError, match=r"stiffness must be symmetric to round-off, got max\|A - A\^T\| = 1\.000e\+00"
    ):
        Structure(_spd(), asymmetric, (stop,))
    with pytest.raises(ValueError, match="mass must be positive definite"):
        Structure(np.diag([1.0, -1.0, 1.0]), _spd(), (stop,))
    with pytest.raises(ValueError, match=r"same shape, got \(3, 3\) and \(2, 2\)"):
        Structure(_spd(), _spd(2), (stop,))
    with pytest.raises(ValueError, match=r"distinct degrees of freedom, got dofs \[0, 0\]"):
        Structure(_spd(), _spd(), (stop, stop))
    with pytest.raises(ValueError, match="at least one stop"):
        Structure(_spd(), _spd(), ())
    with pytest.raises(ValueError, match="non-empty square matrix, got shape \\(3, 2\\)"):
        Structure(np.ones((3, 2)), _spd(), (stop,))
    # sparse input is kept sparse and validated the same way
    structure = Structure(scipy.sparse.identity(3, format="csr"), scipy.sparse.csr_matrix(_spd()), (stop,))
    assert structure.is_sparse and structure.n_dofs == 3
