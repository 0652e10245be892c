"""Finite-element Euler-Bernoulli beam: convergence to the analytical frequencies, nondimensionalization,
validation."""

import numpy as np
import pytest

from nnmstop.models.beam import (
    Beam,
    BeamStop,
    assemble_free_beam,
    beam_deflection,
    beam_scales,
    beam_structure,
    default_tube_parameters,
    euler_bernoulli_frequencies,
    mode_frequencies,
)
from nnmstop.models.structure import generalized_modes, linear_frequencies

LENGTH, EI, RHO_A = 2.0, 3.0, 5.0
RIGID_MODES = {("free", "free"): 2}


def _fe_frequencies(left, right, n_elements, n_modes):
    """Physical FE angular frequencies of the flexible modes (rigid-body modes dropped)."""
    beam = Beam(LENGTH, EI, RHO_A, n_elements, left, right, stops=(BeamStop(1.0, 2.0, 1.0, node=1),))
    scales = beam_scales(beam)
    rigid = RIGID_MODES.get((left, right), 0)
    omega = linear_frequencies(beam_structure(beam), n_modes + rigid)[rigid:]
    return omega * scales["angular_frequency"]


@pytest.mark.parametrize(
    "left, right",
    [("clamped", "free"), ("clamped", "clamped"), ("pinned", "pinned"), ("pinned", "clamped"), ("free", "free")],
)
def test_fe_frequencies_converge_at_fourth_order(left, right):
    # Hermite cubics are conforming for the fourth-order bending operator (m = 2) and complete to degree
    # p = 3, so the eigenvalue error is O(h^(2(p + 1 - m))) = O(h^4) (Strang & Fix); omega = sqrt(lambda) has
    # the same relative order. Consistent mass makes this a Rayleigh-Ritz method: frequencies from above.
    exact = euler_bernoulli_frequencies(left, right, 3, LENGTH, EI, RHO_A)
    errors = np.array([_fe_frequencies(left, right, n, 3) / exact - 1.0 for n in (8, 16, 32)])
    assert np.all(errors > 0)
    observed_order = np.log2(errors[1] / errors[2])
    np.testing.assert_allclose(observed_order, 4.0, atol=0.15)
    assert np.all(np.abs(np.log2(errors[0] / errors[1]) - 4.0) < 0.3)


def test_mode_frequencies_in_nondimensional_hz():
    beam = Beam(LENGTH, EI, RHO_A, 16, "free", "free", stops=(BeamStop(1.0, 2.0, 1.0, node=3),))
    frequencies = mode_frequencies(beam, 3)
    np.testing.assert_allclose(frequencies["fe"][0], 1.0 / (2.0 * np.pi), rtol=1e-12)
    # same physical frequencies as the convergence test's, divided by the same FE first frequency
    exact = euler_bernoulli_frequencies("free", "free", 3, LENGTH, EI, RHO_A)
    fe = _fe_frequencies("free", "free", 16, 3)
    np.testing.assert_allclose(frequencies["euler_bernoulli"] / frequencies["fe"], exact / fe, rtol=1e-12)
    assert np.all(frequencies["fe"] > frequencies["euler_bernoulli"])  # Rayleigh-Ritz: from above


def test_pinned_pinned_frequencies_are_n_pi_squared():
    exact = euler_bernoulli_frequencies("pinned", "pinned", 4, LENGTH, EI, RHO_A)
    n = np.arange(1, 5)
    np.testing.assert_allclose(exact, (n * np.pi / LENGTH) ** 2 * np.sqrt(EI / RHO_A), rtol=1e-15)


@pytest.mark.parametrize("left, right", [("clamped", "free"), ("clamped", "clamped"), ("pinned", "clamped")])
def test_analytical_roots_are_stable_for_high_modes(left, right):
    # beta_n L tends to (n + 1/2) pi (CF: n - 1/2, CP: n + 1/4) exponentially fast; mode 60 must still be found
    # in its bracket and separated from its neighbours by about pi in beta L.
    beta_l = np.sqrt(euler_bernoulli_frequencies(left, right, 60, 1.0, 1.0, 1.0))
    offset = {("clamped", "free"): -0.5, ("clamped", "clamped"): 0.5, ("pinned", "clamped"): 0.25}[(left, right)]
    np.testing.assert_allclose(beta_l[-10:], (np.arange(51, 61) + offset) * np.pi, rtol=1e-14)


def test_nondimensional_structure_scales_and_static_deflection():
    parameters = default_tube_parameters()
    beam = Beam.from_parameters(parameters)
    structure = beam_structure(beam)
    scales = beam_scales(beam)
    (stop,) = structure.stops
    (beam_stop,) = beam.stops
    node = beam.stop_nodes[0]
    assert structure.dof_labels[stop.dof] == f"w{node}"
    np.testing.assert_allclose(structure.node_coordinates[node], beam_stop.position / beam.length, rtol=1e-15)
    np.testing.assert_allclose(linear_frequencies(structure, 1), [1.0], rtol=1e-12)
    assert stop.gap == 1.0
    np.testing.assert_allclose(stop.stiffness, beam_stop.stiffness * beam.length**3 / beam.bending_stiffness)
    np.testing.assert_allclose(stop.eta, beam_stop.eta * beam.length**3 / beam.bending_stiffness)
    # Cubic Hermite elements are exact for point loads at nodes: a force P at the plate of the cantilever
    # deflects it by P a^3 / (3 EI). In the model, force P / (gap EI / L^3) gives deflection w / gap.
    force = 1.0
    a = beam_stop.position
    deflection = force * a**3 / (3.0 * beam.bending_stiffness)
    nondimensional_force = force / (scales["length"] * scales["stiffness"])
    stiffness = structure.stiffness.toarray()
    x = np.linalg.solve(stiffness, nondimensional_force * np.eye(structure.n_dofs)[stop.dof])
    np.testing.assert_allclose(x[stop.dof] * scales["length"], deflection, rtol=1e-12)
    # time unit: the physical first FE frequency, which converges to the analytical cantilever frequency
    k, m = assemble_free_beam(beam.length, beam.bending_stiffness, beam.mass_per_length, beam.n_elements)
    kept = np.arange(2, k.shape[0])  # clamped foot
    omega = generalized_modes(m[kept][:, kept], k[kept][:, kept], 1)[0][0]
    np.testing.assert_allclose(scales["angular_frequency"], omega, rtol=1e-12)
    exact = euler_bernoulli_frequencies("clamped", "free", 1, beam.length, beam.bending_stiffness, beam.mass_per_length)
    assert 0 < omega / exact[0] - 1 < 1e-5


def test_deflection_between_nodes_is_the_static_cubic():
    # Under a force P at s = a the cantilever bends as P s^2 (3a - s) / (6 EI) for s <= a and linearly beyond:
    # cubic per element, which the Hermite interpolation of the FE solution must reproduce between nodes.
    beam = Beam.from_parameters(default_tube_parameters())
    structure = beam_structure(beam)
    scales = beam_scales(beam)
    (stop,) = structure.stops
    a = beam.stops[0].position
    force = 1.0
    x = np.linalg.solve(
        structure.stiffness.toarray(),
        force / (scales["length"] * scales["stiffness"]) * np.eye(structure.n_dofs)[stop.dof],
    )
    s = np.linspace(0.0, 1.0, 37) * beam.length
    under = np.minimum(s, a)
    exact = force * under**2 * (3 * a - under) / (6 * beam.bending_stiffness)
    exact += np.where(s > a, force * a**2 / (2 * beam.bending_stiffness) * (s - a), 0.0)
    w = beam_deflection(structure, np.stack([x, 2 * x]), s / beam.length) * scales["length"]
    np.testing.assert_allclose(w[0], exact, rtol=1e-11, atol=1e-12 * exact.max())
    np.testing.assert_allclose(w[1], 2 * exact, rtol=1e-11, atol=1e-12 * exact.max())


def _tube(**changes):
    parameters = default_tube_parameters()
    stop = dict(parameters["stops"][0])
    stop.update(changes.pop("stop", {}))
    parameters.update(changes, stops=[stop])
    return Beam.from_parameters(parameters)


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"stop": {"position": 0.55}}, r"stop position 0\.55 is not on a node"),
        ({"stop": {"gap": -2e-4}}, r"stop gap must be a finite number > 0, got -0\.0002"),
        ({"stop": {"eta": 1e9}}, r"eta=1000000000\.0 >= stiffness="),
        ({"left": "hinged"}, r"left boundary condition must be one of \['clamped', 'free', 'pinned'\], got 'hinged'"),
        ({"n_elements": 0}, r"n_elements must be an integer >= 1, got 0"),
        ({"stop": {"position": 0.0}}, r"stop at node 0 would act on a clamped end"),
        ({"stop": {"position": 1.5}}, r"stop position must be a number in \[0, 1\.0\], got 1\.5"),
    ],
)
def test_beam_validation_names_the_value(changes, match):
    with pytest.raises(ValueError, match=match):
        _tube(**changes)


def test_parameter_keys_are_checked():
    parameters = default_tube_parameters()
    del parameters["left"]
    parameters["lenght"] = 1.0
    with pytest.raises(ValueError, match=r"missing keys \['left'\], unknown keys \['lenght'\]"):
        Beam.from_parameters(parameters)
    parameters = default_tube_parameters()
    parameters["stops"][0]["clearance"] = 1.0
    with pytest.raises(ValueError, match="each stop must be a dict with keys among"):
        Beam.from_parameters(parameters)


def test_analytical_frequencies_validation():
    with pytest.raises(ValueError, match=r"left_bc must be one of .*got 'sliding'"):
        euler_bernoulli_frequencies("sliding", "free", 2, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"n_modes must be an integer >= 1, got 0"):
        euler_bernoulli_frequencies("clamped", "free", 0, 1.0, 1.0, 1.0)


def _hole(planes=2, **stop):
    parameters = default_tube_parameters()
    parameters["stops"][0].update(stop)
    return Beam.from_parameters({**parameters, "planes": planes})


def test_a_beam_bending_in_two_planes_in_a_circular_hole():
    """Two planes of the same section: the one-plane matrices twice, every frequency twice (the circular stop's eta
    acts in both directions as the bilateral stop's in one), invariant under the rotations turning (w, v) and
    (theta, psi) together; the second plane's deflection is read from its own DOFs."""
    one = beam_structure(_tube())
    two = beam_structure(_hole(kind="circular"))
    n = one.n_dofs
    assert two.n_dofs == 2 * n and two.rotation_pairs == tuple((i, n + i) for i in range(n))
    for name in ("mass", "stiffness"):
        a, b = getattr(one, name).toarray(), getattr(two, name).toarray()
        np.testing.assert_array_equal(b[:n, :n], a)
        np.testing.assert_array_equal(b[n:, n:], a)
        assert not b[:n, n:].any() and not b[n:, :n].any()
    (stop,) = two.stops
    assert stop.kind == "circular" and list(stop.dofs) == [one.stops[0].dof, n + one.stops[0].dof]
    assert two.dof_labels[n + one.stops[0].dof] == "v" + one.dof_labels[one.stops[0].dof][1:]
    np.testing.assert_allclose(linear_frequencies(two, 6), np.repeat(linear_frequencies(one, 3), 2), rtol=1e-10)
    x = np.linalg.solve(one.stiffness.toarray(), np.eye(n)[one.stops[0].dof])
    s = np.linspace(0.0, 1.0, 11)
    q = np.concatenate([np.zeros(n), x])  # bent in the second plane only
    np.testing.assert_allclose(beam_deflection(two, q, s, plane=2), beam_deflection(one, x, s), rtol=1e-14)
    assert not beam_deflection(two, q, s, plane=1).any()
    assert two.attributes["planes"] == 2 and "planes" not in one.attributes  # the one-plane datasets keep theirs


@pytest.mark.parametrize(
    "planes, stop, match",
    [
        (1, {"kind": "circular"}, r"a circular stop needs a beam bending in two planes \(planes: 2\)"),
        (3, {}, r"planes must be 1 or 2 .*got 3"),
        (2, {"kind": "circular", "side": "positive"}, r"'side' is not allowed for a circular beam stop"),
    ],
)
def test_two_plane_validation_names_the_value(planes, stop, match):
    with pytest.raises(ValueError, match=match):
        _hole(planes, **stop)
