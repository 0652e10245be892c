"""The contact laws (nnmstop.models.contact): the factory and its refusals, each law against its closed form."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from nnmstop.models.contact import (
    BilateralStop,
    CircularStop,
    OneSidedStop,
    RelativeStop,
    Stop,
    one_sided_force,
    one_sided_potential,
    one_sided_stiffness,
)
from nnmstop.models.structure import Structure, limit_stiffness
from nnmstop.models.two_dof import (
    ModelParameters,
    regularized_contact_force,
    regularized_contact_potential,
    regularized_contact_stiffness,
)

LAW = {"gap": 1.0, "stiffness": 30.0, "eta": 0.1}


def test_stop_builds_each_kind_and_keeps_the_papers_call():
    assert Stop(dof=0, **LAW) == BilateralStop(0, 1.0, 30.0, 0.1)
    assert isinstance(Stop(0, 1.0, 30.0, 0.1), BilateralStop)
    assert isinstance(Stop(kind="one_sided", dof=1, side="negative", **LAW), OneSidedStop)
    assert isinstance(Stop(kind="relative", dofs=[0, 1], **LAW), RelativeStop)
    assert isinstance(Stop(kind="circular", dofs=[0, 1], **LAW), CircularStop)
    assert all(isinstance(s, Stop) for s in (BilateralStop(0, **LAW), CircularStop((0, 1), **LAW)))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"kind": "circular", "dofs": [0, 1], "side": "positive"}, r"stop key 'side' is not allowed for a circular"),
        ({"kind": "circular", "dof": 0}, r"stop key 'dof' is not allowed for a circular stop"),
        ({"kind": "circular", "dofs": [1]}, r"circular stop dofs must be a list of two degrees of freedom"),
        ({"kind": "relative", "dofs": [1, 1]}, r"relative stop dofs must be two distinct degrees of freedom"),
        ({"kind": "relative", "dof": 1}, r"stop key 'dof' is not allowed for a relative stop"),
        ({"kind": "one_sided", "dof": 0}, r"a one_sided stop needs the key 'side' \(positive or negative\)"),
        ({"kind": "one_sided", "dof": 0, "side": "up"}, r"one_sided stop side must be one of"),
        ({"kind": "bilateral", "dof": 0, "side": "positive"}, r"stop key 'side' is not allowed for a bilateral"),
        ({"kind": "bilateral", "dofs": [0, 1]}, r"stop key 'dofs' is not allowed for a bilateral"),
        ({"kind": "elliptic", "dof": 0}, r"stop kind must be one of \('bilateral', 'one_sided'"),
    ],
)
def test_bad_combinations_are_refused_with_the_key_named(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Stop(**kwargs, **LAW)


def test_regularization_bounds_name_the_law():
    with pytest.raises(ValueError, match=r"eta=30\.0 >= alpha=30\.0"):
        Stop(kind="circular", dofs=[0, 1], gap=1.0, stiffness=30.0, eta=30.0)
    with pytest.raises(ValueError, match=r"smaller than half its stiffness.*eta=16\.0 >= alpha/2=15\.0"):
        Stop(kind="one_sided", dof=0, side="positive", gap=1.0, stiffness=30.0, eta=16.0)


def test_only_one_sided_stops_share_a_degree_of_freedom():
    M = K = np.eye(3)
    unequal = Structure(M, K, [OneSidedStop(0, "positive", **LAW), OneSidedStop(0, "negative", 2.0, 30.0, 0.1)])
    assert unequal.stop_dofs == (0, 0)
    with pytest.raises(ValueError, match=r"distinct degrees of freedom, got dofs \[0, \[0, 1\]\]"):
        Structure(M, K, [BilateralStop(0, **LAW), RelativeStop((0, 1), **LAW)])
    with pytest.raises(ValueError, match=r"stop dof 3 is out of range"):
        Structure(M, K, [CircularStop((1, 3), **LAW)])


def test_the_bilateral_law_is_the_papers():
    params = ModelParameters(alpha=30.0, eta=0.1)
    stop = BilateralStop(0, **LAW)
    x = np.linspace(-4.0, 4.0, 81)[None]
    np.testing.assert_array_equal(stop.force(x)[0], regularized_contact_force(x[0], params))
    np.testing.assert_array_equal(stop.jacobian(x)[0, 0], regularized_contact_stiffness(x[0], params))
    np.testing.assert_array_equal(stop.potential(x), regularized_contact_potential(x[0], params))
    assert stop.odd and stop.recast.family == "squared_gap" and stop.recast.coefficient == -1.0


@pytest.mark.parametrize("alpha, eta", [(30.0, 0.1), (10.0, 2.0), (1e3, 1e-3)])
def test_one_sided_force_is_the_root_through_the_origin_of_its_quadratic(alpha, eta):
    """f - eta x + kappa f (f / alpha - x) = 0 to round-off, f(0) = 0, f'(0) = eta, and the asymptotes of the
    hyperbola: -eta / kappa far from the stop, alpha (x - 1) - eta / kappa deep in contact."""
    kappa = 1.0 - 2.0 * eta / alpha
    x = np.concatenate([-np.geomspace(1e-8, 1e8, 30), [0.0], np.geomspace(1e-8, 1e8, 30), np.linspace(0.9, 1.1, 21)])
    f = one_sided_force(x, alpha, eta)
    # the residual in exact rational arithmetic (the law's kappa is 1 - 2 eps with eps = eta / alpha a float), over
    # its slope d/df = sqrt(D): the force's error in ulps of f
    a, e = Fraction(alpha), Fraction(eta)
    k = 1 - 2 * Fraction(eta / alpha)
    for xi, fi in zip(x, f):
        X, F = Fraction(xi), Fraction(fi)
        residual = float(F - e * X + k * F * (F / a - X))
        slope = np.hypot(kappa * (xi - 1.0), np.sqrt(1.0 - kappa**2))
        assert abs(residual) <= 2e-15 * slope * max(abs(fi), 1e-300), (xi, fi, residual)
    assert one_sided_force(0.0, alpha, eta) == 0.0
    assert one_sided_stiffness(0.0, alpha, eta) == pytest.approx(eta, rel=1e-14)
    assert one_sided_force(-1e12, alpha, eta) == pytest.approx(-eta / kappa, rel=1e-9)
    assert one_sided_force(1e6, alpha, eta) == pytest.approx(alpha * (1e6 - 1) - eta / kappa, rel=1e-12)


def test_one_sided_slope_and_potential_are_the_forces():
    alpha, eta = 30.0, 0.1
    x = np.linspace(-3.0, 4.0, 141)
    h = 1e-6
    slope = (one_sided_force(x + h, alpha, eta) - one_sided_force(x - h, alpha, eta)) / (2 * h)
    np.testing.assert_allclose(one_sided_stiffness(x, alpha, eta), slope, rtol=1e-7, atol=1e-9)
    force = (one_sided_potential(x + h, alpha, eta) - one_sided_potential(x - h, alpha, eta)) / (2 * h)
    np.testing.assert_allclose(one_sided_force(x, alpha, eta), force, rtol=1e-7, atol=1e-8)
    # near rest P = eta x^2 / 2 to relative round-off (no cancellation in the closed form)
    tiny = np.array([-1e-9, 1e-7, 1e-5])
    np.testing.assert_allclose(one_sided_potential(tiny, alpha, eta), 0.5 * eta * tiny**2, rtol=1e-4)


def test_one_sided_law_tends_to_the_piecewise_law_as_eta_vanishes():
    """The largest distance to alpha (x - 1)_+ is at the corner, f(1) = alpha (sqrt(1 - kappa^2) - 1 + kappa) /
    (2 kappa) ~ sqrt(alpha eta), and tends to 0 like sqrt(eta)."""
    alpha, x = 30.0, np.linspace(-5.0, 5.0, 2001)
    gaps = []
    for eta in (1e-2, 1e-4, 1e-6):
        eps = eta / alpha
        kappa = 1.0 - 2.0 * eps
        corner = alpha * (np.sqrt(4.0 * eps * (1.0 - eps)) - 2.0 * eps) / (2.0 * kappa)
        error = np.abs(one_sided_force(x, alpha, eta) - alpha * np.maximum(x - 1.0, 0.0)).max()
        assert error == pytest.approx(corner, rel=1e-12)
        gaps.append(error)
    assert gaps[1] / gaps[0] == pytest.approx(0.1, rel=0.03) and gaps[2] / gaps[1] == pytest.approx(0.1, rel=0.003)


def test_a_negative_one_sided_stop_is_the_mirror_of_a_positive_one():
    positive, negative = OneSidedStop(0, "positive", **LAW), OneSidedStop(0, "negative", **LAW)
    q = np.linspace(-3.0, 3.0, 61)[None]
    np.testing.assert_array_equal(negative.coordinates(q), positive.coordinates(-q))
    np.testing.assert_array_equal(negative.piecewise_force(q[0]), -positive.piecewise_force(-q[0]))
    assert negative.contacts()[0].normal(1).tolist() == [-1.0] and negative.side_sign == -1
    assert positive.impacts(np.array([[0.0, 1.5, 0.0, 2.0, 0.0, -3.0]])) == 2  # the other side is no stop
    assert not positive.odd and positive.recast.family == "linear_gap"


def test_circular_clearance_is_the_bilateral_law_of_the_radius():
    hole, params = CircularStop((0, 1), **LAW), ModelParameters(alpha=30.0, eta=0.1)
    r = np.linspace(0.0, 3.0, 31)
    angle = 0.7
    x = np.stack([r * np.cos(angle), r * np.sin(angle)])
    f = hole.force(x)
    np.testing.assert_allclose(np.hypot(*f), regularized_contact_force(r, params), rtol=1e-14, atol=1e-300)
    np.testing.assert_allclose(f[0] * x[1] - f[1] * x[0], 0.0, atol=1e-13)  # radial
    np.testing.assert_allclose(hole.potential(x), regularized_contact_potential(r, params), rtol=1e-14)
    # along a diameter it is the bilateral stop, on both sides
    along = np.stack([np.linspace(-3, 3, 13), np.zeros(13)])
    np.testing.assert_allclose(hole.force(along)[0], regularized_contact_force(along[0], params), rtol=1e-14)
    assert np.all(hole.force(along)[1] == 0.0)
    # the Jacobian, against central differences, and eta I at the centre
    h = 1e-6
    columns = [(hole.force(x + h * e[:, None]) - hole.force(x - h * e[:, None])) / (2 * h) for e in np.eye(2)]
    np.testing.assert_allclose(hole.jacobian(x), np.stack(columns, axis=1), rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(hole.jacobian(np.zeros((2, 1)))[..., 0], 0.1 * np.eye(2), rtol=1e-14)
    assert hole.impacts(np.stack([np.cos(np.linspace(0, 6, 7)) * 1.5, np.zeros(7)])) == 2
    assert hole.sliding_velocity(np.array([1.0, 0.0]), np.array([0.0, 2.0])) == 2.0


def test_circular_clearance_is_not_piecewise_linear_and_says_so():
    hole = CircularStop((0, 1), **LAW)
    assert not hole.piecewise_linear
    with pytest.raises(ValueError, match="not piecewise linear in the Cartesian coordinates.*regularized engine"):
        hole.contacts()


def test_relative_stop_reads_the_difference_and_pushes_both_ways():
    stop = RelativeStop((2, 0), **LAW)
    q = np.array([1.0, 5.0, 3.5])
    assert stop.coordinates(q).tolist() == [2.5]
    assert stop.coordinate_matrix(3).tolist() == [[-1.0, 0.0, 1.0]]
    structure = Structure(np.eye(3), np.eye(3), [stop])
    forces = np.zeros(3)
    structure.contact.apply(forces, np.array([2.0]))
    assert forces.tolist() == [-2.0, 0.0, 2.0]
    # its slope at rest on the relative coordinate: eta (e_2 - e_0)(e_2 - e_0)^T added to K
    np.testing.assert_allclose(
        limit_stiffness(structure, "regularized"), np.eye(3) + 0.1 * np.array([[1, 0, -1], [0, 0, 0], [-1, 0, 1]])
    )


def test_a_beam_takes_one_sided_stops_and_unequal_gaps_at_a_node():
    from nnmstop.models.beam import Beam, beam_structure

    stops = [
        {"node": 4, "gap": 1e-3, "stiffness": 1e5, "eta": 10.0, "kind": "one_sided", "side": "positive"},
        {"node": 4, "gap": 2e-3, "stiffness": 1e5, "eta": 10.0, "kind": "one_sided", "side": "negative"},
    ]
    beam = Beam.from_parameters(
        {
            "length": 1.0,
            "bending_stiffness": 1.0,
            "mass_per_length": 1.0,
            "n_elements": 4,
            "left": "clamped",
            "right": "free",
            "stops": stops,
        }
    )
    structure = beam_structure(beam)
    positive, negative = structure.stops
    assert isinstance(positive, OneSidedStop) and positive.side == "positive" and negative.side == "negative"
    assert positive.dof == negative.dof and negative.gap == pytest.approx(2.0 * positive.gap, rel=1e-15)
    assert structure.attributes["stop_kinds"] == "one_sided:positive one_sided:negative"
    for bad, match in (
        ({"kind": "relative"}, r"beam stop kind must be one of \('bilateral', 'one_sided', 'circular'\)"),
        ({"kind": "circular"}, r"a circular stop needs a beam bending in two planes \(planes: 2\)"),
        ({"kind": "one_sided"}, "needs the key 'side'"),
        ({"side": "positive"}, "'side' is not allowed for a bilateral beam stop"),
    ):
        with pytest.raises(ValueError, match=match):
            Beam.from_parameters({**beam.__dict__, "stops": [{**stops[0], "kind": "bilateral", "side": None} | bad]})
