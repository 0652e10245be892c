"""Exact forced responses of the non-smooth system against independent references.

Closed-form linear frequency response without contact; event-located DOP853 integration of the
piecewise-linear law (periodicity, return to a stable response, departure from an unstable one at the rate
of its largest multiplier); finite-difference Jacobian.
"""

import numpy as np
import pytest

from nnmstop.checks.forced_integration import integrate_forced_nonsmooth
from nnmstop.exact.forced import grazing_frequencies, non_impacting_response
from nnmstop.models.excitation import linear_response

from .conftest import oscillator_excitation


def test_non_impacting_response_is_the_linear_frequency_response():
    excitation = oscillator_excitation(0.01)
    omega = 2 * np.pi * np.linspace(0.05, 0.35, 31)
    np.testing.assert_allclose(
        non_impacting_response(excitation, omega), linear_response(excitation, omega), rtol=1e-12, atol=0
    )


def test_grazing_frequencies_are_where_the_linear_amplitude_is_the_gap():
    excitation = oscillator_excitation(0.05)
    grazing = grazing_frequencies(excitation, 2 * np.pi * 0.05, 2 * np.pi * 0.35)
    assert len(grazing) == 2
    np.testing.assert_allclose(np.abs(linear_response(excitation, np.array(grazing))[:, 0]), 1.0, rtol=1e-13)


def test_jacobian_matches_finite_differences(contact_family):
    _, problem, _, family = contact_family
    for y in family.unknowns[[0, len(family.unknowns) // 2]]:
        h = 1e-6
        fd = np.array([(problem.residual(y + h * e) - problem.residual(y - h * e)) / (2 * h) for e in np.eye(len(y))]).T
        np.testing.assert_allclose(problem.jacobian(y), fd, atol=1e-7 * np.abs(fd).max())


def test_family_ends_at_the_other_grazing_orbit(contact_family):
    _, problem, grazing, family = contact_family
    assert family.end_margin == "contact_duration"
    last = family.unknowns[-1]
    assert abs(last[-1] - grazing[1]) <= 1e-9 * grazing[1]
    assert all(problem.assess(y).valid for y in family.unknowns[1:-1])


def _free_flight_state(problem, y):
    """A state in the middle of the free flight (no integration starts on a stop) and its phase."""
    z1, z2, _ = problem.switch_states(y)
    theta1, delta, omega = y[-3], y[-2], y[-1]
    theta = theta1 + delta + 0.5 * (np.pi - delta)
    return problem.phases["F"].states(z2, theta1 + delta, omega, theta), theta


@pytest.mark.numerics
def test_orbits_are_periodic_under_time_integration(contact_family):
    excitation, problem, _, family = contact_family
    for y in family.unknowns[[5, len(family.unknowns) // 2, -5]]:
        z, theta = _free_flight_state(problem, y)
        omega = y[-1]
        t = theta / omega + np.array([0.0, np.pi / omega, 2 * np.pi / omega])
        states, switches = integrate_forced_nonsmooth(excitation, omega, z, t)
        assert len(switches) == 4
        np.testing.assert_allclose(states[1], -z, atol=1e-9)
        np.testing.assert_allclose(states[2], z, atol=1e-9)


@pytest.mark.numerics
def test_perturbations_grow_at_the_rate_of_the_largest_multiplier(contact_family):
    """From an unstable response (saddle between the folds) a perturbation grows by |mu|max per period; from a
    stable one it decays."""
    excitation, problem, _, family = contact_family
    largest = np.array([np.abs(problem.multipliers(y)[0]).max() for y in family.unknowns])
    for index in (int(np.argmax(largest)), int(np.argmin(np.where(largest < 1, largest, np.inf)))):
        y = family.unknowns[index]
        z, theta = _free_flight_state(problem, y)
        omega = y[-1]
        periods = 8
        t = theta / omega + np.arange(periods + 1) * 2 * np.pi / omega
        states, _ = integrate_forced_nonsmooth(excitation, omega, z + 1e-8 * np.array([1.0, 0.5, -0.3, 0.2]), t)
        distance = np.linalg.norm(states - z, axis=1)
        rate = (distance[-1] / distance[-5]) ** 0.25
        if largest[index] > 1:
            assert rate == pytest.approx(largest[index], rel=0.05)
        else:
            assert distance[-1] < distance[0]


# ------------------------------------------------------------------ where a contact family ends (issue 25.3)

CONTINUATION = dict(tolerance=1e-12, initial_step=0.01, max_step=0.05)  # the fixture's settings


def test_the_end_of_a_contact_family_is_confirmed_by_a_restart_with_shorter_steps(contact_family):
    from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings
    from nnmstop.exact.forced import confirm_contact_family_end

    _, problem, _, family = contact_family
    message = confirm_contact_family_end(
        problem, family, PseudoArclengthSettings(**CONTINUATION), (0.05, 0.35), "F = 0.05"
    )
    assert message.startswith("end confirmed: restarted before its end with step")
    assert "contact shrinks to zero duration" in message  # the restart ended at the grazing orbit too


def test_a_contact_family_ending_where_it_is_still_valid_fails_its_confirmation(contact_family):
    """A run that stops at a margin that is not the family's (a spurious one, as a step landing on another solution
    curve would see) is not confirmed: the restart, on the true problem, goes on past it."""
    from nnmstop.continuation.confirm import EndNotConfirmed
    from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings
    from nnmstop.exact.forced import ContactAssessment, SymmetricContactProblem, confirm_contact_family_end
    from nnmstop.exact.forced import follow_contact_family as follow

    excitation, problem, grazing, family = contact_family
    cut = 0.5 * float(np.max(family.unknowns[:, -2]))  # half the longest contact of the family

    class SpuriousMargin(SymmetricContactProblem):
        def assess(self, y):
            margins = dict(super().assess(y).margins)
            margins["early_impact"] = min(margins["early_impact"], cut - y[-2])
            return ContactAssessment(margins)

    settings = PseudoArclengthSettings(**CONTINUATION)
    direction = np.zeros(problem.n_unknowns)
    direction[-2] = 1.0
    spurious = follow(SpuriousMargin(excitation), problem.grazing_start(grazing[0]), direction, settings, (0.05, 0.35))
    assert spurious.end_margin == "early_impact" and abs(spurious.unknowns[-1, -2] - cut) <= 1e-9 * cut
    with pytest.raises(EndNotConfirmed) as failure:
        confirm_contact_family_end(problem, spurious, settings, (0.05, 0.35), "F = 0.05 (spurious)")
    message = str(failure.value)
    assert "F = 0.05 (spurious)" in message and "end NOT confirmed" in message
    assert "reaches a stop during the free flight" in message  # the first end, then where the restart ended


def test_pieces_are_chained_along_the_curve_whatever_their_order():
    """A contact family that starts where a non-impacting piece ends follows it, even when another piece starts
    between them in frequency (several families at a large force): the chaining picks pieces by position."""
    from nnmstop.forced.responses import ExactPiece, _along_the_curve

    def piece(kind, low, high, points):
        f = np.linspace(low, high, points)
        n = len(f)
        return ExactPiece(kind, f, np.ones((n, 2)), np.ones((n, 4)), np.zeros((n, 0)), [], "", np.zeros(n))

    first, other = piece("non_impacting", 0.05, 0.10, 5), piece("one_contact", 0.08, 0.09, 3)
    following = piece("one_contact", 0.10, 0.12, 4)
    ordered = _along_the_curve([other, following, first])
    assert [p is q for p, q in zip(ordered, (first, following, other))] == [True, True, True]
