"""Exact non-smooth periodic orbits of an N-DOF structure with one bilateral stop, one impact per side per period.

Covered: a :class:`~nnmstop.models.structure.Structure` with **one struck** stop (degree of freedom ``c``, gap
``g``, stiffness ``alpha``; any other stop must stay untouched, which is checked), the piecewise-linear law, and
symmetric synchronous orbits (NNM-like) built from a quarter period as in Section 3.1 of the paper: free flight
``M q'' + K q = 0`` from ``q = 0`` with velocities ``v`` until ``q_c = g`` at ``tau1``, then contact
``M q'' + (K + alpha e_c e_c^T) q = alpha g e_c`` until all velocities vanish at ``T1``. Unknowns
``(b, tau1, T1)`` (N + 2, ``b`` the modal coordinates of ``v``), equations ``q_c(tau1) = g`` and
``qdot(T1) = 0`` (N + 1): one-parameter families, followed by pseudo-arclength continuation from a grazing
linear mode. Each phase is linear, solved in closed form by its modes (:class:`PhaseFlow`: the matrix
exponential of the 2N-dimensional first-order system, exact to round-off). Orbits are checked against the
assumptions of the construction (:func:`assess_orbit`); a family ends, at a located point, where one fails.
Not covered: orbits striking several stops or with several impacts per stop per period, non-synchronous
orbits, the regularized law. Method notes: docs/methods/exact_ndof.md.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.optimize

from nnmstop.continuation.dense_arclength import DenseArclengthSettings
from nnmstop.continuation.newton import newton_solve, round_off_criterion
from nnmstop.exact.follow import (
    RESTART_POINTS,
    ValidityEvents,
    branch_point_flags,
    confirm_family_end,
    continue_exact_family,
    residual_norms,
)
from nnmstop.exact.grazing import TWO_IMPACT_MARGINS, MarginChecks
from nnmstop.exact.phases import unfold_quarter_states
from nnmstop.models.structure import Structure, generalized_modes

__all__ = [
    "PhaseFlow",
    "OneStopProblem",
    "OneStopAssessment",
    "OneStopFamily",
    "NdofTimeHistory",
    "grazing_orbit",
    "first_grazed_stop",
    "assess_orbit",
    "orbit_at_contact_time",
    "orbit_at_energy",
    "follow_one_stop_family",
    "validity_events",
    "REASONS",
    "time_history",
    "piecewise_energy",
]

logger = logging.getLogger("nnmstop.exact.ndof")

_ROUND_OFF = np.finfo(float).eps
#: Why an orbit stops being admissible, by validity margin: those of the 2-DOF code and the passive stops.
REASONS = {
    **TWO_IMPACT_MARGINS,
    "other_stops": "the degree of freedom of a passive stop reaches its gap (that stop would be struck too)",
}
#: Grid density of the extremum search, in samples per period of the fastest mode of a phase.
SAMPLES_PER_PERIOD = 64


# --------------------------------------------------------------------------- linear phases


class PhaseFlow:
    """Closed-form flow of ``M q'' + K q = force`` for N degrees of freedom (``K`` positive definite).

    State ``z = (q, qdot)`` of length 2N. With the mass-normalized modes ``Phi`` and ``q_eq = K^-1 force``::

        q(t) = q_eq + Phi (a cos(omega t) + b / omega sin(omega t)),  a = Phi^T M (q0 - q_eq),  b = Phi^T M qdot0,

    which is ``exp(A t)`` of the first-order system ``z' = A z + (0, M^-1 force)`` written through its modes.
    Same interface as the 2-DOF ``LinearPhase`` (``state``, ``transition``, ``field``).
    """

    def __init__(self, mass, stiffness, force):
        self.mass = np.asarray(mass, dtype=float)
        self.stiffness = np.asarray(stiffness, dtype=float)
        self.force = np.asarray(force, dtype=float)
        n = self.mass.shape[0]
        omega, modes = generalized_modes(self.mass, self.stiffness, n)
        if not np.all(omega > 0):
            raise ValueError(f"the stiffness of a phase must be positive definite, got angular frequencies {omega}")
        self.n = n
        self.omega, self.modes = omega, modes
        self.q_eq = np.linalg.solve(self.stiffness, self.force)
        self._projection = modes.T @ self.mass  # Phi^T M

    def modal_coordinates(self, z0):
        """``(a, b)``: modal displacement about ``q_eq`` and modal velocity at time 0."""
        z0 = np.asarray(z0, dtype=float)
        return self._projection @ (z0[: self.n] - self.q_eq), self._projection @ z0[self.n :]

    def state(self, z0, t):
        """State at time(s) ``t`` from ``z0`` at time 0, shape ``np.shape(t) + (2N,)``."""
        a, b = self.modal_coordinates(z0)
        wt = np.multiply.outer(np.asarray(t, dtype=float), self.omega)
        c, s = np.cos(wt), np.sin(wt)
        position = self.q_eq + (a * c + (b / self.omega) * s) @ self.modes.T
        velocity = (-(a * self.omega) * s + b * c) @ self.modes.T
        return np.concatenate([position, velocity], axis=-1)

    def coordinate_row(self, dof):
        """``(n^T Phi, n^T q_eq)`` of a coordinate ``n^T q``: ``dof`` an index (``n = e_dof``) or the vector ``n``."""
        if np.ndim(dof) == 0:
            return self.modes[dof], self.q_eq[dof]
        normal = np.asarray(dof, dtype=float)
        return normal @ self.modes, float(normal @ self.q_eq)

    def component(self, z0, t, dof):
        """Position and velocity of one degree of freedom (an index) or one coordinate ``n^T q`` (the vector ``n``)
        at times ``t`` (cheaper than :meth:`state`)."""
        a, b = self.modal_coordinates(z0)
        wt = np.multiply.outer(np.asarray(t, dtype=float), self.omega)
        c, s = np.cos(wt), np.sin(wt)
        row, offset = self.coordinate_row(dof)
        return offset + (a * c + (b / self.omega) * s) @ row, (-(a * self.omega) * s + b * c) @ row

    def component_on_grid(self, z0, duration: float, n: int, dof):
        """Times ``linspace(0, duration, n)`` and :meth:`component` there, by products of exact exponentials.

        ``exp(i omega t_j)`` with ``j = 64 p + r`` is ``exp(i omega 64 p dt) exp(i omega r dt)``, both factors from
        ``np.exp``: one complex product per sample and mode instead of a cosine and a sine (same round-off).
        Evaluated in chunks of at most about 2**21 sample-modes, so memory stays bounded for fine grids.
        """
        a, b = self.modal_coordinates(z0)
        row, offset = self.coordinate_row(dof)
        # a cos + (b / omega) sin = Re((a - i b / omega) e^{i omega t}); velocity = Re((b + i a omega) e^{i omega t})
        c_position, c_velocity = row * (a - 1j * b / self.omega), row * (b + 1j * a * self.omega)
        t = np.linspace(0.0, duration, n)
        dt = duration / (n - 1)
        block = 64
        fine = np.exp(1j * np.multiply.outer(np.arange(block) * dt, self.omega))
        starts = np.arange(-(-n // block)) * block * dt
        blocks_per_chunk = max(1, 2**21 // (block * self.n))
        position, velocity = np.empty(n), np.empty(n)
        for k in range(0, len(starts), blocks_per_chunk):
            coarse = np.exp(1j * np.multiply.outer(starts[k : k + blocks_per_chunk], self.omega))
            phasor = (coarse[:, None, :] * fine[None, :, :]).reshape(-1, self.n)
            j0 = k * block
            j1 = min(n, j0 + phasor.shape[0])
            position[j0:j1] = (phasor[: j1 - j0] @ c_position).real
            velocity[j0:j1] = (phasor[: j1 - j0] @ c_velocity).real
        return t, offset + position, velocity

    def transition(self, t: float) -> np.ndarray:
        """Transition matrix ``d z(t) / d z(0)`` (2N x 2N), i.e. ``expm(A t)``."""
        c, s = np.cos(self.omega * t), np.sin(self.omega * t)
        phi, proj = self.modes, self._projection
        return np.block(
            [
                [phi @ (c[:, None] * proj), phi @ ((s / self.omega)[:, None] * proj)],
                [phi @ ((-self.omega * s)[:, None] * proj), phi @ (c[:, None] * proj)],
            ]
        )

    def field(self, z) -> np.ndarray:
        """Time derivative ``(qdot, qddot)`` of the state(s) ``z`` (last axis)."""
        z = np.asarray(z, dtype=float)
        acc = np.linalg.solve(self.mass, (self.force - z[..., : self.n] @ self.stiffness.T).T).T
        return np.concatenate([z[..., self.n :], acc], axis=-1)


def piecewise_energy(structure: Structure, q, qdot):
    """Total energy of the non-smooth model: ``1/2 qdot M qdot + 1/2 q K q + sum_s alpha_s/2 (|q_s| - g_s)_+^2``.

    ``q`` and ``qdot`` have the degrees of freedom on their last axis.
    """
    mass, stiffness = structure.dense_matrices()
    q, qdot = np.asarray(q, dtype=float), np.asarray(qdot, dtype=float)
    kinetic = 0.5 * np.einsum("...i,ij,...j->...", qdot, mass, qdot)
    energy = kinetic + 0.5 * np.einsum("...i,ij,...j->...", q, stiffness, q)
    for stop in structure.stops:
        energy = energy + stop.piecewise_potential(q[..., stop.dof])
    return energy


# --------------------------------------------------------------------------- the quarter-period problem


class OneStopProblem:
    """Residual and analytic Jacobian of the quarter-period equations of a one-stop structure.

    Unknowns ``y = (b_1 .. b_N, tau1, T1)`` with ``b = Phi^T M v`` the modal velocities of the initial
    velocities ``v = Phi b`` on the mass-normalized free-flight modes ``Phi``: the energy is ``|b|^2 / 2`` and
    arclength steps weigh every mode by its energy rather than by nodal velocities (the rotations of a beam
    mesh carry little mass and large velocities). Residual ``(q_c(tau1) - g, qdot(T1))``.

    Parameters
    ----------
    structure : Structure
        With a positive definite stiffness.
    stop_index : int
        The stop that the orbits strike (index into ``structure.stops``). Any other stop is passive: the
        orbits are those of the whole structure only while its degree of freedom stays inside its gap, which
        :func:`assess_orbit` checks (margin ``other_stops``).
    """

    def __init__(self, structure: Structure, stop_index: int = 0):
        if (
            isinstance(stop_index, bool)
            or not isinstance(stop_index, (int, np.integer))
            or not 0 <= stop_index < len(structure.stops)
        ):
            raise ValueError(f"stop_index must be an integer in [0, {len(structure.stops)}), got {stop_index!r}")
        self.structure = structure
        self.stop = structure.stops[stop_index]
        self.passive_stops = tuple(s for k, s in enumerate(structure.stops) if k != stop_index)
        self.dof, self.gap = self.stop.dof, self.stop.gap
        self.n = structure.n_dofs
        mass, stiffness = structure.dense_matrices()
        unit = np.eye(self.n)[self.dof]
        self.free = PhaseFlow(mass, stiffness, np.zeros(self.n))
        self.contact = PhaseFlow(
            mass, stiffness + self.stop.stiffness * np.outer(unit, unit), self.stop.stiffness * self.gap * unit
        )
        self.n_unknowns = self.n + 2

    def check(self, y) -> np.ndarray:
        """``y`` as a float array, checked for shape and finiteness."""
        y = np.asarray(y, dtype=float)
        if y.shape != (self.n_unknowns,):
            raise ValueError(f"unknowns must be (b_1..b_{self.n}, tau1, T1), shape ({self.n_unknowns},), got {y.shape}")
        if not np.all(np.isfinite(y)):
            raise ValueError(f"unknowns must be finite, got {y}")
        return y

    def switch_states(self, y):
        """States at ``t = 0``, ``tau1`` (entering contact) and ``T1`` (turning point)."""
        y = self.check(y)
        z0 = np.concatenate([np.zeros(self.n), self.initial_velocity(y)])
        z1 = self.free.state(z0, y[-2])
        z2 = self.contact.state(z1, y[-1] - y[-2])
        return z0, z1, z2

    def residual(self, y) -> np.ndarray:
        """``(q_c(tau1) - g, qdot(T1))``, N + 1 values."""
        _, z1, z2 = self.switch_states(y)
        return np.concatenate([[z1[self.dof] - self.gap], z2[self.n :]])

    def state_derivatives(self, y):
        """Exact ``d z(tau1) / dy`` and ``d z(T1) / dy`` (2N x (N + 2)): transition matrices for the velocities,
        vector fields for the durations."""
        _, z1, z2 = self.switch_states(y)
        n = self.n
        e_free = self.free.transition(y[-2])
        e_contact = self.contact.transition(y[-1] - y[-2])
        f2 = self.contact.field(z2)
        dz1 = np.column_stack([e_free[:, n:] @ self.free.modes, self.free.field(z1), np.zeros(2 * n)])
        dz2 = e_contact @ dz1
        dz2[:, -2] -= f2  # d(T1 - tau1) / d tau1 = -1
        dz2[:, -1] = f2
        return dz1, dz2

    def jacobian(self, y) -> np.ndarray:
        """Analytic (N + 1) x (N + 2) Jacobian of :meth:`residual`."""
        dz1, dz2 = self.state_derivatives(y)
        return np.vstack([dz1[self.dof], dz2[self.n :]])

    def initial_velocity(self, y) -> np.ndarray:
        """Nodal velocities ``v = Phi b`` at ``q = 0``."""
        return self.free.modes @ self.check(y)[: self.n]

    def unknowns_from_velocity(self, v, tau1: float, quarter: float) -> np.ndarray:
        """``(b, tau1, T1)`` from nodal initial velocities ``v`` (``b = Phi^T M v``)."""
        return np.concatenate([self.free.modal_coordinates(np.concatenate([np.zeros(self.n), v]))[1], [tau1, quarter]])

    def energy(self, y) -> float:
        """Total energy of the non-smooth model: the kinetic energy at ``q = 0``, ``|b|^2 / 2``."""
        b = self.check(y)[: self.n]
        return float(0.5 * b @ b)

    def frequency(self, y) -> float:
        """``1 / (4 T1)``, in Hz of the nondimensional time."""
        return 1.0 / (4.0 * float(self.check(y)[-1]))

    def diagnostics(self, y) -> dict:
        """Energy, frequency and impacts per period (two: one on each side of the stop), for the continuation."""
        return {"energy": self.energy(y), "frequency": self.frequency(y), "impacts_per_period": 2}

    def quarter_state(self, y, t):
        """State on the quarter period ``0 <= t <= T1``, shape ``np.shape(t) + (2N,)``."""
        z0, z1, _ = self.switch_states(y)
        t = np.asarray(t, dtype=float)
        out = np.empty(t.shape + (2 * self.n,))
        free = t <= y[-2]
        out[free] = self.free.state(z0, t[free])
        out[~free] = self.contact.state(z1, t[~free] - y[-2])
        return out


def grazing_orbit(problem: OneStopProblem, mode: int = 0) -> np.ndarray:
    """Linear mode ``mode`` (no contact) with stop amplitude exactly the gap: ``q = g phi / phi_c sin(omega t)``.

    Returns ``(b, tau1, T1)`` with ``tau1 = T1 = pi / (2 omega)`` (contact duration 0).
    """
    if not 0 <= mode < problem.n:
        raise ValueError(f"mode must be in [0, {problem.n}), got {mode!r}")
    phi, w = problem.free.modes[:, mode], problem.free.omega[mode]
    if abs(phi[problem.dof]) <= 1e-12 * np.abs(phi).max():
        raise ValueError(f"linear mode {mode} does not move the stop degree of freedom {problem.dof}: no grazing orbit")
    quarter = 0.5 * np.pi / w
    b = np.zeros(problem.n)
    b[mode] = w * problem.gap / phi[problem.dof]
    return np.concatenate([b, [quarter, quarter]])


def first_grazed_stop(structure: Structure, mode: int = 0) -> int:
    """Index of the stop that linear mode ``mode`` (no contact) reaches first as its amplitude grows.

    The mode's grazing amplitude at stop ``s`` is ``gap_s / |phi_(dof_s)|``; the smallest one wins (the first
    listed among equals). A family started at another stop's grazing would have the first one struck already.

    Raises
    ------
    ValueError
        If the mode moves none of the stops' degrees of freedom.
    """
    mass, stiffness = structure.dense_matrices()
    _, modes = generalized_modes(mass, stiffness, structure.n_dofs)
    if not 0 <= mode < structure.n_dofs:
        raise ValueError(f"mode must be in [0, {structure.n_dofs}), got {mode!r}")
    phi = modes[:, mode]
    moved = np.abs(phi[list(structure.stop_dofs)]) > 1e-12 * np.abs(phi).max()
    if not moved.any():
        raise ValueError(f"linear mode {mode} moves none of the stops' degrees of freedom: no grazing orbit")
    amplitude = np.full(len(structure.stops), np.inf)
    amplitude[moved] = [s.gap / abs(phi[s.dof]) for s, m in zip(structure.stops, moved) if m]
    return int(np.argmin(amplitude))


# --------------------------------------------------------------------------- validity


@dataclass(frozen=True)
class OneStopAssessment(MarginChecks):
    """Validity margins (names and meanings of :data:`nnmstop.exact.grazing.TWO_IMPACT_MARGINS`, with ``x`` the
    stop degree of freedom and 1 its gap), the maximum ``x_max`` of the stop degree of freedom over the orbit,
    the time ``t_x_max`` of the quarter period where it is reached and the displacements ``q_at_x_max`` of all
    degrees of freedom then."""

    margins: dict
    x_max: float
    t_x_max: float
    q_at_x_max: np.ndarray


def _interior_extreme(phase: PhaseFlow, z0, duration: float, dof, sign: float):
    """``(time, value)`` of the largest interior local maximum of ``sign * q_dof`` over ``(0, duration)``
    (``value`` is ``q_dof`` there), or None; ``dof`` may be a vector ``n`` (the coordinate ``n^T q``).

    The closed-form velocity is sampled at :data:`SAMPLES_PER_PERIOD` points per period of the fastest mode that
    moves ``dof`` by more than 1e-12 of its motion; the three highest sampled candidates are refined by Brent's
    method on the velocity, to round-off.
    """
    if not duration > 0:
        return None
    # Resolve the fastest mode whose own amplitude at ``dof``, with those of all faster modes, exceeds 1e-12 of
    # the motion: faster ones can shift an extremum by less than that, far below the margins that matter.
    a, b = phase.modal_coordinates(z0)
    row, offset = phase.coordinate_row(dof)
    amplitude = np.abs(row) * np.hypot(a, b / phase.omega)
    fastest_first = np.argsort(phase.omega)[::-1]
    tail = np.cumsum(amplitude[fastest_first])
    resolved = fastest_first[np.argmax(tail > 1e-12 * (abs(offset) + amplitude.sum()))]
    n = SAMPLES_PER_PERIOD * max(1, int(np.ceil(duration * phase.omega[resolved] / (2 * np.pi)))) + 1
    t, x, v = phase.component_on_grid(z0, duration, n, dof)
    x, v = sign * x, sign * v
    idx = np.flatnonzero((v[:-1] > 0) & (v[1:] <= 0))
    edge = 1e-12 * max(duration, 1.0)
    best = None

    def velocity(r):
        return phase.component(z0, r, dof)[1]

    for i in idx[np.argsort(-np.maximum(x[idx], x[idx + 1]))[:3]]:
        v_left, v_right = velocity(t[i]), velocity(t[i + 1])
        if v_left * v_right > 0:  # a zero of the velocity at a grid point, seen with opposite round-off signs
            s = t[i] if abs(v_left) < abs(v_right) else t[i + 1]
        else:
            s = scipy.optimize.brentq(velocity, t[i], t[i + 1], xtol=1e-15, rtol=4 * _ROUND_OFF)
        if edge < s < duration - edge:
            value = sign * phase.component(z0, s, dof)[0]
            if best is None or value > best[1]:
                best = (float(s), value)
    return None if best is None else (best[0], sign * best[1])


def assess_orbit(problem: OneStopProblem, y) -> OneStopAssessment:
    """Margins of the assumptions of the one-stop construction (each > 0 when it holds), as in the 2-DOF code:

    ``free_flight_time`` tau1, ``contact_time`` T1 - tau1, ``entry_velocity`` qdot_c(tau1), ``early_impact``
    g - (largest interior maximum of q_c in free flight), ``opposite_stop`` g + (smallest q_c in free flight),
    ``leaves_stop`` (smallest interior minimum of q_c in contact) - g, ``final_position`` q_c(T1) - g, and with
    passive stops ``other_stops``: the smallest ``gap - max |q|`` over them (:data:`REASONS`).
    By the symmetries of the orbit the quarter period decides for the whole period.
    """
    y = problem.check(y)
    tau1, quarter = y[-2], y[-1]
    c, g = problem.dof, problem.gap
    z0, z1, z2 = problem.switch_states(y)
    margins = {"free_flight_time": tau1, "contact_time": quarter - tau1, "entry_velocity": z1[problem.n + c]}
    free_max = _interior_extreme(problem.free, z0, tau1, c, 1.0)
    free_min = _interior_extreme(problem.free, z0, tau1, c, -1.0)
    margins["early_impact"] = np.inf if free_max is None else g - free_max[1]
    margins["opposite_stop"] = g + min(0.0, z1[c], np.inf if free_min is None else free_min[1])
    contact_min = _interior_extreme(problem.contact, z1, quarter - tau1, c, -1.0)
    contact_max = _interior_extreme(problem.contact, z1, quarter - tau1, c, 1.0)
    margins["leaves_stop"] = np.inf if contact_min is None else contact_min[1] - g
    margins["final_position"] = z2[c] - g
    if problem.passive_stops:
        margins["other_stops"] = min(s.gap - _largest_magnitude(problem, y, s.dof) for s in problem.passive_stops)
    # the maximum of q_c over the quarter (hence the orbit): phase ends and interior maxima
    candidates = [(tau1, z1[c]), (quarter, z2[c])]
    candidates += [] if free_max is None else [free_max]
    candidates += [] if contact_max is None else [(tau1 + contact_max[0], contact_max[1])]
    t_max, x_max = max(candidates, key=lambda pair: pair[1])
    q_at = problem.quarter_state(y, np.array([t_max]))[0, : problem.n]
    return OneStopAssessment({k: float(v) for k, v in margins.items()}, float(x_max), float(t_max), q_at)


def _largest_magnitude(problem: OneStopProblem, y, dof: int) -> float:
    """``max |q_dof|`` over the orbit (the quarter period decides): phase ends and interior extrema."""
    z0, z1, z2 = problem.switch_states(y)
    values = [abs(z1[dof]), abs(z2[dof])]
    for phase, start, duration in ((problem.free, z0, y[-2]), (problem.contact, z1, y[-1] - y[-2])):
        for sign in (1.0, -1.0):
            extreme = _interior_extreme(phase, start, duration, dof, sign)
            if extreme is not None:
                values.append(abs(extreme[1]))
    return max(values)


# --------------------------------------------------------------------------- single orbits


def _newton(fun, jac, y, max_iter=30):
    """Newton iteration to round-off (:func:`~nnmstop.continuation.newton.round_off_criterion`); None if it fails."""
    result = newton_solve(fun, jac, y, tol=0.0, max_iter=max_iter, criterion=round_off_criterion())
    return result.y if result.converged else None


def _solve_with(problem: OneStopProblem, seed, extra, extra_gradient, name: str, value: float) -> np.ndarray:
    seed = problem.check(seed)

    def fun(y):
        return np.append(problem.residual(y), extra(y) - value)

    def jac(y):
        return np.vstack([problem.jacobian(y), extra_gradient(y)])

    y = _newton(fun, jac, seed)
    if y is None:
        raise ValueError(f"Newton did not converge for the orbit with {name}={value!r} from the given seed")
    return y


def orbit_at_contact_time(
    problem: OneStopProblem, contact_time: float, seed=None, mode: int = 0, increment: float = 0.01
) -> np.ndarray:
    """The orbit whose quarter-period contact duration ``T1 - tau1`` is ``contact_time``.

    Newton on the quarter-period equations plus that condition. From ``seed`` when given; otherwise from the
    grazing orbit of linear mode ``mode`` through contact times increasing by at most ``increment``, each
    solution seeding the next (natural continuation: it fails past a fold of the contact time along the
    family, where :func:`follow_one_stop_family` is the tool). Not checked: use :func:`assess_orbit`.
    """
    if not (np.isfinite(contact_time) and contact_time >= 0):
        raise ValueError(f"contact_time must be a finite number >= 0, got {contact_time!r}")
    if not (np.isfinite(increment) and increment > 0):
        raise ValueError(f"increment must be a finite number > 0, got {increment!r}")
    gradient = np.zeros(problem.n_unknowns)
    gradient[-2:] = (-1.0, 1.0)
    if seed is not None:
        targets, y = [contact_time], seed
    else:
        n_steps = max(1, int(np.ceil(contact_time / increment)))
        targets, y = np.linspace(0.0, contact_time, n_steps + 1)[1:], grazing_orbit(problem, mode)
    for target in targets:
        y = _solve_with(problem, y, lambda u: u[-1] - u[-2], lambda u: gradient, "contact_time", float(target))
    return y


def orbit_at_energy(problem: OneStopProblem, energy: float, seed) -> np.ndarray:
    """The orbit of total energy ``energy`` nearest ``seed`` (Newton; singular where the energy turns back
    along the family). Not checked: use :func:`assess_orbit`."""
    if not (np.isfinite(energy) and energy > 0):
        raise ValueError(f"energy must be a finite number > 0, got {energy!r}")

    def gradient(y):
        return np.concatenate([y[: problem.n], [0.0, 0.0]])

    return _solve_with(problem, seed, problem.energy, gradient, "energy", energy)


# --------------------------------------------------------------------------- families


def validity_events(problem: OneStopProblem) -> ValidityEvents:
    """The margins of :func:`assess_orbit` as continuation events, described by :data:`REASONS`."""
    return ValidityEvents(lambda y: assess_orbit(problem, y), lambda key: REASONS.get(key, str(key)))


@dataclass
class OneStopFamily:
    """A followed family of one-stop orbits (arrays along the family, in continuation order).

    Attributes
    ----------
    problem : OneStopProblem
    unknowns : ndarray, shape (n, N + 2)
        Rows ``(b, tau1, T1)`` (modal initial velocities, see :class:`OneStopProblem`); the properties give
        the physical quantities.
    arclength : ndarray
        Pseudo-arclength in the unknowns from the first orbit.
    residual : ndarray
        Euclidean norm of the quarter-period equations.
    assessments : list of OneStopAssessment
    branch_point : ndarray of bool
        True where the sign of ``det [J; t^T]`` changed since the previous orbit.
    end_reason : str
    end_margin : str
        The margin that reached zero at the end ('' when the family ended on a stop criterion).
    end_tangent : ndarray or None
    start : str
        Description of the first orbit.
    step : float
        Largest continuation step.
    end_check : str
        How the end was confirmed (:func:`nnmstop.exact.follow.confirm_family_end`; '' when it was not asked).
    mode : int
        The linear mode (0-based) whose grazing orbit starts the family, or that holds most of the energy of
        a user-supplied first orbit.
    """

    problem: OneStopProblem
    unknowns: np.ndarray
    arclength: np.ndarray
    residual: np.ndarray
    assessments: list
    branch_point: np.ndarray
    end_reason: str
    end_margin: str
    end_tangent: np.ndarray | None
    start: str = ""
    step: float = 0.0
    end_check: str = ""
    mode: int = 0

    @classmethod
    def from_branch(cls, problem: OneStopProblem, branch, start: str, step: float) -> OneStopFamily:
        """The family of a :func:`~nnmstop.exact.follow.continue_exact_family` branch."""
        unknowns = np.array(branch.points)
        event = branch.end_event
        return cls(
            problem=problem,
            unknowns=unknowns,
            arclength=np.array(branch.arclength, dtype=float),
            residual=residual_norms(problem, unknowns),
            assessments=list(branch.checks),
            branch_point=branch_point_flags(branch),
            end_reason=branch.end_reason,
            end_margin="" if event is None else event.key,
            end_tangent=branch.end_tangent,
            start=start,
            step=float(step),
        )

    def __len__(self) -> int:
        return len(self.unknowns)

    @property
    def initial_velocity(self) -> np.ndarray:
        """Velocities ``v`` at ``q = 0``, shape (n, N)."""
        return self.unknowns[:, : self.problem.n] @ self.problem.free.modes.T

    @property
    def energy(self) -> np.ndarray:
        """Total energy of the non-smooth model (the kinetic energy at ``q = 0``)."""
        return np.array([self.problem.energy(y) for y in self.unknowns])

    @property
    def period(self) -> np.ndarray:
        """Period ``T = 4 T1`` (nondimensional time)."""
        return 4.0 * self.unknowns[:, -1]

    @property
    def frequency(self) -> np.ndarray:
        """``1 / T`` in Hz of the nondimensional time."""
        return 1.0 / self.period

    @property
    def free_flight_time(self) -> np.ndarray:
        """Free-flight duration ``tau1`` of the quarter period."""
        return self.unknowns[:, -2]

    @property
    def contact_time(self) -> np.ndarray:
        """Contact duration ``T1 - tau1`` of the quarter period (each impact lasts twice this)."""
        return self.unknowns[:, -1] - self.unknowns[:, -2]

    @property
    def x_max(self) -> np.ndarray:
        """Maximum of the stop degree of freedom over the orbit (``x_max - gap`` is the penetration)."""
        return np.array([a.x_max for a in self.assessments])

    @property
    def modal_energy(self) -> np.ndarray:
        """Energy of each linear (free-flight) mode, ``b_k^2 / 2``, shape (n, N): the orbit's energy by mode.

        At ``q = 0`` the energy is kinetic and the free-flight modes are mass-orthonormal, so these add up
        to the total energy (the free flight conserves each of them until the stop is reached).
        """
        return 0.5 * self.unknowns[:, : self.problem.n] ** 2


def follow_one_stop_family(
    structure: Structure,
    step: float = 0.02,
    max_points: int = 2000,
    mode: int = 0,
    start=None,
    direction=None,
    stop_index: int | None = None,
    min_step_ratio: float = 1e-6,
    confirm: bool = False,
) -> OneStopFamily:
    """Follow the family of one-stop orbits of ``structure`` from the grazing orbit of linear mode ``mode``.

    The continuation is :func:`nnmstop.exact.follow.continue_exact_family` (dense pseudo-arclength steps
    corrected to round-off, the validity margins of :func:`assess_orbit` as events located on the step's
    path): the family ends at its first violated assumption (``end_margin``), or at ``max_points``.

    Parameters
    ----------
    structure : Structure
        Its stop ``stop_index`` is struck, the others must stay inside their gaps (see :class:`OneStopProblem`).
    step : float
        Largest pseudo-arclength step in the unknowns ``(b, tau1, T1)``.
    max_points : int
        Maximum number of orbits (>= 2).
    mode : int
        Linear mode whose grazing orbit starts the family (0: the first one), when ``start`` is not given.
    start : array_like, optional
        A first orbit ``(b, tau1, T1)`` instead of the grazing one.
    direction : array_like, optional
        Orientation of the first tangent; by default increasing contact duration.
    stop_index : int, optional
        The struck stop; by default the one the linear mode ``mode`` reaches first (:func:`first_grazed_stop`).
    min_step_ratio : float
        The continuation fails (ContinuationError) when a step below ``min_step_ratio * step`` is needed.
    confirm : bool
        Confirm the end by a restart with a ten times smaller step (``end_check``); raise
        :class:`~nnmstop.continuation.confirm.EndNotConfirmed` when the restart ends elsewhere.
    """
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be a finite number > 0, got {step!r}")
    if stop_index is None:
        stop_index = first_grazed_stop(structure, mode)
    problem = OneStopProblem(structure, stop_index)
    y0 = grazing_orbit(problem, mode) if start is None else problem.check(start)
    if direction is None:
        direction = np.zeros(problem.n_unknowns)
        direction[-2:] = (-1.0, 1.0)
    label = f"grazing orbit of linear mode {mode}" if start is None else "user-supplied orbit"
    if len(structure.stops) > 1:
        label += f" striking stop {stop_index} (on {structure.dof_labels[problem.dof]}, gap {problem.gap:g})"
    settings = DenseArclengthSettings(step=float(step), min_step=min_step_ratio * float(step))
    branch = continue_exact_family(
        problem, y0, direction, validity_events(problem), settings, max_points=max_points, label="one-stop family"
    )
    family = OneStopFamily.from_branch(problem, branch, label, step)
    family.mode = int(mode if start is None else np.argmax(np.abs(y0[: problem.n])))
    if confirm:

        def restart(U, direction, fine_step):
            return follow_one_stop_family(
                structure,
                fine_step,
                RESTART_POINTS,
                start=U,
                direction=direction,
                stop_index=stop_index,
                min_step_ratio=min_step_ratio,
            )

        family.end_check = confirm_family_end(family, restart, "one-stop family")
    logger.info(
        "one-stop family from the %s: %d orbits, energy %.6g..%.6g; end: %s",
        label,
        len(family),
        family.energy.min(),
        family.energy.max(),
        family.end_reason,
    )
    return family


# --------------------------------------------------------------------------- time histories


class NdofTimeHistory(NamedTuple):
    """Time history of a one-stop orbit: ``q`` and ``qdot`` of shape ``t.shape + (N,)``, stop force like ``t``."""

    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    force: np.ndarray


def time_history(problem: OneStopProblem, y, t) -> NdofTimeHistory:
    """Exact time history of the orbit ``y`` at times ``t`` (piecewise-linear stop force)."""
    y = problem.check(y)
    z = unfold_quarter_states(lambda r: problem.quarter_state(y, r), y[-1], t)
    q = z[..., : problem.n]
    force = problem.stop.piecewise_force(q[..., problem.dof])
    return NdofTimeHistory(np.asarray(t, dtype=float), q, z[..., problem.n :], force)
