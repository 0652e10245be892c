"""Exact periodic orbits of the regularized equations (7) near HBM orbits, by shooting, and their monodromy.

Used by :func:`nnmstop.hbm.monodromy.branch_monodromy` where the HBM orbit's own error decides the
verdict (``stability_reason = 2``): the orbit is refined into a periodic orbit of (7) to the
accuracy of the integrator, and the Floquet invariant of the refined orbit resolves the margin test.
All refined orbits are integrated together: one vectorized explicit Runge-Kutta scheme of order 8
on a step grid that concentrates the steps where the contact stiffness changes, over a quarter
period only (the NNMs are time-reversible and half-wave symmetric, so the quarter-period flow gives
both the shooting conditions and the half-period monodromy). Method, conditions, error estimate and
cost: ``docs/methods/monodromy.md``, section "Shooting refinement".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Butcher tableau of the 8th-order Dormand-Prince scheme (Hairer, Norsett & Wanner, Solving ODEs I, II.5).
from scipy.integrate._ivp import dop853_coefficients as _dop853

from nnmstop.checks.shooting import orbit_initial_state
from nnmstop.floquet import transition_matrix
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force, regularized_contact_potential

__all__ = ["RefinedStability", "quarter_period_flow", "step_phases", "shoot", "refined_stability", "shooting_stability"]

_STAGES = _dop853.N_STAGES
_A = np.asarray(_dop853.A[:_STAGES, :_STAGES], dtype=float)
_B = np.asarray(_dop853.B, dtype=float)
# Time reversal (velocities change sign): the NNMs satisfy z(-t) = R z(t).
_REVERSAL = np.diag([1.0, 1.0, -1.0, -1.0])
# Samples of the HBM orbit per quarter period for the step grid (the grid only has to follow the orbit).
_GRID_SAMPLES = 2048
# Step grid density 6 + |dx/dtheta| / (||x| - 1| + 2 w) per radian of phase, w the width of the contact
# transition: the weights that minimized the integration error of s at a given step count over a sample
# of the refined NNM1 and 5:1 orbits (errors 100 to 1000 times smaller than with 1 and w; method notes).
_UNIFORM_DENSITY = 6.0
_WIDTH_FACTOR = 2.0
# Steps per chunk of the vectorized step maps (12 stages x 16 entries x 8 bytes each: 12 MB).
_CHUNK_STEPS = 2**13


class _StateRhs:
    """Right-hand side of (7) for ``n`` orbits: ``rhs(w, out)``, ``w``, ``out``: (4, n).

    Row 0 is the branch coordinate ``y = x - f/alpha`` instead of ``x``: ``x``, ``f`` and
    ``f'(x)`` are rational in ``y`` (``nnmstop.models.two_dof``; the same force as the root of the
    cubic), so no cubic is solved per evaluation. The linear part is one matrix product with
    ``w``, corrected by ``x - y = f/alpha`` where it acts on ``x``; ``dy/dt`` is set apart.
    Evaluated 12 times a step, one step at a time: its cost is numpy's per-call overhead, hence
    few calls.
    """

    def __init__(self, params: ModelParameters):
        b, d = params.beta, params.delta
        self.c = 1.0 - params.eps
        self.eps = params.eps
        # d(x, u, xdot, udot)/dt without the contact force, rows 1-3 (row 0 is set apart).
        self.linear = np.array(
            [[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], [-(1.0 + b), b, 0.0, 0.0], [b / d, -b / d, 0.0, 0.0]]
        )
        # Rows xdot, udot: coefficients of x (linear part) and of -f = -alpha (x - y) on x - y.
        self.on_x_minus_y = np.array([-(1.0 + b) - params.alpha, b / d])[:, None]

    def __call__(self, w, out):
        y = w[0]
        y2 = y * y
        # c - y**2 >= eps y / (|x| - y): relative rounding error about 1e-16 |x| / eps, below 1e-11 here
        s = self.c - y2
        g = self.eps / s
        np.dot(self.linear, w, out=out)
        out[2:] += self.on_x_minus_y * (g * y)  # x - y = g y
        np.divide(w[2], 1.0 + g * (self.c + y2) / s, out=out[0])  # dx/dt = xdot and dx/dy
        return out


def _variational_rhs(Z, y, params: ModelParameters, out):
    """``A(y) Z`` for many 4x4 matrices ``Z`` (rows of ``Z``, ``out``: the 16 entries, row-major).

    ``A(y)`` is the linearization of (7) at the branch coordinate ``y``:
    ``-(1 + beta + f'(x)) Z_x + beta Z_u`` in the ``xdot`` row, ``f'`` rational in ``y``.
    """
    b, d, eta, eps = params.beta, params.delta, params.eta, params.eps
    c = 1.0 - eps
    y2 = y * y
    s = c - y2
    q = c + y2
    out[0:8] = Z[8:16]  # d(rows x, u)/dt = rows xdot, udot
    diff = (b / d) * (Z[0:4] - Z[4:8])
    out[8:12] = -(1.0 + eta * q / (s * s + eps * q)) * Z[0:4] - d * diff  # -(1 + f'(x)) Z_x - beta (Z_x - Z_u)
    out[12:16] = diff
    return out


def _step_maps(params: ModelParameters, stage_y, steps):
    """Runge-Kutta step maps ``Phi_{j+1} = R_j Phi_j`` of the variational equation, all steps at once.

    The variational equation is linear and its coefficient depends only on the state, so the
    scheme applied to ``Phi`` with the stage states of the state integration (``stage_y``) is the
    linear map ``R_j = I + h_j sum_i b_i M_i``, ``M_i = A(y_i) (I + h_j sum_{l<i} a_il M_l)``:
    the same scheme as on the augmented system, vectorized over the steps instead of looping.

    Parameters
    ----------
    stage_y : ndarray, shape (stages, m)
        Branch coordinate at the stages of ``m`` steps (flattened over orbits and steps).
    steps : ndarray, shape (m,)

    Returns
    -------
    ndarray, shape (m, 4, 4)
    """
    m = steps.shape[0]
    maps = np.empty((m, 4, 4))
    identity = np.eye(4).reshape(16, 1)
    for lo in range(0, m, _CHUNK_STEPS):
        sl = slice(lo, min(lo + _CHUNK_STEPS, m))
        h = steps[sl]
        k = h.shape[0]
        M = np.empty((_STAGES, 16, k))
        flat = M.reshape(_STAGES, 16 * k)
        _variational_rhs(np.broadcast_to(identity, (16, k)), stage_y[0, sl], params, M[0])
        for i in range(1, _STAGES):
            _variational_rhs(identity + h * (_A[i, :i] @ flat[:i]).reshape(16, k), stage_y[i, sl], params, M[i])
        maps[sl] = (identity + h * (_B @ flat).reshape(16, k)).T.reshape(k, 4, 4)
    return maps


def quarter_period_flow(params: ModelParameters, start, period, phases):
    """State and fundamental matrix of (7) a quarter period after a start at rest, many orbits at once.

    The state is integrated step by step, all orbits as columns of one array; the fundamental
    matrix by the same scheme afterwards, as the ordered product of the step maps
    (:func:`_step_maps`), vectorized over the steps.

    Parameters
    ----------
    params : ModelParameters
    start : ndarray, shape (n, 2)
        ``(x, u)`` at ``t = 0``; the velocities are zero.
    period : ndarray, shape (n,)
    phases : ndarray, shape (n, N + 1)
        Step grid in the phase ``2 pi t / T``, from 0 to ``pi/2`` (:func:`step_phases`).

    Returns
    -------
    state : ndarray, shape (n, 4)
        ``(x, u, xdot, udot)`` at ``t = T/4``.
    Q : ndarray, shape (n, 4, 4)
        Fundamental matrix ``Phi(T/4)``, ``Phi(0) = I``.
    """
    start = np.asarray(start, dtype=float)
    n = len(start)
    w = np.zeros((4, n))
    w[0] = start[:, 0] - regularized_contact_force(start[:, 0], params) / params.alpha
    w[1] = start[:, 1]
    steps = np.diff(phases, axis=1) * (np.asarray(period, dtype=float) / (2.0 * np.pi))[:, None]
    N = steps.shape[1]
    K = np.empty((_STAGES, 4 * n))
    flat = K.reshape(_STAGES, 4, n)
    stages = np.empty((_STAGES, 4, n))  # stage states of one step
    stage_y = np.empty((N, _STAGES, n))  # their branch coordinate, all steps, for the step maps
    rhs = _StateRhs(params)
    stage_sums = [(_A[i, :i], K[:i], stages[i], stages[i].reshape(4 * n)) for i in range(1, _STAGES)]
    increment = np.empty(4 * n)
    for j in range(N):
        h = steps[:, j]
        stages[0] = w
        rhs(w, flat[0])
        for i, (a, k, stage, stage_flat) in enumerate(stage_sums, start=1):
            np.dot(a, k, out=stage_flat)
            stage *= h
            stage += w
            rhs(stage, flat[i])
        stage_y[j] = stages[:, 0]
        np.dot(_B, K, out=increment)
        w = w + h * increment.reshape(4, n)
    maps = _step_maps(
        params, np.ascontiguousarray(stage_y.transpose(1, 2, 0)).reshape(_STAGES, n * N), steps.reshape(n * N)
    )
    Q = transition_matrix(maps.reshape(n, N, 4, 4))
    eps = params.eps
    s = (np.sqrt(1.0 - eps) - np.abs(w[0])) * (np.sqrt(1.0 - eps) + np.abs(w[0]))
    state = np.stack([w[0] + eps * w[0] / s, w[1], w[2], w[3]], axis=1)
    return state, Q


def step_phases(x_phase, x_slope_phase, steps: int, width: float):
    """Step grid in phase over a quarter period, dense where ``|x|`` crosses the stop.

    The grid equidistributes ``6 + |dx/dtheta| / (||x| - 1| + 2 width)``: nearly uniform away
    from the stops and, near them, a step proportional to the distance to the contact transition
    (where the stiffness goes from ``eta`` to ``alpha`` over about ``width`` in ``x``) divided by
    the speed, so that each passage costs a number of steps growing only with the logarithm of
    the speed.

    Parameters
    ----------
    x_phase, x_slope_phase : ndarray, shape (n, m + 1)
        ``x`` and ``dx/dtheta`` of the (approximate) orbits on a uniform grid of ``[0, pi/2]``.
    steps : int
    width : float

    Returns
    -------
    ndarray, shape (n, steps + 1)
    """
    n, m1 = x_phase.shape
    theta = np.linspace(0.0, 0.5 * np.pi, m1)
    density = _UNIFORM_DENSITY + np.abs(x_slope_phase) / (np.abs(np.abs(x_phase) - 1.0) + _WIDTH_FACTOR * width)
    cumulative = np.concatenate([np.zeros((n, 1)), np.cumsum(0.5 * (density[:, 1:] + density[:, :-1]), axis=1)], axis=1)
    out = np.empty((n, steps + 1))
    for i in range(n):
        out[i] = np.interp(np.linspace(0.0, cumulative[i, -1], steps + 1), cumulative[i], theta)
    out[:, 0], out[:, -1] = 0.0, 0.5 * np.pi
    return out


def shoot(params: ModelParameters, start, period, phases, tol: float, max_iter: int):
    """Newton's method on ``(x(0), u(0), T)`` for ``x(T/4) = u(T/4) = 0``, with minimum-norm updates.

    A time-reversible, half-wave symmetric orbit starts at rest and passes through ``x = u = 0``
    at ``T/4``. The orbits form a one-parameter family, so the two conditions leave one unknown
    free: the minimum-norm update (unknowns ``x(0)``, ``u(0)``, ``T omega / 4`` of comparable
    size) converges to a nearby orbit of the family without fixing ``x(0)``, ``T`` or the energy,
    each of which is singular at some fold of the family.

    Returns
    -------
    start, period : ndarray
        Corrected unknowns (the last iterate where not converged).
    residual : ndarray
        ``max(|x(T/4)|, |u(T/4)|) / max(|x(0)|, |u(0)|)`` at the returned unknowns (at the last
        finite iterate where the flow diverged; ``inf`` if none).
    converged : ndarray of bool
        ``residual <= tol`` within ``max_iter`` updates.
    Q : ndarray, shape (n, 4, 4)
        ``Phi(T/4)`` at the returned unknowns.
    """
    start = np.array(start, dtype=float)
    period = np.array(period, dtype=float)
    n = len(start)
    residual = np.full(n, np.inf)
    converged = np.zeros(n, dtype=bool)
    Q_all = np.full((n, 4, 4), np.nan)
    active = np.arange(n)
    for iteration in range(max_iter + 1):
        state, Q = quarter_period_flow(params, start[active], period[active], phases[active])
        r = state[:, :2]
        closure = np.abs(r).max(axis=1) / np.maximum(np.abs(start[active]).max(axis=1), 1e-300)
        finite = np.isfinite(closure) & np.all(np.isfinite(Q), axis=(1, 2))
        # A diverged orbit (non-finite flow) keeps its last finite closure and is not updated further.
        residual[active[finite]] = closure[finite]
        Q_all[active] = Q
        converged[active] = finite & (closure <= tol)
        keep = ~converged[active] & finite
        if iteration == max_iter or not keep.any():
            break
        active, r, Q, state = active[keep], r[keep], Q[keep], state[keep]
        omega = 2.0 * np.pi / period[active]
        # Columns d/dx0, d/du0 (start at rest: columns 0, 1 of Q), d/d(omega T/4) = velocity / omega.
        J = np.concatenate([Q[:, :2, :2], state[:, 2:, None] / omega[:, None, None]], axis=2)
        update = -np.einsum("nji,nj->ni", J, np.linalg.solve(J @ np.swapaxes(J, 1, 2), r[..., None])[..., 0])
        start[active] += update[:, :2]
        period[active] += 4.0 * update[:, 2] / omega
    return start, period, residual, converged, Q_all


def _half_period_invariant(Q):
    """``s = mu + 1/mu`` of the full-period monodromy from ``Q = Phi(T/4)`` of a symmetric orbit.

    Reversibility maps the second quarter onto the first: ``Phi(T/2) = R Q^-1 R Q``. With the
    half-wave symmetry ``N = -Phi(T/2)`` has the eigenvalues ``{1, 1, nu, 1/nu}``, ``mu = nu**2``,
    so ``s_N = nu + 1/nu = tr N - 2`` and ``s = s_N**2 - 2``. On an orbit periodic to the
    integration accuracy, the trivial pair is at 1 to that accuracy, so the trace, linear in the
    matrix, is accurate to it as well (splitting the quadratic of the two invariants, as for HBM
    orbits, would lose half the digits where both pairs are close to +1).
    """
    P = _REVERSAL @ np.linalg.inv(Q) @ _REVERSAL @ Q
    s_n = -np.trace(P, axis1=-2, axis2=-1) - 2.0
    return s_n * s_n - 2.0


def _quarter_period_samples(system, U_array, samples: int):
    """``x`` and ``dx/dtheta`` of HBM orbits on ``samples + 1`` uniform phases of ``[0, pi/2]``."""
    x = np.stack([system.to_full(system.split(U)[0]) for U in U_array])
    values = system.to_time(x, 4 * samples)[:, : samples + 1]
    slopes = system.to_time(system.derivative(x), 4 * samples)[:, : samples + 1]
    return values, slopes


@dataclass
class RefinedStability:
    """Stability of shooting-refined orbits (arrays along the orbits).

    Attributes
    ----------
    invariant : ndarray
        ``s = mu + 1/mu`` of the refined orbit, from the finer of the last two step counts.
    integration_error : ndarray
        ``|s(2N) - s(N)|`` between those step counts.
    steps : ndarray of int
        Runge-Kutta steps over the quarter period of the stored ``invariant``.
    residual : ndarray
        Closure of the shooting conditions relative to the amplitude (:func:`shoot`).
    converged : ndarray of bool
    start : ndarray, shape (n, 2)
        ``(x, u)`` of the refined orbits at ``t = 0`` (at rest).
    period, energy : ndarray
        Period and energy of the refined orbits.
    initial_period, initial_energy : ndarray
        The same for the start orbits (energy of their state at ``t = 0``).
    """

    invariant: np.ndarray
    integration_error: np.ndarray
    steps: np.ndarray
    residual: np.ndarray
    converged: np.ndarray
    start: np.ndarray
    period: np.ndarray
    energy: np.ndarray
    initial_period: np.ndarray
    initial_energy: np.ndarray


def refined_stability(
    system,
    U_array,
    steps: int,
    max_steps: int,
    tol: float,
    resolution_factor: float,
    max_change: float,
    floor: float = 0.0,
    max_iter: int = 10,
):
    """Refine HBM orbits into periodic orbits of (7) by shooting and compute their Floquet invariant.

    The start (state at ``t = 0`` and period) and the step grid come from the HBM orbits;
    :func:`shooting_stability` does the rest.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    U_array : ndarray, shape (n, n_unknowns)
        Time-reversible, half-wave symmetric HBM orbits (the start of the shooting).
    steps, max_steps, tol, resolution_factor, max_change, floor, max_iter
        As in :func:`shooting_stability`.

    Returns
    -------
    RefinedStability
    """
    values, slopes = _quarter_period_samples(system, U_array, _GRID_SAMPLES)
    initial = [orbit_initial_state(system, U) for U in U_array]
    start = np.array([state[:2] for state, _ in initial])
    period = np.array([T for _, T in initial])
    return shooting_stability(
        system.params,
        start,
        period,
        values,
        slopes,
        steps,
        max_steps,
        tol,
        resolution_factor,
        max_change,
        floor,
        max_iter,
    )


def shooting_stability(
    params: ModelParameters,
    start,
    period,
    x_phase,
    x_slope_phase,
    steps: int,
    max_steps: int,
    tol: float,
    resolution_factor: float,
    max_change: float,
    floor: float = 0.0,
    max_iter: int = 10,
):
    """Periodic orbits of (7) by shooting from approximate ones, and their Floquet invariant.

    Newton's method (:func:`shoot`) with ``N = steps`` Runge-Kutta steps per quarter period, then
    the invariant with ``2N`` steps at the corrected orbit, compared with the ``N``-step one. Where
    ``|s - 2|`` (the distance to the type change of a half-wave symmetric orbit) is within
    ``resolution_factor`` times that difference, ``N`` is doubled (shooting again from the
    corrected orbit) up to ``max_steps``, unless that bound is already below ``floor`` (the
    stability tolerance on ``s``: the pair sits at the type change within it, and more steps
    cannot change the verdict by more).

    Parameters
    ----------
    params : ModelParameters
    start : array_like, shape (n, 2)
        Approximate ``(x, u)`` at ``t = 0`` (at rest) of time-reversible, half-wave symmetric orbits.
    period : array_like, shape (n,)
        Approximate periods.
    x_phase, x_slope_phase : ndarray, shape (n, m + 1)
        Approximate ``x`` and ``dx/dtheta`` on a uniform grid of the phase ``[0, pi/2]``, for the
        step grid (:func:`step_phases`).
    steps, max_steps : int
    tol : float
        Shooting tolerance on the closure relative to the amplitude.
    resolution_factor : float
    max_change : float
        Largest relative change of ``x(0)``, ``u(0)`` (relative to the amplitude) and ``T`` from the
        start: a shooting that goes farther has found another orbit and counts as not converged.
    floor : float
    max_iter : int
        Newton updates per step count.

    Returns
    -------
    RefinedStability
    """
    start = np.array(start, dtype=float)
    period = np.array(period, dtype=float)
    n = len(start)
    initial_start, initial_period, initial_energy = start.copy(), period.copy(), _energy_at_rest(start, params)
    width = np.sqrt(2.0 * params.eps)  # width in x of the contact transition
    s = np.zeros(n)
    err = np.full(n, np.inf)
    used = np.zeros(n, dtype=int)
    residual = np.full(n, np.inf)
    converged = np.zeros(n, dtype=bool)
    todo = np.arange(n)
    N = steps
    while len(todo):
        phases = step_phases(x_phase[todo], x_slope_phase[todo], N, width)
        z, T, res, conv, Q = shoot(params, start[todo], period[todo], phases, tol, max_iter)
        start[todo], period[todo], residual[todo], converged[todo] = z, T, res, conv
        ok = todo[conv]
        if not len(ok):
            break
        coarse = _half_period_invariant(Q[conv])
        fine_phases = step_phases(x_phase[ok], x_slope_phase[ok], 2 * N, width)
        _, Q_fine = quarter_period_flow(params, start[ok], period[ok], fine_phases)
        s[ok] = _half_period_invariant(Q_fine)
        err[ok] = np.abs(s[ok] - coarse)
        used[ok] = 2 * N
        if 2 * N >= max_steps:
            break
        bound = resolution_factor * err[ok]
        todo = ok[(np.abs(s[ok] - 2.0) <= bound) & (bound > floor)]
        N *= 2
    amplitude = np.abs(initial_start).max(axis=1)
    change = np.maximum(np.abs(start - initial_start).max(axis=1) / amplitude, np.abs(period / initial_period - 1.0))
    converged &= change <= max_change
    return RefinedStability(
        invariant=s,
        integration_error=err,
        steps=used,
        residual=residual,
        converged=converged,
        start=start,
        period=period,
        energy=_energy_at_rest(start, params),
        initial_period=initial_period,
        initial_energy=initial_energy,
    )


def _energy_at_rest(start, params: ModelParameters):
    """Total energy of the regularized model at the states ``(x, u, 0, 0)``, ``start``: (n, 2)."""
    x, u = start[:, 0], start[:, 1]
    return 0.5 * x**2 + 0.5 * params.beta * (x - u) ** 2 + regularized_contact_potential(x, params)
