"""The dense pseudo-arclength step, events located on a step's path, end confirmation: curves known in closed form."""

import numpy as np
import pytest
from test_continuation_driver import QUIET, circle

from nnmstop.continuation.anm import ANMSettings
from nnmstop.continuation.confirm import ContinuationEnd, EndNotConfirmed, confirm_end
from nnmstop.continuation.corrected_path import CorrectedPath
from nnmstop.continuation.dense_arclength import DenseArclengthSettings
from nnmstop.continuation.driver import continue_branch
from nnmstop.continuation.events import locate_event


class Margins:
    """An event set of named margins (each > 0 while its condition holds), as the exact orbits' checks."""

    def __init__(self, **margins):
        self.margins = margins

    def __call__(self, U):
        return Check({name: float(f(U)) for name, f in self.margins.items()})

    def describe(self, key):
        return f"{key} reaches zero"


class Check:
    def __init__(self, margins):
        self.margins = margins
        self.violated = sorted((k for k, m in margins.items() if not m > 0), key=margins.get)
        self.valid = not self.violated


def until_x_below(limit):
    return Margins(x_above=lambda U: U[0] - limit)


@pytest.mark.numerics
def test_dense_steps_stay_on_the_circle_and_end_on_the_located_event():
    """From (1, 0) counterclockwise until x = -0.6: the end is (-0.6, 0.8), to the bisection's width."""
    settings = DenseArclengthSettings(step=0.3)
    branch = continue_branch(
        circle(),
        [1.0, 0.0],
        [0.0, 1.0],
        settings.stepper(),
        lambda U, d: "",
        progress_seconds=QUIET,
        events=until_x_below(-0.6),
    )
    U = np.array(branch.points)
    np.testing.assert_allclose(np.hypot(U[:, 0], U[:, 1]), 1.0, rtol=0, atol=1e-15)  # corrected to round-off
    assert branch.end_reason == "x_above reaches zero" and branch.end_event.key == "x_above"
    np.testing.assert_allclose(U[-1], [-0.6, 0.8], rtol=0, atol=2e-13 * settings.step)
    assert all(check.valid for check in branch.checks[1:])
    # the pseudo-arclength adds up the steps' parameters: each chord projected on the tangent (-y, x) at its start
    projections = np.einsum("ij,ij->i", np.diff(U, axis=0), np.column_stack([-U[:-1, 1], U[:-1, 0]]))
    np.testing.assert_allclose(np.diff(branch.arclength), projections, rtol=0, atol=1e-14)


@pytest.mark.numerics
def test_the_anm_locates_the_same_event_on_its_series():
    """The other stepper: the ANM's step path is its series (Padé), the event is located on it alike."""
    branch = continue_branch(
        circle(),
        [1.0, 0.0],
        [0.0, 1.0],
        ANMSettings().stepper(),
        lambda U, d: "",
        progress_seconds=QUIET,
        events=until_x_below(-0.6),
    )
    np.testing.assert_allclose(branch.points[-1], [-0.6, 0.8], rtol=0, atol=1e-7)  # the series' tolerance


class TwoCircles:
    """``(x^2 + y^2 - 1)((x - 2.2)^2 + y^2 - 1) = 0``: two unit circles 0.2 apart."""

    n_unknowns = 2

    def residual(self, U):
        x, y = U
        return np.array([(x * x + y * y - 1.0) * ((x - 2.2) ** 2 + y * y - 1.0)])

    def jacobian(self, U):
        x, y = U
        a, b = x * x + y * y - 1.0, (x - 2.2) ** 2 + y * y - 1.0
        return np.array([[2 * x * b + 2 * (x - 2.2) * a, 2 * y * b + 2 * y * a]])

    def diagnostics(self, U):
        return {"energy": 1.0 + U[1] + 2.0, "frequency": U[0], "impacts_per_period": 0}


def test_an_event_where_the_path_left_the_curve_is_not_trusted():
    """Along x from (0, -1) the hyperplanes x = a leave the left circle at its fold x = 1 and meet the right one
    (x >= 1.2, invalid): the change located there is the path's, not the curve's (its slope grows without bound)."""
    system, events = TwoCircles(), Margins(left=lambda U: 1.1 - U[0])
    U0, far = np.array([0.0, -1.0]), np.array([1.25, -np.sqrt(1.0 - (1.25 - 2.2) ** 2)])
    path = CorrectedPath(system, U0, np.array([1.0, 0.0]), far)
    event = locate_event(path, events, U0, events(U0), path.length, events(far), 1e-13)
    assert event.a == pytest.approx(1.0, abs=1e-6)
    assert not event.trusted


def test_the_driver_shortens_a_step_whose_path_left_the_curve():
    """With the turn limit off and long steps, a step lands on the right circle; the driver refuses to end there."""
    settings = DenseArclengthSettings(step=0.9, max_angle=1.5)
    branch = continue_branch(
        TwoCircles(),
        [0.0, -1.0],
        [1.0, 0.0],
        settings.stepper(),
        lambda U, d: "past the top" if U[0] < 0 and U[1] > 0 else "",
        progress_seconds=QUIET,
        events=Margins(left=lambda U: 1.1 - U[0]),
    )
    U = np.array(branch.points)
    assert branch.end_reason == "past the top" and branch.end_event is None
    np.testing.assert_allclose(np.hypot(U[:, 0], U[:, 1]), 1.0, rtol=0, atol=1e-14)  # never on the right circle


class Line:
    """``y = 0`` in ``(x, y)``: the curve is the x axis; a thin band of x is invalid."""

    n_unknowns = 2

    def residual(self, U):
        return np.array([U[1]])

    def jacobian(self, U):
        return np.array([[0.0, 1.0]])

    def diagnostics(self, U):
        return {"energy": float(np.exp(U[0])), "frequency": 1.0, "impacts_per_period": 0}


def _run(events, start, step, stop_at):
    branch = continue_branch(
        Line(),
        start,
        [1.0, 0.0],
        DenseArclengthSettings(step=step).stepper(),
        lambda U, d: "stop" if U[0] > stop_at else "",
        progress_seconds=QUIET,
        events=events,
    )
    return ContinuationEnd.of_branch(branch, step)


def test_a_step_over_a_thin_invalid_band_is_not_confirmed():
    """Steps of 0.02 jump the band 0.505 < x < 0.508 and end at x > 0.53; a restart with steps of 0.002 from
    two points before meets it: the end is not confirmed, and the message names both ends."""
    band = Margins(band=lambda U: abs(U[0] - 0.5065) - 0.0015)
    first = _run(band, [0.0, 0.0], 0.02, 0.53)
    assert first.event == "" and first.points[-1][0] > 0.53
    with pytest.raises(
        EndNotConfirmed, match=r"with step 0.02 it ends at energy 1\.7.*with step 0\.002 it ends .*band"
    ):
        confirm_end(first, lambda U, d, h: _run(band, U, h, 0.53), 0.02, label="line")


def test_an_event_end_is_confirmed_within_its_location_tolerance():
    edge = Margins(edge=lambda U: 0.5151 - U[0])
    first = _run(edge, [0.0, 0.0], 0.02, 10.0)
    assert first.event == "edge" and first.points[-1][0] == pytest.approx(0.5151, abs=1e-14)
    message = confirm_end(first, lambda U, d, h: _run(edge, U, h, 10.0), 0.02, label="line")
    assert message.startswith("end confirmed: restarted before its end with step 0.002")
