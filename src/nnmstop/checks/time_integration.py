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
* :func:`integrate_structure_regularized`: any structure with the regularized law of each of its stops (any
  kind, :mod:`nnmstop.models.contact`).
* :func:`integrate_structure_piecewise`: any structure whose stops are piecewise linear (bilateral, one-sided,
  relative), every contact entry and exit located as an event.

The 2-DOF integrators take the state ``z = (x, u, xdot, udot)`` at ``t_eval[0]``, the structure's the
state ``(q, qdot)``, and return it at every requested time.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters, linear_modes, regularized_vector_field

__all__ = [
    "Trajectory",
    "integrate_nonsmooth",
    "integrate_regularized",
    "integrate_structure_nonsmooth",
    "integrate_structure_regularized",
    "integrate_structure_piecewise",
]


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

    :func:`integrate_structure_nonsmooth` on the paper's oscillator
    (:func:`nnmstop.models.structure.two_dof_structure`): in each region (free flight, contact with either
    stop) the equations are linear; each crossing of ``x = +-1`` out of the region is a terminal event, and
    the integration restarts from the located event state in the neighbouring region. A grazing contact
    (zero normal velocity at a stop) is handled by the direction of the free acceleration but is inherently
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
    if max_step is None:
        max_step = 2.0 * np.pi / linear_modes(params, "gap_zero")[0][-1] / 200.0
    return integrate_structure_nonsmooth(
        two_dof_structure(params), z0, t_eval, rtol=rtol, atol=atol, max_step=max_step, max_switches=max_switches
    )


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


def _checked_start(z0, t_eval, n: int):
    """``z0`` (2N finite numbers) and ``t_eval`` (non-empty, finite, increasing) as float arrays."""
    z0, t_eval = np.asarray(z0, dtype=float), np.asarray(t_eval, dtype=float)
    if z0.shape != (2 * n,) or not np.all(np.isfinite(z0)):
        raise ValueError(f"z0 must be 2N = {2 * n} finite numbers (q, qdot), got shape {z0.shape}")
    if t_eval.ndim != 1 or t_eval.size < 1 or np.any(np.diff(t_eval) < 0) or not np.all(np.isfinite(t_eval)):
        raise ValueError("t_eval must be a non-empty 1-D array of finite increasing times")
    return z0, t_eval


def _crossing_event(dof: int, level: float, direction: float):
    """A terminal event of ``solve_ivp``: ``q[dof]`` crosses ``level`` in ``direction``."""

    def event(_t, z):
        return z[dof] - level

    event.terminal, event.direction = True, direction
    return event


def integrate_structure_nonsmooth(
    structure,
    z0,
    t_eval,
    stop_index: int = 0,
    rtol: float = 1e-12,
    atol: float = 1e-12,
    max_step: float = np.inf,
    max_switches: int = 100000,
) -> Trajectory:
    """Integrate ``M q'' + K q + e_c f(q_c) = 0`` (stop ``stop_index``, piecewise-linear law) with DOP853.

    Region by region (free flight, contact at ``+gap``, contact at ``-gap``); each crossing of the stop
    coordinate out of its region is a terminal event located by DOP853, where the integration restarts in the
    next region from the located state (the stop coordinate put exactly on the gap), so no step ever
    straddles the kink of the contact law. A start on the gap is in contact when it moves (or, at rest,
    accelerates) outwards.

    Parameters
    ----------
    structure : Structure
    z0 : array_like, shape (2N,)
        ``(q, qdot)`` at ``t_eval[0]``.
    t_eval : array_like
        Increasing output times.
    stop_index : int
        The struck stop.
    rtol, atol : float
        Tolerances of DOP853.
    max_step : float
        Largest step of DOP853.
    max_switches : int
        Safety limit on the number of restarts.

    Returns
    -------
    Trajectory
        ``switch_times`` and ``switch_sides`` of every crossing.
    """
    mass, stiffness = (np.asarray(m, dtype=float) for m in structure.dense_matrices())
    stop = structure.stops[stop_index]
    n, c, gap, alpha = structure.n_dofs, stop.dof, stop.gap, stop.stiffness
    z0, t_eval = _checked_start(z0, t_eval, n)
    minv_k, minv_e = np.linalg.solve(mass, stiffness), np.linalg.solve(mass, np.eye(n)[c])

    def rhs(side):
        def field(_t, z):
            force = alpha * (z[c] - side * gap) if side else 0.0
            return np.concatenate([z[n:], -minv_k @ z[:n] - force * minv_e])

        return field

    def leaving(level, direction):
        return _crossing_event(c, level, direction)

    t, z = float(t_eval[0]), z0.copy()
    side = _start_region(z, gap, float(-(minv_k @ z[:n])[c]), c, n)
    out, k, times, sides = np.empty((t_eval.size, 2 * n)), 1, [], []
    out[0] = z0
    while k < t_eval.size:
        if len(times) > max_switches:
            raise RuntimeError(f"more than max_switches={max_switches} stop crossings; grazing chatter?")
        events = [leaving(gap, 1.0), leaving(-gap, -1.0)] if side == 0 else [leaving(side * gap, -side)]
        sol = solve_ivp(
            rhs(side),
            (t, t_eval[-1]),
            z,
            method="DOP853",
            rtol=rtol,
            atol=atol,
            events=events,
            t_eval=t_eval[k:],
            max_step=max_step,
        )
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        n_out = np.asarray(sol.t).size  # with t_eval, plain empty lists when no output time was reached
        if n_out:
            out[k : k + n_out] = np.asarray(sol.y).reshape(2 * n, n_out).T
        k += n_out
        if sol.status != 1:
            if k < t_eval.size:  # pragma: no cover - solve_ivp reached the end without output
                raise RuntimeError("integration ended before the last requested time")
            continue
        which = next(i for i, te in enumerate(sol.t_events) if te.size)
        t, z = float(sol.t_events[which][0]), sol.y_events[which][0].copy()
        level = gap if (side == 0 and which == 0) or side == 1 else -gap
        z[c] = level  # exactly on the stop
        side = (1 if which == 0 else -1) if side == 0 else 0
        times.append(t)
        sides.append(side)
    return Trajectory(t_eval, out, np.array(times), np.array(sides, dtype=int))


def _start_region(z, gap: float, free_acceleration: float, c: int, n: int) -> int:
    """The region of a start ``z``: +-1 in contact, 0 in free flight; on the gap the motion decides."""
    q, v = z[c], z[n + c]
    if abs(q) != gap:
        return int(np.sign(q)) if abs(q) > gap else 0
    outwards = np.sign(q) * v > 0 or (v == 0 and np.sign(q) * free_acceleration > 0)
    return int(np.sign(q)) if outwards else 0


def integrate_structure_regularized(structure, z0, t_eval, rtol: float = 1e-12, atol: float = 1e-13) -> Trajectory:
    """States ``(q, qdot)`` of any structure with the regularized laws of its stops, at ``t_eval`` (DOP853).

    ``M q'' + K q + sum_s gap_s A_s^T f_s(A_s q / gap_s) = 0`` with each stop's own law
    (:meth:`nnmstop.models.contact.StopSet.forces`): bilateral, one-sided, relative or circular. ``z0`` is the
    state at ``t_eval[0]``; no switch times (the law is smooth).
    """
    mass, stiffness = (np.asarray(m, dtype=float) for m in structure.dense_matrices())
    n = structure.n_dofs
    z0, t_eval = _checked_start(z0, t_eval, n)
    minv = np.linalg.inv(mass)
    contact = structure.contact

    def field(_t, z):
        q = z[:n]
        force = stiffness @ q
        contact.apply(force, contact.forces(contact.coordinates(q)))
        return np.concatenate([z[n:], -minv @ force])

    if t_eval.size == 1:
        return Trajectory(t_eval, z0[None, :].copy(), np.zeros(0), np.zeros(0, dtype=int))
    sol = solve_ivp(field, (t_eval[0], t_eval[-1]), z0, method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    if sol.status < 0:
        raise RuntimeError(f"solve_ivp failed: {sol.message}")
    return Trajectory(t_eval, sol.y.T, np.zeros(0), np.zeros(0, dtype=int))


def integrate_structure_piecewise(
    structure, z0, t_eval, rtol: float = 1e-12, atol: float = 1e-13, max_switches: int = 10000
) -> Trajectory:
    """States ``(q, qdot)`` of any structure with piecewise-linear stops, every contact entry and exit an event.

    The contacts are the half-spaces ``n . q >= gap`` of every stop (:meth:`nnmstop.models.contact.Stop.contacts`:
    bilateral, one-sided and relative stops); within a region (a set of active contacts) the equations are
    linear and DOP853 never steps across a kink: each crossing of a contact's boundary ends the integration, which
    restarts from the located state (put exactly on the boundary) in the new region. ``switch_times`` and
    ``switch_sides`` (+1 entering, -1 leaving, times the contact index + 1) record every crossing.
    """
    mass, stiffness = (np.asarray(m, dtype=float) for m in structure.dense_matrices())
    n = structure.n_dofs
    z0, t_eval = _checked_start(z0, t_eval, n)
    contacts = tuple(c for k, stop in enumerate(structure.stops) for c in stop.contacts(k))
    normals = np.array([c.normal(n) for c in contacts])
    gaps = np.array([c.gap for c in contacts])
    alphas = np.array([c.alpha for c in contacts])
    minv = np.linalg.inv(mass)

    def region_of(z):
        # on a boundary to round-off the motion decides: a start state leaving a contact is outside it
        level, rate = normals @ z[:n] - gaps, normals @ z[n:]
        on = np.abs(level) <= 1e-12 * gaps
        return np.where(on, rate > 0, level > 0)

    def field_of(active):
        k = stiffness + (normals[active].T * alphas[active]) @ normals[active]
        load = normals[active].T @ (alphas[active] * gaps[active])
        return lambda _t, z: np.concatenate([z[n:], minv @ (load - k @ z[:n])])

    def crossing(j, direction):
        def event(_t, z):
            return normals[j] @ z[:n] - gaps[j]

        event.terminal, event.direction = True, direction
        return event

    t, z, active = float(t_eval[0]), z0.copy(), region_of(z0)
    out, k, times, sides = np.empty((t_eval.size, 2 * n)), 1, [], []
    out[0] = z0
    while k < t_eval.size:
        if len(times) > max_switches:
            raise RuntimeError(f"more than max_switches={max_switches} contact crossings; grazing chatter?")
        events = [crossing(j, -1.0 if active[j] else 1.0) for j in range(len(contacts))]
        sol = solve_ivp(
            field_of(active),
            (t, t_eval[-1]),
            z,
            method="DOP853",
            rtol=rtol,
            atol=atol,
            events=events,
            t_eval=t_eval[k:],
        )
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        count = np.asarray(sol.t).size
        if count:
            out[k : k + count] = np.asarray(sol.y).reshape(2 * n, count).T
        k += count
        if sol.status != 1:
            continue
        j = next(i for i, te in enumerate(sol.t_events) if te.size)
        t, z = float(sol.t_events[j][0]), sol.y_events[j][0].copy()
        active = active.copy()
        active[j] = not active[j]
        times.append(t)
        sides.append((j + 1) * (1 if active[j] else -1))
    return Trajectory(t_eval, out, np.array(times), np.array(sides, dtype=int))
