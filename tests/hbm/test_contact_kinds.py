"""Regularized NNMs of every kind of stop through the one engine, checked by independent methods.

Each kind's HBM orbits are periodic orbits of its regularized equations (DOP853 over one period); a relative stop
is a grounded one in other coordinates and a circular clearance moving along a diameter is the bilateral stop
(the unknowns map onto the other system's and solve it); Floquet matrices from the laws' Jacobians agree with
finite differences of the integrated period map; the regularized one-sided NNM converges to the exact one at
first order in eta; a structure of one degree of freedom continues with the default stability.
"""

from __future__ import annotations

import numpy as np
import pytest

from nnmstop import Stop, Structure, continue_nnm
from nnmstop.checks.time_integration import integrate_structure_regularized
from nnmstop.hbm.bifurcation import classify_branch_point
from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.monodromy import orbit_monodromy
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.hbm.variational import halfwave_symmetric

ALPHA = 30.0
CHAIN = np.array([[2.0, -1.0], [-1.0, 1.0]])  # the paper's oscillator, beta = delta = 1


def _law(**kwargs):
    return {"gap": 1.0, "stiffness": ALPHA, "eta": 0.1, **kwargs}


STRUCTURES = {
    "one_sided": (np.eye(2), CHAIN, [Stop(kind="one_sided", dof=0, side="negative", **_law())], 1),
    "unequal_gaps": (
        np.eye(2),
        CHAIN,
        [Stop(kind="one_sided", dof=0, side="positive", **_law()), Stop(kind="one_sided", dof=0, side="negative",
                                                                         **_law(gap=1.4, stiffness=20.0))],
        1,
    ),
    "relative": (np.eye(2), CHAIN, [Stop(kind="relative", dofs=[0, 1], **_law())], 2),
    "relative_one_side": (np.eye(2), CHAIN, [Stop(kind="relative", dofs=[1, 0], side="positive", **_law())], 2),
    # a skew structure: the radial contact force couples both directions (no planar orbit)
    "circular": (np.eye(2), np.array([[1.3, 0.3], [0.3, 1.7]]), [Stop(kind="circular", dofs=[0, 1], **_law())], 1),
}  # fmt: skip


@pytest.fixture(scope="module", params=sorted(STRUCTURES))
def branch(request):
    mass, stiffness, stops, mode = STRUCTURES[request.param]
    structure = Structure(mass, stiffness, stops)
    ds = continue_nnm(structure, mode=mode, harmonics=48, energy_max=4.0)
    system = HarmonicBalanceSystem(structure, 48)
    return request.param, structure, system, ds, dataset_unknowns(ds, system)


def test_hbm_orbits_of_every_kind_are_periodic_orbits_of_the_regularized_equations(branch):
    """The last orbit (beyond the stops) integrated by DOP853 over one period closes on itself within the HBM
    orbit's own error (its time residual, the defect of the equations of motion relative to the restoring force);
    integrated with the law of the other side instead it does not close at all."""
    name, structure, system, ds, U = branch
    i = len(U) - 1
    assert int(ds.impacts_per_period[i]) >= 1, f"{name}: the orbit does not reach a stop"
    history = system.time_history(U[i], 4 * system.nfull)
    z0 = np.concatenate([history["q"][:, 0], history["qdot"][:, 0]])
    period = 1.0 / float(ds.frequency[i])
    run = integrate_structure_regularized(structure, z0, [0.0, period])
    closure = np.abs(run.states[-1] - z0).max() / np.abs(z0).max()
    assert closure < float(ds.time_residual[i]), f"{name}: closure {closure:.2e}"
    mirrored = Structure(structure.mass, structure.stiffness, [_mirror(s) for s in structure.stops])
    run = integrate_structure_regularized(mirrored, z0, [0.0, period])
    assert np.abs(run.states[-1] - z0).max() / np.abs(z0).max() > 100 * closure


def _mirror(stop):
    """The stop seen from the other side: another law for the same orbit (a negative control)."""
    law = {"gap": stop.gap, "stiffness": stop.stiffness, "eta": stop.eta}
    if stop.kind == "one_sided":
        return Stop(kind="one_sided", dof=stop.dof, side="negative" if stop.side == "positive" else "positive", **law)
    if stop.kind == "relative" and stop.side is not None:
        return Stop(kind="relative", dofs=list(stop.dofs[::-1]), side=stop.side, **law)
    return Stop(kind="one_sided", dof=stop.dofs[0], side="positive", **{**law, "eta": min(law["eta"], 1.0)})


def test_stability_uses_each_laws_jacobian(branch):
    """The monodromy matrix (Magnus steps on the laws' Jacobians) equals the finite-difference derivative of the
    DOP853 period map, orbit of the HBM."""
    name, structure, system, ds, U = branch
    i = len(U) - 1
    history = system.time_history(U[i], 4 * system.nfull)
    z0 = np.concatenate([history["q"][:, 0], history["qdot"][:, 0]])
    period = 1.0 / float(ds.frequency[i])
    h = 1e-6 * np.abs(z0).max()
    columns = []
    for e in np.eye(len(z0)):
        ends = [integrate_structure_regularized(structure, z0 + s * h * e, [0.0, period]).states[-1] for s in (1, -1)]
        columns.append((ends[0] - ends[1]) / (2 * h))
    finite = np.column_stack(columns)
    magnus = orbit_monodromy(system, U[i], steps=2048)
    assert np.abs(magnus - finite).max() <= 1e-4 * np.abs(finite).max(), name


def test_orbits_have_the_half_wave_symmetry_only_with_odd_laws(branch):
    name, structure, system, ds, U = branch
    symmetric = halfwave_symmetric(system, U)
    if structure.contact.odd:
        assert symmetric.all(), name
    else:
        assert not symmetric.any(), name
        # even harmonics are there: the mean of the stop coordinate moves away from the stop
        assert np.abs(ds.q_cos.values[-1, :, 0]).max() > 1e-3


@pytest.mark.numerics
def test_a_relative_stop_is_a_grounded_stop_in_the_relative_coordinate():
    """y = (q1 - q2, q2) turns the chain with a stop between its masses into a structure with a stop on y1 alone
    (M' = T^T M T, K' = T^T K T, q = T y): each orbit of the first, mapped to y, solves the HBM equations of the
    second to the accuracy it solves its own, at the same frequency and energy."""
    T = np.array([[1.0, 1.0], [0.0, 1.0]])
    relative = Structure(np.eye(2), CHAIN, [Stop(kind="relative", dofs=[0, 1], **_law())])
    grounded = Structure(T.T @ T, T.T @ CHAIN @ T, [Stop(dof=0, **_law())])
    ds = continue_nnm(relative, mode=2, harmonics=24, energy_max=4.0)
    assert int(ds.impacts_per_period.max()) == 2
    a, b = HarmonicBalanceSystem(relative, 24), HarmonicBalanceSystem(grounded, 24)
    for U in dataset_unknowns(ds, a)[::4]:
        q0, q1, f, z, lam, _ = a.split(U)
        y = np.linalg.solve(T, np.stack([q0, q1]))
        V = b.pack(*y, f, z, lam)
        scale = np.abs(U).max()
        assert np.abs(b.residual(V)).max() <= 10 * max(np.abs(a.residual(U)).max(), 1e-13 * scale)
        assert b.diagnostics(V)["energy"] == pytest.approx(a.diagnostics(U)["energy"], rel=1e-12)


@pytest.mark.numerics
def test_a_circular_clearance_moving_along_a_diameter_is_the_bilateral_stop():
    """An orthotropic structure in a circular hole: along the x axis its NNM1 stays on the diameter (y = 0 is
    invariant) and is the NNM1 of a bilateral stop on x: the unknowns (f_x, z) of one solve the other's system."""
    stiffness = np.diag([1.0, 1.7])
    hole = Structure(np.eye(2), stiffness, [Stop(kind="circular", dofs=[0, 1], **_law())])
    bilateral = Structure(np.eye(2), stiffness, [Stop(dof=0, **_law())])
    ds = continue_nnm(hole, harmonics=24, energy_max=4.0)
    assert np.all(ds.q_cos.values[:, 1] == 0.0) and np.all(ds.f2_cos.values == 0.0)
    assert int(ds.impacts_per_period[-1]) == 2  # both ends of the diameter
    a, b = HarmonicBalanceSystem(hole, 24), HarmonicBalanceSystem(bilateral, 24)
    for U in dataset_unknowns(ds, a)[::4]:
        x, y, fx, fy, z, lam, _ = a.split(U)
        V = b.pack(x, y, fx, z, lam)
        np.testing.assert_allclose(b.residual(V), np.delete(a.residual(U), a.slices["f1"]), rtol=0, atol=1e-15)
        assert b.diagnostics(V)["energy"] == pytest.approx(a.diagnostics(U)["energy"], rel=1e-13)


@pytest.mark.numerics
def test_a_one_dof_structure_continues_with_the_default_stability():
    """The crash of issue 30 (max_multiplier read a third multiplier): one DOF has only the trivial pair, every
    orbit stable, no margin to store."""
    for stop in (Stop(dof=0, **_law()), Stop(kind="one_sided", dof=0, side="positive", **_law())):
        ds = continue_nnm(Structure(np.eye(1), np.eye(1), [stop]), harmonics=16, energy_max=3.0)
        assert ds.sizes["multiplier"] == 2 and np.all(ds.max_multiplier == 1.0)
        assert np.all(ds.stable == 1) and np.all(ds.stability_resolved == 1)
        assert "stability_margin" not in ds and "floquet_invariant" not in ds
        assert float(ds.regularized_frequency[0]) == pytest.approx(np.sqrt(1.1) / (2 * np.pi), rel=1e-14)  # k + eta
        assert float(ds.frequency[0]) == pytest.approx(float(ds.regularized_frequency[0]), rel=1e-3)
        assert int(ds.impacts_per_period[-1]) >= 1


def _one_sided_period(energy: float) -> float:
    """Exact period of x'' + x + alpha (x - 1)_+ = 0 at ``energy`` (> 1/2): free flight on the circle of radius
    R = sqrt(2 E) where x < 1, then the contact arc of x'' + (1 + alpha) x = alpha (docs/methods/one_sided_law.md)."""
    radius = np.sqrt(2.0 * energy)
    omega, rest = np.sqrt(1.0 + ALPHA), ALPHA / (1.0 + ALPHA)
    amplitude = np.sqrt((1.0 - rest) ** 2 + (radius**2 - 1.0) / omega**2)
    return 2.0 * np.pi - 2.0 * np.arccos(1.0 / radius) + 2.0 * np.arccos((1.0 - rest) / amplitude) / omega


@pytest.mark.numerics
def test_the_regularized_one_sided_nnm_converges_to_the_exact_one_at_first_order_in_eta():
    """1 DOF, one-sided stop: the frequency error of the HBM orbit nearest E = 4 against the closed-form exact
    period; the fit of log(error) against log(eta) has slope 1 (the stated order, up to a logarithm)."""
    etas = np.array([0.2, 0.1, 0.05, 0.025])
    errors = []
    for eta in etas:
        stop = Stop(kind="one_sided", dof=0, side="positive", **_law(eta=eta))
        ds = continue_nnm(Structure(np.eye(1), np.eye(1), [stop]), harmonics=60, energy_max=5.0, stability=None)
        assert float(ds.truncation.max()) < 1e-5  # the harmonics resolve the law: the error is the regularization's
        i = int(np.argmin(np.abs(ds.energy.values - 4.0)))
        errors.append(abs(float(ds.frequency[i]) * _one_sided_period(float(ds.energy[i])) - 1.0))
    slope = np.polyfit(np.log(etas), np.log(errors), 1)[0]
    assert 0.9 < slope < 1.1, f"observed order {slope:.3f}, errors {errors}"


def test_branch_points_of_laws_without_symmetry_are_not_called_symmetry_breaking():
    class Point:  # an orbit whose tangent holds even harmonics only
        U = None
        bifurcated = None

    structure = Structure(np.eye(2), CHAIN, [Stop(kind="one_sided", dof=0, side="positive", **_law())])
    system = HarmonicBalanceSystem(structure, 8)
    point = Point()
    point.U = system.linear_mode_guess(1, 0.5)
    point.bifurcated = np.zeros(system.n_unknowns)
    point.bifurcated[system.slices["q0"].start + 2] = 1.0
    assert classify_branch_point(system, point) == (0, False)


MIXED = [
    Stop(kind="one_sided", dof=0, side="positive", **_law()),
    Stop(kind="one_sided", dof=0, side="negative", **_law(gap=1.3, stiffness=20.0, eta=0.2)),
    Stop(kind="relative", dofs=[1, 2], **_law(gap=0.7, eta=0.05)),
    Stop(kind="circular", dofs=[4, 3], **_law(gap=1.5)),
    Stop(dof=3, **_law()),
]


@pytest.mark.parametrize("basis", ["cosine", "full"])
def test_every_recast_is_linear_plus_quadratic_and_its_jacobian_and_series_products_are_exact(basis):
    """S(U + V) - S(U) - J(U) V = Q(V, V): the residual, the Jacobian (dense and sparse) and the ANM's series
    products of every law agree to round-off, and the condensed LU solves the bordered system (determinant sign
    included) as a dense solve does."""
    rng = np.random.default_rng(3)
    stiffness = np.diag([2.0, 2.5, 3.0, 3.5, 4.0]) - 0.5 * (np.eye(5, k=1) + np.eye(5, k=-1))
    stops = MIXED[:3] + MIXED[4:] if basis == "cosine" else MIXED[:4]  # every kind, with and without a circular
    structure = Structure(np.eye(5), stiffness, stops)
    system = HarmonicBalanceSystem(structure, 6, basis=basis)
    U, V = rng.normal(size=(2, system.n_unknowns))
    J = system.jacobian(U)
    np.testing.assert_allclose(J, system.jacobian(U, sparse=True).toarray(), rtol=0, atol=1e-14)
    quadratic = system.series_products(np.stack([U, V]), 2)
    defect = system.residual(U + V) - system.residual(U) - J @ V
    np.testing.assert_allclose(defect, quadratic, rtol=0, atol=1e-12 * np.abs(defect).max())
    tangent, rhs = rng.normal(size=system.n_unknowns), rng.normal(size=system.n_unknowns)
    factors = system.factorize_bordered(U, tangent)
    bordered = np.vstack([J, tangent])
    np.testing.assert_allclose(factors.solve(rhs), np.linalg.solve(bordered, rhs), rtol=1e-9)
    assert factors.determinant_sign() == np.sign(np.linalg.det(bordered))


def test_the_shooting_refinement_says_which_stops_it_integrates():
    from nnmstop.hbm.shooting_refinement import RegularizedDynamics, refinable

    assert refinable(Structure(np.eye(2), CHAIN, [Stop(dof=0, **_law())]))
    one_sided = Structure(np.eye(2), CHAIN, [Stop(kind="one_sided", dof=0, side="positive", **_law())])
    assert not refinable(one_sided)
    with pytest.raises(ValueError, match=r"bilateral stops on one degree of freedom.*one-sided stop \(positive"):
        RegularizedDynamics(one_sided)
