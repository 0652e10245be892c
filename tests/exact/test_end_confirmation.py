"""Issue 25.3 at alpha = 1e6: the exact two-impact family's job ends where the curve ends, or fails saying so.

With the old loop, steps of 0.02 from the grazing orbit landed on neighbouring solution curves of the
quarter-period equations (with a stop this stiff they lie within a period of the contact mode of each
other) and the family "ended" after two orbits on a physical-sounding margin, exit 0; with steps ten
times smaller it runs to E = 21.3.
"""

import copy

import numpy as np
import pytest
import xarray as xr
import yaml

from nnmstop.config import validate_config
from nnmstop.continuation.confirm import ContinuationEnd, EndNotConfirmed, confirm_end, event_tolerance
from nnmstop.exact.grazing import assess_orbit
from nnmstop.exact.ndof import follow_one_stop_family
from nnmstop.exact.problem import TwoImpactProblem
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters
from nnmstop.tasks.exact import build_two_impact_dataset

STIFF = ModelParameters(alpha=1.0e6)


@pytest.fixture(scope="module")
def stiff_dataset(repo_root, tmp_path_factory):
    """The job ``exact_two_impacts`` with ``model.alpha: 1.0e+6`` and the default step."""
    config = copy.deepcopy(yaml.safe_load((repo_root / "tests" / "data" / "small_config.yaml").read_text()))
    config["model"]["alpha"] = STIFF.alpha
    config["exact"] = {"step": 0.02, "max_points": 4000}  # config/config.yaml's
    config = validate_config(config)
    path = build_two_impact_dataset(config, tmp_path_factory.mktemp("stiff") / "two.nc")
    with xr.open_dataset(path) as ds:
        return ds.load()


def test_the_job_runs_to_the_opposite_stop_and_confirms_it(stiff_dataset):
    ds = stiff_dataset
    assert ds.attrs["end_margin"] == "opposite_stop"
    assert ds.attrs["end_check"].startswith("end confirmed: restarted before its end with step 0.002")
    # the end orbit, checked by the 2-DOF code (closed-form phases and extremum search of its own): an orbit of
    # Eqs. (3)-(4) whose x reaches the opposite stop -1 in free flight, all other assumptions holding
    y = np.array([ds[k].values[-1] for k in ("xdot0", "udot0", "free_flight_time")] + [ds["period"].values[-1] / 4])
    problem = TwoImpactProblem(STIFF)
    assert np.linalg.norm(problem.residual(y)) < 1e-10
    margins = assess_orbit(problem, y).margins
    assert abs(margins["opposite_stop"]) < 1e-8
    assert min(m for k, m in margins.items() if k != "opposite_stop") > 1e-4
    # and every orbit before it is admissible, with energy growing from the grazing orbit's
    assert float(ds["validity_margin"].values[1:-1].min()) > 0
    assert ds["energy"].values[-1] > 20 * ds["energy"].values[0]


def test_an_end_after_two_orbits_like_the_old_loops_is_refused():
    """The end the old loop reported (two orbits from the grazing orbit, 'final_position') is not met again by
    a restart with a ten times smaller step: the job fails and the message names both ends."""
    structure = two_dof_structure(STIFF)
    family = follow_one_stop_family(structure, step=0.002, max_points=3)
    early = ContinuationEnd(
        points=family.unknowns,
        arclength=family.arclength,
        event="final_position",
        reason="x is back at the stop position (x(T1) = 1) when both velocities vanish",
        energy=float(family.energy[-1]),
        tolerance=event_tolerance(0.02, family.unknowns[-1]),
    )

    def restart(U, direction, step):
        again = follow_one_stop_family(structure, step=step, max_points=40, start=U, direction=direction)
        return ContinuationEnd(
            again.unknowns,
            again.arclength,
            again.end_margin,
            again.end_reason,
            float(again.energy[-1]),
            event_tolerance(step, again.unknowns[-1]),
        )

    with pytest.raises(EndNotConfirmed, match=r"end NOT confirmed: two-impact family: with step 0.02 it ends at"):
        confirm_end(early, restart, 0.02, label="two-impact family")
