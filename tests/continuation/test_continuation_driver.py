"""One continuation driver, two steppers (nnmstop.continuation.driver, anm, pseudo_arclength).

Both steppers must trace the same curve (a closed-form circle, and NNM1 of the 2-DOF
model), flag a simple branch point in the step that holds it, and give a path over their
steps on which the branch point is located to the accuracy of that path.
"""

from __future__ import annotations

import numpy as np
import pytest

from nnmstop.continuation.anm import ANMSettings, ANMStepper, TaylorPath, continue_anm
from nnmstop.continuation.branch_points import locate_branch_point
from nnmstop.continuation.core import (
    ContinuationError,
    ContinuationStats,
    newton_correct,
    relative_residual,
    unit_tangent,
)
from nnmstop.continuation.corrected_path import CorrectedPath
from nnmstop.continuation.driver import continue_branch
from nnmstop.continuation.linear import BorderedFactorization
from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings, continue_pseudo_arclength
from nnmstop.hbm.bifurcation import locate_flagged_branch_points
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters

QUIET = 1e9  # progress_seconds: no progress messages
METHODS = {"ANM": ANMSettings(), "pseudo-arclength": PseudoArclengthSettings()}


class QuadraticToy:
    """A quadratic system ``S(U) = c + A U + Q(U, U)`` with the interface the steppers use."""

    def __init__(self, c, A, Q):
        self.c, self.A, self.Q = np.asarray(c, float), np.asarray(A, float), np.asarray(Q, float)
        self.n_unknowns = self.A.shape[1]

    def residual(self, U):
        return self.c + self.A @ U + np.einsum("ijk,j,k->i", self.Q, U, U)

    def jacobian(self, U):
        return self.A + np.einsum("ijk,k->ij", self.Q, U) + np.einsum("ikj,k->ij", self.Q, U)

    def series_cache(self, order):
        return None

    def series_products(self, series, p, cache=None):
        return sum(np.einsum("ijk,j,k->i", self.Q, series[r], series[p - r]) for r in range(1, p))

    def diagnostics(self, U):
        return {"energy": float(U[-1]), "frequency": float(U[0]), "impacts_per_period": 0}


def circle():
    """``x^2 + y^2 = 1``: the curve is known everywhere, with folds in ``y`` at ``x = +-1``."""
    Q = np.zeros((1, 2, 2))
    Q[0, 0, 0] = Q[0, 1, 1] = 1.0
    return QuadraticToy([-1.0], np.zeros((1, 2)), Q)


def crossing_on_a_circle():
    """``x (lam - x) = 0``, ``y^2 + lam^2 = 1`` in ``(x, y, lam)``: two curves on the cylinder,
    ``x = 0`` and ``x = lam``, cross at ``(0, 1, 0)`` (a simple branch point; the followed one is curved)."""
    Q = np.zeros((2, 3, 3))
    Q[0, 0, 2], Q[0, 0, 0] = 1.0, -1.0
    Q[1, 1, 1] = Q[1, 2, 2] = 1.0
    return QuadraticToy([0.0, -1.0], np.zeros((2, 3)), Q)


def half_turn(U, d):
    """Stop once the circle is followed past its leftmost point (two folds in y passed)."""
    return "half turn" if U[0] < -0.5 and U[1] < 0 else ""


@pytest.mark.parametrize("name", list(METHODS))
def test_both_steppers_follow_the_circle(name):
    system = circle()
    branch = continue_branch(system, [1.0, 0.0], [0.0, 1.0], METHODS[name].stepper(), half_turn, progress_seconds=QUIET)
    U = np.array(branch.points)
    assert branch.end_reason == "half turn"
    np.testing.assert_allclose(np.hypot(U[:, 0], U[:, 1]), 1.0, atol=1e-8)  # on the curve, to the tolerances
    angle = np.unwrap(np.arctan2(U[:, 1], U[:, 0]))
    assert np.all(np.diff(angle) > 0) and angle[-1] > np.pi  # counter-clockwise through the top, no turn back
    assert branch.branch_points == []  # folds are not branch points
    np.testing.assert_allclose(branch.end_tangent, [-U[-1, 1], U[-1, 0]], atol=1e-7)  # unit, along the travel


class OwnFactorization(QuadraticToy):
    """The circle with its own bordered factorization (as a large structured system would have)."""

    def __init__(self):
        base = circle()
        super().__init__(base.c, base.A, base.Q)
        self.calls = 0

    def factorize_bordered(self, U, tangent):
        self.calls += 1
        return BorderedFactorization.of_matrix(np.vstack([self.jacobian(U), tangent]))


@pytest.mark.parametrize("name", list(METHODS))
def test_every_factorization_goes_through_the_systems_own(name):
    own, dense = OwnFactorization(), circle()
    runs = [
        continue_branch(system, [1.0, 0.0], [0.0, 1.0], METHODS[name].stepper(), half_turn, progress_seconds=QUIET)
        for system in (own, dense)
    ]
    assert own.calls == runs[0].stats.factorizations > 0
    np.testing.assert_array_equal(np.array(runs[0].points), np.array(runs[1].points))


def test_paths_of_both_steppers_stay_on_the_circle():
    system = circle()
    U_a, U_b = np.array([1.0, 0.0]), np.array([np.cos(0.9), np.sin(0.9)])
    t_a = np.array([0.0, 1.0])
    anm_path, a_end = ANMStepper().path_through(
        system, U_a, t_a, np.array([np.cos(0.3), np.sin(0.3)]), ContinuationStats()
    )
    corrected = CorrectedPath(system, U_a, t_a, U_b)
    assert corrected.length == pytest.approx(np.sin(0.9), rel=1e-14)  # a = <U - U_a, t_a> = y
    for a in np.linspace(0.0, corrected.length, 7):
        U = corrected(a)
        assert U[1] == pytest.approx(a, abs=1e-15) and np.hypot(*U) == pytest.approx(1.0, abs=1e-14)
        # dU/da along the circle with <dU/da, t_a> = 1: (-y/x, 1)
        np.testing.assert_allclose(corrected(a, derivative=True), [-U[1] / U[0], 1.0], rtol=1e-12)
    assert a_end == pytest.approx(np.sin(0.3), rel=1e-8)
    for a in np.linspace(0.0, a_end, 5):
        assert np.hypot(*anm_path(a)) == pytest.approx(1.0, abs=1e-8)


@pytest.mark.parametrize("name", list(METHODS))
def test_branch_point_flag_ends_the_step_that_holds_it(name):
    # Along x = 0 from lam = -0.6 upwards the branch point is crossed once.
    system = crossing_on_a_circle()
    stop = lambda U, d: "past" if U[2] > 0.5 else ""  # noqa: E731
    settings = METHODS[name]
    branch = continue_branch(
        system, [0.0, 0.8, -0.6], [0.0, 0.6, 0.8], settings.stepper(), stop, progress_seconds=QUIET
    )
    assert len(branch.branch_points) == 1
    i = branch.branch_points[0]
    start = branch.step.index(branch.step[i]) - 1  # the point that starts the step ending at i
    assert branch.points[start][2] < 0.0 < branch.points[i][2]
    U_star, _ = locate_branch_point(system, branch.points[start], branch.points[i], settings)
    # to the accuracy of the path (the ANM's tolerance relative to its step) and of the
    # projection onto the branch (relative residual 1e-9)
    chord = np.linalg.norm(branch.points[i] - branch.points[start])
    np.testing.assert_allclose(U_star, [0.0, 1.0, 0.0], rtol=0, atol=2.0 * (ANMSettings().tolerance * chord + 1e-9))


def test_errors_name_the_step_and_energy_and_bad_starts_are_refused():
    system = circle()
    with pytest.raises(ContinuationError, match=r"max_steps = 3 steps \(last energy"):
        continue_branch(
            system,
            [1.0, 0.0],
            [0.0, 1.0],
            PseudoArclengthSettings(max_steps=3).stepper(),
            lambda U, d: "",
            progress_seconds=QUIET,
        )
    with pytest.raises(ValueError, match=r"U_start must have shape \(2,\)"):
        continue_anm(system, [1.0, 0.0, 0.0], [0.0, 1.0], half_turn)
    with pytest.raises(ValueError, match="direction must be a non-zero vector"):
        continue_anm(system, [1.0, 0.0], [0.0, 0.0], half_turn)
    with pytest.raises(ValueError, match="expected a continuation stepper or its settings"):
        locate_branch_point(system, [1.0, 0.0], [0.0, 1.0], method="ANM")


# --------------------------------------------------------------------------- the 3:1 branch point of NNM1


@pytest.fixture(scope="module")
def nnm1_through_3to1():
    """NNM1 at H = 21 up its first energy fold, back down through the 3:1 branch point and up again."""
    system = HarmonicBalanceSystem(two_dof_structure(ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)), 21)
    direction = np.zeros(system.n_unknowns)
    direction[system.slices["x"].start + 1] = 1.0
    U0, _ = newton_correct(system, system.linear_mode_guess(1, 0.05), direction, ContinuationStats(), 1e-12)

    def stop_factory():
        state = {"peak": 0.0, "descended": False}

        def stop(U, d):
            state["peak"] = max(state["peak"], d["energy"])
            state["descended"] |= state["peak"] > 30.0 and d["energy"] < 6.0
            return "rising again after the tongue" if state["descended"] and d["energy"] > 9.0 else ""

        return stop

    runs = {
        "ANM": continue_anm(system, U0, direction, stop_factory(), METHODS["ANM"], progress_seconds=QUIET),
        "pseudo-arclength": continue_pseudo_arclength(
            system, U0, direction, stop_factory(), METHODS["pseudo-arclength"], progress_seconds=QUIET
        ),
    }
    return system, runs


def _path_error(system, method, U_a, U_b, U_star) -> float:
    """How far the path of the step from ``U_a`` to ``U_b`` runs from the branch where it met the branch point:
    the distance from the located (projected) point ``U_star`` to the nearest point of that path.

    The located point is the path's crossing of ``det [J; t^T] = 0`` moved onto the branch by least-norm Newton,
    orthogonally to the branch, so this is the path's own error there, whatever the step length (near a branch
    point the ANM path's error is not its nominal ``tolerance`` times the step: the terms are near collinear).
    """
    tangent, _ = unit_tangent(system, U_a, U_b - U_a, singular_tol=None)
    path, length = method.stepper().path_through(system, U_a, tangent, U_b, ContinuationStats(), strict=False)
    a = np.linspace(0.0, length, 401)
    nearest = a[np.argmin([np.linalg.norm(path(x) - U_star) for x in a])]
    for _ in range(30):  # Newton on d/da |path(a) - U_star|^2 = 0 from the nearest sample
        d = path(nearest, derivative=True)
        nearest = min(max(nearest - float(np.dot(path(nearest) - U_star, d) / np.dot(d, d)), 0.0), length)
    return float(np.linalg.norm(path(nearest) - U_star))


def _location_bound(errors, scale) -> float:
    """Two located points of one branch point agree to within twice their paths' errors there (a transversal
    crossing of the branches moves the crossing of ``det = 0`` along the branch by about the path's distance from
    it) plus twice the projection's relative residual (``newton_tol`` of ``locate_branch_point``, 1e-9)."""
    return 2.0 * (sum(errors) + 1e-9 * scale)


@pytest.mark.numerics
def test_both_steppers_locate_the_same_3to1_branch_point(nnm1_through_3to1):
    system, runs = nnm1_through_3to1
    located, errors = {}, {}
    for name, branch in runs.items():
        assert branch.end_reason
        found = locate_flagged_branch_points(system, branch.points, branch.step, branch.branch_points, METHODS[name])
        resonant = [point for _, point, n, _ in found if n == 3]
        assert len(resonant) == 1, f"{name}: {[(n, s) for _, _, n, s in found]}"
        located[name] = resonant[0].U
        # a simple branch point: one singular value of J vanishes, to the location's accuracy
        assert resonant[0].singular_ratio < 1e-6
        i = next(i for i, _, n, _ in found if n == 3)
        start = branch.step.index(branch.step[i]) - 1
        errors[name] = _path_error(system, METHODS[name], branch.points[start], branch.points[i], located[name])
    # The ANM locates on its series (or Padé approximant), the corrected path of pseudo-arclength on the branch to
    # its corrector's tolerance; both paths are the branch to their settings' tolerance (relative to U), and the
    # located points are projected onto the branch.
    U_anm, U_pal = located["ANM"], located["pseudo-arclength"]
    scale = np.linalg.norm(U_anm)
    for name, error in errors.items():
        assert error <= 100 * METHODS[name].tolerance * scale, name
    bound = _location_bound(errors.values(), scale)
    assert np.linalg.norm(U_anm - U_pal) <= bound
    # the energy is quadratic in the amplitudes: relative change at most about twice that of U
    E_anm, E_pal = (system.diagnostics(U)["energy"] for U in (U_anm, U_pal))
    assert abs(E_anm - E_pal) <= 2.0 * bound / scale * E_anm
    assert relative_residual(system, U_pal) <= 1e-9 and relative_residual(system, U_anm) <= 1e-9


@pytest.mark.numerics
def test_location_from_a_step_end_off_the_series_matches_pseudo_arclength(nnm1_through_3to1):
    """A flagged ANM step whose end does not lie on the recomputed series (as after a Newton correction that
    moved it) is located on the step's own path up to its own end: the same 3:1 branch point as pseudo-arclength.

    The end passed is the point stored after the step (on the branch, beyond the series' end), so the
    recomputed series does not reach it and the strict path check refuses it.
    """
    system, runs = nnm1_through_3to1
    located = {}
    for name, branch in runs.items():
        found = locate_flagged_branch_points(system, branch.points, branch.step, branch.branch_points, METHODS[name])
        i = next(i for i, _, n, _ in found if n == 3)
        located[name] = (i, next(point for _, point, n, _ in found if n == 3))
    branch = runs["ANM"]
    i, _ = located["ANM"]
    start = branch.step.index(branch.step[i]) - 1
    U_a, U_off = branch.points[start], branch.points[i + 1]
    tangent, _ = unit_tangent(system, U_a, U_off - U_a)
    with pytest.raises(ValueError, match="not on the ANM step"):
        METHODS["ANM"].stepper().path_through(system, U_a, tangent, U_off, ContinuationStats())
    U_star, _ = locate_branch_point(system, U_a, U_off, METHODS["ANM"])
    U_pal = located["pseudo-arclength"][1].U
    error = _path_error(system, METHODS["ANM"], U_a, U_off, U_star)
    assert error <= 100 * ANMSettings().tolerance * np.linalg.norm(U_pal)
    assert np.linalg.norm(U_star - U_pal) <= _location_bound([error], np.linalg.norm(U_pal))
    assert relative_residual(system, U_star) <= 1e-9


@pytest.mark.numerics
def test_sparse_null_plane_matches_the_dense_svd(nnm1_through_3to1):
    """The 3:1 branch point located and resolved with the sparse LU (inverse iterations on the bordered
    matrix) and with the dense SVD of the same Jacobian: same point, same pair of tangents."""
    system, runs = nnm1_through_3to1
    branch = runs["ANM"]
    found = locate_flagged_branch_points(system, branch.points, branch.step, branch.branch_points, METHODS["ANM"])
    flagged, dense = next((i, point) for i, point, n, _ in found if n == 3)
    sparse = HarmonicBalanceSystem(system.structure, system.H, linear_algebra="sparse")
    sparse_point = locate_flagged_branch_points(sparse, branch.points, branch.step, [flagged], METHODS["ANM"])[0][1]
    assert np.linalg.norm(dense.U - sparse_point.U) <= 1e-7 * np.linalg.norm(dense.U)
    assert abs(abs(dense.bifurcated @ sparse_point.bifurcated) - 1.0) < 1e-6
    assert abs(abs(dense.incoming @ sparse_point.incoming) - 1.0) < 1e-6
    assert dense.singular_ratio < 1e-6 and sparse_point.singular_ratio < 1e-6


class _FailsAfterTwo(ANMStepper):
    """The ANM on the circle, storing four points per step, of which the third of every step cannot be produced."""

    def _points(self, system, result, stats):
        for j, item in enumerate(super()._points(system, result, stats)):
            if j == 2:
                raise ContinuationError("interior point 3: Newton did not converge (injected)")
            yield item


class _PadeInteriorFails(ANMStepper):
    """The ANM on the circle whose Padé steps cannot correct an interior point (as near a pole of the
    approximant); the plain series' points can be, as in anm_step when a Padé step's end cannot be."""

    def __init__(self, settings):
        super().__init__(settings)
        self.refused = 0

    def _points(self, system, result, stats):
        for j, item in enumerate(super()._points(system, result, stats)):
            if j == 1 and not isinstance(result.path, TaylorPath):
                self.refused += 1
                raise ContinuationError("interior point 2: Newton did not converge (injected on the Padé path)")
            yield item


def test_a_pade_step_whose_interior_point_cannot_be_corrected_is_taken_on_the_series():
    # NNM2 of the oscillator at H = 20, where the approximant reaches further than the series
    system = HarmonicBalanceSystem(two_dof_structure(ModelParameters()), harmonics=20)
    e = np.zeros(system.n_unknowns)
    e[system.slices["x"].start + 1] = 1.0
    U0, _ = newton_correct(system, system.linear_mode_guess(2, 0.05), e, ContinuationStats(), 1e-12)

    def energy_above_50(U, d):
        return "E > 50" if d["energy"] > 50.0 else ""

    settings = ANMSettings(points_per_step=3)
    stepper = _PadeInteriorFails(settings)
    branch = continue_branch(system, U0, e, stepper, energy_above_50, progress_seconds=QUIET)
    pade = continue_branch(system, U0, e, settings.stepper(), energy_above_50, progress_seconds=QUIET)
    plain = continue_branch(system, U0, e, ANMSettings(points_per_step=3, pade=False).stepper(), energy_above_50, QUIET)
    # the Padé ANM takes steps on the approximant here; with their interior points refused, every such step
    # fell back to the series (none counted), and its points are those of the ANM without Padé
    assert pade.stats.pade_steps > 0 and stepper.refused > 0 and branch.stats.pade_steps == 0
    assert max(relative_residual(system, U) for U in branch.points) <= settings.newton_threshold
    np.testing.assert_allclose(np.array(branch.points), np.array(plain.points), rtol=0, atol=1e-9)


class _ManyDiagnostics(QuadraticToy):
    """The circle with a batched ``diagnostics_many`` that records how many points each call held."""

    def __init__(self):
        base = circle()
        super().__init__(base.c, base.A, base.Q)
        self.batches = []

    def diagnostics_many(self, U_list):
        self.batches.append(len(U_list))
        return [self.diagnostics(U) for U in U_list]


def test_a_step_point_that_fails_past_the_end_does_not_fail_the_branch_one_before_it_does():
    system = circle()
    stepper = _FailsAfterTwo(ANMSettings(points_per_step=4))
    # the first stored point of the first step ends the branch: the failure further on is never reached
    ends_early = continue_branch(system, [1.0, 0.0], [0.0, 1.0], stepper, lambda U, d: "now", progress_seconds=QUIET)
    assert ends_early.end_reason == "now" and len(ends_early.points) == 2
    with pytest.raises(ContinuationError, match=r"step 1 failed .*interior point 3: Newton did not converge"):
        continue_branch(system, [1.0, 0.0], [0.0, 1.0], stepper, half_turn, progress_seconds=QUIET)


def test_the_points_of_a_step_get_their_diagnostics_together():
    batched, plain = _ManyDiagnostics(), circle()
    settings = ANMSettings(points_per_step=4)
    runs = [
        continue_branch(system, [1.0, 0.0], [0.0, 1.0], settings.stepper(), half_turn, progress_seconds=QUIET)
        for system in (batched, plain)
    ]
    np.testing.assert_array_equal(np.array(runs[0].points), np.array(runs[1].points))
    assert runs[0].diagnostics == runs[1].diagnostics
    assert len(batched.batches) == runs[0].stats.steps and min(batched.batches) >= 4
