"""A body in a circular hole (an isotropic 2-DOF oscillator, mass m and stiffness k in both directions), against
closed forms and independent computations.

* The planar NNM family along any diameter is the bilateral stop's family: the regularized orbits (rotation phase
  condition at an angle) map onto the bilateral system's unknowns and solve it; the exact orbits of the bilateral
  stop, turned onto a diameter, are periodic orbits of the piecewise-linear hole (DOP853 with located contacts).
* The whirling family (constant contact at radius R, circular orbit) has omega^2 = (k + g f_b(R/g) / R) / m to
  round-off with the regularized law, within the law's stated distance of (k + k_s (1 - g/R)) / m.
* Wear: on the whirl the wear power is k_s (R - g) omega R with the piecewise law (g f_b(R/g) omega R with the
  regularized one) and there is no impact work; planar motion wears nothing by sliding and its impact work rate is
  k_s (A - g)^2 / T; an orbit that does not touch has none of them.
* The isotropic planar family has no branch point at finite amplitude (the SO(2) degeneracy: its transverse
  multipliers stay at 1); an imperfect hole (k_y = k (1 + delta)) has one where planar motion gives way to whirl,
  located where an independent shooting of the transverse variational equation puts it, and the branch switched
  there goes round the hole and tends to the isotropic whirling family as delta -> 0.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

import nnmstop
from nnmstop.checks.time_integration import integrate_structure_nonsmooth
from nnmstop.continuation.anm import ANMSettings
from nnmstop.continuation.core import ContinuationStats, newton_correct, relative_residual
from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.stability import StabilitySettings
from nnmstop.hbm.stages import BifurcationSpec, BranchSettings, BranchSpec, StageSpec, bifurcated_branch, continue_stage
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.contact import Stop
from nnmstop.models.structure import Structure
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force, regularized_contact_potential
from nnmstop.wear import orbit_wear, structure_wear

M, K, GAP, ALPHA, ETA = 2.0, 3.0, 0.5, 40.0, 0.2
LAW = ModelParameters(alpha=ALPHA, eta=ETA)
H = 16


def hole() -> Stop:
    return Stop(kind="circular", dofs=[0, 1], gap=GAP, stiffness=ALPHA, eta=ETA)


def isotropic() -> Structure:
    return Structure(M * np.eye(2), K * np.eye(2), [hole()], rotation_pairs=[(0, 1)])


def diameter() -> Structure:
    """The same body moving on one diameter: a bilateral stop of the same gap, stiffness and eta."""
    return Structure(M * np.eye(1), K * np.eye(1), [Stop(dof=0, gap=GAP, stiffness=ALPHA, eta=ETA)])


def settings() -> BranchSettings:
    return BranchSettings(ANMSettings(points_per_step=2), 1e-3, StabilitySettings())


def branch(system, energy_max: float, amplitude: float = 0.05, motion: str = "planar"):
    stage = StageSpec("up", {"energy_above": energy_max})
    spec = BranchSpec(f"{motion}1", 1, amplitude, (stage,), energy_max=energy_max, motion=motion)
    return continue_stage(system, settings(), spec, 1)


def test_rotation_pairs_are_checked():
    """A structure declared invariant under rotations must be: matrices that commute with the generator, stops on
    rotated DOFs that are circular clearances on a pair; the second mode of a rotated pair is refused by name."""
    with pytest.raises(ValueError, match="stiffness matrix is not invariant"):
        Structure(np.eye(2), np.diag([1.0, 1.1]), [hole()], rotation_pairs=[(0, 1)])
    with pytest.raises(ValueError, match="must be a circular clearance"):
        Structure(np.eye(2), np.eye(2), [Stop(dof=0, gap=1.0, stiffness=ALPHA, eta=ETA)], rotation_pairs=[(0, 1)])
    with pytest.raises(ValueError, match="distinct degrees of freedom"):
        Structure(np.eye(2), np.eye(2), [hole()], rotation_pairs=[(0, 2)])
    system = HarmonicBalanceSystem(isotropic(), 4)
    assert system.rotation and system.n_unknowns == system.n_equations + 1
    with pytest.raises(ValueError, match="mode 2 is mode 1 turned by 90 degrees"):
        system.linear_mode_guess(2, 0.1)
    with pytest.raises(ValueError, match="full basis without the rotation phase condition"):
        system.whirl_guess(1, 0.1)
    with pytest.raises(ValueError, match="rotation=True needs a structure invariant"):
        HarmonicBalanceSystem(diameter(), 4, rotation=True)


@pytest.mark.numerics
@pytest.mark.parametrize("angle", [0.0, 0.7])
def test_regularized_planar_family_is_the_bilateral_family_along_any_diameter(angle):
    """The isotropic body's planar NNM, its rotation fixed along ``angle``, stays on that diameter, its rotation
    unfolding at zero, and every orbit mapped onto the radial coordinate solves the bilateral stop's HBM system to
    the residual it was computed with; no branch point is flagged on it."""
    system = HarmonicBalanceSystem(isotropic(), H, rotation_angle=angle)
    ds = branch(system, energy_max=3.0)
    assert ds.attrs["rotation_condition"] == 1 and ds.attrs["end_reason"] == "energy above 3"
    assert int(ds["branch_point"].sum()) == 0
    U = dataset_unknowns(ds, system)
    Q, F = (
        U[:, : 2 * system.nc].reshape(-1, 2, system.nc),
        U[:, 2 * system.nc : 4 * system.nc].reshape(-1, 2, system.nc),
    )
    across = -np.sin(angle) * Q[:, 0] + np.cos(angle) * Q[:, 1]
    assert np.abs(across).max() <= 1e-12 * np.abs(Q).max()
    # zero on the family, to the accuracy of the continuation's points (their algebraic residual)
    assert np.all(np.abs(ds["rotation_unfolding"].values) <= 10 * ds["algebraic_residual"].values + 1e-14)
    bilateral = HarmonicBalanceSystem(diameter(), H)
    radial = np.cos(angle) * Q[:, 0] + np.sin(angle) * Q[:, 1]
    force = np.cos(angle) * F[:, 0] + np.sin(angle) * F[:, 1]
    z = U[:, 4 * system.nc : 5 * system.nc]
    for k in range(len(U)):
        V = np.concatenate([radial[k], force[k], z[k], [U[k, system.i_lam]]])
        assert relative_residual(bilateral, V) <= 10 * float(ds["algebraic_residual"][k]) + 1e-13
    assert float(ds["x_max"].max()) / np.cos(angle) > 1.5  # the radius goes well into contact (x_max: along q0)


def _hole_piecewise(z0, period: float):
    """The body in the piecewise-linear hole over one period, DOP853 restarted at every crossing of r = g (each
    region's law is smooth: no step straddles the kink)."""

    def field(outside):
        def rhs(_t, z):
            q, r = z[:2], np.hypot(*z[:2])
            force = K * q + (ALPHA * (r - GAP) * q / r if outside else 0.0)
            return np.concatenate([z[2:], -force / M])

        return rhs

    def leaving(outside):
        def event(_t, z):
            return np.hypot(*z[:2]) - GAP

        event.terminal, event.direction = True, -1.0 if outside else 1.0
        return event

    t, z, outside = 0.0, np.asarray(z0, float), False
    while t < period:
        sol = solve_ivp(
            field(outside), (t, period), z, method="DOP853", rtol=1e-12, atol=1e-13, events=leaving(outside)
        )
        if sol.status != 1:
            return sol.y[:, -1]
        t, z, outside = float(sol.t_events[0][0]), sol.y_events[0][0], not outside
    return z


@pytest.mark.numerics
@pytest.mark.parametrize("angle", [0.0, 1.1])
def test_exact_planar_family_is_the_bilateral_family_along_any_diameter(angle):
    """The exact NNM of the bilateral stop (closed-form phases), started on the diameter at ``angle`` in the
    piecewise-linear circular hole, returns to its start after its period: it is a periodic orbit of the hole."""
    family = nnmstop.exact_family(diameter(), step=0.1, max_points=12)
    direction = np.array([np.cos(angle), np.sin(angle)])
    for v0, frequency, x_max in zip(
        family["initial_velocity"].values[:, 0], family["frequency"].values, family["x_max"].values
    ):
        z0 = np.concatenate([[0.0, 0.0], v0 * direction])
        z1 = _hole_piecewise(z0, 1.0 / frequency)
        assert np.abs(z1 - z0).max() <= 1e-8 * abs(v0), (x_max, z1 - z0)
    assert family["x_max"].values[-1] > 1.25 * GAP  # the last orbits go well into contact


def whirl_points(energy_max: float = 30.0):
    """The regularized whirling family of the isotropic body from inside the clearance, its orbits corrected onto
    the family at fixed radius."""
    structure = isotropic()
    ds = nnmstop.continue_nnm(structure, harmonics=H, energy_max=energy_max, start_amplitude=0.4, motion="whirl")
    system = HarmonicBalanceSystem(structure, H, basis="full", rotation=False)
    direction = system.amplitude_direction(1)
    U = np.array(
        [newton_correct(system, u, direction, ContinuationStats(), tol=1e-14)[0] for u in dataset_unknowns(ds, system)]
    )
    return ds, system, U


@pytest.mark.numerics
def test_whirling_family_against_its_closed_form():
    """omega^2 = (k + g f_b(R/g) / R) / m on every whirling orbit, to round-off; the orbits are circles (one
    harmonic, x = R cos, y = R sin); above the piecewise-linear closed form (k + k_s (1 - g/R)) / m by the
    regularized law's distance, eta / (2 m (R/g - 1)) to first order in eta (a bound for R < 3 g)."""
    ds, system, U = whirl_points()
    Q = U[:, : 2 * system.nc].reshape(-1, 2, system.nc)
    R = Q[:, 0, 1]
    np.testing.assert_allclose(Q[:, 1, system.H + 1], R, rtol=1e-12)  # y = R sin
    others = np.abs(Q).copy()
    others[:, 0, 1] = others[:, 1, system.H + 1] = 0.0
    assert others.max() <= 1e-12 * R.max()
    lam = U[:, system.i_lam]
    rho = R / GAP
    regularized = (K + GAP * regularized_contact_force(rho, LAW) / R) / M
    np.testing.assert_allclose(lam, regularized, rtol=1e-12)
    deep = rho >= 1.2
    assert deep.sum() >= 5 and R.max() > 2 * GAP
    piecewise = (K + ALPHA * (1 - GAP / R[deep])) / M
    ratio = (lam[deep] - piecewise) / (ETA / (2 * M * (rho[deep] - 1)))  # the first-order distance in eta
    assert np.all((ratio > 0.8) & (ratio <= 1.0))
    assert ds.attrs["motion"] == "whirl" and ds.attrs["rotation_condition"] == 0


@pytest.mark.numerics
def test_wear_power_of_the_whirl_and_of_orbits_that_do_not_touch():
    """On the whirl the wear power is F_N omega R with a permanent contact (no impact work): k_s (R - g) omega R with
    the piecewise law on the computed orbits (to round-off), g f_b(R/g) omega R with the regularized one (stored in
    the dataset), its distance to the closed form with the closed-form omega the law's, to first order in eta; zero
    for every quantity inside the clearance."""
    ds, system, U = whirl_points()
    R, omega = U[:, 1], np.sqrt(U[:, system.i_lam])  # x = R cos(theta): its first cosine coefficient
    history = system.time_history(U, 512)
    period = 2 * np.pi / omega
    q, qdot = np.moveaxis(history["q"], 1, 0), np.moveaxis(history["qdot"], 1, 0)
    piecewise = structure_wear(system.structure, q, qdot, period, law="piecewise_linear")
    regularized = orbit_wear(system, U)
    touching = R > GAP
    assert touching.sum() >= 5 and (~touching).sum() >= 2
    np.testing.assert_allclose(
        piecewise["wear_power"][:, 0], ALPHA * np.maximum(R - GAP, 0) * omega * R, rtol=1e-12, atol=0
    )
    force = GAP * regularized_contact_force(R / GAP, LAW)
    np.testing.assert_allclose(regularized["wear_power"][touching, 0], (force * omega * R)[touching], rtol=1e-12)
    np.testing.assert_allclose(regularized["sliding_speed_max"][touching, 0], (omega * R)[touching], rtol=1e-12)
    for name, values in list(regularized.items()) + list(piecewise.items()):
        assert np.all(values[~touching] == 0.0), name
    assert np.all(regularized["impact_work_rate"] == 0.0) and np.all(piecewise["impact_work_rate"] == 0.0)
    # the stored dataset carries the regularized wear of its own (uncorrected) orbits
    stored = ds["wear_power"].values[:, 0]
    np.testing.assert_allclose(stored, orbit_wear(system, dataset_unknowns(ds, system))["wear_power"][:, 0], rtol=1e-12)
    # against the closed form of the piecewise-linear law at the same radius (its own omega)
    rho = R / GAP
    deep = rho >= 1.2
    omega_pw = np.sqrt((K + ALPHA * (1 - GAP / R[deep])) / M)
    closed = ALPHA * (R[deep] - GAP) * omega_pw * R[deep]
    # to first order in eta: the force is above alpha (rho - 1) by eta rho / (2 (rho - 1)), omega^2 by
    # eta / (2 m (rho - 1))
    force_excess = ETA * rho[deep] / (2 * ALPHA * (rho[deep] - 1) ** 2)
    omega_excess = ETA / (4 * M * (rho[deep] - 1) * omega_pw**2)
    ratio = (regularized["wear_power"][deep, 0] / closed - 1) / (force_excess + omega_excess)
    assert np.all((ratio > 0.8) & (ratio < 1.1))


@pytest.mark.numerics
def test_planar_motion_wears_by_impacts_only():
    """Along a diameter there is no sliding: zero wear power. The exact orbit's impact work rate is
    k_s (A - g)^2 / T (two impacts per period storing k_s (A - g)^2 / 2 each), to the sampling's second order; the
    regularized planar orbits' is their potential's rise beyond the gap twice per period; orbits inside the
    clearance have none."""
    structure = diameter()
    family = nnmstop.exact_family(structure, step=0.1, max_points=10)
    for v0, frequency, x_max in zip(
        family["initial_velocity"].values[:, 0], family["frequency"].values, family["x_max"].values
    ):
        period, samples = 1.0 / frequency, 4096
        t = np.arange(samples) * period / samples
        z = integrate_structure_nonsmooth(structure, [0.0, v0], t).states.T
        wear = structure_wear(structure, z[:1], z[1:], period, law="piecewise_linear")
        A = x_max  # physical, as the exact family stores it
        assert wear["wear_power"][0] == 0.0
        scale = ALPHA * GAP**2 / period
        np.testing.assert_allclose(
            wear["impact_work_rate"][0], ALPHA * (A - GAP) ** 2 / period, rtol=1e-4, atol=1e-12 * scale
        )
    system = HarmonicBalanceSystem(isotropic(), H)
    ds = branch(system, energy_max=3.0)
    assert np.all(ds["wear_power"].values == 0.0) and np.all(ds["sliding_speed_max"].values == 0.0)
    inside = ds["x_max"].values < 1.0
    assert inside.sum() >= 3
    for name in ("contact_force_max", "contact_force_mean", "impact_work_rate"):
        assert np.all(ds[name].values[inside] == 0.0), name
    U = dataset_unknowns(ds, system)
    deep = ds["x_max"].values > 1.2
    A = ds["x_max"].values[deep]
    rise = GAP**2 * (regularized_contact_potential(A, LAW) - regularized_contact_potential(1.0, LAW))
    period = ds["period"].values[deep]
    np.testing.assert_allclose(ds["impact_work_rate"].values[deep, 0], 2 * rise / period, rtol=1e-4)
    assert np.all(ds["contact_force_max"].values[deep, 0] > 0) and len(U) == ds.sizes["point"]


def _transverse_branch_point(delta: float):
    """Where the planar orbit of the regularized hole with k_y = k (1 + delta) has a periodic transverse motion out
    of phase (y odd in time): by DOP853 on the orbit and its transverse variational equation over a quarter period,
    y(0) = 0, y'(0) = 1 and y'(T/4) = 0 solved for the amplitude (independent of the harmonic balance). Returns the
    orbit's energy and frequency."""

    def quarter(A):
        def rhs(_t, s):
            x, v, y, dy = s
            r = abs(x)
            secant = GAP * float(regularized_contact_force(r / GAP, LAW)) / r if r > 0 else ETA
            force = GAP * float(regularized_contact_force(x / GAP, LAW))
            return [v, -(K * x + force) / M, dy, -(K * (1 + delta) + secant) * y / M]

        def centre(_t, s):
            return s[0]

        centre.terminal, centre.direction = True, -1
        sol = solve_ivp(rhs, (0, 100), [A, 0, 0, 1], method="DOP853", rtol=1e-12, atol=1e-14, events=centre)
        return sol.y_events[0][0][3], sol.t_events[0][0]

    A = brentq(lambda a: quarter(a)[0], 0.2 * GAP, 1.5 * GAP, xtol=1e-14)
    energy = 0.5 * K * A**2 + GAP**2 * float(regularized_contact_potential(A / GAP, LAW))
    return energy, 1.0 / (4 * quarter(A)[1])


def imperfect(delta: float) -> Structure:
    return Structure(M * np.eye(2), np.diag([K, K * (1 + delta)]), [hole()])


@pytest.mark.numerics
def test_planar_motion_gives_way_to_whirl_in_an_imperfect_hole():
    """With k_y = k (1 + delta) the planar family along x (full basis) has one branch point, classified as planar
    motion giving way to whirl, where the transverse shooting puts it; switched there, the branch goes round the hole
    (swept area -> 1) and its frequency at a fixed energy tends to the isotropic whirling family's as delta -> 0
    (first order in delta)."""
    energy_probe, gaps = 5.0, []
    _, _, whirl = whirl_points(energy_max=8.0)
    iso_system = HarmonicBalanceSystem(isotropic(), H, basis="full", rotation=False)
    iso_energy = np.array([iso_system.diagnostics(u)["energy"] for u in whirl])
    iso_frequency = np.sqrt(whirl[:, iso_system.i_lam]) / (2 * np.pi)
    reference = float(CubicSpline(np.log(iso_energy), iso_frequency)(np.log(energy_probe)))
    for delta in (0.04, 0.02):
        system = HarmonicBalanceSystem(imperfect(delta), H, basis="full")
        planar = branch(system, energy_max=8.0)
        assert planar.sizes["located_branch_point"] == 1
        assert int(planar["branch_point_whirl"][0]) == 1
        energy, frequency = _transverse_branch_point(delta)
        np.testing.assert_allclose(float(planar["branch_point_energy"][0]), energy, rtol=1e-6)
        np.testing.assert_allclose(float(planar["branch_point_frequency"][0]), frequency, rtol=1e-7)
        # resolved verdicts: stable well before the branch point, unstable (to whirl) well after it
        energies, resolved = planar["energy"].values, planar["stability_resolved"].values == 1
        before, after = resolved & (energies < 0.9 * energy), resolved & (energies > 1.1 * energy)
        assert before.sum() >= 3 and after.sum() >= 3
        assert np.all(planar["stable"].values[before] == 1) and np.all(planar["stable"].values[after] == 0)
        spec = BifurcationSpec("whirl", "nnm1", 0, (0.0, 8.0), 1e-3, crossing="whirl")
        switched = bifurcated_branch(system, settings(), spec, planar.assign_attrs(branch="nnm1"))
        assert switched.attrs["resonance"] == 0 and "subharmonic_share" not in switched
        high = switched["energy"].values > energy_probe
        assert np.abs(switched["swept_area"].values[high]).min() > 0.99
        for sense in (1, -1):  # each side of the branch point whirls one way round, up in energy
            side = sense * switched["swept_area"].values > 0
            e, f = switched["energy"].values[side], switched["frequency"].values[side]
            order = np.argsort(e)
            probe = float(CubicSpline(np.log(e[order]), f[order])(np.log(energy_probe)))
            gaps.append(abs(probe - reference) / reference)
    assert max(gaps) < 2e-3 and all(1.7 < a / b < 2.4 for a, b in zip(gaps[:2], gaps[2:]))


@pytest.mark.parametrize("angle", [0.0, 0.3, np.pi / 4, 2.0])
def test_identity_counts_a_mode_and_its_turned_copy_as_one(angle):
    """In a hole every diameter is alike: planar motion along any of them, and a whirl, are NNM1 with all of the
    motion in it (a mode and its copy turned by 90 degrees share a frequency; which basis of the pair the
    eigensolver returns is round-off, the pair's share is not)."""
    from nnmstop.hbm.identity import orbit_identity

    q_cos, q_sin = np.zeros((2, 2, 3)), np.zeros((2, 2, 3))
    q_cos[0, :, 1] = 0.8 * np.array([np.cos(angle), np.sin(angle)])  # planar, along the diameter at angle
    q_cos[1, :, 1] = [0.8, 0.0]  # a whirl: x = R cos, y = R sin
    q_sin[1, :, 1] = [0.0, 0.8]
    f_cos, f_sin = ETA * q_cos[:, :1], ETA * q_sin[:, :1]
    f2_cos, f2_sin = ETA * q_cos[:, 1:], ETA * q_sin[:, 1:]
    found = orbit_identity(isotropic(), q_cos, q_sin, f_cos, f_sin, f2_cos, f2_sin)
    assert list(found["dominant_mode"]) == [1, 1]
    np.testing.assert_allclose(found["dominant_mode_share"], 1.0, rtol=1e-12)
