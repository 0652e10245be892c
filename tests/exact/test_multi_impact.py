"""The exact NNM1 with any number of impacts per period, against independent references.

References: the two-impact problem (:class:`nnmstop.exact.problem.TwoImpactProblem`), finite differences, and
the event-driven time integration of Eqs. (3)-(4) (:mod:`nnmstop.checks.time_integration`,
DOP853 restarted at every located stop crossing). Everything here is computed from
scratch (no pipeline output is read) and runs in well under a minute.
"""

import numpy as np
import pytest
import scipy.linalg
import xarray as xr

from nnmstop.checks.time_integration import integrate_nonsmooth
from nnmstop.exact.dataset import two_impact_dataset
from nnmstop.exact.family import FamilySettings, follow_branch, follow_two_impact_family
from nnmstop.exact.grazing import OrbitAssessment, assess_orbit, classify_boundary, merge_seed, split_start
from nnmstop.exact.problem import SequenceProblem, TwoImpactProblem, from_two_impact_unknowns, high_energy_orbit
from nnmstop.exact.sequences import check_sequence, sequence_impacts
from nnmstop.hbm.system import impacts_per_period as sampled_impacts
from nnmstop.models.two_dof import total_energy
from nnmstop.tasks.exact import build_multi_impact_dataset

#: One orbit inside each phase-sequence segment of the paper's NNM1 (12 digits; refined below).
SEEDS = {
    "FLFR": [-3.32571291347, 3.72770066815, 0.317041300733, 0.473122293805, 0.520956893725, 0.285028731426],
    "FLF": [-1.36214252196, -3.11476639254, 0.719241631803, 0.595237490946, 0.552017931707],
    "FL": [3.58117585002, -67.9525338339, 0.659053425763, 0.94891098536],
    "FRFL": [4.89968359833, -85.7168374147, 0.261823288542, 0.117913362811, 0.273142193535, 0.952303860863],
    "FRFLF": [
        8.18306455422,
        -75.1564366294,
        0.12591644523,
        0.38252558803,
        0.159081806857,
        0.819070494983,
        0.118618766641,
    ],
    "FRFLFR": [
        22.1488562221,
        2.17760844609,
        0.0451782773206,
        0.552029818726,
        0.0914679219936,
        0.54166874271,
        0.0908059545011,
        0.279162626281,
    ],
    "FRFR": [12.7283350125, 46.5547850713, 0.0784317292241, 0.64750810085, 0.484740969017, 0.401108899658],
    "FR": [12.3734998422, 286.101172806, 0.0790786761847, 1.5211388878],
}
IMPACTS = {"FLFR": 6, "FLF": 4, "FL": 2, "FRFL": 6, "FRFLF": 8, "FRFLFR": 10, "FRFR": 6, "FR": 2}

#: Coarse but exact continuation settings (fewer orbits, same transitions).
COARSE = FamilySettings(step=0.25, max_frequency_step=2e-4, max_log_energy_step=0.1, max_points=400)


def _refine(problem, y):
    """Gauss-Newton (minimum-norm steps) onto the family through the seed, to round-off."""
    y = np.asarray(y, dtype=float)
    for _ in range(8):
        y = y - np.linalg.lstsq(problem.jacobian(y), problem.residual(y), rcond=None)[0]
    return y


@pytest.fixture(scope="module")
def orbits(paper_params):
    out = {}
    for seq, seed in SEEDS.items():
        problem = SequenceProblem(paper_params, seq)
        y = _refine(problem, seed)
        assert np.linalg.norm(problem.residual(y)) < 1e-12
        assert np.linalg.norm(y - seed) < 1e-9
        out[seq] = (problem, y)
    return out


@pytest.fixture(scope="module")
def two_family(paper_params):
    return follow_two_impact_family(paper_params, step=0.1)


@pytest.fixture(scope="module")
def first_segments(paper_params, two_family):
    """The continuation from the end of the two-impact family: FR -> FLFR -> FLF."""
    y = from_two_impact_unknowns(two_family.unknowns)
    settings = FamilySettings(
        step=0.25, max_frequency_step=5e-4, max_log_energy_step=0.1, max_points=400, max_segments=3
    )
    return follow_branch(paper_params, "FR", y[-1], y[-1] - y[-2], settings)


def _z0(y):
    return np.array([0.0, 0.0, y[0], y[1]])


# --------------------------------------------------------------------------- sequences and equations


def test_sequences_are_validated():
    assert check_sequence("FRFL") == "FRFL"
    for bad in ("", "RF", "FF", "FRL", "FRRF", "FXR", None):
        with pytest.raises(ValueError):
            check_sequence(bad)
    assert [sequence_impacts(s) for s in ("F", "FR", "FLF", "FLFR", "FRFLF", "FRFLFR")] == [0, 2, 4, 6, 8, 10]


def test_fr_equations_are_the_two_impact_equations(paper_params, two_family):
    fr = SequenceProblem(paper_params, "FR")
    two = TwoImpactProblem(paper_params)
    for y4 in two_family.unknowns[::20]:
        y = from_two_impact_unknowns(y4)
        np.testing.assert_allclose(fr.residual(y), two.residual(y4), atol=1e-14)
        # d/d(d2) = d/dT1 and d/d(d1) = d/dtau1 + d/dT1
        j4 = two.jacobian(y4)
        expected = np.column_stack([j4[:, 0], j4[:, 1], j4[:, 2] + j4[:, 3], j4[:, 3]])
        np.testing.assert_allclose(fr.jacobian(y), expected, rtol=1e-12, atol=1e-12)
        assert fr.energy(y) == two.energy(y4)
    with pytest.raises(ValueError, match="expected shape"):
        fr.residual([1.0, 2.0, 3.0])


@pytest.mark.parametrize("seq", ["FLFR", "FRFLFR"])
def test_analytic_jacobian_matches_finite_differences(orbits, seq):
    problem, y = orbits[seq]
    y = y + 1e-3 * np.linspace(-1, 1, y.size)  # off the family too
    h = 1e-6
    fd = np.column_stack(
        [(problem.residual(y + h * e) - problem.residual(y - h * e)) / (2 * h) for e in np.eye(y.size)]
    )
    np.testing.assert_allclose(problem.jacobian(y), fd, rtol=1e-6, atol=1e-7)


# --------------------------------------------------------------------------- orbits against time integration


@pytest.mark.parametrize("seq", list(SEEDS))
def test_orbits_are_periodic_for_the_event_driven_integrator(paper_params, orbits, seq):
    problem, y = orbits[seq]
    assert assess_orbit(problem, y).valid
    period = 4 * problem.quarter(y)
    t = np.linspace(0.0, period, 25)
    traj = integrate_nonsmooth(paper_params, _z0(y), t)
    hist = SequenceProblem(paper_params, seq).time_history(y, t)
    np.testing.assert_allclose(traj.states[-1], _z0(y), rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        np.column_stack([hist.x, hist.u, hist.xdot, hist.udot]),
        traj.states,
        rtol=0,
        atol=1e-9,
    )
    # every impact: the integrator enters and leaves a stop once
    assert problem.impacts_per_period == IMPACTS[seq]
    assert len(traj.switch_times) == 2 * IMPACTS[seq]


@pytest.mark.parametrize("seq", list(SEEDS))
def test_energy_is_conserved_and_impacts_are_counted_like_the_regularized_branch(paper_params, orbits, seq):
    problem, y = orbits[seq]
    period = 4 * problem.quarter(y)
    hist = SequenceProblem(paper_params, seq).time_history(y, np.linspace(0.0, period, 20000, endpoint=False))
    energy = total_energy(hist.x, hist.u, hist.xdot, hist.udot, paper_params, model="piecewise")
    np.testing.assert_allclose(energy, problem.energy(y), rtol=1e-12)
    assert sampled_impacts(hist.x) == problem.impacts_per_period
    check = assess_orbit(problem, y)
    assert hist.x.max() <= check.x_max + 1e-12 and check.x_max - hist.x.max() < 1e-5 * check.x_max  # sampled
    # the symmetries of the class: q(t + T/2) = -q(t), and a turning point at T1
    half = SequenceProblem(paper_params, seq).time_history(y, hist.t + period / 2)
    np.testing.assert_allclose(half.x, -hist.x, atol=1e-12 * max(1.0, abs(y[:2]).max()))
    turn = SequenceProblem(paper_params, seq).time_history(y, np.array([problem.quarter(y)]))
    assert abs(turn.xdot[0]) < 1e-11 * max(1.0, abs(y[:2]).max()) and abs(turn.udot[0]) < 1e-11 * abs(y[:2]).max()


def test_high_energy_fr_orbits_are_those_of_the_two_impact_module(paper_params, orbits):
    problem, y = orbits["FR"]
    x_max = assess_orbit(problem, y).x_turning
    y_he = from_two_impact_unknowns(high_energy_orbit(paper_params, x_max))
    np.testing.assert_allclose(y_he, y, rtol=1e-9)


# --------------------------------------------------------------------------- grazing transitions


def test_the_two_impact_family_ends_at_a_grazing_of_the_other_stop(paper_params, two_family, first_segments):
    fr, flfr = first_segments[0], first_segments[1]
    assert two_family.end_margin == "opposite_stop"
    tr = fr.transition
    assert (tr.kind, tr.old, tr.new, tr.level) == ("split", "FR", "FLFR", -1.0)
    # located where the end of the two-impact family was (to its bisection tolerance)
    y_end = from_two_impact_unknowns(two_family.unknowns[-1])
    np.testing.assert_allclose(tr.y_graze, y_end, rtol=0, atol=1e-9)
    # the grazing condition: x = -1 with xdot = 0 at t* inside the free flight, x >= -1 around
    problem = SequenceProblem(paper_params, "FR")
    z = problem.phases[0].state(problem.switch_states(tr.y_graze)[0], tr.t_star)
    assert abs(z[0] + 1.0) < 1e-13 and abs(z[2]) < 1e-12
    assert 0 < tr.t_star < tr.y_graze[2]
    hist = SequenceProblem(paper_params, "FR").time_history(tr.y_graze, np.linspace(0, tr.y_graze[2], 20001))
    assert -1.0 - 1e-13 < hist.x.min() < -1.0 + 1e-8  # sampled: the tangency lies between two samples
    # the new left-stop contact starts at the tangency, with the duration of the first orbit
    y1 = flfr.unknowns[0]
    assert y1[3] == pytest.approx(COARSE.grazing_epsilon, rel=1e-12)
    assert y1[2] + y1[3] / 2 == pytest.approx(tr.t_star, abs=1e-5)
    gap = flfr.problem.energy(y1) - problem.energy(tr.y_graze)
    assert 0 < gap < 2e-6 * problem.energy(tr.y_graze)
    # the new family is analytic in the new duration, the old one in its square: halving the
    # duration of the new contact divides the energy gap by four
    _, y_half, index = split_start(paper_params, "FR", tr.y_graze, 0, tr.t_star, -1.0, 0.5 * y1[3])
    assert index == 3 and y_half[3] == 0.5 * y1[3]
    ratio = gap / (flfr.problem.energy(y_half) - problem.energy(tr.y_graze))
    assert ratio == pytest.approx(4.0, rel=0.05)


def test_a_vanishing_contact_merges_the_sequences(paper_params, first_segments):
    flfr, flf = first_segments[1], first_segments[2]
    tr = flfr.transition
    assert (tr.kind, tr.old, tr.new, tr.margin) == ("merge", "FLFR", "FLF", ("duration", 3))
    last = flfr.unknowns[-1]
    assert 0 < last[-1] < 1e-5 * flfr.problem.quarter(last)  # the contact duration vanishes there
    # the grazing orbit: FLF whose turning point touches the stop x = 1
    g = flf.unknowns[0]
    assert flf.grazing[0] and np.array_equal(g, tr.y_graze)
    assert SequenceProblem(paper_params, "FLF").switch_states(g)[-1, 0] == pytest.approx(1.0, abs=1e-13)
    assert flf.problem.energy(g) == pytest.approx(flfr.problem.energy(last), rel=1e-9)
    assert flf.problem.frequency(g) == pytest.approx(flfr.problem.frequency(last), rel=1e-9)
    assert all(a.valid for a in flf.assessments[1:])
    # the 3:1 internal resonance: one simple bifurcation crossed, near the least energy of FLFR
    k = int(np.flatnonzero(flfr.branch_point)[0])
    assert sum(flfr.branch_point) == 1
    assert flfr.energy[k - 1 : k + 1].min() < 1.1 * flfr.energy.min()


def test_transitions_are_found_again_in_the_reverse_direction(paper_params, first_segments):
    """From inside FRFL towards lower energy: FRFL -> FL (merge) -> FLF (turning point) -> FLFR.

    Each grazing orbit is the one of the forward transition (FL -> FRFL split, FLF -> FL merge,
    FLFR -> FLF merge), found from the other side.
    """
    problem = SequenceProblem(paper_params, "FRFL")
    y0 = _refine(problem, SEEDS["FRFL"])
    direction = scipy.linalg.null_space(problem.jacobian(y0))[:, 0]
    direction *= -np.sign(direction[3])  # shrink the right-stop contact
    settings = FamilySettings(
        step=0.25, max_frequency_step=5e-4, max_log_energy_step=0.1, max_points=900, max_segments=4
    )
    segs = follow_branch(paper_params, "FRFL", y0, direction, settings)
    kinds = [(s.transition.kind, s.transition.old, s.transition.new) for s in segs[:3]]
    assert kinds == [("merge", "FRFL", "FL"), ("append", "FL", "FLF"), ("append", "FLF", "FLFR")]
    # the reversed transitions meet the same grazing orbits as the forward ones
    fl_split = segs[1].unknowns[0]  # FL grazing orbit: x grazes x = 1 in its free flight
    problem_fl = SequenceProblem(paper_params, "FL")
    check = assess_orbit(problem_fl, fl_split)
    assert abs(check.margins[("interior", 0)]) < 1e-12
    flf_turn = segs[2].transition.y_graze  # FLF whose turning point reaches x = 1
    assert SequenceProblem(paper_params, "FLF").switch_states(flf_turn)[-1, 0] == pytest.approx(1.0, abs=1e-13)
    # the very orbit where the forward continuation merged FLFR into FLF
    forward = first_segments[1].transition
    assert (forward.kind, forward.old, forward.new) == ("merge", "FLFR", "FLF")
    np.testing.assert_allclose(flf_turn, forward.y_graze, rtol=1e-9)
    expected = first_segments[2].problem.energy(forward.y_graze)
    assert segs[2].problem.energy(flf_turn) == pytest.approx(expected, rel=1e-9)
    # FL -> FLF: the turning point in the left stop comes back to x = -1 (the contact splits)
    fl_turn = segs[1].transition.y_graze
    assert problem_fl.switch_states(fl_turn)[-1, 0] == pytest.approx(-1.0, abs=1e-13)


def test_the_six_impact_high_energy_family_ends_on_the_two_impact_high_energy_orbits(paper_params, orbits):
    problem, y = orbits["FRFR"]
    direction = scipy.linalg.null_space(problem.jacobian(y))[:, 0]
    direction *= -np.sign(direction[4])  # shrink the free flight between the two right-stop contacts
    settings = FamilySettings(
        step=0.25, max_frequency_step=5e-4, max_log_energy_step=0.1, max_points=500, max_segments=2, energy_max=2000.0
    )
    segs = follow_branch(paper_params, "FRFR", y, direction, settings)
    tr = segs[0].transition
    assert (tr.kind, tr.old, tr.new, tr.margin) == ("merge", "FRFR", "FR", ("duration", 2))
    # the grazing orbit: FR whose contact has an interior minimum x = 1 (x leaves the stop)
    fr = SequenceProblem(paper_params, "FR")
    z = fr.phases[1].state(fr.switch_states(tr.y_graze)[1], tr.t_star)
    assert abs(z[0] - 1.0) < 1e-13 and abs(z[2]) < 1e-11
    # then the FR family grows in energy and its orbits are the high-energy orbits of exact.py
    high = segs[1]
    assert high.sequence == "FR" and high.energy[-1] > 2000.0 and np.all(np.diff(high.energy) > 0)
    for yk, check in list(zip(high.unknowns, high.assessments))[10::40]:
        y_he = from_two_impact_unknowns(high_energy_orbit(paper_params, check.x_turning))
        np.testing.assert_allclose(y_he, yk, rtol=1e-9)


def test_classification_refuses_non_generic_ends(paper_params):
    problem = SequenceProblem(paper_params, "FR")
    with pytest.raises(ValueError, match="first free flight"):
        merge_seed("FR", [1.0, 1.0, 0.0, 1.0], 0)
    with pytest.raises(ValueError, match="cannot vanish"):
        merge_seed("FRFLF", np.ones(7), 2)
    fake = OrbitAssessment({("switch", 0): -1.0}, {}, 1.0, 0.0, 1.0)
    with pytest.raises(RuntimeError, match="not a generic grazing"):
        classify_boundary(problem, [1.0, 1.0, 1.0, 1.0], fake, fake)


# --------------------------------------------------------------------------- dataset


def test_dataset_starts_with_the_two_impact_family_unchanged(paper_params, two_family, tmp_path):
    two_path = tmp_path / "two.nc"
    two = two_impact_dataset(two_family)
    two.to_netcdf(two_path)
    config = {
        "model": {"alpha": 30.0, "beta": 1.0, "delta": 1.0, "eta": 0.1},
        "exact_multi": {
            "step": 0.25,
            "max_points": 150,
            "energy_max": 1.5e5,
            "max_log_energy_step": 0.1,
            "max_frequency_step": 5e-4,
            "grazing_epsilon": 1e-3,
        },
    }
    out = build_multi_impact_dataset(config, two_path, tmp_path / "nnm1.nc")
    with xr.open_dataset(two_path) as a, xr.open_dataset(out) as b:
        two, ds = a.load(), b.load()
    n = two.sizes["point"]
    head = ds.isel(point=slice(0, n))
    for name in list(two.data_vars) + ["arclength"]:
        np.testing.assert_array_equal(head[name].values, two[name].values, err_msg=name)
    assert set(head["phase_sequence"].values) == {"FR"}
    assert list(head["impacts_per_period"].values) == [0] + [2] * (n - 1)
    rest = ds.isel(point=slice(n, None))
    assert rest["phase_sequence"].values[0] == "FLFR" and rest["impacts_per_period"].values[0] == 6
    assert rest["residual"].max() < 1e-12
    for name, var in {**ds.coords, **ds.data_vars}.items():
        assert var.attrs.get("long_name") and "units" in var.attrs, name
    assert (ds.attrs["alpha"], ds.attrs["beta"], ds.attrs["delta"]) == (30.0, 1.0, 1.0)
    assert "merge FLFR -> FLF" in ds.attrs["segment_1"]
    # inconsistent parameters are refused
    config["model"]["alpha"] = 20.0
    with pytest.raises(ValueError, match="alpha"):
        build_multi_impact_dataset(config, two_path, tmp_path / "bad.nc")


def test_settings_are_checked():
    with pytest.raises(ValueError, match="unknown exact_multi settings"):
        FamilySettings.from_config({"step": 0.1, "stepp": 1})
    with pytest.raises(ValueError, match="step"):
        FamilySettings(step=-1.0)
    with pytest.raises(ValueError, match="max_points"):
        FamilySettings(max_points=0)


def test_the_phase_sequences_take_a_two_dof_structure_and_refuse_others(paper_params):
    """Any 2-DOF structure with one stop on its first DOF (gap 1) gets the multi-impact sequences: on one that is
    not the paper's, an FLFR orbit past the two-impact family is checked by time integration; other structures
    are refused with a message naming what is not supported."""
    from nnmstop.checks.time_integration import integrate_structure_nonsmooth
    from nnmstop.exact.problem import from_two_impact_unknowns
    from nnmstop.models.structure import Stop, Structure, two_dof_structure

    y = np.array([1.2, 0.9, 0.7, 0.1, 1.1, 0.3])
    paper, as_structure = (
        SequenceProblem(paper_params, "FLFR"),
        SequenceProblem(two_dof_structure(paper_params), "FLFR"),
    )
    np.testing.assert_array_equal(paper.residual(y), as_structure.residual(y))
    other = Structure(np.diag([1.5, 1.0]), np.array([[2.2, -1.0], [-1.0, 1.3]]), (Stop(0, 1.0, 30.0, 0.1),))
    two = follow_two_impact_family(other, step=0.25)
    assert two.end_margin == "opposite_stop"
    start = from_two_impact_unknowns(two.unknowns)
    settings = FamilySettings(
        step=0.25, max_points=40, max_log_energy_step=0.1, max_frequency_step=5e-4, max_segments=2
    )
    segments = follow_branch(other, "FR", start[-1], start[-1] - start[-2], settings)
    flfr = segments[-1]
    assert flfr.sequence == "FLFR"
    orbit = flfr.unknowns[-1]
    run = integrate_structure_nonsmooth(other, [0.0, 0.0, orbit[0], orbit[1]], [0.0, 4.0 * flfr.problem.quarter(orbit)])
    np.testing.assert_allclose(run.states[-1], run.states[0], rtol=0, atol=1e-8 * np.abs(run.states[0]).max())
    assert np.count_nonzero(run.switch_sides) == flfr.problem.impacts_per_period == 6
    three = Structure(np.eye(3), np.diag([1.0, 2.0, 3.0]), (Stop(0, 1.0, 30.0, 0.1),))
    with pytest.raises(ValueError, match="implemented for the 2-DOF oscillator only; this structure has 3 degrees"):
        follow_branch(three, "FR", np.ones(4), np.ones(4), settings)
