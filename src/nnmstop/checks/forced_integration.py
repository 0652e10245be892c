"""Time integration of the forced, damped structure, as an independent check of the forced responses.

``M q'' + C q' + K q + sum_s e_s f_s(q_s / e_s) = F cos(Omega t) b`` integrated by
:func:`scipy.integrate.solve_ivp` (DOP853) for any :class:`~nnmstop.models.excitation.Excitation`:

* :func:`integrate_forced_nonsmooth`: the piecewise-linear law of every stop, as its half-space contacts
  (:meth:`nnmstop.models.contact.StopSet.contacts`: a bilateral stop's two sides, a one-sided stop, a relative
  stop on ``q_i - q_j``); every crossing of a switching surface ``n . q = g`` is a terminal event, and the
  integration restarts from the located state with that contact toggled, so the integrator never steps across a
  kink of the law;
* :func:`integrate_forced_regularized`: the smooth regularized law of every stop (Eq. 5 with the sign slip
  corrected for the paper's stop; :mod:`nnmstop.models.contact` for the others).

Nothing in :mod:`nnmstop.exact` or :mod:`nnmstop.hbm` uses this module.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
from scipy.integrate import solve_ivp

from nnmstop.models.excitation import Excitation

__all__ = ["integrate_forced_nonsmooth", "integrate_forced_regularized", "period_map"]


def _matrices(excitation: Excitation):
    M, K = excitation.structure.dense_matrices()
    C = excitation.damping_matrix
    C = C.toarray() if scipy.sparse.issparse(C) else np.asarray(C, dtype=float)
    return np.linalg.inv(M), K, C


def integrate_forced_regularized(excitation: Excitation, omega: float, z0, t_eval, rtol=1e-12, atol=1e-13):
    """States ``(q, qdot)`` at ``t_eval`` (shape (len, 2N)) from ``z0`` at ``t_eval[0]``, the regularized law of
    every stop (any kind, :meth:`nnmstop.models.contact.StopSet.forces`)."""
    m_inv, K, C = _matrices(excitation)
    contact = excitation.structure.contact
    load = excitation.load
    n = len(load)

    def rhs(t, z):
        q, v = z[:n], z[n:]
        restoring = K @ q + C @ v
        contact.apply(restoring, contact.forces(contact.coordinates(q)))
        return np.concatenate([v, m_inv @ (load * np.cos(omega * t) - restoring)])

    t_eval = np.asarray(t_eval, dtype=float)
    sol = solve_ivp(
        rhs, (t_eval[0], t_eval[-1]), np.asarray(z0, dtype=float), method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol
    )
    if sol.status < 0:
        raise RuntimeError(f"solve_ivp failed: {sol.message}")
    return sol.y.T


def integrate_forced_nonsmooth(
    excitation: Excitation, omega: float, z0, t_eval, rtol=1e-12, atol=1e-13, max_switches: int = 100000
):
    """States ``(q, qdot)`` at ``t_eval`` from ``z0`` at ``t_eval[0]``, piecewise-linear law, event-located switches.

    Returns the states (len, 2N) and the switching times. The contacts active at the start are those whose
    coordinate is beyond the gap (or on it, moving in).
    """
    m_inv, K, C = _matrices(excitation)
    contacts = excitation.structure.contact.contacts()
    load = excitation.load
    n = len(load)
    normals = np.array([c.normal(n) for c in contacts])
    gaps = np.array([c.gap for c in contacts])
    alphas = np.array([c.alpha for c in contacts])
    t_eval = np.asarray(t_eval, dtype=float)
    z = np.asarray(z0, dtype=float).copy()
    t = float(t_eval[0])
    out = np.empty((len(t_eval), 2 * n))
    out[0] = z
    c_q, c_v = normals @ z[:n], normals @ z[n:]
    active = (c_q > gaps) | ((c_q == gaps) & (c_v > 0))
    k, switches = 1, []
    while k < len(t_eval):
        if len(switches) > max_switches:
            raise RuntimeError(f"more than max_switches={max_switches} stop crossings; grazing chatter?")

        stiff = alphas * active  # the contacts' stiffness in this linear region

        def rhs(time, y, stiff=stiff):
            q, v = y[:n], y[n:]
            force = load * np.cos(omega * time) - K @ q - C @ v
            force -= (stiff * (normals @ q - gaps)) @ normals
            return np.concatenate([v, m_inv @ force])

        events = []
        for normal, gap, on in zip(normals, gaps, active):

            def event(time, y, normal=normal, gap=gap):
                return normal @ y[:n] - gap

            event.terminal, event.direction = True, (-1.0 if on else 1.0)
            events.append(event)
        sol = solve_ivp(
            rhs, (t, t_eval[-1]), z, method="DOP853", t_eval=t_eval[k:], rtol=rtol, atol=atol, events=events
        )
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        count = np.asarray(sol.t).size
        if count:
            out[k : k + count] = np.asarray(sol.y).reshape(2 * n, count).T
        k += count
        if sol.status == 1:
            which = next(i for i, te in enumerate(sol.t_events) if te.size)
            t = float(sol.t_events[which][0])
            z = sol.y_events[which][0].copy()
            active[which] = not active[which]
            switches.append(t)
    return out, np.array(switches)


def period_map(integrate, excitation: Excitation, omega: float, z0, periods: int, samples_per_period: int = 1):
    """States at ``t = k 2 pi / omega``, ``k = 0..periods`` (the stroboscopic map), from ``z0`` at ``t = 0``."""
    t = np.arange(periods * samples_per_period + 1) * (2 * np.pi / omega) / samples_per_period
    states = integrate(excitation, omega, z0, t)
    return states[0] if isinstance(states, tuple) else states
