"""Exact periodic orbits of the regularized equations (7) near HBM orbits, by shooting, and their monodromy.

Used by :func:`nnmstop.hbm.monodromy.branch_monodromy` where the HBM orbit's own error decides the
verdict (``stability_reason = 2``): the orbit is refined into a periodic orbit of (7) to the
accuracy of the integrator, and the Floquet invariant of the refined orbit resolves the margin test.
The quarter period (the NNMs are time-reversible and half-wave symmetric, so the quarter-period flow
gives both the shooting conditions and the half-period monodromy) is cut into segments started
from the HBM orbit's states (multiple shooting); all segments of all refined orbits are integrated
together by one vectorized explicit Runge-Kutta scheme of order 8, on a step grid that concentrates
the steps where the contact stiffness changes. Method, conditions, error estimate and cost:
``docs/methods/monodromy.md``, section "Shooting refinement".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Butcher tableau of the 8th-order Dormand-Prince scheme (Hairer, Norsett & Wanner, Solving ODEs I, II.5).
from scipy.integrate._ivp import dop853_coefficients as _dop853

from nnmstop import fourier
from nnmstop.floquet import transition_matrix
from nnmstop.models.structure import two_dof_parameters
from nnmstop.models.two_dof import (
    ModelParameters,
    regularized_contact_force,
    regularized_contact_potential,
    regularized_vector_field,
)

__all__ = [
    "RefinedStability",
    "segment_flow",
    "segment_joints",
    "step_phases",
    "shoot",
    "refined_stability",
    "shooting_stability",
]

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
# Segments of the quarter period (multiple shooting): the sequential step loop, whose cost is
# numpy's per-call overhead, is 8 times shorter over 8 times as many columns.
_SEGMENTS = 8


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


def segment_flow(params: ModelParameters, states, period, phases):
    """State and fundamental matrix of (7) at the end of phase grids, many trajectories at once.

    The state is integrated step by step, all trajectories as columns of one array, keeping the
    branch coordinate of every stage; the fundamental matrix by the same scheme afterwards, as
    the ordered product of the step maps (:func:`_step_maps`), vectorized over the steps.

    Parameters
    ----------
    params : ModelParameters
    states : ndarray, shape (c, 4)
        ``(x, u, xdot, udot)`` at ``phases[:, 0]``.
    period : ndarray, shape (c,)
        Period ``T`` of each trajectory's orbit: a phase step ``d theta`` lasts ``T d theta / (2 pi)``.
    phases : ndarray, shape (c, K + 1)
        Step grid in the phase ``2 pi t / T``.

    Returns
    -------
    end : ndarray, shape (c, 4)
        ``(x, u, xdot, udot)`` at ``phases[:, -1]``.
    Q : ndarray, shape (c, 4, 4)
        Fundamental matrix over the grid (identity at its start).
    """
    states = np.asarray(states, dtype=float)
    n = len(states)
    w = np.empty((4, n))
    w[0] = states[:, 0] - regularized_contact_force(states[:, 0], params) / params.alpha
    w[1:] = states[:, 1:].T
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
    eps = params.eps
    s = (np.sqrt(1.0 - eps) - np.abs(w[0])) * (np.sqrt(1.0 - eps) + np.abs(w[0]))
    end = np.stack([w[0] + eps * w[0] / s, w[1], w[2], w[3]], axis=1)
    return end, transition_matrix(maps.reshape(n, N, 4, 4))


def _step_density(x_phase, x_slope_phase, width: float):
    """Cumulative step density along the uniform phase samples (see :func:`step_phases`)."""
    n = x_phase.shape[0]
    density = _UNIFORM_DENSITY + np.abs(x_slope_phase) / (np.abs(np.abs(x_phase) - 1.0) + _WIDTH_FACTOR * width)
    return np.concatenate([np.zeros((n, 1)), np.cumsum(0.5 * (density[:, 1:] + density[:, :-1]), axis=1)], axis=1)


def segment_joints(x_phase, x_slope_phase, segments: int, width: float):
    """Samples where the segments of the multiple shooting join: equal shares of the step density.

    Each joint is the uniform sample nearest to ``m / segments`` of the cumulative step density
    (:func:`step_phases`), so that the segments get equal step counts on a grid close to the
    single-segment one, and the joint states are samples of the approximate orbit.

    Parameters
    ----------
    x_phase, x_slope_phase : ndarray, shape (n, m + 1)
        ``x`` and ``dx/dtheta`` of the (approximate) orbits on a uniform grid of ``[0, pi/2]``.
    segments : int
    width : float

    Returns
    -------
    ndarray of int, shape (n, segments + 1)
        Increasing sample indices from 0 to ``m``.
    """
    cumulative = _step_density(x_phase, x_slope_phase, width)
    n, m1 = cumulative.shape
    if m1 - 1 < segments:
        raise ValueError(f"{m1 - 1} phase samples cannot hold {segments} segments")
    targets = cumulative[:, -1:] * (np.arange(segments + 1) / segments)
    joints = np.empty((n, segments + 1), dtype=int)
    for i in range(n):
        above = np.clip(np.searchsorted(cumulative[i], targets[i]), 1, m1 - 1)
        nearer_below = targets[i] - cumulative[i, above - 1] < cumulative[i, above] - targets[i]
        joints[i] = np.where(nearer_below, above - 1, above)
    joints[:, 0], joints[:, -1] = 0, m1 - 1
    # distinct joints (a segment of at least one sample), keeping the ends
    for m in range(1, segments):
        joints[:, m] = np.maximum(joints[:, m], joints[:, m - 1] + 1)
    for m in range(segments - 1, 0, -1):
        joints[:, m] = np.minimum(joints[:, m], joints[:, m + 1] - 1)
    return joints


def step_phases(x_phase, x_slope_phase, joints, steps: int, width: float):
    """Step grid in phase over a quarter period, dense where ``|x|`` crosses the stop.

    The grid equidistributes ``6 + |dx/dtheta| / (||x| - 1| + 2 width)``: nearly uniform away
    from the stops and, near them, a step proportional to the distance to the contact transition
    (where the stiffness goes from ``eta`` to ``alpha`` over about ``width`` in ``x``) divided by
    the speed, so that each passage costs a number of steps growing only with the logarithm of
    the speed. Each segment between two joints (:func:`segment_joints`) gets ``steps / segments``
    steps and starts and ends on its joints' samples.

    Parameters
    ----------
    x_phase, x_slope_phase : ndarray, shape (n, m + 1)
        ``x`` and ``dx/dtheta`` of the (approximate) orbits on a uniform grid of ``[0, pi/2]``.
    joints : ndarray of int, shape (n, segments + 1)
    steps : int
        A multiple of the number of segments.
    width : float

    Returns
    -------
    ndarray, shape (n, steps + 1)
    """
    n, m1 = x_phase.shape
    segments = joints.shape[1] - 1
    if steps % segments:
        raise ValueError(f"steps must be a multiple of the {segments} segments, got {steps}")
    per_segment = steps // segments
    theta = np.linspace(0.0, 0.5 * np.pi, m1)
    cumulative = _step_density(x_phase, x_slope_phase, width)
    at_joints = np.take_along_axis(cumulative, joints, axis=1)
    fraction = np.arange(per_segment) / per_segment
    targets = at_joints[:, :-1, None] + np.diff(at_joints, axis=1)[:, :, None] * fraction
    targets = np.concatenate([targets.reshape(n, steps), at_joints[:, -1:]], axis=1)
    out = np.empty((n, steps + 1))
    for i in range(n):
        out[i] = np.interp(targets[i], cumulative[i], theta)
    out[:, ::per_segment] = theta[joints]
    return out


def shoot(params: ModelParameters, states, period, phases, tol: float, max_iter: int):
    """Multiple shooting: Newton's method for ``x(T/4) = u(T/4) = 0`` with minimum-norm updates.

    A time-reversible, half-wave symmetric orbit starts at rest and passes through ``x = u = 0``
    at ``T/4``. The quarter period is cut into segments, each integrated from its own start
    state (the joints), all side by side. The unknowns are ``x(0)``, ``u(0)``, ``T`` and the joint
    states; the conditions are the two at ``T/4`` and continuity at the joints. The joints are
    eliminated from the Newton system (condensing: the joint corrections follow from the start's
    by the segments' fundamental matrices), which leaves the single-shooting system in
    ``(x(0), u(0), omega T/4)`` with the joints' mismatches carried along. The orbits form a
    one-parameter family, so its minimum-norm update (unknowns of comparable size) converges
    to a nearby orbit of the family without fixing ``x(0)``, ``T`` or the energy, each of which
    is singular at some fold.

    Parameters
    ----------
    states : ndarray, shape (n, segments, 4)
        Start states of the segments (the first at rest, ``(x0, u0, 0, 0)``).
    period : ndarray, shape (n,)
    phases : ndarray, shape (n, N + 1)
        Step grid of the quarter period (:func:`step_phases`), ``N / segments`` steps a segment.

    Returns
    -------
    states, period : ndarray
        Corrected unknowns (the last iterate where not converged).
    residual : ndarray
        Closure relative to the amplitude ``max(|x0|, |u0|)``: the largest of ``|x|, |u|`` at
        ``T/4`` and of the joints' mismatches (velocities divided by ``omega``), at the returned
        unknowns (at the last finite iterate where the flow diverged; ``inf`` if none).
    converged : ndarray of bool
        ``residual <= tol`` within ``max_iter`` updates.
    Q : ndarray, shape (n, 4, 4)
        ``Phi(T/4)``, the product of the segments' fundamental matrices, at the returned unknowns.
    """
    states = np.array(states, dtype=float)
    period = np.array(period, dtype=float)
    n, segments, _ = states.shape
    per_segment = (phases.shape[1] - 1) // segments
    segment_phases = np.stack([phases[:, m * per_segment : (m + 1) * per_segment + 1] for m in range(segments)], axis=1)
    phase_span = (segment_phases[..., -1] - segment_phases[..., 0]) / (0.5 * np.pi)  # shares of T/4
    residual = np.full(n, np.inf)
    converged = np.zeros(n, dtype=bool)
    Q_all = np.full((n, 4, 4), np.nan)
    active = np.arange(n)
    for iteration in range(max_iter + 1):
        a = len(active)
        end, Qs = segment_flow(
            params,
            states[active].reshape(a * segments, 4),
            np.repeat(period[active], segments),
            segment_phases[active].reshape(a * segments, per_segment + 1),
        )
        end, Qs = end.reshape(a, segments, 4), Qs.reshape(a, segments, 4, 4)
        omega = 2.0 * np.pi / period[active]
        # mismatch of each segment's end: with the next joint, and with x = u = 0 for the last one
        mismatch = end.copy()
        mismatch[:, :-1] -= states[active, 1:]
        scale = np.array([1.0, 1.0, 0.0, 0.0]) + np.array([0.0, 0.0, 1.0, 1.0]) / omega[:, None, None]
        scaled = np.abs(mismatch * scale)
        scaled[:, -1, 2:] = 0.0  # the velocities at T/4 are free
        closure = scaled.max(axis=(1, 2)) / np.maximum(np.abs(states[active, 0, :2]).max(axis=1), 1e-300)
        Q = transition_matrix(Qs)
        finite = np.isfinite(closure) & np.all(np.isfinite(Q), axis=(1, 2))
        # A diverged orbit (non-finite flow) keeps its last finite closure and is not updated further.
        residual[active[finite]] = closure[finite]
        Q_all[active] = Q
        converged[active] = finite & (closure <= tol)
        keep = ~converged[active] & finite
        if iteration == max_iter or not keep.any():
            break
        active, end, Qs, mismatch, omega = active[keep], end[keep], Qs[keep], mismatch[keep], omega[keep]
        # d(segment end)/d(omega T/4): the segment lasts its share of T/4
        dp = regularized_vector_field(end, params) * (phase_span[active] / omega[:, None])[..., None]
        # condensing: the last segment's end as a function of (dx0, du0, dp) and the joints' mismatches
        A, b, c = Qs[:, 0, :, :2], dp[:, 0], mismatch[:, 0]
        for m in range(1, segments):
            A = Qs[:, m] @ A
            b = np.einsum("nij,nj->ni", Qs[:, m], b) + dp[:, m]
            c = np.einsum("nij,nj->ni", Qs[:, m], c) + mismatch[:, m]
        J = np.concatenate([A[:, :2], b[:, :2, None]], axis=2)
        update = -np.einsum("nji,nj->ni", J, np.linalg.solve(J @ np.swapaxes(J, 1, 2), c[:, :2, None])[..., 0])
        correction = np.zeros((len(active), 4))
        correction[:, :2] = update[:, :2]
        states[active, 0] += correction
        for m in range(segments - 1):
            correction = mismatch[:, m] + np.einsum("nij,nj->ni", Qs[:, m], correction) + dp[:, m] * update[:, 2:3]
            states[active, m + 1] += correction
        period[active] += 4.0 * update[:, 2] / omega
    return states, period, residual, converged, Q_all


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
    x = system.to_full(system.split(np.asarray(U_array))[0])
    values = system.to_time(x, 4 * samples)[:, : samples + 1]
    slopes = system.to_time(system.derivative(x), 4 * samples)[:, : samples + 1]
    return values, slopes


def _hbm_states_at(system, U_array):
    """``states_at(theta)`` for :func:`shooting_stability`: ``(x, u, xdot, udot)`` of the HBM orbits
    ``U_array`` at the phases ``theta`` (n, J), by direct synthesis of their series."""
    parts = system.split(np.asarray(U_array))
    omega = np.sqrt(np.asarray(parts[4], dtype=float))
    series = [
        {"x": fourier.to_cos_sin(x, system.H), "u": fourier.to_cos_sin(u, system.H)} for x, u in zip(parts[0], parts[1])
    ]

    def states_at(theta):
        out = np.empty(np.shape(theta) + (4,))
        for i, (phases, w, pairs) in enumerate(zip(theta, omega, series)):
            fields = fourier.fields_at_phases(phases, float(w), pairs)
            out[i] = np.stack([fields[name] for name in ("x", "u", "xdot", "udot")], axis=-1)
        return out

    return states_at, 2.0 * np.pi / omega


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
    x_phase, x_slope_phase = _quarter_period_samples(system, U_array, _GRID_SAMPLES)
    states_at, period = _hbm_states_at(system, U_array)
    return shooting_stability(
        two_dof_parameters(system.structure, "the shooting refinement"),
        period,
        x_phase,
        x_slope_phase,
        states_at,
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
    period,
    x_phase,
    x_slope_phase,
    states_at,
    steps: int,
    max_steps: int,
    tol: float,
    resolution_factor: float,
    max_change: float,
    floor: float = 0.0,
    max_iter: int = 10,
):
    """Periodic orbits of (7) by shooting from approximate ones, and their Floquet invariant.

    Multiple shooting (:func:`shoot`) with ``N = steps`` Runge-Kutta steps per quarter period,
    then the invariant with ``2N`` steps from the corrected start and joints, compared with the
    ``N``-step one. Where ``|s - 2|`` (the distance to the type change of a half-wave symmetric
    orbit) is within ``resolution_factor`` times that difference, ``N`` is doubled (shooting again
    from the corrected orbit) up to ``max_steps``, unless that bound is already below ``floor``
    (the stability tolerance on ``s``: the pair sits at the type change within it, and more steps
    cannot change the verdict by more).

    Parameters
    ----------
    params : ModelParameters
    period : array_like, shape (n,)
        Approximate periods.
    x_phase, x_slope_phase : ndarray, shape (n, m + 1)
        Approximate ``x`` and ``dx/dtheta`` of time-reversible, half-wave symmetric orbits on a
        uniform grid of the phase ``[0, pi/2]`` (``m >= 8``), for the step grid
        (:func:`step_phases`) and the joints (:func:`segment_joints`).
    states_at : callable
        ``states_at(theta)``, ``theta`` of shape (n, J): the approximate orbits' states
        ``(x, u, xdot, udot)``, shape (n, J, 4), at those phases: the start (at ``theta = 0``, at rest;
        its velocities are taken as zero) and the joints' start states.
    steps, max_steps : int
        Multiples of the number of segments (8).
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
    period = np.array(period, dtype=float)
    x_phase, x_slope_phase = np.asarray(x_phase, dtype=float), np.asarray(x_slope_phase, dtype=float)
    n = len(period)
    width = np.sqrt(2.0 * params.eps)  # width in x of the contact transition
    joints = segment_joints(x_phase, x_slope_phase, _SEGMENTS, width)
    theta = np.linspace(0.0, 0.5 * np.pi, x_phase.shape[1])
    states = np.array(states_at(theta[joints[:, :-1]]), dtype=float)
    if states.shape != (n, _SEGMENTS, 4):
        raise ValueError(f"states_at must return shape {(n, _SEGMENTS, 4)}, got {states.shape}")
    states[:, 0, 2:] = 0.0
    initial_start, initial_period = states[:, 0, :2].copy(), period.copy()
    initial_energy = _energy_at_rest(initial_start, params)
    s = np.zeros(n)
    err = np.full(n, np.inf)
    used = np.zeros(n, dtype=int)
    residual = np.full(n, np.inf)
    converged = np.zeros(n, dtype=bool)
    todo = np.arange(n)
    N = steps
    while len(todo):
        phases = step_phases(x_phase[todo], x_slope_phase[todo], joints[todo], N, width)
        z, T, res, conv, Q = shoot(params, states[todo], period[todo], phases, tol, max_iter)
        states[todo], period[todo], residual[todo], converged[todo] = z, T, res, conv
        ok = todo[conv]
        if not len(ok):
            break
        coarse = _half_period_invariant(Q[conv])
        # the fine invariant from one trajectory over the quarter period, started at the converged
        # start: integrated anew at 2N steps everywhere (joints restarted from the N-step orbit would
        # keep its integration error there and hide it from the estimate)
        fine_phases = step_phases(x_phase[ok], x_slope_phase[ok], joints[ok], 2 * N, width)
        _, Q_fine = segment_flow(params, states[ok, 0] * [1.0, 1.0, 0.0, 0.0], period[ok], fine_phases)
        s[ok] = _half_period_invariant(Q_fine)
        err[ok] = np.abs(s[ok] - coarse)
        used[ok] = 2 * N
        if 2 * N >= max_steps:
            break
        bound = resolution_factor * err[ok]
        todo = ok[(np.abs(s[ok] - 2.0) <= bound) & (bound > floor)]
        N *= 2
    start = states[:, 0, :2]
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
