"""The harmonic-balance system of a structure with stops: N-DOF physics, the 2-DOF embedding, sparse LU.

Independent references: the closed-form frequencies and shapes of a uniform spring-mass
chain, the paper's oscillator computed alone, a dense determinant (numpy ``slogdet``),
finite differences and the exact quadratic structure of the residual, and time
integration of the regularized equations of motion.
"""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.integrate import solve_ivp

from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import Stop, Structure, two_dof_parameters, two_dof_structure
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force


def chain(n, stops, masses=None, springs=None, ground=None):
    """Fixed-fixed chain of ``n`` masses: ``n + 1`` springs (sparse K) and optional ground springs."""
    masses = np.ones(n) if masses is None else masses
    springs = np.ones(n + 1) if springs is None else springs
    ground = np.zeros(n) if ground is None else ground
    main = springs[:-1] + springs[1:] + ground
    stiffness = sp.diags([main, -springs[1:-1], -springs[1:-1]], [0, -1, 1], format="csr")
    return Structure(sp.diags(masses, format="csr"), stiffness, tuple(stops))


def bordered_newton(system, U, fixed_index, tol=1e-12, max_iter=30):
    """Newton on ``S(U) = 0`` with the unknown ``U[fixed_index]`` held (bordering row e_fixed)."""
    border = np.zeros(system.n_unknowns)
    border[fixed_index] = 1.0
    for _ in range(max_iter):
        r = system.residual(U)
        if np.linalg.norm(r) <= tol * max(np.linalg.norm(U), 1.0):
            return U
        U = U + system.factorize_bordered(U, border).solve(-np.append(r, 0.0))
    raise AssertionError(f"Newton did not converge: |S| = {np.linalg.norm(system.residual(U)):.3e}")


def tangent(system, U, previous):
    """Unit tangent of the branch at ``U``, on the side of ``previous``."""
    e_last = np.zeros(system.n_unknowns)
    e_last[-1] = 1.0
    t = system.factorize_bordered(U, previous).solve(e_last)
    return t / np.linalg.norm(t)


def follow_branch(system, x_max, mode=1, step=0.05):
    """Pseudo-arclength continuation of ``mode`` from rest until the first stop's coordinate exceeds ``x_max``."""
    U = system.linear_mode_guess(mode, 0.1)
    direction = np.zeros(system.n_unknowns)
    direction[system.slices["x"].start + 1] = 1.0
    t = tangent(system, U, direction)
    for _ in range(500):
        V = U + step * t
        for _ in range(20):  # Newton in the hyperplane orthogonal to t
            r = system.residual(V)
            if np.linalg.norm(r) <= 1e-12 * max(np.linalg.norm(V), 1.0):
                break
            V = V + system.factorize_bordered(V, t).solve(-np.append(r, 0.0))
        else:
            raise AssertionError(f"Newton did not converge: |S| = {np.linalg.norm(r):.3e}")
        U, t = V, tangent(system, V, t)
        if system.diagnostics(U)["x_max"] > x_max:
            return U
    raise AssertionError(f"x_max = {x_max} not reached")


@pytest.mark.parametrize("linear_algebra", ["dense", "sparse"])
@pytest.mark.parametrize("mode", [1, 4])
def test_chain_linear_limit_matches_closed_form(mode, linear_algebra):
    # uniform fixed-fixed chain: omega_j = 2 sin(j pi / (2 (N + 1))), shape_i = sin(i j pi / (N + 1));
    # the stop's regularization adds eta = 1e-9 on one DOF (relative shift ~1e-9)
    n = 6
    structure = chain(n, [Stop(dof=2, gap=0.5, stiffness=10.0, eta=1e-9)])
    system = HarmonicBalanceSystem(structure, 4, basis="full", linear_algebra=linear_algebra)
    omega = 2 * np.sin(mode * np.pi / (2 * (n + 1)))
    shape = np.sin(np.arange(1, n + 1) * mode * np.pi / (n + 1))
    U = system.linear_mode_guess(mode, 1e-4)
    U[system.i_lam] *= 1.02  # start the solve away from the answer
    fixed = system.slices["x"].start + 1
    U = bordered_newton(system, U, fixed)
    assert np.sqrt(U[system.i_lam]) == pytest.approx(omega, rel=1e-7)
    first_harmonic = np.array(system.split(U)[:n])[:, 1]
    np.testing.assert_allclose(first_harmonic / first_harmonic[2], shape / shape[2], rtol=1e-6, atol=1e-9)
    assert abs(U[system.i_nu]) < 1e-12


def padded_oscillator(params):
    """The paper's oscillator as DOFs 1, 2 of a 5-DOF structure whose other DOFs are decoupled."""
    two = two_dof_structure(params)
    mass, stiffness = np.diag([2.0, 0.0, 0.0, 1.5, 0.7]), np.diag([3.0, 0.0, 0.0, 5.0, 1.1])
    mass[1:3, 1:3], stiffness[1:3, 1:3] = (m.toarray() if sp.issparse(m) else m for m in (two.mass, two.stiffness))
    (stop,) = two.stops
    return Structure(mass, stiffness, (Stop(dof=1, gap=stop.gap, stiffness=stop.stiffness, eta=stop.eta),))


@pytest.mark.parametrize("basis", ["cosine", "full"])
def test_oscillator_inside_larger_structure_gives_the_same_orbit(basis):
    params = ModelParameters()
    small = HarmonicBalanceSystem(two_dof_structure(params), 10, basis=basis)
    large = HarmonicBalanceSystem(padded_oscillator(params), 10, basis=basis)
    U_small = follow_branch(small, 1.5)
    assert small.diagnostics(U_small)["impacts_per_period"] == 2  # one impact per stop
    x, u, f, z = small.split(U_small)[:4]
    zero = np.zeros(small.nc)
    U_large = large.pack(zero, x, u, zero, zero, f, z, U_small[small.i_lam])
    # the embedded orbit is an orbit of the large structure, and Newton there stays on it
    assert np.linalg.norm(large.residual(U_large)) < 1e-12
    U_large[large.i_lam] *= 1.01
    U_large = bordered_newton(large, U_large, large.slices["x"].start + 1)
    assert U_large[large.i_lam] == pytest.approx(U_small[small.i_lam], rel=1e-12)
    blocks = large.split(U_large)
    np.testing.assert_allclose(np.concatenate(blocks[1:3] + blocks[5:7]), np.concatenate([x, u, f, z]), atol=1e-12)
    assert max(np.abs(blocks[i]).max() for i in (0, 3, 4)) < 1e-14
    assert large.diagnostics(U_large)["energy"] == pytest.approx(small.diagnostics(U_small)["energy"], rel=1e-12)


def random_structure(n=20, seed=3):
    rng = np.random.default_rng(seed)
    stops = [Stop(dof=4, gap=0.7, stiffness=25.0, eta=0.2), Stop(dof=13, gap=1.6, stiffness=8.0, eta=0.05)]
    return chain(
        n, stops, masses=rng.uniform(0.5, 2.0, n), springs=rng.uniform(0.5, 3.0, n + 1), ground=rng.uniform(0.0, 0.3, n)
    ), rng


def random_point(system, rng):
    U = rng.standard_normal(system.n_unknowns)
    U[system.i_lam] = 0.8
    return U


@pytest.mark.filterwarnings("ignore::scipy.linalg.LinAlgWarning")  # LAPACK on the singular case below
@pytest.mark.parametrize("basis", ["cosine", "full"])
def test_sparse_and_dense_factorizations_agree(basis):
    """The dense path (z condensed out, then LAPACK) and the sparse path (SuperLU) against numpy on the full
    bordered matrix: solutions, determinant signs, singularity."""
    structure, rng = random_structure()
    dense = HarmonicBalanceSystem(structure, 6, basis=basis, linear_algebra="dense")
    sparse = HarmonicBalanceSystem(structure, 6, basis=basis, linear_algebra="sparse")
    U, tangent = random_point(dense, rng), rng.standard_normal(dense.n_unknowns)
    np.testing.assert_array_equal(dense.jacobian(U), sparse.jacobian(U).toarray())
    bordered = np.vstack([dense.jacobian(U), tangent])
    reference_sign = np.linalg.slogdet(bordered)[0]
    rhs = rng.standard_normal((dense.n_unknowns, 3))
    for sign in (1.0, -1.0):  # the determinant is linear in the bordering row
        lu_dense = dense.factorize_bordered(U, sign * tangent)
        lu_sparse = sparse.factorize_bordered(U, sign * tangent)
        assert lu_dense.determinant_sign() == lu_sparse.determinant_sign() == sign * reference_sign
    solution = np.linalg.solve(bordered, rhs)
    tolerance = 1e-9 * np.abs(solution).max()
    for lu in (dense.factorize_bordered(U, tangent), sparse.factorize_bordered(U, tangent)):
        np.testing.assert_allclose(lu.solve(rhs), solution, rtol=0, atol=tolerance)
        np.testing.assert_allclose(lu.solve(rhs[:, 0]), solution[:, 0], rtol=0, atol=tolerance)
        assert not lu.is_singular(1e-14)
    # a bordering row that repeats a row of J makes the matrix singular: both paths see it
    repeated = dense.jacobian(U)[7]
    for system in (dense, sparse):
        assert system.factorize_bordered(U, repeated).is_singular(1e-12)


@pytest.mark.parametrize("basis", ["cosine", "full"])
def test_jacobian_and_series_products_of_a_multi_stop_structure(basis):
    structure, rng = random_structure()
    system = HarmonicBalanceSystem(structure, 5, basis=basis, linear_algebra="sparse")
    U, V = random_point(system, rng), rng.standard_normal(system.n_unknowns)
    h = 1e-6
    difference = (system.residual(U + h * V) - system.residual(U - h * V)) / (2 * h)
    np.testing.assert_allclose(system.jacobian(U) @ V, difference, rtol=1e-7, atol=1e-7 * np.abs(difference).max())
    # S is exactly quadratic: its quadratic part Q(V, V) is (S(V) + S(-V))/2 - S(0), the order-2 ANM product
    quadratic = 0.5 * (system.residual(V) + system.residual(-V)) - system.residual(np.zeros_like(V))
    products = system.series_products(np.vstack([U, V]), 2)
    np.testing.assert_allclose(products, quadratic, rtol=1e-10, atol=1e-10 * np.abs(quadratic).max())


def _orbit_in_contact(harmonics):
    """NNM1 of a 5-DOF chain with a stop on its middle mass, followed into contact."""
    structure = chain(5, [Stop(dof=2, gap=0.5, stiffness=2.0, eta=0.05)])
    system = HarmonicBalanceSystem(structure, harmonics)
    return system, follow_branch(system, 1.3)


def _periodicity_defect(system, U):
    """Largest state difference after one period of the regularized equations from the HBM start."""
    structure = system.structure
    mass, stiffness = (m.toarray() if sp.issparse(m) else np.asarray(m) for m in (structure.mass, structure.stiffness))
    (stop,) = structure.stops
    law = ModelParameters(alpha=stop.stiffness, eta=stop.eta)

    def rhs(_, y):
        q, v = np.split(y, 2)
        force = stiffness @ q
        force[stop.dof] += stop.gap * regularized_contact_force(q[stop.dof] / stop.gap, law)
        return np.concatenate([v, -np.linalg.solve(mass, force)])

    history = system.time_history(U, 64)
    period = 2 * np.pi / np.sqrt(U[system.i_lam])
    start = np.concatenate([history["q"][:, 0], history["qdot"][:, 0]])
    end = solve_ivp(rhs, (0.0, period), start, method="DOP853", rtol=1e-11, atol=1e-13).y[:, -1]
    return np.abs(end - start).max() / np.abs(start).max()


def test_hbm_orbit_with_impacts_is_periodic_in_time():
    orbits = [_orbit_in_contact(harmonics) for harmonics in (5, 15)]
    defects = []
    for system, U in orbits:
        diagnostics = system.diagnostics(U)
        assert diagnostics["impacts_per_period"] == 2  # one excursion beyond each side of the gap
        defects.append(_periodicity_defect(system, U))
        # the HBM orbit solves the equations up to a force residual of relative size eps (the
        # truncation); over one period such a forcing moves the state by at most about pi eps
        # (resonant growth eps omega t / 2 of an oscillator), relative to the amplitude
        assert defects[-1] <= np.pi * diagnostics["time_residual"]
    assert defects[1] < 1e-2 * defects[0]  # and it falls with the truncation


def test_bad_input_is_named():
    params = ModelParameters()
    with pytest.raises(TypeError, match="two_dof_structure"):
        HarmonicBalanceSystem(params, 5)
    with pytest.raises(ValueError, match="linear_algebra"):
        HarmonicBalanceSystem(two_dof_structure(params), 5, linear_algebra="banded")
    system = HarmonicBalanceSystem(chain(4, [Stop(dof=1, gap=1.0, stiffness=10.0, eta=0.1)]), 5)
    with pytest.raises(ValueError, match="1..4"):
        system.linear_mode_guess(5, 0.1)
    assert not hasattr(system, "params")  # nothing asks whether a structure is the paper's
    with pytest.raises(ValueError, match="only for the paper's 2-DOF oscillator.*4 degrees of freedom"):
        two_dof_parameters(system.structure)
    with pytest.raises(ValueError, match="tangent"):
        system.factorize_bordered(np.zeros(system.n_unknowns), np.ones(3))


@pytest.mark.parametrize("basis", ["cosine", "full"])
def test_diagnostics_of_orbits_together_are_those_of_each_alone(basis):
    """Batched diagnostics share transforms and contact-law calls across orbits, never mixing them."""
    structure, rng = random_structure()
    system = HarmonicBalanceSystem(structure, 6, basis=basis)
    U = np.array([random_point(system, rng) for _ in range(3)])
    U[:, system.i_lam] = [0.8, 1.3, 0.5]
    together = system.diagnostics_many(U)
    for alone, batched in zip((system.diagnostics(u) for u in U), together):
        assert alone.keys() == batched.keys()
        for key, value in alone.items():
            np.testing.assert_array_equal(batched[key], value, err_msg=key)
    assert len({d["energy"] for d in together}) == 3  # three different orbits
