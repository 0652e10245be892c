"""Harmonic balance formulation: derivatives, products, linear limit and time-domain checks.

The HBM system is checked against quantities computed independently of it: finite
differences, trigonometric identities, the linear modes of :mod:`nnmstop.models.two_dof`, and a
time integration (and shooting) of the regularized equations (7) with the contact
force of :func:`nnmstop.models.two_dof.regularized_contact_force`.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nnmstop.continuation.anm import ANMSettings, anm_series, continue_anm
from nnmstop.continuation.core import ContinuationStats, newton_correct, relative_residual
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters, linear_modes, regularized_contact_force

PARAMS = ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
BASES = ("cosine", "full")


# --------------------------------------------------------------------------- helpers


def amplitude_direction(system):
    """Unit vector on ``x_c^1``: the bordering row that fixes the amplitude."""
    e = np.zeros(system.n_unknowns)
    e[system.slices["x"].start + 1] = 1.0
    return e


def start_point(system, mode, amplitude):
    """Linear mode ``mode`` at ``x_c^1 = amplitude``, corrected onto the branch."""
    e = amplitude_direction(system)
    U, _ = newton_correct(system, system.linear_mode_guess(mode, amplitude), e, ContinuationStats(), 1e-13)
    return U, e


def generic_point(system, seed):
    """A point away from the branch with every coefficient non-zero (impacts included).

    Starts from linear mode 2 with ``x`` beyond the stops and adds a random
    perturbation decaying with the harmonic rank, so that every term of ``S`` (and, in
    the full basis, the sine parts and ``nu``) is exercised.
    """
    rng = np.random.default_rng(seed)
    U = system.linear_mode_guess(2, 1.5)
    rank = np.concatenate([[0.0], system.k, system.k])[: system.nc]
    decay = np.tile(1.0 / (1.0 + rank) ** 2, 4)
    U[: 4 * system.nc] += 0.3 * decay * rng.standard_normal(4 * system.nc)
    U[system.i_lam] *= 1.3
    if system.full:
        U[system.i_nu] = 0.07
    return U


def continue_to(system, U0, e, stop, **settings):
    return continue_anm(system, U0, e, stop, ANMSettings(**settings), progress_seconds=1e9)


def scale_of(v):
    return max(float(np.max(np.abs(v))), 1.0)


# --------------------------------------------------------------------------- derivatives


@pytest.mark.parametrize("basis", BASES)
def test_jacobian_matches_central_differences(basis):
    # S is quadratic in U, so central differences are exact up to round-off whatever
    # the increment: the comparison can be tight.
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 10, basis=basis)
    U = generic_point(system, seed=1)
    J = system.jacobian(U)
    assert J.shape == (system.n_equations, system.n_unknowns)
    h = 1e-3
    J_fd = np.empty_like(J)
    for j in range(system.n_unknowns):
        dU = np.zeros(system.n_unknowns)
        dU[j] = h
        J_fd[:, j] = (system.residual(U + dU) - system.residual(U - dU)) / (2 * h)
    assert np.max(np.abs(J - J_fd)) <= 1e-10 * np.max(np.abs(J))


@pytest.mark.parametrize("basis", BASES)
def test_series_products_is_the_quadratic_part(basis):
    # S(U + aV) = S(U) + a J(U) V + a^2 Q(V, V) exactly, with Q(V, V) the order-2
    # right-hand side of the ANM (series [U, V]).
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 12, basis=basis)
    U = generic_point(system, seed=2)
    V = generic_point(system, seed=3) - system.linear_mode_guess(2, 1.5)
    V[system.i_lam] = 0.4
    if system.full:
        V[system.i_nu] = -0.05
    q = system.series_products([U, V], 2)
    assert np.max(np.abs(q)) > 1e-3  # a non-trivial check
    J = system.jacobian(U)
    for a in (0.3, -1.7):
        lhs = system.residual(U + a * V) - system.residual(U) - a * (J @ V)
        assert np.max(np.abs(lhs - a * a * q)) <= 1e-11 * scale_of(lhs)


@pytest.mark.parametrize("basis", BASES)
def test_series_products_order_three_is_symmetric_sum(basis):
    # Order 3: Q(U1, U2) + Q(U2, U1) = Q(U1 + U2, U1 + U2) - Q(U1, U1) - Q(U2, U2).
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 8, basis=basis)
    U0 = generic_point(system, seed=4)
    U1 = generic_point(system, seed=5) - U0
    U2 = generic_point(system, seed=6) - U0

    def q(v):
        return system.series_products([U0, v], 2)

    expected = q(U1 + U2) - q(U1) - q(U2)
    got = system.series_products([U0, U1, U2], 3)
    assert np.max(np.abs(got - expected)) <= 1e-11 * scale_of(expected)


@pytest.mark.parametrize("basis", BASES)
def test_anm_series_solves_the_order_equations(basis):
    # Reference series built without series_products or the preallocated cache: the
    # quadratic part from residuals alone, Q(V, W) = (S(V + W) - S(V) - S(W) + S(0)) / 2
    # (exact for a quadratic S; on unit vectors, scaled back, to keep round-off relative),
    # and a dense solve of the bordered system at every order.
    order = 12
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 12, basis=basis)
    U0 = generic_point(system, seed=7)
    n = system.n_unknowns
    t = np.random.default_rng(8).standard_normal(n)
    t /= np.linalg.norm(t)
    S0 = system.residual(np.zeros(n))

    def q(v, w):
        nv, nw = np.linalg.norm(v), np.linalg.norm(w)
        v, w = v / nv, w / nw
        return nv * nw * 0.5 * (system.residual(v + w) - system.residual(v) - system.residual(w) + S0)

    A = np.vstack([system.jacobian(U0), t])
    reference = [U0, np.linalg.solve(A, np.eye(n)[-1])]
    for p in range(2, order + 1):
        rhs = -sum(q(reference[r], reference[p - r]) for r in range(1, p))
        reference.append(np.linalg.solve(A, np.concatenate([rhs, [0.0]])))
    series = anm_series(system, U0, t, order, ContinuationStats())
    assert series.shape == (order + 1, n)
    for p in range(order + 1):
        assert np.linalg.norm(series[p] - reference[p]) <= 1e-10 * np.linalg.norm(reference[p]), p
    # the cache only saves transforms: every order's right-hand side is the uncached one
    cache = system.series_cache(order)
    for p in range(2, order + 1):
        cached = system.series_products(series, p, cache)
        assert np.array_equal(cached, system.series_products(list(series[:p]), p)), p


# --------------------------------------------------------------------------- products


def trigonometric_product(system, a, b):
    """Projection of the product of two series on the first H harmonics, by identities.

    ``cos j cos k = (cos(j-k) + cos(j+k))/2``, ``sin j sin k = (cos(j-k) - cos(j+k))/2``,
    ``sin j cos k = (sin(j+k) + sin(j-k))/2``; terms above ``H`` are dropped. No FFT.
    """
    H = system.H
    a, b = system.to_full(a), system.to_full(b)
    ac, as_ = np.concatenate([[a[0]], a[1 : H + 1]]), np.concatenate([[0.0], a[H + 1 :]])
    bc, bs = np.concatenate([[b[0]], b[1 : H + 1]]), np.concatenate([[0.0], b[H + 1 :]])
    cos_out = np.zeros(2 * H + 1)  # index = harmonic, 0..2H
    sin_out = np.zeros(2 * H + 1)
    for j in range(H + 1):
        for k in range(H + 1):
            d, s = abs(j - k), j + k
            sign = 1.0 if j >= k else -1.0  # sin(j-k) = sign * sin|j-k|
            cos_out[d] += 0.5 * (ac[j] * bc[k] + as_[j] * bs[k])
            cos_out[s] += 0.5 * (ac[j] * bc[k] - as_[j] * bs[k])
            sin_out[s] += 0.5 * (as_[j] * bc[k] + ac[j] * bs[k])
            sin_out[d] += 0.5 * sign * (as_[j] * bc[k] - ac[j] * bs[k])
    # cos_out[0] is the mean: j = k = 0 adds (1 + 1)/2 = 1 times a_0 b_0, and
    # cos^2 = (1 + cos 2)/2 adds the halves of the harmonics.
    return np.concatenate([[cos_out[0]], cos_out[1 : H + 1], sin_out[1 : H + 1]])


@pytest.mark.parametrize("basis", BASES)
@pytest.mark.parametrize("time_samples", [0, 31])
def test_products_are_alias_free(basis, time_samples):
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 10, time_samples=time_samples, basis=basis)
    rng = np.random.default_rng(7)
    a = rng.standard_normal(system.nc)
    b = rng.standard_normal(system.nc)
    by_fft = system.to_coefficients(system.to_time(a) * system.to_time(b))
    # Two references without FFT: the trigonometric identities, and the discrete
    # convolution of the complex-exponential coefficients; both truncated at H.
    direct = trigonometric_product(system, a, b)
    H = system.H
    A = np.zeros(2 * H + 1, complex)  # e^{i n theta}, n = -H..H
    B = np.zeros(2 * H + 1, complex)
    for c, C in ((system.to_full(a), A), (system.to_full(b), B)):
        C[H] = c[0]
        C[H + 1 :] = 0.5 * (c[1 : H + 1] - 1j * c[H + 1 :])
        C[:H] = np.conj(C[H + 1 :][::-1])
    conv = np.convolve(A, B)[H : 3 * H + 1]  # n = -H..H of the product
    from_exponentials = np.concatenate([[conv[H].real], 2 * conv[H + 1 :].real, -2 * conv[H + 1 :].imag])
    assert np.max(np.abs(direct - from_exponentials)) < 1e-12 * scale_of(direct)
    assert np.max(np.abs(by_fft - direct[: system.nc])) < 1e-12 * scale_of(direct)
    # The multiplication matrix used by the Jacobian is the same projected product.
    assert np.max(np.abs(system.multiplication_matrix(a) @ b - by_fft)) < 1e-12 * scale_of(by_fft)


def test_too_few_time_samples_are_rejected():
    with pytest.raises(ValueError, match=r"time_samples must be .* >= 3H\+1 = 31 .*got 30"):
        HarmonicBalanceSystem(two_dof_structure(PARAMS), 10, time_samples=30)


# --------------------------------------------------------------------------- linear limit


@pytest.mark.parametrize("mode", [1, 2])
def test_small_amplitude_frequency_is_the_regularized_linear_mode(mode):
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 10)
    f_linear = linear_modes(PARAMS, "regularized")[0][mode - 1] / (2 * np.pi)
    U0, e = start_point(system, mode, 1e-3)
    branch = continue_to(
        system, U0, e, lambda U, d: "inside" if np.sum(np.abs(system.split(U)[0])) > 0.2 else "", points_per_step=4
    )
    amplitude = np.array([system.split(U)[0][1] for U in branch.points])
    shift = np.array([system.frequency_hz(U) for U in branch.points]) / f_linear - 1.0
    small = amplitude < 0.05
    assert small.sum() >= 3 and amplitude.min() <= 1.1e-3
    # The frequency leaves the linear value quadratically in the amplitude (the force
    # is odd and smooth): shift / a^2 is constant to O(a^2) at small amplitude ...
    curvature = shift[small] / amplitude[small] ** 2
    assert np.ptp(curvature) <= 0.01 * np.abs(curvature).max()
    # ... and the a -> 0 limit of the continued branch is the linear mode.
    assert abs(shift[np.argmin(amplitude)]) < 1e-7
    i, j = np.argsort(amplitude)[:2]
    limit = (shift[i] * amplitude[j] ** 2 - shift[j] * amplitude[i] ** 2) / (amplitude[j] ** 2 - amplitude[i] ** 2)
    assert abs(limit) < 1e-11


# --------------------------------------------------------------------------- time domain


def _vector_field(t, y):
    """Eq. (7), and for ``len(y) == 20`` its variational equations (row-major 4x4 STM).

    The stiffness ``df/dx`` of the STM comes from the implicit-function theorem on the
    corrected cubic ``P(f, x) = 0`` at the admissible root ``f``: it is only needed for
    the Newton matrix of the shooting, so its conditioning at large ``|x|`` is harmless.
    """
    p = PARAMS
    x, u, xd, ud = y[:4]
    f = float(regularized_contact_force(x, p))
    out = np.empty_like(y)
    out[:4] = (xd, ud, -x - p.beta * (x - u) - f, -p.beta * (u - x) / p.delta)
    if y.size > 4:
        a = p.alpha
        P_x = -2 * a * f * f + 2 * a * a * x * f + p.eta * a * a
        P_f = 3 * f * f - 4 * a * x * f - a * a * (1 - x * x)
        k = -P_x / P_f
        A = np.array(
            [[0, 0, 1, 0], [0, 0, 0, 1], [-(1 + p.beta + k), p.beta, 0, 0], [p.beta / p.delta, -p.beta / p.delta, 0, 0]]
        )
        out[4:] = (A @ y[4:].reshape(4, 4)).ravel()
    return out


def _flow(y0, period, with_stm=False):
    y = np.concatenate([y0, np.eye(4).ravel()]) if with_stm else np.asarray(y0, float)
    sol = solve_ivp(_vector_field, (0.0, period), y, method="DOP853", rtol=1e-11, atol=1e-12)
    assert sol.success, sol.message
    end = sol.y[:, -1]
    return (end[:4], end[4:].reshape(4, 4)) if with_stm else end


# HBM points with contact on both sides (two impacts per period), H = 60 harmonics.
TIME_DOMAIN_CASES = {"NNM2": (2, 3.0), "NNM1": (1, 4.0)}


@pytest.fixture(scope="module", params=list(TIME_DOMAIN_CASES))
def time_domain(request):
    """One HBM orbit, its return map over one HBM period, and its shooting refinement.

    Shooting: unknowns ``(u(0), u'(0), T)`` with ``x(0)`` fixed at the HBM value (the
    amplitude, which picks the member of the family) and ``x'(0) = 0`` (the phase);
    equations ``phi_T(y0) - y0 = 0`` (4 of them, one redundant by energy
    conservation), solved by Gauss-Newton (least squares) with the monodromy matrix of
    the first iterate (chord iterations after that).
    """
    mode, energy = TIME_DOMAIN_CASES[request.param]
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 60)
    U0, e = start_point(system, mode, 0.05)
    branch = continue_to(system, U0, e, lambda U, d: "reached" if d["energy"] > energy else "")
    U = branch.points[-1]
    diag = system.diagnostics(U)
    history = system.time_history(U, 1024)
    states = np.concatenate([history["q"], history["qdot"]])  # x, u, xdot, udot
    y0 = states[:, 0]
    scale = np.max(np.abs(states), axis=1)
    T_hbm = 1.0 / diag["frequency"]

    yT, stm = _flow(y0, T_hbm, with_stm=True)
    return_error = float(np.max(np.abs(yT - y0) / scale))

    z = np.array([y0[1], y0[3], T_hbm])
    y, end = y0.copy(), yT
    jac = np.column_stack([(stm - np.eye(4))[:, 1], (stm - np.eye(4))[:, 3], _vector_field(0.0, yT)])
    for _ in range(6):
        F = end - y
        if np.max(np.abs(F) / scale) < 1e-10:
            break
        z += np.linalg.lstsq(jac, -F, rcond=None)[0]
        y = np.array([y0[0], z[0], 0.0, z[1]])
        end = _flow(y, z[2])
    return {
        "name": request.param,
        "diag": diag,
        "return_error": return_error,
        "T_hbm": T_hbm,
        "T_shooting": float(z[2]),
        "shooting_residual": float(np.max(np.abs(end - y) / scale)),
        "shooting_state": y,
        "hbm_state": y0,
        "scale": scale,
    }


def test_hbm_orbit_is_periodic_for_the_time_integrator(time_domain):
    diag = time_domain["diag"]
    # The orbit really engages both stops and the HBM is converged there.
    assert diag["impacts_per_period"] >= 2
    assert diag["truncation"] < 1e-5 and diag["time_residual"] < 1e-2
    # The HBM orbit satisfies Eq. (7) up to a defect r(t) of relative size
    # eps = time_residual (restoring-force units). Started from the HBM state, the
    # exact flow departs from the HBM orbit by the response to that forcing over one
    # period; with the neutral (unit-modulus) Floquet multipliers of a conservative
    # orbit this grows like omega * T * eps = 2 pi eps relative to the amplitude
    # (measured: 1e-3 of it for NNM2, 2e-2 for NNM1, the NNM1 orbit being the less
    # resolved). The integrator error (rtol 1e-11) is negligible against it.
    assert time_domain["return_error"] <= 2 * np.pi * diag["time_residual"]


def test_shooting_period_matches_hbm_period(time_domain):
    diag = time_domain["diag"]
    assert time_domain["shooting_residual"] < 1e-9
    # The shooting orbit has the same amplitude, phase and (to the HBM error) shape.
    state_gap = np.max(np.abs(time_domain["shooting_state"] - time_domain["hbm_state"]) / time_domain["scale"])
    assert state_gap <= 2 * np.pi * diag["time_residual"]
    # The period is much more accurate than the orbit: the HBM is a Galerkin method on
    # a conservative system, whose frequency error is of second order in the orbit
    # error (measured |dT|/T: 8e-9 for NNM2 with time_residual 2e-5, 1e-5 for NNM1
    # with time_residual 3e-3). A tenth of the first-order indicator, and 5e-5 at
    # most, is thus a tight bound that still leaves a margin of 10 or more.
    rel = abs(time_domain["T_shooting"] - time_domain["T_hbm"]) / time_domain["T_hbm"]
    assert rel <= 0.1 * diag["time_residual"]
    assert rel <= 5e-5


# --------------------------------------------------------------------------- bases


@pytest.fixture(scope="module")
def both_bases():
    """NNM2 at H = 15 continued in both bases by the ANM, up to two impacts per period."""
    out = {}
    for basis in BASES:
        system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 15, basis=basis)
        U0, e = start_point(system, 2, 0.05)
        branch = continue_to(system, U0, e, lambda U, d: "reached" if d["energy"] > 20.0 else "")
        out[basis] = (system, branch)
    return out


@pytest.mark.numerics
def test_unfolding_parameter_stays_at_round_off(both_bases):
    system, branch = both_bases["full"]
    P = np.array(branch.points)
    x, u, f, z, lam, nu = system.split(P)
    assert system.diagnostics(P[-1])["impacts_per_period"] >= 2
    # nu = 0 on every periodic orbit of a conservative system (energy balance); along
    # the continued branch it stays at round-off, not at the continuation tolerance.
    assert np.max(np.abs(nu)) <= 1e-12 * np.max(np.sqrt(lam))
    # The phase condition x'(0) = 0 keeps the orbits time-reversible: no sine parts.
    H = system.H
    for field in (x, u, f, z):
        assert np.max(np.abs(field[:, H + 1 :])) <= 1e-12 * np.max(np.abs(field))


@pytest.mark.numerics
def test_cosine_and_full_bases_give_the_same_orbit(both_bases):
    cos_system, cos_branch = both_bases["cosine"]
    full_system, full_branch = both_bases["full"]
    # Same orbit: at a common amplitude x_c^1, correct the cosine point in the full
    # basis and compare every coefficient and the frequency.
    U_c = cos_branch.points[len(cos_branch.points) // 2 + 3]
    U_c, _ = newton_correct(cos_system, U_c, amplitude_direction(cos_system), ContinuationStats(), 1e-13)
    x, u, f, z, lam, _ = cos_system.split(U_c)
    U_guess = full_system.pack(*(cos_system.to_full(v) for v in (x, u, f, z)), lam, 0.0)
    rng = np.random.default_rng(8)
    U_guess[: 4 * full_system.nc] += 1e-4 * rng.standard_normal(4 * full_system.nc)  # off the orbit
    U_guess[full_system.slices["x"].start + 1] = x[1]
    U_f, _ = newton_correct(full_system, U_guess, amplitude_direction(full_system), ContinuationStats(), 1e-13)
    assert relative_residual(full_system, U_f) < 1e-12
    xf, uf, ff, zf, lamf, nuf = full_system.split(U_f)
    for kept, full in ((x, xf), (u, uf), (f, ff), (z, zf)):
        assert np.max(np.abs(cos_system.to_full(kept) - full)) <= 1e-11 * scale_of(kept)
    assert abs(lamf - lam) <= 1e-10 * lam and abs(nuf) <= 1e-12
    # And every point of the full-basis continuation lies on the cosine branch: the
    # cosine system solved by Newton at the point's own amplitude x_c^1 (a fixed
    # parameter, so no interpolation between stored points across the contact onset)
    # has the point's frequency. A stored point's relative residual is below the
    # Newton threshold (1e-7), so its frequency is that accurate, not better.
    H = full_system.H
    newton_threshold = ANMSettings().newton_threshold
    for U in full_branch.points[1:-1]:
        xf, uf, ff, zf, lamf, _ = full_system.split(U)
        guess = cos_system.pack(*(v[: H + 1] for v in (xf, uf, ff, zf)), lamf)
        U_on_cosine, _ = newton_correct(cos_system, guess, amplitude_direction(cos_system), ContinuationStats(), 1e-13)
        assert abs(cos_system.split(U_on_cosine)[0][1] - xf[1]) <= 1e-14 * abs(xf[1])  # same amplitude
        f_cosine = cos_system.frequency_hz(U_on_cosine)
        assert abs(full_system.frequency_hz(U) - f_cosine) <= newton_threshold * f_cosine
        # the full-basis point corrected at the same amplitude is the cosine orbit to round-off
        U_full, _ = newton_correct(full_system, U, amplitude_direction(full_system), ContinuationStats(), 1e-13)
        assert abs(full_system.frequency_hz(U_full) - f_cosine) <= 1e-12 * f_cosine


def test_an_overflowing_trial_point_gives_a_non_finite_residual_without_warnings():
    """A diverging step's trial point overflows in the products: the residual is non-finite (which Newton and
    the ANM take as a failed correction) and no RuntimeWarning reaches the terminal; a point on the branch is
    untouched."""
    import warnings

    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), 5)
    U, _ = start_point(system, 1, 0.5)
    far = U * 1e160
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not np.all(np.isfinite(system.residual(far)))
        assert not np.isfinite(relative_residual(system, far))
        assert relative_residual(system, U) < 1e-12
