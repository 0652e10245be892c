"""Independent time-domain integrators, used as cross-checks of the closed-form orbits.

Nothing in :mod:`nnmstop.exact` uses this module: the point is to check the closed-form
construction against a different method.

* :func:`integrate_nonsmooth`: Eqs. (3)-(4) with :func:`scipy.integrate.solve_ivp`
  (DOP853), locating the crossings of ``x = +-1`` as terminal events and restarting
  the integration in the new linear phase at each of them, so that the integrator never
  steps across the kink of the contact law.
* :func:`integrate_regularized`: Eq. (7) with the smooth regularized contact force
  (:func:`nnmstop.models.two_dof.regularized_vector_field`).
* :func:`integrate_structure_nonsmooth`: any :class:`~nnmstop.models.structure.Structure` with one struck
  stop and the piecewise-linear law, region by region in the same way (the other stops stay passive).

The 2-DOF integrators take the state ``z = (x, u, xdot, udot)`` at ``t_eval[0]``, the structure's the
state ``(q, qdot)``, and return it at every requested time.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from nnmstop.models.two_dof import ModelParameters, linear_modes, regularized_vector_field

__all__ = ["Trajectory", "integrate_nonsmooth", "integrate_regularized", "integrate_structure_nonsmooth"]


class Trajectory(NamedTuple):
    """States at the requested times.

    Attributes
    ----------
    t : ndarray, shape (n,)
    states : ndarray, shape (n, 4)
        ``(x, u, xdot, udot)`` at each time.
    switch_times : ndarray
        Times where x crossed a stop (empty for the regularized system).
    switch_sides : ndarray
        For :func:`integrate_structure_nonsmooth`: +1 (-1) where the stop coordinate entered the stop at
        ``+gap`` (``-gap``), 0 where it left it; empty otherwise.
    """

    t: np.ndarray
    states: np.ndarray
    switch_times: np.ndarray
    switch_sides: np.ndarray = np.empty(0)


def _check_inputs(z0, t_eval):
    z0 = np.asarray(z0, dtype=float)
    if z0.shape != (4,) or not np.all(np.isfinite(z0)):
        raise ValueError(f"z0 must be 4 finite numbers (x, u, xdot, udot), got {z0!r}")
    t_eval = np.asarray(t_eval, dtype=float)
    if t_eval.ndim != 1 or t_eval.size < 1 or not np.all(np.isfinite(t_eval)):
        raise ValueError(f"t_eval must be a non-empty 1-D array of finite times, got {t_eval!r}")
    if np.any(np.diff(t_eval) < 0):
        raise ValueError("t_eval must be sorted in increasing order")
    return z0, t_eval


def _region(x, xdot, acc_free):
    """Which linear phase applies: -1 (left stop), 0 (free flight), +1 (right stop).

    On a boundary the direction of motion decides (the acceleration if the velocity is 0).
    """
    if x > 1.0:
        return 1
    if x < -1.0:
        return -1
    if x == 1.0:
        return 1 if (xdot > 0 or (xdot == 0 and acc_free > 0)) else 0
    if x == -1.0:
        return -1 if (xdot < 0 or (xdot == 0 and acc_free < 0)) else 0
    return 0


def integrate_nonsmooth(
    params: ModelParameters,
    z0,
    t_eval,
    rtol: float = 1e-12,
    atol: float = 1e-13,
    max_step: float | None = None,
    max_switches: int = 100000,
) -> Trajectory:
    """Integrate the non-smooth system (3)-(4) with event location at ``x = +-1``.

    In region ``r`` (-1, 0 or +1) the equations are linear:
    ``x'' = -(1 + beta) x + beta u - alpha (x - r) [r != 0]``,
    ``u'' = beta (x - u) / delta``. Each crossing of ``x = r_boundary`` in the direction
    that leaves the region is a terminal event; the integration restarts from the located
    event state in the neighbouring region. A grazing contact (zero normal velocity at a
    stop) is handled by the direction of the free acceleration but is inherently
    ill-conditioned for any event-driven scheme.

    Parameters
    ----------
    params : ModelParameters
    z0 : array_like, shape (4,)
        State at ``t_eval[0]``.
    t_eval : array_like, shape (n,)
        Increasing output times.
    rtol, atol : float
        Tolerances of DOP853.
    max_step : float, optional
        Largest step; by default 1/200 of the shortest linear period of the contact phase.
    max_switches : int
        Safety limit on the number of restarts.

    Returns
    -------
    Trajectory
    """
    z0, t_eval = _check_inputs(z0, t_eval)
    a, b, d = params.alpha, params.beta, params.delta
    if max_step is None:
        max_step = 2.0 * np.pi / linear_modes(params, "gap_zero")[0][-1] / 200.0
    if not max_step > 0:
        raise ValueError(f"max_step must be > 0, got {max_step!r}")

    def rhs_for(region):
        def rhs(_t, z):
            x, u, xd, ud = z
            acc = -(1.0 + b) * x + b * u
            if region != 0:
                acc -= a * (x - region)
            return [xd, ud, acc, b * (x - u) / d]

        return rhs

    def event_for(level, direction):
        def event(_t, z):
            return z[0] - level

        event.terminal = True
        event.direction = direction
        return event

    events = {
        0: [event_for(1.0, 1.0), event_for(-1.0, -1.0)],
        1: [event_for(1.0, -1.0)],
        -1: [event_for(-1.0, 1.0)],
    }
    next_region = {(0, 0): 1, (0, 1): -1, (1, 0): 0, (-1, 0): 0}

    t, z = float(t_eval[0]), z0.copy()
    region = _region(z[0], z[2], -(1.0 + b) * z[0] + b * z[1])
    out = np.empty((t_eval.size, 4))
    out[0] = z0
    k = 1  # next output index
    switches = []
    while k < t_eval.size:
        if len(switches) > max_switches:
            raise RuntimeError(f"more than max_switches={max_switches} stop crossings; grazing chatter?")
        sol = solve_ivp(
            rhs_for(region),
            (t, t_eval[-1]),
            z,
            method="DOP853",
            rtol=rtol,
            atol=atol,
            events=events[region],
            t_eval=t_eval[k:],
            max_step=max_step,
        )
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        # with t_eval, solve_ivp returns plain empty lists when no output time was reached
        n_out = np.asarray(sol.t).size
        if n_out:
            out[k : k + n_out] = np.asarray(sol.y).reshape(4, n_out).T
        k += n_out
        if sol.status == 1:  # a terminal event
            which = next(i for i, te in enumerate(sol.t_events) if te.size)
            t = float(sol.t_events[which][0])
            z = sol.y_events[which][0].copy()
            z[0] = 1.0 if (region, which) in ((0, 0), (1, 0)) else -1.0  # exactly on the stop
            region = next_region[(region, which)]
            switches.append(t)
        elif k < t_eval.size:  # pragma: no cover - solve_ivp reached the end without output
            raise RuntimeError("integration ended before the last requested time")
    return Trajectory(t_eval, out, np.array(switches))


def integrate_regularized(params: ModelParameters, z0, t_eval, rtol: float = 1e-12, atol: float = 1e-13) -> Trajectory:
    """Integrate the regularized system (7) with DOP853.

    Parameters
    ----------
    params : ModelParameters
        ``eta`` sets the regularization.
    z0 : array_like, shape (4,)
        State at ``t_eval[0]``.
    t_eval : array_like, shape (n,)
        Increasing output times.
    rtol, atol : float
        Tolerances of DOP853.

    Returns
    -------
    Trajectory
    """
    z0, t_eval = _check_inputs(z0, t_eval)

    def rhs(_t, z):
        return regularized_vector_field(z, params)

    if t_eval.size == 1:
        return Trajectory(t_eval, z0[None, :].copy(), np.empty(0))
    sol = solve_ivp(rhs, (t_eval[0], t_eval[-1]), z0, method="DOP853", rtol=rtol, atol=atol, t_eval=t_eval)
    if sol.status != 0:
        raise RuntimeError(f"solve_ivp failed: {sol.message}")
    return Trajectory(t_eval, sol.y.T, np.empty(0))


def integrate_structure_nonsmooth(
    structure, z0, t_eval, stop_index: int = 0, rtol: float = 1e-12, atol: float = 1e-12
) -> Trajectory:
    """Integrate ``M q'' + K q + e_c f(q_c) = 0`` (stop ``stop_index``, piecewise-linear law) with DOP853.

    Region by region (free flight, contact at ``+gap``, contact at ``-gap``); each crossing of the stop
    coordinate out of its region is a terminal event located by DOP853, where the integration restarts in the
    next region, so no step ever straddles the kink of the contact law.

    Parameters
    ----------
    structure : Structure
    z0 : array_like, shape (2N,)
        ``(q, qdot)`` at ``t_eval[0]``; the stop coordinate must not sit exactly on the gap.
    t_eval : array_like
        Increasing output times.
    stop_index : int
        The struck stop.
    rtol, atol : float
        Tolerances of DOP853.

    Returns
    -------
    Trajectory
        ``switch_times`` and ``switch_sides`` of every crossing.
    """
    mass, stiffness = structure.dense_matrices()
    stop = structure.stops[stop_index]
    n, c, gap, alpha = structure.n_dofs, stop.dof, stop.gap, stop.stiffness
    z0, t_eval = np.asarray(z0, dtype=float), np.asarray(t_eval, dtype=float)
    if z0.shape != (2 * n,) or not np.all(np.isfinite(z0)):
        raise ValueError(f"z0 must be 2N = {2 * n} finite numbers (q, qdot), got shape {z0.shape}")
    if t_eval.ndim != 1 or t_eval.size < 2 or np.any(np.diff(t_eval) <= 0):
        raise ValueError("t_eval must be at least two increasing times")
    minv_k, minv_e = np.linalg.solve(mass, stiffness), np.linalg.solve(mass, np.eye(n)[c])

    def rhs(side):
        def field(_t, z):
            force = alpha * (z[c] - side * gap) if side else 0.0
            return np.concatenate([z[n:], -minv_k @ z[:n] - force * minv_e])

        return field

    def leaving(level, direction):
        def event(_t, z):
            return z[c] - level

        event.terminal, event.direction = True, direction
        return event

    t, z, side = float(t_eval[0]), z0.copy(), int(np.sign(z0[c])) if abs(z0[c]) > gap else 0
    out, k, times, sides = np.empty((t_eval.size, 2 * n)), 1, [], []
    out[0] = z0
    while k < t_eval.size:
        events = [leaving(gap, 1.0), leaving(-gap, -1.0)] if side == 0 else [leaving(side * gap, -side)]
        sol = solve_ivp(
            rhs(side), (t, t_eval[-1]), z, method="DOP853", rtol=rtol, atol=atol, events=events, t_eval=t_eval[k:]
        )
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        n_out = np.asarray(sol.t).size
        if n_out:
            out[k : k + n_out] = np.asarray(sol.y).reshape(2 * n, n_out).T
        k += n_out
        if sol.status != 1:
            continue
        which = next(i for i, te in enumerate(sol.t_events) if te.size)
        t, z = float(sol.t_events[which][0]), sol.y_events[which][0].copy()
        side = (1 if which == 0 else -1) if side == 0 else 0
        times.append(t)
        sides.append(side)
    return Trajectory(t_eval, out, np.array(times), np.array(sides))
