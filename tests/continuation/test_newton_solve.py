"""The shared dense Newton iteration and bisection (nnmstop.continuation.newton).

Checked against closed forms: Newton's error recursion for ``y^2 = c``, the linear
convergence of chord iterations, a root of a known function; failures must be reported.
"""

from __future__ import annotations

import numpy as np
import pytest

from nnmstop.continuation import bisect_sign_change, newton_solve
from nnmstop.continuation.linear import BorderedFactorization


def circle_and_line():
    """``y0^2 + y1^2 = 4``, ``y1 = y0``: root ``(sqrt 2, sqrt 2)``; the iterates stay on the line."""
    iterates = []

    def residual(y):
        iterates.append(np.array(y))
        return np.array([y[0] ** 2 + y[1] ** 2 - 4.0, y[1] - y[0]])

    def jacobian(y):
        return np.array([[2 * y[0], 2 * y[1]], [-1.0, 1.0]])

    return residual, jacobian, iterates


def test_newton_error_follows_the_closed_form_quadratic_recursion():
    # On the line y1 = y0 = x Newton is Newton on 2 x^2 = 4, whose error obeys exactly
    # e_{k+1} = e_k^2 / (2 x_k): quadratic convergence with a known constant.
    residual, jacobian, iterates = circle_and_line()
    result = newton_solve(residual, jacobian, [3.0, 3.0], tol=1e-15, max_iter=30)
    assert result.converged and result.reason == ""
    root = np.sqrt(2.0)
    np.testing.assert_allclose(result.y, [root, root], rtol=0, atol=4e-16)
    x = np.array([it[0] for it in iterates])
    errors = x - root
    for k in range(len(x) - 1):
        if abs(errors[k]) < 1e-7:
            break
        assert errors[k + 1] == pytest.approx(errors[k] ** 2 / (2 * x[k]), rel=1e-6, abs=1e-15)
    assert 4 <= result.iterations <= 8  # 3 -> sqrt(2) in digits doubling per iteration
    assert result.residual_norm <= 1e-14


def test_polish_makes_one_more_update_after_the_step_test():
    residual, jacobian, _ = circle_and_line()
    plain = newton_solve(residual, jacobian, [3.0, 3.0], tol=1e-6, max_iter=30)
    polished = newton_solve(residual, jacobian, [3.0, 3.0], tol=1e-6, max_iter=30, polish=True)
    assert plain.converged and polished.converged
    assert polished.iterations == plain.iterations + 1
    # one more quadratic step from an error of at most ~1e-6: round-off
    assert polished.residual_norm <= 1e-14 < plain.residual_norm


def test_residual_criterion_accepts_a_converged_guess_without_iterating():
    residual, jacobian, _ = circle_and_line()
    root = np.sqrt(2.0)
    result = newton_solve(residual, jacobian, [root, root], tol=1e-12, max_iter=5, criterion="residual")
    assert result.converged and result.iterations == 0 and result.step is None


def test_custom_criterion_and_combined_residual_jacobian():
    residual, jacobian, _ = circle_and_line()
    seen = []

    def both(y):
        return residual(y), jacobian(y)

    def criterion(y, r, dy):
        seen.append(dy is None)
        return np.max(np.abs(r)) <= 1e-12

    result = newton_solve(both, None, [1.0, 2.0], tol=0.0, max_iter=20, criterion=criterion)
    assert result.converged
    assert seen[0] and not any(seen[1:])  # first call on the guess, then after each update
    np.testing.assert_allclose(result.y, [np.sqrt(2.0)] * 2, atol=1e-12)


def test_chord_iterations_on_a_fixed_factorization_converge_linearly():
    # A constant Jacobian J0 = F'(x0) on F(x) = x^2 - 2 gives e_{k+1} = e_k (1 - (x_k + root) / (2 x0)):
    # linear convergence with ratio -> 1 - root / x0.
    x0 = 1.6
    factors = BorderedFactorization.of_matrix(np.array([[2 * x0]]))
    xs = []

    def residual(y):
        xs.append(float(y[0]))
        return np.array([y[0] ** 2 - 2.0])

    result = newton_solve(residual, lambda y: factors, [x0], tol=1e-14, max_iter=200)
    assert result.converged and result.jacobian is factors
    errors = np.array(xs) - np.sqrt(2.0)
    ratios = errors[3:8] / errors[2:7]
    np.testing.assert_allclose(ratios, 1 - np.sqrt(2.0) / x0, rtol=0.02)


def test_failure_is_reported_not_raised():
    # x^2 + 1 has no real root: Newton wanders and never converges
    result = newton_solve(
        lambda y: np.array([y[0] ** 2 + 1.0]), lambda y: np.array([[2 * y[0]]]), [0.5], tol=1e-12, max_iter=25
    )
    assert not result.converged and result.iterations == 25
    assert "no convergence in 25 iterations" in result.reason
    # non-finite residual on the way
    with np.errstate(invalid="ignore"):  # log of a negative iterate
        result = newton_solve(
            lambda y: np.array([np.log(y[0])]), lambda y: np.array([[1.0 / y[0]]]), [5.0], tol=1e-12, max_iter=10
        )
    assert not result.converged and "non-finite" in result.reason


def test_stop_on_growth_gives_up_early():
    calls = []

    def residual(y):
        calls.append(1)
        return np.array([np.arctan(y[0])])  # Newton diverges from |x0| > 1.39

    kwargs = dict(tol=1e-12, max_iter=6)  # x_6 ~ 1e21: no overflow yet
    jac = lambda y: np.array([[1.0 / (1.0 + y[0] ** 2)]])  # noqa: E731
    diverging = newton_solve(residual, jac, [2.0], **kwargs)
    assert not diverging.converged
    stopped = newton_solve(residual, jac, [2.0], stop_on_growth=True, **kwargs)
    assert not stopped.converged and "growing" in stopped.reason and stopped.iterations == 2


def test_bad_arguments_are_refused():
    residual, jacobian, _ = circle_and_line()
    with pytest.raises(ValueError, match="criterion"):
        newton_solve(residual, jacobian, [1.0, 1.0], tol=1e-12, max_iter=5, criterion="update")
    with pytest.raises(ValueError, match="max_iter"):
        newton_solve(residual, jacobian, [1.0, 1.0], tol=1e-12, max_iter=-1)


def test_bisection_locates_a_known_root_to_the_tolerance():
    root = 1.0 / 3.0
    out = bisect_sign_change(lambda x: np.cos(np.pi * x) - 0.5, 0.0, 1.0, tol=1e-12)
    assert out.hi - out.lo <= 1e-12 and out.lo <= root <= out.hi
    assert abs(out.midpoint - root) <= 0.5e-12
    assert np.sign(out.value_lo) == 1 and np.sign(out.value_hi) == -1
    # reversed bracket and a labelled side with values known at the ends
    out = bisect_sign_change(
        lambda x: {"valid": x < root},
        1.0,
        0.0,
        tol=1e-10,
        side=lambda v: v["valid"],
        f_a={"valid": False},
        f_b={"valid": True},
    )
    assert out.lo >= root >= out.hi and abs(out.lo - out.hi) <= 1e-10


def test_bisection_needs_a_sign_change():
    with pytest.raises(ValueError, match="same side"):
        bisect_sign_change(lambda x: x * x + 1.0, -1.0, 1.0, tol=1e-6)
    with pytest.raises(ValueError, match="tol"):
        bisect_sign_change(lambda x: x, -1.0, 1.0, tol=0.0)
