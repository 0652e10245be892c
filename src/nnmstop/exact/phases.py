"""Linear phases of the non-smooth 2-DOF system and the time histories built from them.

Between switchings Eqs. (3)-(4) are linear with constant coefficients: free flight ``F``
(Eq. 8), contact with the right stop ``R`` or the left stop ``L`` (Eq. 9 and its mirror).
Each phase is solved in closed form by its mass-normalized modes, so states, vector field
and transition matrix are exact to round-off (:class:`LinearPhase`). The orbits of the
symmetry class of Section 3.1 are decided by their quarter period; :func:`unfold_quarter`
builds the whole period from it. Method notes: ``docs/methods/exact.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import scipy.linalg
import scipy.optimize

from nnmstop.models.two_dof import ModelParameters, mass_matrix, piecewise_contact_force, stiffness_matrix

__all__ = [
    "PHASE_NAMES",
    "STOP_SIDE",
    "LinearPhase",
    "check_sequence_model",
    "phase_of",
    "stop_stiffness",
    "interior_extrema",
    "OrbitTimeHistory",
    "unfold_quarter_states",
    "unfold_quarter",
]

#: The linear phases and what they mean.
PHASE_NAMES = {
    "F": "free flight, |x| <= 1 (Eq. 8)",
    "R": "contact with the right stop, x >= 1 (Eq. 9)",
    "L": "contact with the left stop, x <= -1 (Eq. 9 mirrored)",
}
#: Position of the stop of each contact phase.
STOP_SIDE = {"R": 1.0, "L": -1.0}

_ROUND_OFF = np.finfo(float).eps


@dataclass(frozen=True)
class LinearPhase:
    """Closed-form flow of ``M q'' + K q = force`` (constant coefficients).

    The state is ``z = (x, u, xdot, udot)``. With the mass-normalized modes ``Phi``
    (``Phi^T M Phi = I``, ``Phi^T K Phi = diag(omega**2)``) and ``q_eq = K^{-1} force``::

        q(t) = q_eq + Phi (a cos(omega t) + b / omega sin(omega t)),
        a = Phi^T M (q(0) - q_eq),  b = Phi^T M qdot(0).

    Parameters
    ----------
    mass, stiffness : ndarray, shape (2, 2)
        Symmetric positive definite matrices.
    force : ndarray, shape (2,)
        Constant right-hand side.
    """

    mass: np.ndarray
    stiffness: np.ndarray
    force: np.ndarray
    omega: np.ndarray = field(init=False)
    modes: np.ndarray = field(init=False)
    q_eq: np.ndarray = field(init=False)
    projection: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        lam, modes = scipy.linalg.eigh(self.stiffness, self.mass)  # Phi^T M Phi = I
        if np.any(lam <= 0):
            raise ValueError(f"stiffness matrix must be positive definite, got eigenvalues {lam}")
        object.__setattr__(self, "omega", np.sqrt(lam))
        object.__setattr__(self, "modes", modes)
        object.__setattr__(self, "q_eq", np.linalg.solve(self.stiffness, self.force))
        # Phi^T M formed once: every state and transition uses it.
        object.__setattr__(self, "projection", modes.T @ self.mass)
        diagonal = np.diag(self.mass)
        object.__setattr__(self, "_mass_diagonal", diagonal if np.all(self.mass == np.diag(diagonal)) else None)
        # Scalar-time states and the transition matrices are called some 10^5 times per branch: their
        # constants are formed once. The scalar path works on Python floats between the matrix products,
        # which are kept as the same numpy calls, so every result has the bits of the array path.
        object.__setattr__(self, "_modes_t", modes.T)
        object.__setattr__(self, "_omega_floats", tuple(self.omega.tolist()))
        object.__setattr__(self, "_omega_max", float(self.omega.max()))
        object.__setattr__(self, "_q_eq_floats", tuple(self.q_eq.tolist()))
        object.__setattr__(self, "_projection_floats", tuple(map(tuple, self.projection.tolist())))

    @classmethod
    def free_flight(cls, params: ModelParameters) -> LinearPhase:
        """Eq. (8): no contact force, ``|x| <= 1``."""
        return cls(mass_matrix(params), stiffness_matrix(params), np.zeros(2))

    @classmethod
    def contact(cls, params: ModelParameters, side: float = 1.0) -> LinearPhase:
        """Eq. (9): in contact with the stop at ``x = side`` (stiffness ``alpha`` and force ``side alpha`` on x)."""
        return cls(mass_matrix(params), stiffness_matrix(params, params.alpha), np.array([side * params.alpha, 0.0]))

    def state(self, z0, t):
        """State ``(x, u, xdot, udot)`` at time(s) ``t`` from ``z0`` at time 0.

        Returns an array of shape ``np.shape(t) + (4,)``.
        """
        z0 = np.asarray(z0, dtype=float)
        if isinstance(t, float):  # switch states, root finding: the same numbers, fewer numpy calls
            return self._state_at(z0, t)
        omega, modes_t = self.omega, self._modes_t
        a, b = self._modal_start(z0)
        wt = np.multiply.outer(np.asarray(t, dtype=float), omega)
        c, s = np.cos(wt), np.sin(wt)
        eta = a * c + (b / omega) * s
        eta_dot = -(a * omega) * s + b * c
        out = np.empty(wt.shape[:-1] + (4,))
        out[..., :2] = self.q_eq + eta @ modes_t
        out[..., 2:] = eta_dot @ modes_t
        return out

    def _modal_start(self, z0) -> tuple[np.ndarray, np.ndarray]:
        """Modal coordinates ``a = Phi^T M (q(0) - q_eq)`` and ``b = Phi^T M qdot(0)`` of the start ``z0``."""
        return self.projection @ (z0[:2] - self.q_eq), self.projection @ z0[2:]

    def _coefficients(self, z0) -> tuple:
        """:meth:`_modal_start` as Python floats."""
        a, b = self._modal_start(z0)
        return a.tolist(), b.tolist()

    def _state_at(self, z0: np.ndarray, t: float) -> np.ndarray:
        """:meth:`state` at one time: the elementwise operations of the array path on Python floats."""
        (a0, a1), (b0, b1) = self._coefficients(z0)
        wt = t * self.omega
        c0, c1 = np.cos(wt).tolist()
        s0, s1 = np.sin(wt).tolist()
        w0, w1 = self._omega_floats
        eta = np.array((a0 * c0 + (b0 / w0) * s0, a1 * c1 + (b1 / w1) * s1))
        eta_dot = np.array((-(a0 * w0) * s0 + b0 * c0, -(a1 * w1) * s1 + b1 * c1))
        x, u = (eta @ self._modes_t).tolist()
        q0, q1 = self._q_eq_floats
        return np.array((q0 + x, q1 + u, *(eta_dot @ self._modes_t).tolist()))

    def velocity_function(self, z0):
        """``t -> xdot(t)`` from ``z0`` for a scalar ``t``: the bits of ``state(z0, t)[2]``, cheaper."""
        (a0, a1), (b0, b1) = self._coefficients(np.asarray(z0, dtype=float))
        w0, w1 = self._omega_floats
        na0, na1 = -(a0 * w0), -(a1 * w1)
        omega, modes_t = self.omega, self._modes_t

        def velocity(t):
            wt = t * omega
            c0, c1 = np.cos(wt).tolist()
            s0, s1 = np.sin(wt).tolist()
            return float((np.array((na0 * s0 + b0 * c0, na1 * s1 + b1 * c1)) @ modes_t)[0])

        return velocity

    def velocities(self, z0, t: np.ndarray) -> np.ndarray:
        """Velocity of x at the times ``t`` (1-D array): column 2 of :meth:`state`, bit for bit."""
        a, b = self._modal_start(np.asarray(z0, dtype=float))
        wt = np.multiply.outer(t, self.omega)
        eta_dot = -(a * self.omega) * np.sin(wt) + b * np.cos(wt)
        return (eta_dot @ self._modes_t)[:, 0]

    def transition(self, t: float) -> np.ndarray:
        """Transition matrix ``d z(t) / d z(0)`` (4 x 4), exact."""
        wt = self.omega * t
        c0, c1 = np.cos(wt).tolist()
        s0, s1 = np.sin(wt).tolist()
        w0, w1 = self._omega_floats
        # the three distinct 2 x 2 blocks Phi diag(.) Phi^T M in one stacked product (the same numbers
        # as three products): cos, sin / omega and -omega sin of each mode
        (p00, p01), (p10, p11) = self._projection_floats
        scaled = [
            ((d0 * p00, d0 * p01), (d1 * p10, d1 * p11))
            for d0, d1 in ((c0, c1), (s0 / w0, s1 / w1), (-w0 * s0, -w1 * s1))
        ]
        (c, s, m) = (self.modes @ np.array(scaled)).tolist()
        return np.array((c[0] + s[0], c[1] + s[1], m[0] + c[0], m[1] + c[1]))

    def transitions(self, t) -> np.ndarray:
        """Transition matrices at the times ``t`` (1-D array), shape ``(len(t), 4, 4)``.

        The numbers of :meth:`transition` at each time, in stacked products.
        """
        t = np.asarray(t, dtype=float)
        wt = np.multiply.outer(t, self.omega)
        s = np.sin(wt)
        diagonals = np.stack((np.cos(wt), s / self.omega, -self.omega * s), axis=1)
        blocks = self.modes @ (diagonals[..., None] * self.projection)
        out = np.empty((t.size, 4, 4))
        out[:, :2, :2] = out[:, 2:, 2:] = blocks[:, 0]
        out[:, :2, 2:] = blocks[:, 1]
        out[:, 2:, :2] = blocks[:, 2]
        return out

    def field(self, z) -> np.ndarray:
        """Time derivative ``(xdot, udot, xddot, uddot)`` of the state ``z`` (last axis)."""
        z = np.asarray(z, dtype=float)
        rhs = self.force - z[..., :2] @ self.stiffness.T
        if self._mass_diagonal is not None:  # M = diag(1, delta): the solve is a division
            acc = rhs / self._mass_diagonal
        else:
            acc = np.linalg.solve(self.mass, rhs.T).T
        out = np.empty(z.shape)
        out[..., :2] = z[..., 2:]
        out[..., 2:] = acc
        return out


def check_sequence_model(model):
    """``model`` if the phase sequences apply to it, else a ValueError naming what is not supported.

    The paper's oscillator (:class:`~nnmstop.models.two_dof.ModelParameters`), or a
    :class:`~nnmstop.models.structure.Structure` with two degrees of freedom and one stop, on the first,
    with gap 1 (lengths made nondimensional by the gap). The closed-form phases of the sequences are
    written for two degrees of freedom; the one-impact family of any structure is
    :func:`nnmstop.exact.ndof.follow_one_stop_family`.
    """
    if isinstance(model, ModelParameters):
        return model
    missing = []
    if getattr(model, "n_dofs", None) != 2:
        missing.append(f"{getattr(model, 'n_dofs', '?')} degrees of freedom (2 are supported)")
    stops = getattr(model, "stops", ())
    if len(stops) != 1:
        missing.append(f"{len(stops)} stops (one is supported)")
    elif stops[0].dof != 0 or stops[0].gap != 1.0:
        missing.append(f"a stop on degree of freedom {stops[0].dof} with gap {stops[0].gap:g} (dof 0, gap 1)")
    if missing:
        raise ValueError(
            "the phase sequences with several impacts per stop are implemented for the 2-DOF oscillator only; "
            f"this structure has {', '.join(missing)}; its one-impact family: "
            "nnmstop.exact.ndof.follow_one_stop_family"
        )
    return model


def phase_of(model, kind: str) -> LinearPhase:
    """The linear phase ``kind`` (``"F"``, ``"R"`` or ``"L"``, see :data:`PHASE_NAMES`) of ``model``
    (:func:`check_sequence_model`)."""
    model = check_sequence_model(model)
    if kind not in PHASE_NAMES:
        raise ValueError(f"unknown phase {kind!r}; use one of {sorted(PHASE_NAMES)}")
    if isinstance(model, ModelParameters):
        return LinearPhase.free_flight(model) if kind == "F" else LinearPhase.contact(model, STOP_SIDE[kind])
    mass, stiffness = (np.asarray(m, dtype=float) for m in model.dense_matrices())
    if kind == "F":
        return LinearPhase(mass, stiffness, np.zeros(2))
    alpha = model.stops[0].stiffness
    contact = stiffness.copy()
    contact[0, 0] += alpha
    return LinearPhase(mass, contact, np.array([STOP_SIDE[kind] * alpha, 0.0]))


def stop_stiffness(model) -> float:
    """The stop stiffness ``alpha`` of a sequence model."""
    model = check_sequence_model(model)
    return model.alpha if isinstance(model, ModelParameters) else model.stops[0].stiffness


def interior_extrema(phase: LinearPhase, z0, duration: float, samples_per_period: int = 64):
    """Interior extrema of x over ``(0, duration)`` of a linear phase: times and states.

    Sign changes of the closed-form xdot on a grid of ``samples_per_period`` samples per
    period of the fastest mode, refined by Brent's method to round-off; times in
    increasing order. Two extrema closer than one grid interval (a nearly degenerate
    inflection) would be missed; with 64 samples per period their amplitude is negligible.
    """
    if not duration > 0:
        return np.empty(0), np.empty((0, 4))
    n = samples_per_period * max(1, math.ceil(duration * phase._omega_max / (2 * np.pi))) + 1
    t = np.linspace(0.0, duration, n)
    xdot = phase.velocities(z0, t)
    signs = np.sign(xdot)
    changes = np.flatnonzero(signs[:-1] * signs[1:] < 0)
    times = list(t[1:-1][xdot[1:-1] == 0.0])
    if changes.size:
        velocity = phase.velocity_function(z0)
        times.extend(scipy.optimize.brentq(velocity, t[i], t[i + 1], xtol=1e-15, rtol=4 * _ROUND_OFF) for i in changes)
    # discard the end points themselves (they are not interior extrema)
    tol = 1e-12 * max(duration, 1.0)
    times = np.array(sorted(s for s in times if tol < s < duration - tol))
    if times.size == 0:
        return times, np.empty((0, 4))
    return times, phase.state(z0, times)


class OrbitTimeHistory(NamedTuple):
    """Full-period time history of an exact orbit (all arrays have the shape of ``t``)."""

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    xdot: np.ndarray
    udot: np.ndarray
    force: np.ndarray


def unfold_quarter_states(quarter_state, quarter: float, t) -> np.ndarray:
    """Full-period states ``(q, qdot)`` (last axis, ``2N``) at times ``t`` from the quarter period ``[0, quarter]``.

    ``quarter_state(r)`` gives the states at times ``r`` of the quarter period (last axis, positions
    then velocities, any number ``N`` of degrees of freedom). The NNM symmetries unfold it: the mirror
    ``q(T1 + s) = q(T1 - s)`` (velocities change sign) and the half-period shift
    ``q(t + T/2) = -q(t)``; ``t`` may be any real times (the orbit is ``4 quarter``-periodic).
    """
    t = np.asarray(t, dtype=float)
    period = 4.0 * quarter
    s = np.mod(t, period)
    second_half = s >= 0.5 * period
    s = np.where(second_half, s - 0.5 * period, s)
    mirrored = s > quarter
    r = np.where(mirrored, 2.0 * quarter - s, s)
    z = np.asarray(quarter_state(np.clip(r, 0.0, quarter)))
    n = z.shape[-1] // 2
    sign_q = np.where(second_half, -1.0, 1.0)[..., None]
    sign_v = sign_q * np.where(mirrored, -1.0, 1.0)[..., None]
    return np.concatenate([sign_q * z[..., :n], sign_v * z[..., n:]], axis=-1)


def unfold_quarter(quarter_state, quarter: float, t, alpha: float) -> OrbitTimeHistory:
    """Full-period time history of the 2-DOF system at times ``t`` from the quarter period ``[0, quarter]``.

    ``quarter_state(r)`` gives the states ``(x, u, xdot, udot)`` at times ``r`` of the
    quarter period (last axis), unfolded by :func:`unfold_quarter_states`. The contact force
    is the piecewise-linear law, Eq. (4).
    """
    t = np.asarray(t, dtype=float)
    z = unfold_quarter_states(quarter_state, quarter, t)
    x, u, xdot, udot = z[..., 0], z[..., 1], z[..., 2], z[..., 3]
    return OrbitTimeHistory(t, x, u, xdot, udot, piecewise_contact_force(x, alpha))
