"""Exact periodic orbits of the regularized equations of a structure near HBM orbits, by shooting.

Used by :func:`nnmstop.hbm.monodromy.branch_monodromy` where the HBM orbit's own error decides the
verdict (``stability_reason = 2``): the orbit is refined into a periodic orbit of the regularized
equations of motion to the accuracy of the integrator, and the Floquet invariants of the refined
orbit resolve the margin test. The quarter period (NNM orbits are time-reversible and half-wave
symmetric, so the quarter-period flow gives both the shooting conditions and the half-period
monodromy) is cut into segments started from the HBM orbit's states (multiple shooting); all
segments of all refined orbits are integrated together by one vectorized explicit Runge-Kutta
scheme of order 8, on a step grid that concentrates the steps where the contact stiffness changes.
Any structure (:class:`~nnmstop.models.structure.Structure`): ``N`` degrees of freedom, any stops.
Method, conditions, error estimate and cost: ``docs/methods/monodromy.md``, section "Shooting
refinement".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Butcher tableau of the 8th-order Dormand-Prince scheme (Hairer, Norsett & Wanner, Solving ODEs I, II.5).
from scipy.integrate._ivp import dop853_coefficients as _dop853

from nnmstop import fourier
from nnmstop.floquet import PairInvariants, transition_matrix
from nnmstop.hbm.variational import dof_coefficients
from nnmstop.models.contact import BilateralStop
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force, regularized_contact_potential

__all__ = [
    "refinable",
    "RegularizedDynamics",
    "RefinedStability",
    "segment_flow",
    "segment_joints",
    "step_phases",
    "shoot",
    "refined_stability",
    "explicit_steps",
    "shooting_stability",
]

_STAGES = _dop853.N_STAGES
_A = np.asarray(_dop853.A[:_STAGES, :_STAGES], dtype=float)
_B = np.asarray(_dop853.B, dtype=float)
# Samples of the HBM orbit per quarter period for the step grid (the grid only has to follow the orbit).
_GRID_SAMPLES = 2048
# Step grid density 6 + sum_i |dx_i/dtheta| / (||x_i| - 1| + 2 w_i) per radian of phase, w_i the width of
# stop i's contact transition: the weights that minimized the integration error of s at a given step count
# over a sample of the refined NNM1 and 5:1 orbits of the 2-DOF oscillator (errors 100 to 1000 times
# smaller than with 1 and w; method notes).
_UNIFORM_DENSITY = 6.0
_WIDTH_FACTOR = 2.0
# Entries of the vectorized step maps per chunk (12 stages x 16 entries x 2**13 steps x 8 bytes: 12 MB).
_CHUNK_ENTRIES = 2**17
# Segments of the quarter period (multiple shooting): the sequential step loop, whose cost is
# numpy's per-call overhead, is 8 times shorter over 8 times as many columns.
_SEGMENTS = 8
#: Largest step times the stiffest angular frequency of the structure for the explicit scheme: at
#: h omega = 0.25 DOP853 damps an undamped mode by about 2e-14 a step (its stability polynomial on the
#: imaginary axis: 1 - |R(i y)| = 2.4e-8 y**10 for small y), so the stiffest pairs stay on the unit circle to
#: well below the verdict's tolerance; stiffer steps would turn them into spurious quartets.
MAX_STEP_STIFFNESS = 0.25


def refinable(structure) -> bool:
    """Whether :class:`RegularizedDynamics` integrates ``structure``: every stop bilateral on one DOF."""
    return all(isinstance(stop, BilateralStop) for stop in structure.stops)


class RegularizedDynamics:
    """The regularized equations of motion of a structure, ``M q'' + K q + sum_i gap_i f_i(q_{d_i}/gap_i) e_{d_i} = 0``.

    In the integrator's state ``w`` (2N, n) the row of each stop's degree of freedom holds
    ``gap_i y_i`` with ``y_i = x_i - f_i / alpha_i`` the branch coordinate of the contact law
    instead of ``q_{d_i} = gap_i x_i``: ``x``, ``f`` and ``f'(x)`` are rational in ``y``
    (``x = y + eps y / s``, ``f = eta y / s``, ``s = 1 - eps - y**2``; ``nnmstop.models.two_dof``, the
    same force as the root of the cubic), so no cubic is solved per evaluation.

    Parameters
    ----------
    structure : Structure
    """

    def __init__(self, structure):
        if not refinable(structure):
            raise ValueError(
                "the shooting refinement integrates bilateral stops on one degree of freedom (the branch coordinate of "
                f"Eq. (5)); this structure has {', '.join(stop.label for stop in structure.stops)}"
            )
        mass, stiffness = structure.dense_matrices()
        self.n_dofs = N = structure.n_dofs
        self.mass_factor = np.linalg.cholesky(mass)
        mass_inverse = np.linalg.inv(mass)
        self.stiffness = stiffness
        self.stop_dofs = np.array(structure.stop_dofs, dtype=int)
        self.gaps = np.array([s.gap for s in structure.stops], dtype=float)
        self.laws = tuple(ModelParameters(alpha=s.stiffness, eta=s.eta) for s in structure.stops)
        self.eps = np.array([law.eps for law in self.laws])
        self.eta = np.array([law.eta for law in self.laws])
        # d(velocities)/dt without the stops' rational corrections: -M^-1 K on the positions
        self.linear = np.zeros((2 * N, 2 * N))
        self.linear[:N, N:] = np.eye(N)
        self.linear[N:, :N] = -mass_inverse @ stiffness
        # per stop, the column multiplying gap y / s: -(eps M^-1 K e_d + eta M^-1 e_d)
        self.mass_inverse_stops = mass_inverse[:, self.stop_dofs]
        self.on_stop = -(self.eps * (mass_inverse @ stiffness)[:, self.stop_dofs] + self.eta * self.mass_inverse_stops)
        # rows of the stops' coordinates and velocities in the state: views where they are contiguous
        self._stop_rows = _rows(self.stop_dofs)
        self._velocity_rows = _rows(N + self.stop_dofs)
        self._inverse_gap = (1.0 / self.gaps)[:, None]
        self._c = (1.0 - self.eps)[:, None]
        self._eps = self.eps[:, None]

    def to_state(self, states):
        """Integrator states ``w`` (2N, n) from physical ``(q, q')`` (n, 2N)."""
        w = np.array(np.asarray(states, dtype=float).T)
        for dof, gap, law in zip(self.stop_dofs, self.gaps, self.laws):
            x = w[dof] / gap
            w[dof] = gap * (x - regularized_contact_force(x, law) / law.alpha)
        return w

    def from_state(self, w):
        """Physical ``(q, q')`` (n, 2N) from integrator states ``w`` (2N, n)."""
        out = np.array(w)
        for i, (dof, gap) in enumerate(zip(self.stop_dofs, self.gaps)):
            y = w[dof] / gap
            root = np.sqrt(1.0 - self.eps[i])
            s = (root - np.abs(y)) * (root + np.abs(y))
            out[dof] = gap * (y + self.eps[i] * y / s)
        return out.T

    def rhs(self, w, out):
        """``dw/dt`` (2N, n) into ``out``. Evaluated 12 times a step, one step at a time: its cost is
        numpy's per-call overhead, hence few calls (views of the stops' rows, in-place operations)."""
        stops, velocities = self._stop_rows, self._velocity_rows
        gap_y = w[stops]
        y = gap_y * self._inverse_gap
        y2 = y * y
        s = self._c - y2
        np.dot(self.linear, w, out=out)
        gap_y = gap_y / s
        out[self.n_dofs :] += np.dot(self.on_stop, gap_y)
        # dx/dt = xdot / gap and dx/dy = 1 + eps (c + y**2) / s**2
        y2 += self._c
        y2 *= self._eps
        y2 /= s
        y2 /= s
        y2 += 1.0
        if isinstance(stops, slice):
            np.divide(w[velocities], y2, out=out[stops])
        else:  # fancy indexing gives a copy: assign
            out[stops] = w[velocities] / y2
        return out

    def contact_stiffness(self, y):
        """``f_i'(x_i)`` at the branch coordinates ``y`` (s, ...): ``eta (c + y**2) / (s**2 + eps (c + y**2))``."""
        eps = self.eps.reshape((-1,) + (1,) * (np.ndim(y) - 1))
        eta = self.eta.reshape(eps.shape)
        q = (1.0 - eps) + y * y
        s = (1.0 - eps) - y * y
        return eta * q / (s * s + eps * q)

    def variational_rhs(self, Z, y, out):
        """``A(y) Z`` for many ``2N x 2N`` matrices ``Z`` (2N, 2N, k), ``y`` (s, k) the stops' branch coordinates.

        ``A = [[0, I], [-M^-1 (K + sum_i f_i'(x_i) e_{d_i} e_{d_i}^T), 0]]``.
        """
        N = self.n_dofs
        out[:N] = Z[N:]
        np.dot(self.linear[N:, :N], Z[:N].reshape(N, -1), out=out[N:].reshape(N, -1))
        slopes = self.contact_stiffness(y)
        for i, dof in enumerate(self.stop_dofs):
            out[N:] -= self.mass_inverse_stops[:, i, None, None] * (slopes[i] * Z[dof])
        return out

    def vector_field(self, states):
        """Right-hand side of the equations of motion at physical states ``(q, q')`` (..., 2N)."""
        states = np.asarray(states, dtype=float)
        N = self.n_dofs
        q = states[..., :N]
        acceleration = q @ self.linear[N:, :N].T
        for i, (dof, gap, law) in enumerate(zip(self.stop_dofs, self.gaps, self.laws)):
            acceleration = (
                acceleration
                - (gap * regularized_contact_force(q[..., dof] / gap, law))[..., None] * (self.mass_inverse_stops[:, i])
            )
        return np.concatenate([states[..., N:], acceleration], axis=-1)

    def energy_at_rest(self, q):
        """Total energy of the states ``(q, 0)``, ``q``: (n, N)."""
        energy = 0.5 * np.einsum("ni,ij,nj->n", q, self.stiffness, q)
        for dof, gap, law in zip(self.stop_dofs, self.gaps, self.laws):
            energy = energy + gap * gap * regularized_contact_potential(q[:, dof] / gap, law)
        return energy

    def stiffest_frequency(self) -> float:
        """Largest angular frequency of the linearization with every stop fully engaged (``f' <= alpha``)."""
        stiffness = self.stiffness.copy()
        stiffness[self.stop_dofs, self.stop_dofs] += [law.alpha for law in self.laws]
        L = self.mass_factor
        return float(np.sqrt(np.linalg.eigvalsh(np.linalg.solve(L, np.linalg.solve(L, stiffness).T).T)[-1]))

    def width(self):
        """Width in ``x`` of each stop's contact transition, ``sqrt(2 eps)``."""
        return np.sqrt(2.0 * self.eps)


def _rows(indices):
    """``indices`` as a slice where they are consecutive (basic indexing: views), else as they are."""
    indices = np.asarray(indices, dtype=int)
    if np.all(np.diff(indices) == 1):
        return slice(int(indices[0]), int(indices[-1]) + 1)
    return indices


def _step_maps(dynamics: RegularizedDynamics, stage_y, steps):
    """Runge-Kutta step maps ``Phi_{j+1} = R_j Phi_j`` of the variational equation, all steps at once.

    The variational equation is linear and its coefficient depends only on the state, so the
    scheme applied to ``Phi`` with the stage states of the state integration (``stage_y``) is the
    linear map ``R_j = I + h_j sum_i b_i M_i``, ``M_i = A(y_i) (I + h_j sum_{l<i} a_il M_l)``:
    the same scheme as on the augmented system, vectorized over the steps instead of looping.

    Parameters
    ----------
    stage_y : ndarray, shape (stages, s, m)
        Stops' branch coordinates at the stages of ``m`` steps (flattened over orbits and steps).
    steps : ndarray, shape (m,)

    Returns
    -------
    ndarray, shape (m, 2N, 2N)
    """
    n = 2 * dynamics.n_dofs
    m = steps.shape[0]
    maps = np.empty((m, n, n))
    identity = np.eye(n)[:, :, None]
    chunk = max(1, _CHUNK_ENTRIES // (n * n))
    for lo in range(0, m, chunk):
        sl = slice(lo, min(lo + chunk, m))
        h = steps[sl]
        k = h.shape[0]
        M = np.empty((_STAGES, n, n, k))
        dynamics.variational_rhs(np.broadcast_to(identity, (n, n, k)), stage_y[0, :, sl], M[0])
        for i in range(1, _STAGES):
            dynamics.variational_rhs(identity + h * np.tensordot(_A[i, :i], M[:i], axes=1), stage_y[i, :, sl], M[i])
        maps[sl] = np.moveaxis(identity + h * np.tensordot(_B, M, axes=1), 2, 0)
    return maps


def segment_flow(dynamics: RegularizedDynamics, states, period, phases):
    """State and fundamental matrix of the equations of motion at the end of phase grids, many trajectories at once.

    The state is integrated step by step, all trajectories as columns of one array, keeping the
    stops' branch coordinates at every stage; the fundamental matrix by the same scheme afterwards,
    as the ordered product of the step maps (:func:`_step_maps`), vectorized over the steps.

    Parameters
    ----------
    dynamics : RegularizedDynamics
    states : ndarray, shape (c, 2N)
        ``(q, q')`` at ``phases[:, 0]``.
    period : ndarray, shape (c,)
        Period ``T`` of each trajectory's orbit: a phase step ``d theta`` lasts ``T d theta / (2 pi)``.
    phases : ndarray, shape (c, K + 1)
        Step grid in the phase ``2 pi t / T``.

    Returns
    -------
    end : ndarray, shape (c, 2N)
        ``(q, q')`` at ``phases[:, -1]``.
    Q : ndarray, shape (c, 2N, 2N)
        Fundamental matrix over the grid (identity at its start), in ``(q, q')``.
    """
    w = dynamics.to_state(states)
    n_states, c = w.shape
    steps = np.diff(phases, axis=1) * (np.asarray(period, dtype=float) / (2.0 * np.pi))[:, None]
    N = steps.shape[1]
    K = np.empty((_STAGES, n_states * c))
    flat = K.reshape(_STAGES, n_states, c)
    stages = np.empty((_STAGES, n_states, c))  # stage states of one step
    stops = dynamics.stop_dofs
    stage_y = np.empty((N, _STAGES, len(stops), c))  # the stops' rows, all steps, for the step maps
    stage_sums = [(_A[i, :i], K[:i], stages[i], stages[i].reshape(n_states * c)) for i in range(1, _STAGES)]
    increment = np.empty(n_states * c)
    for j in range(N):
        h = steps[:, j]
        stages[0] = w
        dynamics.rhs(w, flat[0])
        for i, (a, k, stage, stage_flat) in enumerate(stage_sums, start=1):
            np.dot(a, k, out=stage_flat)
            stage *= h
            stage += w
            dynamics.rhs(stage, flat[i])
        stage_y[j] = stages[:, stops]
        np.dot(_B, K, out=increment)
        w = w + h * increment.reshape(n_states, c)
    stage_y /= dynamics.gaps[:, None]
    maps = _step_maps(
        dynamics,
        np.ascontiguousarray(stage_y.transpose(1, 2, 3, 0)).reshape(_STAGES, len(stops), c * N),
        steps.reshape(c * N),
    )
    return dynamics.from_state(w), transition_matrix(maps.reshape(c, N, n_states, n_states))


def _step_density(x_phase, x_slope_phase, width):
    """Cumulative step density along the uniform phase samples (see :func:`step_phases`).

    ``x_phase``, ``x_slope_phase``: (n, s, m + 1); ``width``: (s,).
    """
    w = np.asarray(width, dtype=float)[:, None]
    density = _UNIFORM_DENSITY + (np.abs(x_slope_phase) / (np.abs(np.abs(x_phase) - 1.0) + _WIDTH_FACTOR * w)).sum(
        axis=1
    )
    n = density.shape[0]
    return np.concatenate([np.zeros((n, 1)), np.cumsum(0.5 * (density[:, 1:] + density[:, :-1]), axis=1)], axis=1)


def _stops_axis(x):
    """``(n, m + 1)`` (one stop) or ``(n, s, m + 1)`` as ``(n, s, m + 1)``."""
    x = np.asarray(x, dtype=float)
    return x[:, None] if x.ndim == 2 else x


def segment_joints(x_phase, x_slope_phase, segments: int, width):
    """Samples where the segments of the multiple shooting join: equal shares of the step density.

    Each joint is the uniform sample nearest to ``m / segments`` of the cumulative step density
    (:func:`step_phases`), so that the segments get equal step counts on a grid close to the
    single-segment one, and the joint states are samples of the approximate orbit.

    Parameters
    ----------
    x_phase, x_slope_phase : ndarray, shape (n, s, m + 1) or (n, m + 1) for one stop
        Stop coordinates ``x_i`` and ``dx_i/dtheta`` of the (approximate) orbits on a uniform grid of
        ``[0, pi/2]``.
    segments : int
    width : float or array_like, shape (s,)

    Returns
    -------
    ndarray of int, shape (n, segments + 1)
        Increasing sample indices from 0 to ``m``.
    """
    cumulative = _step_density(_stops_axis(x_phase), _stops_axis(x_slope_phase), np.atleast_1d(width))
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


def step_phases(x_phase, x_slope_phase, joints, steps: int, width):
    """Step grid in phase over a quarter period, dense where a stop coordinate ``|x_i|`` crosses 1.

    The grid equidistributes ``6 + sum_i |dx_i/dtheta| / (||x_i| - 1| + 2 width_i)``: nearly uniform
    away from the stops and, near them, a step proportional to the distance to the contact
    transition (where the stiffness goes from ``eta`` to ``alpha`` over about ``width`` in ``x``)
    divided by the speed, so that each passage costs a number of steps growing only with the
    logarithm of the speed. Each segment between two joints (:func:`segment_joints`) gets
    ``steps / segments`` steps and starts and ends on its joints' samples.

    Parameters
    ----------
    x_phase, x_slope_phase : ndarray, shape (n, s, m + 1) or (n, m + 1)
    joints : ndarray of int, shape (n, segments + 1)
    steps : int
        A multiple of the number of segments.
    width : float or array_like, shape (s,)

    Returns
    -------
    ndarray, shape (n, steps + 1)
    """
    x_phase = _stops_axis(x_phase)
    n, _, m1 = x_phase.shape
    segments = joints.shape[1] - 1
    if steps % segments:
        raise ValueError(f"steps must be a multiple of the {segments} segments, got {steps}")
    per_segment = steps // segments
    theta = np.linspace(0.0, 0.5 * np.pi, m1)
    cumulative = _step_density(x_phase, _stops_axis(x_slope_phase), np.atleast_1d(width))
    at_joints = np.take_along_axis(cumulative, joints, axis=1)
    fraction = np.arange(per_segment) / per_segment
    targets = at_joints[:, :-1, None] + np.diff(at_joints, axis=1)[:, :, None] * fraction
    targets = np.concatenate([targets.reshape(n, steps), at_joints[:, -1:]], axis=1)
    out = np.empty((n, steps + 1))
    for i in range(n):
        out[i] = np.interp(targets[i], cumulative[i], theta)
    out[:, ::per_segment] = theta[joints]
    return out


def shoot(dynamics: RegularizedDynamics, states, period, phases, tol: float, max_iter: int):
    """Multiple shooting: Newton's method for ``q(T/4) = 0`` with minimum-norm updates.

    A time-reversible, half-wave symmetric orbit starts at rest and passes through ``q = 0`` at
    ``T/4``. The quarter period is cut into segments, each integrated from its own start state
    (the joints), all side by side. The unknowns are ``q(0)``, ``T`` and the joint states; the
    conditions are the ``N`` at ``T/4`` and continuity at the joints. The joints are eliminated from
    the Newton system (condensing: the joint corrections follow from the start's by the segments'
    fundamental matrices), which leaves the single-shooting system in ``(q(0), omega T/4)`` with the
    joints' mismatches carried along. The orbits form a one-parameter family, so its minimum-norm
    update (unknowns of comparable size) converges to a nearby orbit of the family without fixing
    ``q(0)``, ``T`` or the energy, each of which is singular at some fold.

    Parameters
    ----------
    dynamics : RegularizedDynamics
    states : ndarray, shape (n, segments, 2N)
        Start states of the segments (the first at rest, ``(q0, 0)``).
    period : ndarray, shape (n,)
    phases : ndarray, shape (n, K + 1)
        Step grid of the quarter period (:func:`step_phases`), ``K / segments`` steps a segment.

    Returns
    -------
    states, period : ndarray
        Corrected unknowns (the last iterate where not converged).
    residual : ndarray
        Closure relative to the amplitude ``max |q0|``: the largest of ``|q|`` at ``T/4`` and of the
        joints' mismatches (velocities divided by ``omega``), at the returned unknowns (at the last
        finite iterate where the flow diverged; ``inf`` if none).
    converged : ndarray of bool
        ``residual <= tol`` within ``max_iter`` updates.
    Q : ndarray, shape (n, 2N, 2N)
        ``Phi(T/4)``, the product of the segments' fundamental matrices, at the returned unknowns.
    singular : ndarray of bool
        The Newton system was singular (no minimum-norm update: the conditions' Jacobian has rank below
        ``N``, as on an orbit whose period is a multiple of its own, at an ``n:1`` branch point): the
        orbit is left at its last iterate, not converged.
    """
    states = np.array(states, dtype=float)
    period = np.array(period, dtype=float)
    n, segments, n_states = states.shape
    N = n_states // 2
    per_segment = (phases.shape[1] - 1) // segments
    segment_phases = np.stack([phases[:, m * per_segment : (m + 1) * per_segment + 1] for m in range(segments)], axis=1)
    phase_span = (segment_phases[..., -1] - segment_phases[..., 0]) / (0.5 * np.pi)  # shares of T/4
    residual = np.full(n, np.inf)
    converged = np.zeros(n, dtype=bool)
    singular = np.zeros(n, dtype=bool)
    Q_all = np.full((n, n_states, n_states), np.nan)
    active = np.arange(n)
    positions = np.r_[np.ones(N), np.zeros(N)]
    for iteration in range(max_iter + 1):
        a = len(active)
        end, Qs = segment_flow(
            dynamics,
            states[active].reshape(a * segments, n_states),
            np.repeat(period[active], segments),
            segment_phases[active].reshape(a * segments, per_segment + 1),
        )
        end, Qs = end.reshape(a, segments, n_states), Qs.reshape(a, segments, n_states, n_states)
        omega = 2.0 * np.pi / period[active]
        # mismatch of each segment's end: with the next joint, and with q = 0 for the last one
        mismatch = end.copy()
        mismatch[:, :-1] -= states[active, 1:]
        scale = positions + (1.0 - positions) / omega[:, None, None]
        scaled = np.abs(mismatch * scale)
        scaled[:, -1, N:] = 0.0  # the velocities at T/4 are free
        closure = scaled.max(axis=(1, 2)) / np.maximum(np.abs(states[active, 0, :N]).max(axis=1), 1e-300)
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
        dp = dynamics.vector_field(end) * (phase_span[active] / omega[:, None])[..., None]
        update, solvable = _newton_update(Qs, dp, mismatch, N)
        singular[active[~solvable]] = True
        active, end, Qs, mismatch, omega, dp = (a[solvable] for a in (active, end, Qs, mismatch, omega, dp))
        update = update[solvable]
        if not len(active):
            break
        correction = np.zeros((len(active), n_states))
        correction[:, :N] = update[:, :N]
        states[active, 0] += correction
        for m in range(segments - 1):
            correction = mismatch[:, m] + np.einsum("nij,nj->ni", Qs[:, m], correction) + dp[:, m] * update[:, N:]
            states[active, m + 1] += correction
        period[active] += 4.0 * update[:, N] / omega
    return states, period, residual, converged, Q_all, singular


def _newton_update(Qs, dp, mismatch, N: int):
    """Minimum-norm update ``(dq0, d(omega T/4))`` (a, N + 1) of the condensed multiple-shooting system.

    ``Qs`` (a, segments, 2N, 2N) the segments' fundamental matrices, ``dp`` (a, segments, 2N) the
    derivatives of their ends with respect to ``omega T/4``, ``mismatch`` (a, segments, 2N).
    Returns the updates and whether each system was solvable: where ``J J^T`` is singular (LAPACK finds
    an exactly zero pivot) the update is zero and the flag False, the others solved as usual.
    """
    # condensing: the last segment's end as a function of (dq0, dp) and the joints' mismatches
    A, b, c = Qs[:, 0, :, :N], dp[:, 0], mismatch[:, 0]
    for m in range(1, Qs.shape[1]):
        A = Qs[:, m] @ A
        b = np.einsum("nij,nj->ni", Qs[:, m], b) + dp[:, m]
        c = np.einsum("nij,nj->ni", Qs[:, m], c) + mismatch[:, m]
    J = np.concatenate([A[:, :N], b[:, :N, None]], axis=2)
    normal, rhs = J @ np.swapaxes(J, 1, 2), c[:, :N, None]
    solvable = np.ones(len(J), dtype=bool)
    try:
        y = np.linalg.solve(normal, rhs)[..., 0]
    except np.linalg.LinAlgError:  # one singular system fails the batch: solve them one by one
        y = np.zeros(rhs.shape[:2])
        for i in range(len(J)):
            try:
                y[i] = np.linalg.solve(normal[i], rhs[i])[:, 0]
            except np.linalg.LinAlgError:
                solvable[i] = False
    return -np.einsum("nji,nj->ni", J, y), solvable


def _half_period_invariants(dynamics: RegularizedDynamics, Q):
    """:class:`~nnmstop.floquet.PairInvariants` of symmetric orbits from ``Q = Phi(T/4)`` in ``(q, q')``.

    Reversibility maps the second quarter onto the first: ``Phi(T/2) = R Q^-1 R Q``, ``R`` reversing the
    velocities; with the half-wave symmetry ``-Phi(T/2)`` gives the invariants (mass-normalized
    coordinates ``(L^T q, L^T q')``, in which the flow is symplectic for the standard form).
    """
    N = dynamics.n_dofs
    R = np.diag(np.r_[np.ones(N), -np.ones(N)])
    P = R @ np.linalg.inv(Q) @ R @ Q
    S = np.kron(np.eye(2), dynamics.mass_factor.T)
    S_inv = np.kron(np.eye(2), np.linalg.inv(dynamics.mass_factor.T))
    return PairInvariants.of(S @ P @ S_inv, halfwave=True)


def _quarter_period_samples(system, U_array, samples: int):
    """Stop coordinates ``x_i`` and ``dx_i/dtheta`` of HBM orbits on ``samples + 1`` uniform phases of
    ``[0, pi/2]``, each (n, s, samples + 1)."""
    q = dof_coefficients(system, U_array)
    x = q[:, system.stop_dofs] / np.asarray(system.gaps, dtype=float)[:, None]
    values = system.to_time(x, 4 * samples)[..., : samples + 1]
    slopes = system.to_time(system.derivative(x), 4 * samples)[..., : samples + 1]
    return values, slopes


def _hbm_states_at(system, U_array):
    """``states_at(theta)`` for :func:`shooting_stability`: ``(q, q')`` of the HBM orbits ``U_array`` at the
    phases ``theta`` (n, J), by direct synthesis of their series; and their periods."""
    omega = np.sqrt(np.asarray(system.split(np.asarray(U_array))[-2], dtype=float))
    cos, sin = fourier.to_cos_sin(dof_coefficients(system, U_array), system.H)  # (n, N, H + 1) each

    def states_at(theta):
        out = np.empty(np.shape(theta) + (2 * system.n_dofs,))
        for i, phases in enumerate(theta):
            at = fourier.PhaseSynthesis(phases, system.H)
            c, s = cos[i].T, sin[i].T  # (H + 1, N)
            out[i, :, : system.n_dofs] = at.values(c, s)
            out[i, :, system.n_dofs :] = omega[i] * at.values(at.k[:, None] * s, -at.k[:, None] * c)
        return out

    return states_at, 2.0 * np.pi / omega


@dataclass
class RefinedStability:
    """Stability of shooting-refined orbits (arrays along the orbits).

    Attributes
    ----------
    invariants : PairInvariants
        Of the refined orbit's monodromy (:class:`nnmstop.floquet.PairInvariants`), from the finer
        of the last two step counts.
    integration_error : ndarray
        Largest change of a pair's ``s`` between those step counts.
    steps : ndarray of int
        Runge-Kutta steps over the quarter period of the stored invariants.
    residual : ndarray
        Closure of the shooting conditions relative to the amplitude (:func:`shoot`).
    converged : ndarray of bool
    singular : ndarray of bool
        Not converged because the shooting's Newton system was singular (:func:`shoot`).
    start : ndarray, shape (n, N)
        ``q`` of the refined orbits at ``t = 0`` (at rest).
    period, energy : ndarray
        Period and energy of the refined orbits.
    initial_period, initial_energy : ndarray
        The same for the start orbits (energy of their state at ``t = 0``).
    """

    invariants: object
    integration_error: np.ndarray
    steps: np.ndarray
    residual: np.ndarray
    converged: np.ndarray
    singular: np.ndarray
    start: np.ndarray
    period: np.ndarray
    energy: np.ndarray
    initial_period: np.ndarray
    initial_energy: np.ndarray


def explicit_steps(structure, period) -> np.ndarray:
    """Fewest Runge-Kutta steps per quarter period (powers of two, multiples of the segments) that keep
    ``h omega_max <= MAX_STEP_STIFFNESS`` for the stiffest mode of ``structure``, per period."""
    omega = RegularizedDynamics(structure).stiffest_frequency()
    need = np.maximum(np.asarray(period, dtype=float) / 4.0 * omega / MAX_STEP_STIFFNESS, _SEGMENTS)
    return (2 ** np.ceil(np.log2(need))).astype(int)


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
    """Refine HBM orbits into periodic orbits of the regularized equations by shooting; their Floquet invariants.

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
        system.structure,
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
    structure,
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
    """Periodic orbits of the regularized equations by shooting from approximate ones, and their Floquet invariants.

    Multiple shooting (:func:`shoot`) with ``K = steps`` Runge-Kutta steps per quarter period, then
    again with ``2K`` steps from the corrected orbit (usually converged at once); the invariants of the
    ``2K``-step orbit are kept and compared with the ``K``-step ones. Where the margin
    (:meth:`nnmstop.floquet.PairInvariants.margin`) is within ``resolution_factor`` times that
    difference, the steps are doubled again (shooting from the corrected orbit) up to ``max_steps``,
    unless that bound is already below ``floor`` (the stability tolerance on ``s``: the pair sits at the
    type change within it, and more steps cannot change the verdict by more).

    Parameters
    ----------
    structure : Structure
    period : array_like, shape (n,)
        Approximate periods.
    x_phase, x_slope_phase : ndarray, shape (n, s, m + 1) or (n, m + 1) for one stop
        Approximate stop coordinates ``x_i`` and ``dx_i/dtheta`` of time-reversible, half-wave
        symmetric orbits on a uniform grid of the phase ``[0, pi/2]`` (``m >= 8``), for the step grid
        (:func:`step_phases`) and the joints (:func:`segment_joints`).
    states_at : callable
        ``states_at(theta)``, ``theta`` of shape (n, J): the approximate orbits' states ``(q, q')``,
        shape (n, J, 2N), at those phases: the start (at ``theta = 0``, at rest; its velocities are
        taken as zero) and the joints' start states.
    steps, max_steps : int
        Multiples of the number of segments (8).
    tol : float
        Shooting tolerance on the closure relative to the amplitude.
    resolution_factor : float
    max_change : float
        Largest relative change of ``q(0)`` (relative to the amplitude) and ``T`` from the start: a
        shooting that goes farther has found another orbit and counts as not converged.
    floor : float
    max_iter : int
        Newton updates per step count.

    Returns
    -------
    RefinedStability
    """
    dynamics = RegularizedDynamics(structure)
    N = dynamics.n_dofs
    period = np.array(period, dtype=float)
    x_phase, x_slope_phase = _stops_axis(x_phase), _stops_axis(x_slope_phase)
    n = len(period)
    width = dynamics.width()
    joints = segment_joints(x_phase, x_slope_phase, _SEGMENTS, width)
    theta = np.linspace(0.0, 0.5 * np.pi, x_phase.shape[-1])
    states = np.array(states_at(theta[joints[:, :-1]]), dtype=float)
    if states.shape != (n, _SEGMENTS, 2 * N):
        raise ValueError(f"states_at must return shape {(n, _SEGMENTS, 2 * N)}, got {states.shape}")
    states[:, 0, N:] = 0.0
    initial_start, initial_period = states[:, 0, :N].copy(), period.copy()
    levels = _Levels(dynamics, n, (x_phase, x_slope_phase, joints, width), steps, max_steps, resolution_factor, floor)
    found, err, used, residual, converged, singular = levels.run(states, period, tol, max_iter)
    start = states[:, 0, :N]
    amplitude = np.abs(initial_start).max(axis=1)
    change = np.maximum(np.abs(start - initial_start).max(axis=1) / amplitude, np.abs(period / initial_period - 1.0))
    converged &= change <= max_change
    return RefinedStability(
        invariants=found,
        integration_error=err,
        steps=used,
        residual=residual,
        converged=converged,
        singular=singular & ~converged,
        start=start,
        period=period,
        energy=dynamics.energy_at_rest(start),
        initial_period=initial_period,
        initial_energy=dynamics.energy_at_rest(initial_start),
    )


class _Levels:
    """The levels of steps of :func:`shooting_stability`: a converged orbit at each, compared with the previous.

    Each level's invariants come from the orbit converged at its own step count (started from the
    previous level's orbit, so usually converged at once): the change between levels bounds the error
    of the orbit's states as well as of its monodromy. ``grid``: ``(x_phase, x_slope_phase, joints,
    width)`` of :func:`step_phases`.
    """

    def __init__(self, dynamics, n, grid, steps, max_steps, resolution_factor, floor):
        self.dynamics, self.grid = dynamics, grid
        self.steps, self.max_steps, self.factor, self.floor = steps, max_steps, resolution_factor, floor
        pairs = dynamics.n_dofs - 1
        self.found, self.previous = PairInvariants.empty(n, pairs), PairInvariants.empty(n, pairs)
        self.err, self.used = np.full(n, np.inf), np.zeros(n, dtype=int)
        self.residual, self.converged = np.full(n, np.inf), np.zeros(n, dtype=bool)
        self.singular = np.zeros(n, dtype=bool)

    def run(self, states, period, tol, max_iter):
        """Shoot level after level (``states``, ``period`` corrected in place) while the margin needs it."""
        x_phase, x_slope_phase, joints, width = self.grid
        todo, K = np.arange(len(period)), self.steps
        while len(todo):
            phases = step_phases(x_phase[todo], x_slope_phase[todo], joints[todo], K, width)
            z, T, res, conv, Q, singular = shoot(self.dynamics, states[todo], period[todo], phases, tol, max_iter)
            states[todo], period[todo], self.residual[todo], self.converged[todo] = z, T, res, conv
            self.singular[todo] |= singular
            ok = todo[conv]
            if not len(ok):
                break
            level = _half_period_invariants(self.dynamics, Q[conv])
            if K > self.steps:
                ok = self._compare(ok, level, K)
                if K >= self.max_steps:
                    break
            self.previous.assign(todo[conv], level)
            todo, K = ok, 2 * K
        return self.found, self.err, self.used, self.residual, self.converged, self.singular

    def _compare(self, ok, level, K):
        """Keep ``level`` for the orbits ``ok`` with its change from the previous level; those to refine further."""
        self.found.assign(ok, level)
        self.err[ok] = level.change_from(self.previous.select(ok))
        self.used[ok] = K
        margin, _ = level.margin(np.ones(len(ok), dtype=bool), self.floor)
        bound = self.factor * self.err[ok]
        return ok[(margin <= bound) & (bound > self.floor)]
