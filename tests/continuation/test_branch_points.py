"""Method-generic branch points (nnmstop.continuation.branch_points) on systems with known crossings."""

import numpy as np
import pytest

from nnmstop.continuation.branch_points import (
    bifurcation_tangents,
    difference_quadratic,
    locate_branch_point,
    switch_branch,
)
from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings


class Transcritical:
    """``S(x, y, lam) = [x (lam - x), y]``: the curves ``x = 0`` and ``x = lam`` cross at 0.

    Their tangents there, ``(0, 0, 1)`` and ``(1, 0, 1)/sqrt(2)``, are 45 degrees apart:
    a switch along the null vector orthogonal to the incoming tangent would be wrong.
    """

    n_equations, n_unknowns = 2, 3

    def residual(self, U):
        x, y, lam = U
        return np.array([x * (lam - x), y])

    def jacobian(self, U):
        x, y, lam = U
        return np.array([[lam - 2 * x, 0.0, x], [0.0, 1.0, 0.0]])


class Pitchfork:
    """``S(x, y, lam) = [x (lam - x^2), y]``: not quadratic; ``x = 0`` and ``lam = x^2`` cross at 0 at right angles."""

    n_equations, n_unknowns = 2, 3

    def residual(self, U):
        x, y, lam = U
        return np.array([x * (lam - x * x), y])

    def jacobian(self, U):
        x, y, lam = U
        return np.array([[lam - 3 * x * x, 0.0, x], [0.0, 1.0, 0.0]])


def test_difference_quadratic_is_exact_for_a_quadratic_system():
    toy = Transcritical()
    a, b = np.array([1.0, 2.0, 3.0]), np.array([-0.5, 1.0, 2.0])
    # quadratic part of S_1: x lam - x^2 -> Q(a, b) = (a_x b_lam + a_lam b_x) / 2 - a_x b_x
    expected = 0.5 * (a[0] * b[2] + a[2] * b[0]) - a[0] * b[0]
    form = difference_quadratic(toy, np.array([0.3, -1.0, 2.0]))
    np.testing.assert_allclose(form(a, b), [expected, 0.0], atol=1e-10)


#: The toys are not quadratic recasts (no ANM series): their steps are pseudo-arclength steps.
NEWTON = PseudoArclengthSettings(initial_step=0.2)


def test_locate_and_switch_at_a_transcritical_point():
    """The generic location with the quadratic form by differences (the ANM path: tests/hbm/test_bifurcation.py)."""
    toy = Transcritical()
    U_a, U_b = np.array([0.0, 0.0, -0.3]), np.array([0.0, 0.0, 0.5])
    U_star, _ = locate_branch_point(toy, U_a, U_b, NEWTON, tol=1e-12)
    np.testing.assert_allclose(U_star, 0.0, atol=1e-11)
    point = bifurcation_tangents(toy, U_star, U_b - U_a)
    np.testing.assert_allclose(point.incoming, [0.0, 0.0, 1.0], atol=1e-8)
    np.testing.assert_allclose(abs(point.bifurcated @ np.array([1.0, 0.0, 1.0])) / np.sqrt(2), 1.0, atol=1e-8)
    assert point.angle == pytest.approx(45.0, abs=1e-6)
    for step in (0.1, -0.1):
        U1 = switch_branch(toy, point, step)
        assert U1[0] == pytest.approx(U1[2], abs=1e-12)  # on x = lam
        assert abs(U1[0]) > 0.05


def test_pitchfork_tangents_by_differences_of_the_jacobian():
    """The bifurcated tangent of ``x (lam - x^2)`` at 0 is the x axis (the parabola ``lam = x^2`` starts vertically)."""
    toy = Pitchfork()
    U_a, U_b = np.array([0.0, 0.0, -0.4]), np.array([0.0, 0.0, 0.3])
    U_star, _ = locate_branch_point(toy, U_a, U_b, NEWTON, tol=1e-12)
    np.testing.assert_allclose(U_star, 0.0, atol=1e-11)
    point = bifurcation_tangents(toy, U_star, U_b - U_a)
    np.testing.assert_allclose(abs(point.bifurcated), [1.0, 0.0, 0.0], atol=1e-7)
    U1 = switch_branch(toy, point, 0.1)
    assert U1[2] == pytest.approx(U1[0] ** 2, abs=1e-12)  # on lam = x^2


def test_no_branch_point_between_regular_points():
    toy = Transcritical()
    with pytest.raises(ValueError, match="no branch point"):
        locate_branch_point(toy, np.array([0.0, 0.0, 0.2]), np.array([0.0, 0.0, 0.5]), NEWTON)
