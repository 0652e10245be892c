"""Floquet stability of the regularized NNMs: Hill's method against the monodromy matrix.

Small harmonic counts (H = 24 for the linear limit, H = 40 on the branches) keep the
module under a minute. References are exact periodic orbits of (7) (shooting from the
HBM state, :func:`refine_orbit`) and their monodromy matrices, so the tolerances
below measure the HBM orbit's error at H = 40, not Hill's.
"""

import numpy as np
import pytest

from fixed_energy import orbit_at_energy
from nnmstop.catalogue import kind
from nnmstop.checks.shooting import monodromy, orbit_initial_state, refine_orbit
from nnmstop.compare.matching import regularized_monotone_part
from nnmstop.hbm.dataset import dataset_unknowns
from nnmstop.hbm.hill import floquet, hill_matrix, is_halfwave_symmetric
from nnmstop.hbm.stability import BranchHill, branch_hill
from nnmstop.hbm.stages import start_point
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import two_dof_parameters, two_dof_structure
from nnmstop.models.two_dof import ModelParameters, linear_modes
from nnmstop.tasks.hbm import build_stage


@pytest.fixture(scope="module")
def config(h40_config):
    return h40_config


@pytest.fixture(scope="module")
def system(h40_system):
    return h40_system


@pytest.fixture(scope="module")
def nnm1(h40_nnm1_stages, system):
    """NNM1: stage 1 (0 then 2 impacts per period) and stage 2 (6 impacts, down to the energy fold and back)."""
    first, second = h40_nnm1_stages
    return first, dataset_unknowns(first, system), second, dataset_unknowns(second, system)


@pytest.fixture(scope="module")
def nnm2(config, system):
    ds = build_stage(config, "nnm2", 1)
    return ds, dataset_unknowns(ds, system)


def reference_multipliers(system, U):
    """Non-trivial multiplier pair of the exact orbit of (7) through the HBM orbit's x(0)."""
    state, period = orbit_initial_state(system, U)
    state, period = refine_orbit(two_dof_parameters(system.structure), state, period)
    mono = monodromy(two_dof_parameters(system.structure), state, period)
    mu = mono.multipliers
    nontrivial = mu[np.argsort(np.abs(mu - 1.0))[2:]]
    return nontrivial[np.argsort(-np.abs(nontrivial))], mono


def pair_distance(a, b):
    """Distance between two multiplier pairs as sets (conjugate pairs may come in either order)."""
    a, b = np.asarray(a), np.asarray(b)
    return min(np.max(np.abs(a - b)), np.max(np.abs(a - b[::-1])))


# --------------------------------------------------------------------------- linear limit


@pytest.mark.parametrize("mode", [1, 2])
@pytest.mark.parametrize("method,symmetry", [("reversible", True), ("reversible", False), ("companion", True)])
def test_linear_limit_is_neutral_with_modal_exponents(mode, method, symmetry):
    params = ModelParameters()
    system = HarmonicBalanceSystem(two_dof_structure(params), harmonics=24)
    U, _ = start_point(system, mode, 1e-3)
    r = floquet(system, U, method=method, symmetry=symmetry)
    omega_modes = linear_modes(params, "regularized")[0]
    omega = np.sqrt(system.split(U)[4])
    assert omega == pytest.approx(omega_modes[mode - 1], rel=1e-6)
    # Neutral: every multiplier on the unit circle to round-off (the trivial pair of the
    # raw companion problem is split only by the orbit's residual, ~1e-13 here).
    assert np.allclose(np.abs(r.multipliers), 1.0, rtol=0, atol=1e-9)
    assert np.allclose(r.multipliers[:2], 1.0, rtol=0, atol=1e-5)
    assert r.stable and r.resolved
    # Non-trivial exponents: +-i omega_other, centred (eigenvector on harmonic 0),
    # hence equal to the modal frequency itself, not just modulo omega.
    other = omega_modes[2 - mode]
    s = r.exponents[2:]
    assert np.allclose(s.real, 0.0, atol=1e-9)
    assert sorted(s.imag) == pytest.approx([-other, other], rel=1e-6)
    shift = (s.imag[0] - other) / omega
    assert min(abs(shift), abs((s.imag[0] + other) / omega)) == pytest.approx(0.0, abs=1e-6)
    assert np.allclose(r.centroids[2:], 0.0, atol=1e-6)
    assert r.tail_fraction < 1e-20


def test_hill_matrix_matches_linear_theory_at_rest():
    """At vanishing amplitude the Hill spectrum is {+-i omega_k + i m omega} exactly."""
    params = ModelParameters()
    system = HarmonicBalanceSystem(two_dof_structure(params), harmonics=6)
    U, _ = start_point(system, 1, 1e-6)
    A, omega = hill_matrix(system, U)
    assert A.shape == (4 * 13, 4 * 13)
    sigma = np.linalg.eigvals(A)
    omega_modes = linear_modes(params, "regularized")[0]
    m = np.arange(-6, 7)
    expected = np.concatenate([1j * (sign * w / omega + m) for w in omega_modes for sign in (1, -1)])
    assert np.sort_complex(np.round(sigma, 6)) == pytest.approx(np.sort_complex(np.round(expected, 6)), abs=2e-6)


# --------------------------------------------------------------------------- against the monodromy matrix


@pytest.mark.numerics
def test_nnm2_with_impacts_matches_monodromy_and_is_stable(system, nnm2):
    ds, U = nnm2
    impacts = ds["impacts_per_period"].values
    energy = ds["energy"].values
    assert impacts.max() == 2 and energy[-1] > 20.0
    picks = [int(np.argmax(impacts > 0)), int(np.argmin(np.abs(energy - 5.0))), len(U) - 1]
    for i in picks:
        r = floquet(system, U[i])
        ref, mono = reference_multipliers(system, U[i])
        assert r.method == "reversible" and r.halfwave
        assert r.stable and r.resolved
        assert np.allclose(np.abs(ref), 1.0, atol=1e-8)  # elliptic for the exact orbit too
        assert pair_distance(r.multipliers[2:], ref) < 1e-4, (i, r.multipliers, ref)
    # The whole stretch is stable (NNM2 is stable over its whole range at H = 100 too).
    b = branch_hill(system, U)
    assert b.stable.all()


@pytest.mark.numerics
def test_nnm1_one_impact_per_stop_matches_monodromy(system, nnm1):
    first, U, _, _ = nnm1
    # Two impacts per period, energies 1 to 20: orbit error below 3e-2 at H = 40. The
    # orbits are solved at fixed energies (the stored points only seed Newton).
    part = regularized_monotone_part(first)
    for energy in (1.5, 4.0, 12.0):
        Ui = orbit_at_energy(system, U[part], first["energy"].values[part], energy)
        assert system.diagnostics(Ui)["impacts_per_period"] == 2
        r = floquet(system, Ui)
        ref, _ = reference_multipliers(system, Ui)
        assert r.stable and r.resolved
        assert pair_distance(r.multipliers[2:], ref) < 2e-3, (energy, r.multipliers, ref)


def six_impact_arms(second, U):
    """Stage 2 split at the energy fold its energy falls to (the tip of the 3:1 tongue, the lowest located
    fold): the arm falling to it and the arm rising from it.

    Returns the fold energy and, per arm, the stored points and energies (seeds for
    :func:`orbit_at_energy`) up to the next change of direction of the energy. The stage ends at its first
    stored orbit with four impacts, just past the next fold (an energy maximum near 16.6): whether that fold
    is located too depends on where the steps stored their points, so it is not counted on.
    """
    assert second["fold_energy"].size >= 1
    lowest = int(np.argmin(second["fold_energy"].values))
    fold_energy = float(second["fold_energy"].values[lowest])
    k = int(second["fold_point"].values[lowest])  # the stored point nearest to the fold
    energy = second["energy"].values
    rising = k + 1
    while rising < energy.size and energy[rising] > energy[rising - 1]:
        rising += 1
    return fold_energy, (U[: k + 1], energy[: k + 1]), (U[k:rising], energy[k:rising])


@pytest.mark.numerics
def test_nnm1_three_impacts_per_stop_is_unstable_and_matches_monodromy(system, nnm1):
    _, _, second, U = nnm1
    fold_energy, falling, _ = six_impact_arms(second, U)
    # Unstable stretch right after the first orbits with six impacts (energy 20 to 40;
    # the stage starts at the first stored orbit with more than two impacts, wherever a
    # step of stage 1 landed past the onset: near E = 42 to 47).
    assert fold_energy < 20.0
    for energy in (22.0, 30.0, 38.0):
        Ui = orbit_at_energy(system, *falling, energy)
        assert system.diagnostics(Ui)["impacts_per_period"] == 6
        r = floquet(system, Ui)
        ref, mono = reference_multipliers(system, Ui)
        assert not r.stable and r.resolved
        assert r.multipliers[2].imag == 0.0 and r.multipliers[2].real > 1.0  # real pair (saddle type)
        assert r.max_multiplier == pytest.approx(abs(ref[0]), rel=0.05)
        assert abs(ref[0]) > 1.3 and mono.closure < 1e-8
        # Both solvers and both symmetries agree on the raw Hill problem.
        rc = floquet(system, Ui, method="companion")
        rf = floquet(system, Ui, symmetry=False)
        assert rc.max_multiplier == pytest.approx(r.max_multiplier, rel=0.05)
        assert rf.max_multiplier == pytest.approx(r.max_multiplier, rel=1e-3)


@pytest.mark.numerics
def test_nnm1_stability_changes_at_the_energy_fold(system, nnm1):
    """Along the six-impact stretch the energy falls to a minimum and grows again; the
    non-trivial pair goes through +1 there: unstable before, stable after (up to the
    next energy fold, where it may change again).

    Orbits at fixed multiples of the located fold energy, so that nothing depends on
    where the continuation stored its points. At H = 40 the HBM orbits turn stable a
    little after the fold (near 1.4 times its energy; the exact orbits right after it),
    so the stable side is checked from 1.6 times the fold energy.
    """
    _, _, second, U = nnm1
    fold_energy, falling, rising = six_impact_arms(second, U)
    before = np.array([orbit_at_energy(system, *falling, f * fold_energy) for f in (1.2, 1.5, 2.0, 3.0, 5.0)])
    after = np.array([orbit_at_energy(system, *rising, f * fold_energy) for f in (1.2, 1.6, 2.0)])
    b, a = branch_hill(system, before), branch_hill(system, after)
    assert not b.stable.any()
    assert a.stable[1:].all()
    # the pair is close to +1 near the fold (orbits at 1.2 times its energy)
    assert b.margin[0] < 0.1 and a.margin[0] < 0.1
    assert b.margin[0] < b.margin[-1] and a.margin[0] < a.margin[-1]
    # The exact orbits agree on both sides.
    for Ui, unstable in ((before[1], True), (after[-1], False)):
        ref, _ = reference_multipliers(system, Ui)
        assert (np.max(np.abs(ref)) > 1 + 1e-6) == unstable


# --------------------------------------------------------------------------- structure


def test_pair_structure(system, nnm1):
    _, _, second, U = nnm1
    energy = second["energy"].values
    i = int(np.argmin(np.abs(energy - 30.0)))
    rc = floquet(system, U[i], method="companion")
    # Raw Hill problem: reciprocal pair to round-off (Hamiltonian structure kept exactly),
    # double +1 up to the orbit's error (square-root split).
    assert rc.pairing_error < 1e-10
    assert rc.trivial_deviation < 5 * np.sqrt(rc.orbit_residual)
    assert np.allclose(rc.exponents[0], -rc.exponents[1], atol=1e-8) or np.allclose(
        rc.exponents[0], np.conj(rc.exponents[1]), atol=1e-8
    )
    # Reversible solver: exact pair structure by construction.
    r = floquet(system, U[i])
    assert np.array_equal(r.multipliers[:2], [1.0, 1.0])
    assert r.multipliers[2] * r.multipliers[3] == pytest.approx(1.0, abs=1e-12)
    assert r.exponents[3] == -r.exponents[2]
    # Monodromy of the exact orbit: symplectic, so det = 1, two multipliers at 1 and a reciprocal pair.
    ref, mono = reference_multipliers(system, U[i])
    assert np.linalg.det(mono.matrix) == pytest.approx(1.0, abs=1e-8)
    mu = mono.multipliers
    assert np.sort(np.abs(mu - 1.0))[:2] == pytest.approx([0.0, 0.0], abs=1e-4)
    assert ref[0] * ref[1] == pytest.approx(1.0, abs=1e-8)


def test_elliptic_pairs_are_exactly_on_the_unit_circle(system, nnm2):
    _, U = nnm2
    for Ui in U[::4]:
        r = floquet(system, Ui)
        assert np.abs(r.multipliers[2:]) == pytest.approx([1.0, 1.0], abs=1e-14)
        assert r.exponents[2].real == 0.0


def test_perturbation_harmonics_converge(system, nnm1):
    """Fewer or more harmonics on the perturbation than on the orbit: same multipliers."""
    first, U, _, _ = nnm1
    i = int(np.argmin(np.abs(first["energy"].values - 5.0)))
    base = floquet(system, U[i])
    more = floquet(system, U[i], harmonics=2 * system.H)
    fewer = floquet(system, U[i], harmonics=3 * system.H // 4)
    assert pair_distance(more.multipliers[2:], base.multipliers[2:]) < 1e-4
    assert pair_distance(fewer.multipliers[2:], base.multipliers[2:]) < 1e-3
    assert more.harmonics == 2 * system.H and fewer.harmonics == 30


def test_recast_linearization_agrees_at_low_energy(system, nnm1):
    first, U, _, _ = nnm1
    i = int(np.argmax(first["impacts_per_period"].values > 0)) - 1  # last orbit without impacts
    a = floquet(system, U[i])
    b = floquet(system, U[i], linearization="recast")
    assert pair_distance(a.multipliers[2:], b.multipliers[2:]) < 1e-6


def test_full_basis_orbit_uses_the_companion_solver():
    params = ModelParameters()
    cos_system = HarmonicBalanceSystem(two_dof_structure(params), harmonics=12)
    full_system = HarmonicBalanceSystem(two_dof_structure(params), harmonics=12, basis="full")
    U, _ = start_point(cos_system, 2, 0.5)
    x, u, f, z, lam, _ = cos_system.split(U)
    Uf = full_system.pack(*(cos_system.to_full(c) for c in (x, u, f, z)), lam, 0.0)
    r_cos = floquet(cos_system, U)
    r_full = floquet(full_system, Uf)  # still time-reversible: reversible solver
    assert r_full.method == "reversible"
    assert pair_distance(r_full.multipliers[2:], r_cos.multipliers[2:]) < 1e-12
    # Phase-shifted orbit: sine content, not reversible about t = 0.
    theta0 = 0.3
    k = np.arange(1, 13)

    def shift(c):
        c = c.copy()
        cc, ss = c[1:13].copy(), c[13:].copy()
        c[1:13] = cc * np.cos(k * theta0) - ss * np.sin(k * theta0)
        c[13:] = cc * np.sin(k * theta0) + ss * np.cos(k * theta0)
        return c

    xs, us, fs, zs = (shift(cos_system.to_full(c)) for c in (x, u, f, z))
    shifted = full_system.pack(xs, us, fs, zs, lam, 0.0)
    r_shift = floquet(full_system, shifted)
    assert r_shift.method == "companion"
    assert pair_distance(r_shift.multipliers[2:], r_cos.multipliers[2:]) < 1e-8
    with pytest.raises(ValueError, match="time-reversible"):
        floquet(full_system, shifted, method="reversible")


# --------------------------------------------------------------------------- branch API


def test_branch_hill_layout(system, nnm1):
    first, U, _, _ = nnm1
    b = branch_hill(system, U[:5])
    assert isinstance(b, BranchHill)
    assert b.stable.shape == (5,) and b.stable.dtype == bool
    assert b.multipliers.shape == (5, 4) and np.iscomplexobj(b.multipliers)
    assert b.seconds_per_point > 0 and b.harmonics == system.H and b.method == "reversible"
    single = floquet(system, U[3])
    assert np.array_equal(b.multipliers[3], single.multipliers)
    data = b.data_vars()
    assert set(data) >= {"stable", "multiplier_real", "multiplier_imag", "max_multiplier"}
    assert data["multiplier_real"][0] == ("point", "multiplier")
    assert data["stable"][1].dtype == np.int8
    catalogue = kind("nnm_branch")  # plain arrays; long names and units from the catalogue
    for name, (dims, values) in data.items():
        assert name in catalogue and catalogue[name].dims == tuple(np.atleast_1d(dims))
        assert np.shape(values)[0] == 5


def test_halfwave_detection(system, nnm1):
    _, U, _, _ = nnm1
    assert is_halfwave_symmetric(system, U[-1])
    V = U[-1].copy()
    V[system.slices["x"].start + 2] += 1e-3  # an even harmonic on x
    assert not is_halfwave_symmetric(system, V)
    # Without the symmetry the full reversible problem gives the same pair.
    r = floquet(system, V)
    assert not r.halfwave


def test_bad_arguments(system, nnm1):
    _, U, _, _ = nnm1
    with pytest.raises(ValueError, match="unknown vector of length"):
        floquet(system, U[0][:-1])
    with pytest.raises(ValueError, match="tol"):
        floquet(system, U[0], tol=-1.0)
    with pytest.raises(ValueError, match="method"):
        floquet(system, U[0], method="qz")
    with pytest.raises(ValueError, match="linearization"):
        floquet(system, U[0], linearization="exact")
    with pytest.raises(ValueError, match="harmonics"):
        floquet(system, U[0], harmonics=0)
    bad = U[0].copy()
    bad[system.i_lam] = -1.0
    with pytest.raises(ValueError, match="omega"):
        floquet(system, bad)
    with pytest.raises(ValueError, match="U_array"):
        branch_hill(system, U[0])
