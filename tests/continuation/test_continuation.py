"""The two continuation methods (ANM and Newton pseudo-arclength) on the same branches.

They must trace the same frequency-energy curve at the same accuracy (relative
residual), the ANM with several times fewer factorizations, and both must fail loudly
(step and energy in the message) and reject bad settings.
"""

from __future__ import annotations

import numpy as np
import pytest

from nnmstop.continuation.anm import ANMSettings, continue_anm
from nnmstop.continuation.core import ContinuationError, ContinuationStats, newton_correct, relative_residual
from nnmstop.continuation.pseudo_arclength import (
    PseudoArclengthSettings,
    PseudoArclengthStats,
    continue_pseudo_arclength,
)
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters, linear_modes

PARAMS = ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
TOLERANCE = 1e-8  # ANM series tolerance and pseudo-arclength corrector tolerance
QUIET = 1e9  # progress_seconds: no progress messages


def start_point(system, mode, amplitude=0.05):
    e = np.zeros(system.n_unknowns)
    e[system.slices["x"].start + 1] = 1.0
    U, _ = newton_correct(system, system.linear_mode_guess(mode, amplitude), e, ContinuationStats(), 1e-12)
    return U, e


def nnm2_asymptote_stop():
    """NNM2 up to 98 % of the gap-0 second mode (its high-energy asymptote)."""
    target = 0.98 * linear_modes(PARAMS, "gap_zero")[0][1] / (2 * np.pi)
    return lambda U, d: "asymptote" if d["frequency"] > target else ""


def past_first_fold_stop():
    """NNM1 until the energy has fallen to half of its largest value (the first fold)."""
    peak = [0.0]

    def stop(U, d):
        peak[0] = max(peak[0], d["energy"])
        return "past the first energy fold" if peak[0] > 10.0 and d["energy"] < 0.5 * peak[0] else ""

    return stop


def fep(system, branch):
    """Frequency-energy points ``(log10 E, f)`` of a branch (diagnostics recomputed if absent)."""
    diags = [d if d is not None else system.diagnostics(U) for U, d in zip(branch.points, branch.diagnostics)]
    return np.array([[np.log10(d["energy"]), d["frequency"]] for d in diags])


def distance_to_polyline(points, polyline, scale):
    """Distance from each point to the polyline, coordinates divided by ``scale``."""
    points, polyline = points / scale, polyline / scale
    a, b = polyline[:-1], polyline[1:]
    d = b - a
    out = np.empty(len(points))
    for i, q in enumerate(points):
        t = np.clip(np.sum((q - a) * d, axis=1) / np.maximum(np.sum(d * d, axis=1), 1e-300), 0.0, 1.0)
        out[i] = np.min(np.linalg.norm(a + t[:, None] * d - q, axis=1))
    return out


def same_branch_gap(system, U_p, reference_points, direction):
    """Relative distance between ``U_p`` and the reference branch, in the unknown space.

    The reference point nearest to ``U_p`` is moved into the hyperplane through ``U_p``
    orthogonal to ``direction`` (the local chord of the branch) and corrected by Newton
    in that hyperplane: a locally unique curve meets it in one point, which is ``U_p``
    itself (to the tolerances) if both lie on the same branch.
    """
    reference = np.asarray(reference_points)
    nearest = reference[np.argmin(np.linalg.norm(reference - U_p, axis=1))]
    t = direction / np.linalg.norm(direction)
    guess = nearest + np.dot(U_p - nearest, t) * t
    U_c, _ = newton_correct(system, guess, t, ContinuationStats(), 1e-12)
    return np.linalg.norm(U_c - U_p) / np.linalg.norm(U_p)


# --------------------------------------------------------------------------- same branch

CASES = {
    # name: (harmonics, mode, stop factory)
    "NNM2 to its asymptote, H=20": (20, 2, nnm2_asymptote_stop),
    "NNM1 through the first fold, H=30": (30, 1, past_first_fold_stop),
}


@pytest.fixture(scope="module", params=list(CASES))
def both_methods(request):
    H, mode, stop = CASES[request.param]
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), H)
    U0, e = start_point(system, mode)
    anm = continue_anm(
        system, U0, e, stop(), ANMSettings(tolerance=TOLERANCE, points_per_step=8), progress_seconds=QUIET
    )
    pal = continue_pseudo_arclength(
        system, U0, e, stop(), PseudoArclengthSettings(tolerance=TOLERANCE), progress_seconds=QUIET
    )
    return request.param, system, anm, pal


@pytest.mark.numerics
def test_both_methods_reach_the_same_end(both_methods):
    name, system, anm, pal = both_methods
    assert anm.end_reason and anm.end_reason == pal.end_reason
    # Comparable accuracy. The ANM step ends are corrected by Newton only above its
    # threshold (1e-7), so their residuals sit, in practice, at about the series
    # tolerance; its interior points are never corrected, so the threshold bounds them
    # only if the series' step-length estimate holds. (The baseline's residuals are
    # bounded by its own corrector: nothing to check there.)
    anm_ends = [U for U, k, k_next in zip(anm.points, anm.step, anm.step[1:] + [-1]) if k != k_next]
    assert np.median([relative_residual(system, U) for U in anm_ends]) <= TOLERANCE
    assert max(relative_residual(system, U) for U in anm.points) <= ANMSettings().newton_threshold
    if name.startswith("NNM1"):
        E = fep(system, pal)[:, 0]
        assert np.any(np.diff(E) < 0), "the pseudo-arclength branch must turn back in energy"


@pytest.mark.numerics
def test_frequency_energy_curves_coincide(both_methods):
    name, system, anm, pal = both_methods
    A, P = fep(system, anm), fep(system, pal)
    scale = np.array([1.0, A[0, 1]])  # decades of energy, and frequency relative to the start
    # Every baseline point (but the last, which overshoots the stop differently) on the
    # dense ANM curve (8 points per series step) ...
    assert np.max(distance_to_polyline(P[:-1], A, scale)) < 2e-3
    # ... and every ANM step end on the coarser baseline polyline: no part skipped.
    ends = A[[i for i, (k, k_next) in enumerate(zip(anm.step, anm.step[1:])) if k != k_next]]
    assert np.max(distance_to_polyline(ends, P, scale)) < 5e-3
    # (Frequencies at the same orbit are compared without interpolation below, in the
    # unknown space.)


@pytest.mark.numerics
def test_same_branch_in_the_unknown_space(both_methods):
    name, system, anm, pal = both_methods
    points = pal.points[1:-1:3]
    chords = [pal.points[i + 1] - pal.points[i - 1] for i in range(1, len(pal.points) - 1)][::3]
    gaps = [same_branch_gap(system, U, anm.points, c) for U, c in zip(points, chords)]
    # Both points are within the 1e-8 residual tolerance of the same curve.
    assert max(gaps) < 1e-7


def test_anm_needs_several_times_fewer_factorizations(both_methods):
    # Counts, not timings: deterministic. One factorization per ANM step (plus the rare
    # Newton corrections) against one per Newton iteration of the baseline.
    name, system, anm, pal = both_methods
    assert isinstance(pal.stats, PseudoArclengthStats)
    assert pal.stats.factorizations >= 3 * anm.stats.factorizations
    assert pal.stats.newton_iterations >= 2 * pal.stats.steps


def test_pseudo_arclength_bookkeeping(both_methods):
    name, system, anm, pal = both_methods
    stats = pal.stats
    assert len(pal.points) == stats.steps + 1 == len(pal.step)
    assert pal.step == list(range(stats.steps + 1))
    assert stats.corrected_steps == stats.steps
    # One factorization for the first tangent, one per Newton iteration, and one per
    # step whose last Newton update was too long to reuse its factors for the tangent.
    assert stats.newton_iterations + 1 <= stats.factorizations <= stats.newton_iterations + 1 + stats.steps
    assert stats.wall_time > 0
    assert np.isclose(np.linalg.norm(pal.end_tangent), 1.0)


# --------------------------------------------------------------------------- failures


@pytest.fixture(scope="module")
def small_system():
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 10)
    U0, e = start_point(system, 2)
    return system, U0, e


def never(U, d):
    return ""


def test_pseudo_arclength_max_steps_error_names_step_and_energy(small_system):
    system, U0, e = small_system
    with pytest.raises(ContinuationError, match=r"max_steps = 2 steps \(last energy [0-9.e+-]+"):
        continue_pseudo_arclength(system, U0, e, never, PseudoArclengthSettings(max_steps=2), progress_seconds=QUIET)


def test_pseudo_arclength_minimum_step_error_names_step_and_energy(small_system):
    # An absurd angle limit rejects every step until the length is below min_step.
    system, U0, e = small_system
    settings = PseudoArclengthSettings(initial_step=1.0, min_step=0.1, max_angle=1e-9)
    energy = system.diagnostics(U0)["energy"]
    with pytest.raises(ContinuationError) as info:
        continue_pseudo_arclength(system, U0, e, never, settings, label="NNM2 baseline", progress_seconds=QUIET)
    message = str(info.value)
    assert message.startswith("NNM2 baseline: step 1 failed at energy ")
    assert f"{energy:.6g}" in message and "min_step" in message and "max_angle" in message


def test_pseudo_arclength_newton_failure_error(small_system):
    # One Newton iteration allowed and a tolerance at round-off level: the corrector
    # never converges and the step shrinks to nothing.
    system, U0, e = small_system
    tolerance = max(1e-15, relative_residual(system, U0))
    settings = PseudoArclengthSettings(tolerance=tolerance, max_iterations=1, target_iterations=1, min_step=1e-3)
    with pytest.raises(ContinuationError, match=r"step 1 failed at energy [0-9.e+-]+ .*no convergence in 1 iterations"):
        continue_pseudo_arclength(system, U0, e, never, settings, progress_seconds=QUIET)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # the forced failure overflows on purpose
def test_anm_errors_name_step_and_energy(small_system):
    system, U0, e = small_system
    with pytest.raises(ContinuationError, match=r"max_steps = 2 steps \(last energy [0-9.e+-]+"):
        continue_anm(system, U0, e, never, ANMSettings(max_steps=2), progress_seconds=QUIET)
    # An absurd Newton threshold: every step end is "corrected" to an unreachable
    # tolerance and the first step fails.
    with pytest.raises(ContinuationError, match=r"step 1 failed at energy [0-9.e+-]+ \(frequency"):
        continue_anm(system, U0, e, never, ANMSettings(newton_threshold=1e-30), progress_seconds=QUIET)


def test_pseudo_arclength_rejects_bad_inputs(small_system):
    system, U0, e = small_system
    with pytest.raises(ValueError, match=rf"U_start must have shape \({system.n_unknowns},\)"):
        continue_pseudo_arclength(system, U0[:-1], e, never)
    with pytest.raises(ValueError, match="direction must be a non-zero vector"):
        continue_pseudo_arclength(system, U0, np.zeros_like(e), never)
    off = U0.copy()
    off[system.i_lam] *= 1.01
    with pytest.raises(ValueError, match="U_start is not on the branch: relative residual"):
        continue_pseudo_arclength(system, off, e, never)


# --------------------------------------------------------------------------- settings


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"order": 1}, "order"),
        ({"order": 2.5}, "order"),
        ({"tolerance": 0.0}, "tolerance"),
        ({"tolerance": float("nan")}, "tolerance"),
        ({"tolerance": float("inf")}, "tolerance"),
        ({"newton_threshold": -1e-7}, "newton_threshold"),
        ({"max_steps": 0}, "max_steps"),
        ({"points_per_step": 0}, "points_per_step"),
    ],
)
def test_anm_settings_reject_bad_values(kwargs, name):
    (value,) = kwargs.values()
    with pytest.raises(ValueError, match=rf"^{name} must .*got {value!r}$"):
        ANMSettings(**kwargs)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"tolerance": 0.0}, "tolerance"),
        ({"tolerance": float("nan")}, "tolerance"),
        ({"initial_step": -0.1}, "initial_step"),
        ({"min_step": float("inf")}, "min_step"),
        ({"min_step": 1.0}, "min_step"),
        ({"max_step": 0.01}, "max_step"),
        ({"max_step": float("nan")}, "max_step"),
        ({"max_iterations": 0}, "max_iterations"),
        ({"max_iterations": 2.0}, "max_iterations"),
        ({"target_iterations": 9}, "target_iterations"),
        ({"growth": 1.0}, "growth"),
        ({"max_angle": 4.0}, "max_angle"),
        ({"max_angle": 0.0}, "max_angle"),
        ({"max_steps": True}, "max_steps"),
    ],
)
def test_pseudo_arclength_settings_reject_bad_values(kwargs, name):
    (value,) = kwargs.values()
    with pytest.raises(ValueError, match=rf"^{name} must .*got {value!r}$"):
        PseudoArclengthSettings(**kwargs)
