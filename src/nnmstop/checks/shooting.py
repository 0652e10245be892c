"""Independent check of Floquet multipliers: exact periodic orbits of (7) and their monodromy matrix.

Used by the tests and calibration benchmarks, never by the pipeline. Hill's method
(:mod:`nnmstop.hbm.hill`) and the Magnus monodromy (:mod:`nnmstop.hbm.monodromy`) work on the
HBM orbit; this module goes back to the equations of motion (7):

* :func:`orbit_initial_state`: the state ``(x, u, xdot, udot)`` of an HBM orbit at ``t = 0`` and its period;
* :func:`refine_orbit`: shooting on ``(u(0), T)`` at fixed ``x(0)`` to an exact time-reversible periodic orbit of (7);
* :func:`monodromy`: the monodromy matrix by integrating (7) and its variational equations with DOP853.

Started from the HBM state the monodromy inherits the HBM orbit's error (amplified over the period on
unstable orbits); after :func:`refine_orbit` its multipliers are references for both HBM-based methods.
The regularized force is evaluated through the exact rational parametrization of the cubic's admissible
root (see ``docs/methods/hill.md``), which keeps the integration fast.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from nnmstop import fourier
from nnmstop.continuation.newton import newton_solve
from nnmstop.hbm.hill import check_unknowns
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force

__all__ = ["MonodromyResult", "orbit_initial_state", "monodromy", "refine_orbit"]


@dataclass(frozen=True)
class MonodromyResult:
    """Monodromy matrix of the regularized equations (7) over one period.

    Attributes
    ----------
    matrix : ndarray, shape (4, 4)
        ``dz(T)/dz(0)`` for the state ``z = (x, u, xdot, udot)``.
    multipliers : ndarray of complex, shape (4,)
        Its eigenvalues, sorted by decreasing modulus.
    final_state : ndarray, shape (4,)
        The state after one period.
    closure : float
        ``|z(T) - z(0)| / |z(0)|``: how periodic the start state is for (7).
    """

    matrix: np.ndarray
    multipliers: np.ndarray
    final_state: np.ndarray
    closure: float


def orbit_initial_state(system, U):
    """State ``(x, u, xdot, udot)`` of an HBM orbit at ``t = 0`` and its period ``T``."""
    U = check_unknowns(system, U)
    x, u, _, _, lam, _ = system.split(U)
    omega = float(np.sqrt(lam))
    pairs = {"x": fourier.to_cos_sin(x, system.H), "u": fourier.to_cos_sin(u, system.H)}
    at_start = fourier.fields_at_phases([0.0], omega, pairs)
    state = np.array([at_start[name][0] for name in ("x", "u", "xdot", "udot")])
    return state, 2 * np.pi / omega


def _check_params(params):
    if not isinstance(params, ModelParameters):
        raise ValueError(f"params must be a ModelParameters, got {type(params).__name__}")


def _check_state(state0):
    z0 = np.asarray(state0, dtype=float)
    if z0.shape != (4,) or not np.all(np.isfinite(z0)):
        raise ValueError(f"state0 must be 4 finite numbers (x, u, xdot, udot), got {state0!r}")
    return z0


def _check_period(period):
    if not (np.isfinite(period) and period > 0):
        raise ValueError(f"period must be finite and > 0, got {period!r}")
    return float(period)


def _variational_flow(params: ModelParameters, z0, t_end, rtol, atol):
    """State and fundamental matrix of (7) at ``t_end`` (DOP853).

    The regularized force is the admissible root of the cubic; instead of solving the
    cubic at every evaluation, the integrated displacement of the first mass is the
    branch coordinate ``y = x - f/alpha`` (``= -g`` of :mod:`nnmstop.models.two_dof`), from
    which the exact rational parametrization gives, with ``s = c - y**2``,
    ``c = 1 - eps``::

        x = y + eps y / s,   f = eta y / s,   f'(x) = eta (c + y**2) / (s**2 + eps (c + y**2)),
        dy/dt = xdot / (dx/dy),   dx/dy = 1 + eps (c + y**2) / s**2.

    This is the same force as :func:`nnmstop.models.two_dof.regularized_contact_force` (the
    start ``y`` is taken from it), evaluated in closed form: it makes the integration
    an order of magnitude faster. The variational equations are those of the
    original coordinates ``(x, u, xdot, udot)``.
    """
    b, d = params.beta, params.delta
    eta, eps = params.eta, params.eps
    c = 1.0 - eps
    sqrt_c = float(np.sqrt(c))

    def parts(y):
        ay = abs(y)
        s = (sqrt_c - ay) * (sqrt_c + ay)  # c - y**2 without cancellation in the subtraction
        q = c + y * y
        return s, q

    def rhs(t, w):
        y, u, xd, ud = w[0], w[1], w[2], w[3]
        s, q = parts(y)
        x = y + eps * y / s
        f = eta * y / s
        kx = eta * q / (s * s + eps * q)
        dxdy = 1.0 + eps * q / (s * s)
        phi = w[4:].reshape(4, 4)
        out = np.empty(20)
        out[0] = xd / dxdy
        out[1] = ud
        out[2] = -(1.0 + b) * x + b * u - f
        out[3] = b * (x - u) / d
        dphi = out[4:].reshape(4, 4)
        dphi[0] = phi[2]
        dphi[1] = phi[3]
        dphi[2] = -(1.0 + b + kx) * phi[0] + b * phi[1]
        dphi[3] = (b / d) * (phi[0] - phi[1])
        return out

    x0 = float(z0[0])
    y0 = x0 - float(regularized_contact_force(np.array([x0]), params)[0]) / params.alpha
    w0 = np.concatenate([[y0], z0[1:], np.eye(4).ravel()])
    sol = solve_ivp(rhs, (0.0, float(t_end)), w0, method="DOP853", rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"variational integration failed: {sol.message}")
    wT = sol.y[:, -1]
    s, _ = parts(wT[0])
    zT = np.array([wT[0] + eps * wT[0] / s, wT[1], wT[2], wT[3]])
    return zT, wT[4:].reshape(4, 4).copy(), rhs


def monodromy(params: ModelParameters, state0, period, rtol: float = 1e-12, atol: float = 1e-12) -> MonodromyResult:
    """Monodromy matrix of the regularized equations (7) by direct integration.

    Integrates ``z = (x, u, xdot, udot)`` and the variational equations
    ``Phi' = J(z) Phi``, ``Phi(0) = I``, over one period with DOP853; the contact
    force and its slope are those of :mod:`nnmstop.models.two_dof` (true root of the cubic,
    evaluated through its exact rational parametrization, see
    :func:`_variational_flow`).

    Parameters
    ----------
    params : ModelParameters
    state0 : array_like, shape (4,)
        Start state, e.g. from :func:`orbit_initial_state` (or :func:`refine_orbit`).
    period : float
        Integration time (> 0).
    rtol, atol : float
        Tolerances of :func:`scipy.integrate.solve_ivp`.

    Returns
    -------
    MonodromyResult
    """
    _check_params(params)
    z0 = _check_state(state0)
    period = _check_period(period)
    if not (rtol > 0 and atol > 0):
        raise ValueError(f"rtol and atol must be > 0, got {rtol!r}, {atol!r}")
    zT, Phi, _ = _variational_flow(params, z0, period, rtol, atol)
    mu = np.linalg.eigvals(Phi)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    closure = float(np.linalg.norm(zT - z0) / max(np.linalg.norm(z0), 1e-300))
    return MonodromyResult(matrix=Phi, multipliers=mu, final_state=zT, closure=closure)


def refine_orbit(
    params: ModelParameters,
    state0,
    period,
    tol: float = 1e-11,
    max_iter: int = 20,
    rtol: float = 1e-12,
    atol: float = 1e-12,
):
    """Exact time-reversible periodic orbit of (7) near an HBM orbit, by shooting.

    A time-reversible orbit that starts at rest (``xdot = udot = 0``) is at rest
    again at ``T/2``. Keeping ``x(0)`` fixed (the period is nearly flat along parts of
    the branches, so fixing ``T`` would be ill-conditioned there), Newton's method
    on ``(u(0), T)`` solves ``xdot(T/2) = udot(T/2) = 0``.

    Parameters
    ----------
    params : ModelParameters
    state0 : array_like, shape (4,)
        Start state ``(x, u, 0, 0)`` (velocities must vanish: cosine-basis orbit).
    period : float
        Period guess.
    tol : float
        Convergence tolerance on the half-period velocities relative to the peak
        velocity scale ``|x(0)| 2 pi / T``.

    Returns
    -------
    state : ndarray, shape (4,)
    period : float

    Raises
    ------
    ValueError
        If the start velocities are not zero.
    RuntimeError
        If Newton's method does not converge.
    """
    _check_params(params)
    z = _check_state(state0).copy()
    T = _check_period(period)
    scale = max(abs(z[0]), abs(z[1]), 1e-300)
    if abs(z[2]) > 1e-8 * scale * 2 * np.pi / T or abs(z[3]) > 1e-8 * scale * 2 * np.pi / T:
        raise ValueError(f"state0 must start at rest (xdot = udot = 0) for a time-reversible orbit, got {state0!r}")
    z[2:] = 0.0
    x0 = z[0]

    def half_period_velocities(y):
        """``(xdot, udot)(T/2)`` for ``y = (u(0), T)`` and their Jacobian in ``y``."""
        zh, Phi, _ = _variational_flow(params, np.array([x0, y[0], 0.0, 0.0]), y[1] / 2, rtol, atol)
        # d(xdot, udot)(T/2) / d(u0, T): Phi column of u0; accelerations at T/2 times 1/2.
        force = float(regularized_contact_force(np.array([zh[0]]), params)[0])
        acc = np.array(
            [
                -(1 + params.beta) * zh[0] + params.beta * zh[1] - force,
                params.beta * (zh[0] - zh[1]) / params.delta,
            ]
        )
        return zh[2:], np.column_stack([Phi[2:, 1], 0.5 * acc])

    def at_rest(y, r, dy):
        return bool(np.max(np.abs(r)) <= tol * scale * 2 * np.pi / y[1])

    result = newton_solve(
        half_period_velocities,
        None,
        [z[1], T],
        tol=tol,
        max_iter=max_iter,
        criterion=at_rest,
        norm=lambda y, r: float(np.max(np.abs(r))),
    )
    if not result.converged:
        raise RuntimeError(
            f"shooting did not converge: {result.reason} (largest half-period velocity {result.residual_norm:.3g})"
        )
    u0, T = result.y
    return np.array([x0, u0, 0.0, 0.0]), float(T)
