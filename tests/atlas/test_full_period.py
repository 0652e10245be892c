"""The atlas of stops without the half-wave symmetry: one-sided, unequal gaps, relative (full-period formulation).

A 2-DOF chain (unit masses, springs 2, -1), damping ratio 0.02 on both modes, forced on its first mass; its first
mode resonates near 0.16 Hz. The curves are checked against what does not come from them: the closed-form
grazing force of the linear response, the folds that independent one-parameter exact responses locate, time
integration of the piecewise-linear equations of motion.
"""

from pathlib import Path

import numpy as np
import pytest
import scipy.integrate
from tests.atlas.conftest import central_differences

import nnmstop
from nnmstop.bifurcation_atlas.build import (
    AtlasMap,
    _crossings,
    check_curves,
    curves_dataset,
    follow_kind,
    slice_dataset,
)
from nnmstop.bifurcation_atlas.curves import CurveSettings
from nnmstop.bifurcation_atlas.equations import ExactContactEquations, contact_entered, exact_equations
from nnmstop.exact.forced import non_impacting_response
from nnmstop.forced.responses import exact_response
from nnmstop.models.excitation import Damping, Excitation, HarmonicForce

FAST = CurveSettings(step=0.05, tolerance=1e-11, max_points=1200, max_frequency_step=0.002)
#: Around the first mode only (the second one grazes above F = 0.2 near 0.27 Hz).
WINDOW_HZ = (0.12, 0.21)
STIFFNESS = [[2.0, -1.0], [-1.0, 2.0]]


def one_sided(side="positive", gap=1.0):
    return nnmstop.Stop(kind="one_sided", dof=0, side=side, gap=gap, stiffness=20.0, eta=0.05)


def chain_excitation(stops, force=0.2) -> Excitation:
    chain = nnmstop.Structure(np.eye(2), STIFFNESS, stops)
    return Excitation(chain, Damping.from_modal_ratios(chain, [0.02, 0.02]), HarmonicForce(force, [0]))


def force_map(stops, kinds, values, second=(0.1, 0.3)) -> AtlasMap:
    return AtlasMap("full_period", chain_excitation(stops), "force", WINDOW_HZ, second, tuple(values),
                    (values[0],), (), tuple(kinds), curve=FAST)  # fmt: skip


def located_folds(stops, force) -> list:
    """``(force, omega)`` of the folds of the exact one-parameter response at ``force`` (its own continuation)."""
    pieces = exact_response(chain_excitation(stops, force), WINDOW_HZ)
    return [(force, float(c.U[-1])) for p in pieces for c in p.changes if c.kind == "fold"]


def test_the_formulation_follows_the_stops():
    """Bilateral stops: the half-wave formulation; one-sided, unequal gaps, one-sided relative: the full period;
    a relative stop on both sides (odd law): half-wave on the general formulation; a state tells its contact."""
    assert exact_equations(chain_excitation([nnmstop.Stop(0, 1.0, 20.0, 0.05)])).half_period
    for stops in (
        [one_sided()],
        [one_sided("positive", 1.0), one_sided("negative", 1.3)],
        [nnmstop.Stop(kind="relative", dofs=[0, 1], side="positive", gap=0.5, stiffness=20.0, eta=0.05)],
    ):
        equations = exact_equations(chain_excitation(stops))
        assert isinstance(equations, ExactContactEquations) and not equations.half_period
    both = nnmstop.Stop(kind="relative", dofs=[0, 1], gap=0.5, stiffness=20.0, eta=0.05)
    equations = exact_equations(chain_excitation([both]))
    assert type(equations) is ExactContactEquations and equations.half_period
    excitation = chain_excitation([one_sided("positive", 1.0), one_sided("negative", 1.3)])
    assert contact_entered(excitation, [-1.3, 0.4, 0.0, 0.0, 0.1, 0.2]) == 1
    with pytest.raises(ValueError, match="enters no contact"):
        contact_entered(excitation, [0.2, 0.4, 0.0, 0.0, 0.1, 0.2])


def test_full_period_jacobian_and_monodromy_derivatives_match_differences():
    """[G_x | G_Omega, G_F, G_p] (analytic in x and Omega, affine in F) and the monodromy's derivatives in d0,
    Omega and the gap against central differences, at a located fold of the one-sided stop's response."""
    y = next(c.U for p in exact_response(chain_excitation([one_sided()]), WINDOW_HZ) for c in p.changes
             if c.kind == "fold")  # fmt: skip
    equations = ExactContactEquations(chain_excitation([one_sided()]), "gap", contact=0)
    x, params = y[:-1], np.array([y[-1], 0.2, 1.0])
    assert np.abs(equations.residual(x, params)).max() < 1e-12
    n = equations.n

    J = equations.jacobian(x, params)
    numeric = central_differences(lambda v: equations.residual(v[:n], v[n:]), np.concatenate([x, params]))
    np.testing.assert_allclose(J, numeric, atol=2e-7 * np.abs(J).max())
    indices, d_state, d_params = equations.monodromy_derivatives(x, params)
    numeric = central_differences(lambda v: equations.monodromy(np.r_[x[:-1], v[0]], v[1:]), np.r_[x[-1], params])
    np.testing.assert_allclose(d_state[0], numeric[..., 0], atol=1e-6)
    for k in range(3):
        np.testing.assert_allclose(d_params[k], numeric[..., 1 + k], atol=1e-6)


@pytest.mark.numerics
def test_grazing_curve_of_a_one_sided_stop_is_the_closed_form():
    """The grazing curve of the one-sided stop (zero contact duration, full period) is F_g(Omega) = g / max_t q(t)
    of the linear response at unit force, its coordinate's largest value (one side), to 1e-9 along the curve;
    the stop on the negative side with gap 1.3 grazes where -q reaches 1.3: the same curve times 1.3."""
    for stop, gap in ((one_sided("positive", 1.0), 1.0), (one_sided("negative", 1.3), 1.3)):
        atlas = force_map([stop], ("grazing",), (0.2,), second=(0.02, 0.4))
        curves = follow_kind(atlas, "grazing", [slice_dataset(atlas, 0)])
        assert len(curves) == 1
        params = curves[0].params()
        theta = np.linspace(0, 2 * np.pi, 4001)
        Q = non_impacting_response(chain_excitation([stop], 1.0), params[:, 0])[:, 0]
        side = 1.0 if stop.side == "positive" else -1.0
        largest = (side * np.real(np.multiply.outer(Q, np.exp(1j * theta)))).max(axis=1)  # sampled: to 1e-6
        np.testing.assert_allclose(params[:, 1], gap / largest, rtol=2e-6)
        np.testing.assert_allclose(params[:, 1], gap / np.abs(Q), rtol=1e-9)  # its maximum: |Q|


@pytest.fixture(scope="module")
def one_sided_folds():
    """The fold curves of the one-sided stop seeded on the slice at F = 0.2, and their map."""
    atlas = force_map([one_sided()], ("fold",), (0.2,))
    return atlas, follow_kind(atlas, "fold", [slice_dataset(atlas, 0)])


@pytest.mark.numerics
def test_fold_curve_of_a_one_sided_stop_holds_the_folds_of_the_responses_at_other_forces(one_sided_folds):
    """The fold curves seeded at F = 0.2 pass through the folds that the exact responses at F = 0.15 and 0.25 locate
    (both are roots to round-off: 1e-9 relative)."""
    atlas, curves = one_sided_folds
    located = located_folds([one_sided()], 0.15) + located_folds([one_sided()], 0.25)
    assert len(located) == 4
    rows = check_curves(atlas, "fold", curves, located, tolerance=1e-9)
    assert len(rows) == 4 and max(r[-1] for r in rows) < 1e-9, rows


@pytest.mark.numerics
def test_the_gap_map_of_a_one_sided_stop_is_its_force_map_rescaled(one_sided_folds):
    """The piecewise-linear law is homogeneous of degree one in (q, gap, F): the fold at gap g and force 0.2 is the
    fold at gap 1 and force 0.2 / g. The fold curves continued in (Omega, gap) at F = 0.2 (the full-period
    formulation's gap derivative by central differences) meet g = 0.2 / 0.17 where the curves in (Omega, F) meet
    F = 0.17, to 1e-9."""
    force_atlas, force_curves = one_sided_folds
    gap_atlas = AtlasMap("gap", chain_excitation([one_sided()]), "gap", WINDOW_HZ, (0.7, 1.5), (1.0,), (1.0,), (),
                         ("fold",), curve=FAST)  # fmt: skip
    gap_curves = follow_kind(gap_atlas, "fold", [slice_dataset(gap_atlas, 0)])
    by_force = sorted(c for curve in force_curves for c in _crossings(curve, force_atlas, 0.17, 1e-11))
    by_gap = sorted(c for curve in gap_curves for c in _crossings(curve, gap_atlas, 0.2 / 0.17, 1e-11))
    assert len(by_force) == 2 and len(by_gap) == 2, (by_force, by_gap)
    np.testing.assert_allclose(by_gap, by_force, rtol=1e-9)


@pytest.mark.numerics
def test_a_fold_orbit_is_periodic_with_a_multiplier_one_under_time_integration(one_sided_folds):
    """At a point of the one-sided stop's fold curve (F = 0.17, between the slices), time integration of the
    piecewise-linear equations of motion from the orbit's state returns to it after one period, and the monodromy
    by finite differences of integrated orbits has a multiplier 1: what the fold curve claims, checked without
    its closed forms."""
    atlas, curves = one_sided_folds
    curve = curves[0]
    crossings = _crossings(curve, atlas, 0.17, 1e-11)
    assert crossings
    params = curve.params()
    i = int(np.argmin(np.abs(params[:, 1] - 0.17) + np.abs(params[:, 0] - crossings[0])))
    x, _, params = curve.system.split(curve.points[i])
    omega, force = float(params[0]), float(params[1])
    excitation = chain_excitation([one_sided()], force)
    M, K = excitation.structure.dense_matrices()
    C = np.asarray(excitation.damping_matrix.toarray() if hasattr(excitation.damping_matrix, "toarray")
                   else excitation.damping_matrix)  # fmt: skip
    b = excitation.load

    def field(t, z, in_contact):
        """The piecewise-linear field of one phase (no kink inside an integration: phases meet at events)."""
        q, v = z[:2], z[2:]
        contact = 20.0 * (q[0] - 1.0) * np.array([1.0, 0.0]) if in_contact else 0.0
        return np.concatenate([v, np.linalg.solve(M, np.cos(omega * t) * b - C @ v - K @ q - contact)])

    def enters(t, z, in_contact):
        return z[0] - 1.0

    enters.terminal, enters.direction = True, 1.0

    def leaves(t, z, in_contact):
        return z[0] - 1.0

    leaves.terminal, leaves.direction = True, -1.0

    # start in the middle of the free flight: the flow map from there is smooth (its orbits cross the switching
    # surface transversally), so that central differences of it converge as h**2
    problem = curve.system.equations.problem(params)
    theta1, delta = float(x[4]), float(x[5])
    theta_start = theta1 + delta + 0.5 * (2 * np.pi - delta)
    z_start = problem.phase_list[1].states(problem.switch_states(np.append(x, omega))[1], theta1 + delta, omega,
                                           theta_start)  # fmt: skip
    t0, period = theta_start / omega, 2 * np.pi / omega

    def flow(z):
        """One period of the piecewise-linear equations of motion, phase after phase (switches by events)."""
        t, z, in_contact = t0, np.asarray(z, dtype=float), False
        while t < t0 + period:
            run = scipy.integrate.solve_ivp(field, (t, t0 + period), z, method="DOP853", rtol=1e-13, atol=1e-14,
                                            events=leaves if in_contact else enters, args=(in_contact,))  # fmt: skip
            t, z = run.t[-1], run.y[:, -1]
            in_contact = not in_contact if run.status == 1 else in_contact
        return z

    z0 = np.asarray(z_start)
    assert np.abs(flow(z0) - z0).max() < 1e-10  # measured 1.5e-13

    def differences(h):
        return np.column_stack([(flow(z0 + h * e) - flow(z0 - h * e)) / (2 * h) for e in np.eye(4)])

    # Richardson on h = 1e-3, 2e-3: truncation O(h**4) ~1e-12, flow errors ~1e-14 amplified by 1/h; measured: the
    # multipliers agree with the closed form's to 1e-11
    monodromy = (4 * differences(1e-3) - differences(2e-3)) / 3
    mu = np.linalg.eigvals(monodromy)
    assert np.abs(mu - 1.0).min() < 1e-8, mu
    np.testing.assert_allclose(np.sort_complex(mu), np.sort_complex(curve.system.equations.multipliers(x, params)),
                               atol=1e-8)  # fmt: skip


@pytest.mark.numerics
def test_regularized_folds_converge_to_the_exact_fold_curve_at_first_order_in_eta(one_sided_folds):
    """A second method: the harmonic-balance responses (H = 40) of the regularized one-sided law at F = 0.17 have
    their jump-down fold within O(eta) of where the exact fold curve crosses F = 0.17 (a point of the curve
    between the slices): the distance falls at first order as eta halves (0.04, 0.02) and stays below eta."""
    from nnmstop.bifurcation_atlas.artefacts import fold_distances
    from nnmstop.continuation.anm import ANMSettings

    atlas, curves = one_sided_folds
    exact = max(c for curve in curves for c in _crossings(curve, atlas, 0.17, 1e-11)) / (2 * np.pi)
    anm = ANMSettings(order=20, tolerance=1e-8, newton_threshold=1e-7, max_steps=3000, points_per_step=2)
    etas = (0.04, 0.02)
    _, regularized, _ = fold_distances(chain_excitation([one_sided()]), etas, (0.17,), 40, anm, 1e-2, (0.14, 0.2))
    distance = np.abs(regularized[:, 0] - exact) / exact
    order = np.log(distance[0] / distance[1]) / np.log(2.0)
    assert order > 0.8, (distance, order)
    assert np.all(distance < np.array(etas)), distance


@pytest.mark.numerics
def test_with_unequal_gaps_the_fold_curve_ends_on_the_second_contact_curve():
    """Gaps 1 (positive side) and 1.3 (negative side) on the first mass: the one-contact responses end where the
    orbit reaches the other side. The fold curve seeded at F = 0.15 ends there (a located codimension-two point,
    second contact); the second-contact curve seeded on the family ends at F = 0.25 passes through it (1e-8), and
    the orbit there touches -1.3 (dense time history, 1e-7)."""
    stops = [one_sided("positive", 1.0), one_sided("negative", 1.3)]
    atlas = AtlasMap("unequal", chain_excitation(stops), "force", WINDOW_HZ, (0.1, 0.3), (0.15, 0.25), (0.15, 0.25),
                     (), ("fold", "second_contact"), curve=FAST)  # fmt: skip
    seeds = [slice_dataset(atlas, 0), slice_dataset(atlas, 1)]
    folds = follow_kind(atlas, "fold", seeds[:1])
    ends = [p for curve in folds for p in curve.codim2 if p.kind == "second_contact"]
    assert len(ends) == 1, [p.kind for curve in folds for p in curve.codim2]
    contacts = follow_kind(atlas, "second_contact", seeds[1:])
    assert contacts
    omega, force = float(ends[0].params[0]), float(ends[0].params[1])
    crossings = [c for curve in contacts for c in _crossings(curve, atlas, force, 1e-11)]
    assert min(abs(c - omega) / omega for c in crossings) < 1e-8, (omega, crossings)
    fold = next(curve for curve in folds if any(p is ends[0] for p in curve.codim2))
    x = fold.system.split(ends[0].U)[0]
    problem = fold.system.equations.problem(ends[0].params)
    history = problem.time_history(np.append(x, omega), samples=200000)
    assert -history["q"][0].min() == pytest.approx(1.3, abs=1e-7)


@pytest.mark.numerics
def test_atlas_of_a_relative_stop_between_two_masses():
    """``nnmstop.atlas`` of a one-sided relative stop (q0 - q1 >= 0.5) near the second mode, where the masses move
    against each other: its grazing curve is g / |Q0 - Q1| of the linear response at unit force (1e-9), and the
    checks at another force hold (every located grazing and fold point on a curve)."""
    stop = nnmstop.Stop(kind="relative", dofs=[0, 1], side="positive", gap=0.5, stiffness=20.0, eta=0.05)
    chain = nnmstop.Structure(np.eye(2), STIFFNESS, [stop])
    ds = nnmstop.atlas(chain, (0.24, 0.31), [0], (0.15, 0.25), slices=2, damping=0.02, kinds=("grazing", "fold"),
                       frequency_samples=20, seeds=[0.25], checks=[0.15], curve=FAST)  # fmt: skip
    assert ds.sizes["check"] >= 3 and float(ds["check_deviation"].max()) < 1e-7
    grazing = ds["point_curve"].isin(np.flatnonzero(ds["curve_kind"].values == 0))
    omega = 2 * np.pi * ds["frequency"].values[grazing.values]
    Q = non_impacting_response(chain_excitation([stop], 1.0), omega)
    np.testing.assert_allclose(ds["second"].values[grazing.values], 0.5 / np.abs(Q[:, 0] - Q[:, 1]), rtol=1e-9)


def test_a_circular_clearance_is_refused_with_its_name():
    """No exact responses for a circular clearance: its exact curves are refused, naming it, where they would be
    computed, and its slices (regularized) without a `regularized` section; the map itself is still read (a
    configuration of that structure stays valid)."""
    hole = nnmstop.Stop(kind="circular", dofs=[0, 1], gap=1.0, stiffness=10.0, eta=0.1)
    structure = nnmstop.Structure(np.eye(2), np.diag([1.0, 1.5]), [hole])
    refused = "circular clearance of q0, q1 is not piecewise linear.*regularized_fold"
    with pytest.raises(ValueError, match=refused):
        nnmstop.atlas(structure, (0.1, 0.2), [0], (0.1, 0.2), kinds=("grazing", "fold"))
    excitation = Excitation(structure, Damping.from_modal_ratios(structure, [0.02, 0.02]), HarmonicForce(0.1, [0]))
    atlas = AtlasMap("hole", excitation, "force", (0.1, 0.2), (0.1, 0.2), (0.1,), (0.1,), (), ("fold",))
    with pytest.raises(ValueError, match=refused):
        slice_dataset(atlas, 0)
    with pytest.raises(ValueError, match=refused):
        curves_dataset(atlas, "fold", [], [])
    with pytest.raises(ValueError, match="circular"):
        exact_equations(excitation)


@pytest.mark.numerics
def test_the_configuration_route_takes_a_one_sided_stop(tmp_path):
    """The workflow's jobs (slices, curves, map: :mod:`nnmstop.tasks.atlas`) on the 3-DOF example with its stop made
    one-sided (its map `structure: structure`): datasets written and read back, the grazing curve the closed form
    gap / max_t x1(t) of the chain's linear response at unit force (1e-9)."""
    import yaml

    from nnmstop.config import validate_config
    from nnmstop.forced.scenes import forced_scenes
    from nnmstop.netcdf import read_dataset
    from nnmstop.tasks import atlas as tasks

    example = Path(__file__).resolve().parents[2] / "examples" / "three_dof_chain"
    config = yaml.safe_load((example / "config.yaml").read_text())
    matrices = config["structure"]["matrices"]
    for name in ("mass", "stiffness"):
        matrices[name] = str(example / f"{name}.mtx")
    matrices["stops"] = [{"kind": "one_sided", "dof": 0, "side": "positive", "gap": 1.0, "stiffness": 30.0,
                          "eta": 0.1}]  # fmt: skip
    config["atlas"]["maps"]["chain_force"].update(
        slices={"from": 0.02, "to": 0.04, "count": 2}, seeds=[0.04], checks=[0.02], kinds=["grazing"]
    )
    config["atlas"]["frequency_samples"] = 20
    config = validate_config(config)
    slices = [str(tmp_path / f"slice_{k}.nc") for k in range(2)]
    for k, path in enumerate(slices):
        tasks.atlas_slice(config, {}, {"dataset": path}, map="chain_force", index=str(k))
    curves = str(tmp_path / "curves_grazing.nc")
    tasks.atlas_curves(config, {"seeds": slices[1:], "checks": slices[:1]}, {"dataset": curves}, map="chain_force",
                       kind="grazing")  # fmt: skip
    tasks.atlas_map(config, {"slices": slices, "curves": [curves]}, {"dataset": str(tmp_path / "map.nc")},
                    map="chain_force")  # fmt: skip
    ds = read_dataset(tmp_path / "map.nc")
    assert ds.sizes["point"] > 10 and ds.sizes["check"] >= 1
    omega, force = 2 * np.pi * ds["frequency"].values, ds["second"].values
    unit = forced_scenes({**config, "forced": {**config["forced"], "force": {"dofs": ["x3"], "amplitudes": [1.0]}}},
                         "structure")[0].excitation  # fmt: skip
    assert unit.structure.stops[0].kind == "one_sided"
    np.testing.assert_allclose(force, 1.0 / np.abs(non_impacting_response(unit, omega)[:, 0]), rtol=1e-9)
