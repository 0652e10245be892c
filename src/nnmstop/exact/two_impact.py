"""Exact NNM1 orbits of the non-smooth system with one impact per stop per period (Section 3.1).

Between impacts, Eqs. (3)-(4) are linear with constant coefficients:

* free flight, ``|x| <= 1`` (Eq. 8): ``M q'' + K q = 0``;
* contact with the right stop, ``x >= 1`` (Eq. 9): ``M q'' + K_c q = (alpha, 0)``,
  ``K_c = K + alpha e_x e_x^T``, i.e. the same oscillator with its equilibrium
  shifted to ``K_c^{-1} (alpha, 0)``;

with ``q = (x, u)``, ``M = diag(1, delta)`` and ``K = [[1 + beta, -beta], [-beta, beta]]``
(:func:`nnmstop.models.two_dof.mass_matrix`, :func:`nnmstop.models.two_dof.stiffness_matrix`). Each phase
is solved in closed form by its modes (generalized eigenproblem ``K phi = omega**2 M phi``,
mass-normalized), so the state at any time, its derivative with respect to time (the
vector field) and with respect to the initial state (the transition matrix) are exact
to round-off. No time-stepping ODE solver is used in this module; the independent
cross-checks live in :mod:`nnmstop.checks.time_integration`.

Quarter-period construction
---------------------------
Unknowns ``y = (xdot0, udot0, tau1, T1)``: free flight from ``(x, u) = (0, 0)`` with
velocities ``(xdot0, udot0)`` during ``tau1``, then contact during ``T1 - tau1``.
Equations::

    x(tau1) = 1,    xdot(T1) = 0,    udot(T1) = 0.

The whole period ``T = 4 T1`` follows from the symmetries of Section 3.1
(``q(T1 + s) = q(T1 - s)`` because the velocities vanish at ``T1``, and
``q(t + T/2) = -q(t)`` because the system is odd), see :func:`time_history`.

The solutions form one-parameter families, followed by pseudo-arclength continuation
(:func:`follow_family`) from the grazing orbit (:func:`grazing_orbit`, the first linear
mode with x amplitude 1). Along the way every orbit is checked against the assumptions
of the construction (:func:`assess_orbit`) and the curve is cut, at an accurately
located point, where one of them first fails; the reason is recorded.

What happens for the paper values (alpha = 30, beta = 1, delta = 1)
------------------------------------------------------------------
The family leaving the grazing orbit first loses a little energy (the energy is not
monotone along it), then gains energy while its frequency rises towards the gap-0 first
mode. From ``xdot0 = 0`` on, x starts each quarter period by moving *away* from the stop
it is about to hit: a secondary oscillation of x between the impacts. That excursion
grows with energy until x touches the opposite stop ``x = -1`` during free flight,
which ends the two-impact family (at an energy of about 56; the algebraic solution
continues past it but is not an orbit of Eqs. (3)-(4) any more). A second, separate
segment of two-impact orbits exists at high energy (:func:`high_energy_orbit`), whose
frequency tends to the gap-0 first mode; followed downwards in energy it ends where x
leaves the stop during the contact phase.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
import scipy.linalg
import scipy.optimize
import xarray as xr

from nnmstop.netcdf import write_dataset
from nnmstop.models.two_dof import (
    ModelParameters,
    linear_modes,
    mass_matrix,
    piecewise_contact_force,
    stiffness_matrix,
    total_energy,
)

__all__ = [
    "LinearPhase",
    "TwoImpactProblem",
    "OrbitAssessment",
    "TwoImpactFamily",
    "OrbitTimeHistory",
    "grazing_orbit",
    "high_energy_orbit",
    "assess_orbit",
    "follow_family",
    "time_history",
    "symmetric_time_history",
    "interior_extrema",
    "family_dataset",
    "build_two_impact_dataset",
    "MARGIN_REASONS",
]

logger = logging.getLogger(__name__)

#: Why a two-impact orbit stops being admissible, for each validity margin of
#: :func:`assess_orbit` (a margin is > 0 when its assumption holds).
MARGIN_REASONS = {
    "free_flight_time": "the free-flight duration tau1 vanishes",
    "contact_time": "the contact duration T1 - tau1 vanishes (back to grazing)",
    "entry_velocity": "x reaches the stop with zero velocity (grazing impact)",
    "early_impact": "x reaches the stop x = 1 before tau1 during free flight (an extra impact)",
    "opposite_stop": (
        "x reaches the opposite stop x = -1 during free flight: the secondary oscillation of x "
        "between the impacts has grown until it strikes the other stop"
    ),
    "leaves_stop": "x leaves the stop during the contact phase (x < 1 before T1)",
    "final_position": (
        "x is back at the stop position (x(T1) = 1) when both velocities vanish: the turning point "
        "leaves the contact region"
    ),
}

_ROUND_OFF = np.finfo(float).eps


# --------------------------------------------------------------------------- linear phases


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

    def __post_init__(self):
        lam, modes = scipy.linalg.eigh(self.stiffness, self.mass)  # Phi^T M Phi = I
        if np.any(lam <= 0):
            raise ValueError(f"stiffness matrix must be positive definite, got eigenvalues {lam}")
        object.__setattr__(self, "omega", np.sqrt(lam))
        object.__setattr__(self, "modes", modes)
        object.__setattr__(self, "q_eq", np.linalg.solve(self.stiffness, self.force))

    @classmethod
    def free_flight(cls, params: ModelParameters) -> "LinearPhase":
        """Eq. (8): no contact force, ``|x| <= 1``."""
        return cls(mass_matrix(params), stiffness_matrix(params), np.zeros(2))

    @classmethod
    def contact(cls, params: ModelParameters) -> "LinearPhase":
        """Eq. (9): in contact with the stop at ``x = 1`` (stiffness and force ``alpha`` on x)."""
        return cls(mass_matrix(params), stiffness_matrix(params, params.alpha), np.array([params.alpha, 0.0]))

    def _modal(self, z0):
        z0 = np.asarray(z0, dtype=float)
        proj = self.modes.T @ self.mass
        return proj @ (z0[:2] - self.q_eq), proj @ z0[2:]

    def state(self, z0, t):
        """State ``(x, u, xdot, udot)`` at time(s) ``t`` from ``z0`` at time 0.

        Returns an array of shape ``np.shape(t) + (4,)``.
        """
        a, b = self._modal(z0)
        wt = np.multiply.outer(np.asarray(t, dtype=float), self.omega)
        c, s = np.cos(wt), np.sin(wt)
        eta = a * c + (b / self.omega) * s
        eta_dot = -(a * self.omega) * s + b * c
        return np.concatenate([self.q_eq + eta @ self.modes.T, eta_dot @ self.modes.T], axis=-1)

    def transition(self, t: float) -> np.ndarray:
        """Transition matrix ``d z(t) / d z(0)`` (4 x 4), exact."""
        c, s = np.cos(self.omega * t), np.sin(self.omega * t)
        proj = self.modes.T @ self.mass
        phi = self.modes
        return np.block(
            [
                [phi @ (c[:, None] * proj), phi @ ((s / self.omega)[:, None] * proj)],
                [phi @ ((-self.omega * s)[:, None] * proj), phi @ (c[:, None] * proj)],
            ]
        )

    def field(self, z) -> np.ndarray:
        """Time derivative ``(xdot, udot, xddot, uddot)`` of the state ``z`` (last axis)."""
        z = np.asarray(z, dtype=float)
        acc = np.linalg.solve(self.mass, (self.force - z[..., :2] @ self.stiffness.T).T).T
        return np.concatenate([z[..., 2:], acc], axis=-1)


# --------------------------------------------------------------------------- the algebraic problem


class TwoImpactProblem:
    """Residual and analytic Jacobian of the quarter-period equations.

    Parameters
    ----------
    params : ModelParameters
        Only ``alpha``, ``beta`` and ``delta`` matter (``eta`` is not used).
    """

    n_unknowns = 4
    names = ("xdot0", "udot0", "tau1", "T1")

    def __init__(self, params: ModelParameters):
        self.params = params
        self.free = LinearPhase.free_flight(params)
        self.contact = LinearPhase.contact(params)

    @staticmethod
    def _check(y) -> np.ndarray:
        y = np.asarray(y, dtype=float)
        if y.shape != (4,):
            raise ValueError(f"unknowns must be (xdot0, udot0, tau1, T1), got shape {y.shape}")
        if not np.all(np.isfinite(y)):
            raise ValueError(f"unknowns must be finite, got {y}")
        return y

    def switch_states(self, y):
        """States at ``t = 0``, ``tau1`` (entering contact) and ``T1`` (turning point)."""
        y = self._check(y)
        z0 = np.array([0.0, 0.0, y[0], y[1]])
        z1 = self.free.state(z0, y[2])
        z2 = self.contact.state(z1, y[3] - y[2])
        return z0, z1, z2

    def residual(self, y) -> np.ndarray:
        """``(x(tau1) - 1, xdot(T1), udot(T1))``."""
        _, z1, z2 = self.switch_states(y)
        return np.array([z1[0] - 1.0, z2[2], z2[3]])

    def state_derivatives(self, y):
        """Exact derivatives of ``z(tau1)`` and ``z(T1)`` with respect to ``(xdot0, udot0, tau1, T1)``.

        ``z1 = F_free(tau1) z0`` and ``z2 = F_contact(T1 - tau1) z1``: derivatives with respect to
        the initial velocities come from the transition matrices, those with respect to the
        durations from the vector fields.

        Returns
        -------
        dz1, dz2 : ndarray, shape (4, 4)
            Row ``i`` is state component ``i``, column ``j`` unknown ``j``.
        """
        _, z1, z2 = self.switch_states(y)
        e_free = self.free.transition(y[2])
        e_contact = self.contact.transition(y[3] - y[2])
        f2 = self.contact.field(z2)
        dz1 = np.column_stack([e_free[:, 2], e_free[:, 3], self.free.field(z1), np.zeros(4)])
        dz2 = e_contact @ dz1
        dz2[:, 2] -= f2  # d(T1 - tau1)/d tau1 = -1
        dz2[:, 3] = f2
        return dz1, dz2

    def jacobian(self, y) -> np.ndarray:
        """Analytic 3 x 4 Jacobian of :meth:`residual` with respect to ``(xdot0, udot0, tau1, T1)``."""
        dz1, dz2 = self.state_derivatives(y)
        return np.vstack([dz1[0], dz2[2], dz2[3]])

    def energy(self, y) -> float:
        """Total (conserved) energy of the piecewise model: the kinetic energy at ``x = u = 0``."""
        y = self._check(y)
        return float(total_energy(0.0, 0.0, y[0], y[1], self.params, model="piecewise"))


def grazing_orbit(params: ModelParameters) -> np.ndarray:
    """The grazing orbit: first linear mode (no contact) with x amplitude exactly 1.

    ``q(t) = phi_1 sin(omega_1 t)`` with ``phi_1 = (1, u/x)``, so ``xdot0 = omega_1``,
    ``udot0 = omega_1 phi_1[1]`` and ``tau1 = T1 = pi / (2 omega_1)`` (contact duration 0).

    Returns
    -------
    ndarray, shape (4,)
        ``(xdot0, udot0, tau1, T1)``.
    """
    omega, shapes = linear_modes(params, "no_contact")
    w = omega[0]
    quarter = 0.5 * np.pi / w
    return np.array([w, w * shapes[1, 0], quarter, quarter])


def _newton(fun, jac, y, tol=1e-14, max_iter=30):
    """Plain Newton iteration to round-off; returns (y, converged)."""
    best = None
    for _ in range(max_iter):
        r = fun(y)
        dy = np.linalg.solve(jac(y), -r)
        y = y + dy
        small = np.linalg.norm(dy) <= tol * (1.0 + np.linalg.norm(y))
        if small:
            best = y
            break
    if best is None:
        return y, False
    # one more iteration: the residual is then at round-off level
    return best + np.linalg.solve(jac(best), -fun(best)), True


def high_energy_orbit(params: ModelParameters, x_max: float) -> np.ndarray:
    """Two-impact orbit with turning point ``x(T1) = x_max``, for large ``x_max``.

    Seeded from the gap-0 first linear mode (stop always engaged) of x amplitude
    ``x_max``, then solved by Newton on the three quarter-period equations plus
    ``x(T1) = x_max``. Meant for ``x_max`` of at least about 10 (the seed is poor below);
    the result is **not** checked here, use :func:`assess_orbit`.

    Returns
    -------
    ndarray, shape (4,)
        ``(xdot0, udot0, tau1, T1)``.

    Raises
    ------
    ValueError
        If ``x_max <= 1`` or Newton does not converge.
    """
    if not np.isfinite(x_max) or x_max <= 1.0:
        raise ValueError(f"x_max must be a finite number > 1, got {x_max!r}")
    problem = TwoImpactProblem(params)
    omega, shapes = linear_modes(params, "gap_zero")
    w = omega[0]
    y0 = np.array([w * x_max, w * x_max * shapes[1, 0], np.arcsin(1.0 / x_max) / w, 0.5 * np.pi / w])

    def fun(y):
        _, _, z2 = problem.switch_states(y)
        return np.append(problem.residual(y), z2[0] - x_max)

    def jac(y):
        dz1, dz2 = problem.state_derivatives(y)
        return np.vstack([dz1[0], dz2[2], dz2[3], dz2[0]])

    y, ok = _newton(fun, jac, y0)
    if not ok:
        raise ValueError(f"Newton did not converge for the high-energy orbit with x_max={x_max!r}")
    return y


# --------------------------------------------------------------------------- validity


class MarginChecks:
    """Verdicts on a ``margins`` dict (an assumption holds when its margin is > 0)."""

    margins: dict

    @property
    def valid(self) -> bool:
        """All assumptions hold strictly."""
        return margins_valid(self.margins)

    @property
    def violated(self) -> list:
        """Names of the violated assumptions, most violated first."""
        return violated_margins(self.margins)

    @property
    def min_margin(self) -> float:
        """Smallest finite margin (``inf`` when none is finite)."""
        return smallest_margin(self.margins)


@dataclass(frozen=True)
class OrbitAssessment(MarginChecks):
    """Validity margins of a quarter-period orbit (see :data:`MARGIN_REASONS`).

    Attributes
    ----------
    margins : dict
        Margin name -> value; the assumption holds when the value is > 0 (``inf`` when the
        corresponding extremum does not exist).
    x_max, t_x_max, u_at_x_max : float
        Maximum of x over the orbit, the time of the quarter period where it occurs, and u then.
    """

    margins: dict
    x_max: float
    t_x_max: float
    u_at_x_max: float


def margins_valid(margins: dict) -> bool:
    """All validity margins strictly positive."""
    return all(m > 0 for m in margins.values())


def violated_margins(margins: dict) -> list:
    """Keys of the violated (non-positive) margins, most violated first."""
    bad = [k for k, m in margins.items() if not m > 0]
    return sorted(bad, key=lambda k: margins[k])


def smallest_margin(margins: dict) -> float:
    """Smallest finite margin, ``inf`` when none is finite."""
    finite = [m for m in margins.values() if np.isfinite(m)]
    return float(min(finite)) if finite else np.inf


def interior_extrema(phase: LinearPhase, z0, duration: float, samples_per_period: int = 64):
    """Interior extrema of x over ``(0, duration)`` of a linear phase: times and states.

    Sign changes of the closed-form xdot on a grid of ``samples_per_period`` samples per
    period of the fastest mode, refined by Brent's method to round-off; times in
    increasing order. Two extrema closer than one grid interval (a nearly degenerate
    inflection) would be missed; with 64 samples per period their amplitude is negligible.
    """
    if not duration > 0:
        return np.empty(0), np.empty((0, 4))
    n = samples_per_period * max(1, int(np.ceil(duration * phase.omega.max() / (2 * np.pi)))) + 1
    t = np.linspace(0.0, duration, n)
    xdot = phase.state(z0, t)[:, 2]

    def velocity(s):
        return phase.state(z0, s)[2]

    times = [
        scipy.optimize.brentq(velocity, t[i], t[i + 1], xtol=1e-15, rtol=4 * _ROUND_OFF)
        for i in np.flatnonzero(np.sign(xdot[:-1]) * np.sign(xdot[1:]) < 0)
    ]
    times.extend(t[1:-1][xdot[1:-1] == 0.0])
    # discard the end points themselves (they are not interior extrema)
    tol = 1e-12 * max(duration, 1.0)
    times = np.array(sorted(s for s in times if tol < s < duration - tol))
    if times.size == 0:
        return times, np.empty((0, 4))
    return times, phase.state(z0, times)


def _extrema(phase: LinearPhase, z0, duration: float):
    """Interior local extrema of x of a phase: (times, values, is_max), classified by the
    sign of the acceleration."""
    times, states = interior_extrema(phase, z0, duration)
    if times.size == 0:
        return times, np.empty(0), np.empty(0, dtype=bool)
    return times, states[:, 0], phase.field(states)[:, 2] < 0


def assess_orbit(y, params: ModelParameters, problem: TwoImpactProblem | None = None) -> OrbitAssessment:
    """Check the assumptions of the two-impact construction for the orbit ``y``.

    Margins (> 0 when the assumption holds):

    * ``free_flight_time`` = tau1, ``contact_time`` = T1 - tau1;
    * ``entry_velocity`` = xdot(tau1): x enters the stop;
    * ``early_impact`` = 1 - (largest interior local maximum of x during free flight):
      x stays below 1 before tau1, so the impact at tau1 is the first one;
    * ``opposite_stop`` = 1 + min of x over the free flight: x stays above -1;
    * ``leaves_stop`` = (smallest interior local minimum of x during contact) - 1: x >= 1
      throughout the contact;
    * ``final_position`` = x(T1) - 1.

    Extrema are located exactly (closed-form velocity, Brent's method) from sign changes on a
    grid of 64 samples per period of the fastest mode. By the symmetries of the orbit, the
    quarter period decides for the whole period.
    """
    problem = problem or TwoImpactProblem(params)
    y = TwoImpactProblem._check(y)
    tau1, quarter = y[2], y[3]
    z0, z1, z2 = problem.switch_states(y)
    margins = {"free_flight_time": tau1, "contact_time": quarter - tau1, "entry_velocity": z1[2]}

    t_f, x_f, max_f = _extrema(problem.free, z0, tau1)
    margins["early_impact"] = 1.0 - x_f[max_f].max() if np.any(max_f) else np.inf
    margins["opposite_stop"] = 1.0 + min([0.0, z1[0], *x_f[~max_f]])

    t_c, x_c, max_c = _extrema(problem.contact, z1, quarter - tau1)
    margins["leaves_stop"] = x_c[~max_c].min() - 1.0 if np.any(~max_c) else np.inf
    margins["final_position"] = z2[0] - 1.0

    # maximum of x over the quarter (hence over the orbit, by symmetry)
    cand_t = [tau1, quarter, *(tau1 + t_c[max_c]), *t_f[max_f]]
    cand_x = [z1[0], z2[0], *x_c[max_c], *x_f[max_f]]
    k = int(np.argmax(cand_x))
    t_max = float(cand_t[k])
    u_max = float(_quarter_state(problem, y, np.array([t_max]))[0, 1])
    return OrbitAssessment({name: float(v) for name, v in margins.items()}, float(cand_x[k]), t_max, u_max)


def _quarter_state(problem: TwoImpactProblem, y, t):
    """State on the quarter period, ``0 <= t <= T1``."""
    z0, z1, _ = problem.switch_states(y)
    t = np.asarray(t, dtype=float)
    free = t <= y[2]
    out = np.empty(t.shape + (4,))
    out[free] = problem.free.state(z0, t[free])
    out[~free] = problem.contact.state(z1, t[~free] - y[2])
    return out


# --------------------------------------------------------------------------- continuation


@dataclass
class TwoImpactFamily:
    """A followed family of two-impact orbits.

    Attributes
    ----------
    params : ModelParameters
    unknowns : ndarray, shape (n, 4)
        ``(xdot0, udot0, tau1, T1)`` of each orbit, in continuation order.
    arclength : ndarray, shape (n,)
        Pseudo-arclength from the first orbit.
    residual : ndarray, shape (n,)
        Euclidean norm of the three quarter-period equations.
    assessments : list of OrbitAssessment
    end_reason : str
        Why the family stops (a :data:`MARGIN_REASONS` text, ``max_points`` or a failure).
    end_margin : str
        Name of the violated margin at the end ('' if the family did not end on a violation).
    step : float
        Nominal continuation step.
    """

    params: ModelParameters
    unknowns: np.ndarray
    arclength: np.ndarray
    residual: np.ndarray
    assessments: list
    end_reason: str
    end_margin: str
    step: float
    start: str = "grazing orbit"
    end_tangent: np.ndarray | None = None

    @property
    def energy(self) -> np.ndarray:
        """Total energy of the piecewise model (the kinetic energy at ``x = u = 0``)."""
        y = self.unknowns
        return total_energy(0.0, 0.0, y[:, 0], y[:, 1], self.params, model="piecewise")

    @property
    def frequency(self) -> np.ndarray:
        """``1 / T`` with ``T = 4 T1``, in Hz of the nondimensional time."""
        return 1.0 / (4.0 * self.unknowns[:, 3])

    def __len__(self) -> int:
        return len(self.unknowns)


def _tangent(jac: np.ndarray, previous: np.ndarray) -> np.ndarray:
    """Unit tangent: null vector of the 3 x 4 Jacobian, oriented like ``previous``."""
    t = np.linalg.solve(np.vstack([jac, previous]), np.array([0.0, 0.0, 0.0, 1.0]))
    return t / np.linalg.norm(t)


def _correct(problem, y_prev, tangent, sigma, max_iter=12):
    """Pseudo-arclength corrector: F(y) = 0 and tangent . (y - y_prev) = sigma.

    Returns ``(y, residual norm)`` or ``(None, inf)`` if Newton fails.
    """
    y = y_prev + sigma * tangent
    converged = False
    for _ in range(max_iter):
        f = np.append(problem.residual(y), tangent @ (y - y_prev) - sigma)
        a = np.vstack([problem.jacobian(y), tangent])
        try:
            dy = np.linalg.solve(a, -f)
        except np.linalg.LinAlgError:
            return None, np.inf
        y = y + dy
        if not np.all(np.isfinite(y)):
            return None, np.inf
        if converged:  # one extra iteration after convergence: residual at round-off
            break
        converged = np.linalg.norm(dy) <= 1e-13 * (1.0 + np.linalg.norm(y))
    if not converged:
        return None, np.inf
    res = float(np.linalg.norm(problem.residual(y)))
    # guard against a jump to another branch: the corrector must stay close to the predictor
    if res > 1e-10 or np.linalg.norm(y - (y_prev + sigma * tangent)) > 0.5 * abs(sigma) + 1e-12:
        return None, np.inf
    return y, res


def follow_family(
    params: ModelParameters,
    step: float = 0.02,
    max_points: int = 4000,
    start=None,
    direction=None,
    start_label: str | None = None,
    min_step_ratio: float = 1e-6,
) -> TwoImpactFamily:
    """Follow a family of two-impact orbits by pseudo-arclength continuation.

    The predictor is the unit tangent (null vector of the analytic Jacobian), the corrector a
    Newton iteration on the three equations plus the arclength condition, iterated to
    round-off. Nothing assumes the energy to be monotone along the family: the natural
    parameter is the arclength in ``(xdot0, udot0, tau1, T1)``.

    After every step the orbit is checked with :func:`assess_orbit`. At the first violated
    assumption the boundary is located by bisection on the arclength of the last step (to a
    relative ``1e-13`` of the step), the last valid orbit is appended and the continuation
    stops: the curve is never extended past the end of the family.

    Parameters
    ----------
    params : ModelParameters
    step : float
        Nominal arclength step (> 0); halved when Newton fails, restored after success.
    max_points : int
        Maximum number of orbits (>= 2).
    start : array_like, shape (4,), optional
        First orbit; the grazing orbit (:func:`grazing_orbit`) by default.
    direction : array_like, shape (4,), optional
        The tangent is oriented to have a positive dot product with it. By default, the
        direction of increasing contact duration ``T1 - tau1``.
    start_label : str, optional
        Description of the start, kept in the result.
    min_step_ratio : float
        The continuation fails when the step falls below ``min_step_ratio * step``.

    Returns
    -------
    TwoImpactFamily
    """
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be a finite number > 0, got {step!r}")
    if int(max_points) != max_points or max_points < 2:
        raise ValueError(f"max_points must be an integer >= 2, got {max_points!r}")
    problem = TwoImpactProblem(params)
    y = grazing_orbit(params) if start is None else TwoImpactProblem._check(start).copy()
    label = start_label or ("grazing orbit" if start is None else "user-supplied orbit")
    res0 = float(np.linalg.norm(problem.residual(y)))
    if res0 > 1e-8:
        raise ValueError(f"start is not a solution of the quarter-period equations (residual {res0:.3e})")
    first = assess_orbit(y, params, problem)
    if start is not None and first.min_margin < -1e-9:
        raise ValueError(f"start {y} violates the two-impact assumptions {first.violated}")

    jac = problem.jacobian(y)
    null = scipy.linalg.null_space(jac)
    if null.shape[1] != 1:
        raise ValueError(f"the Jacobian at the start has a {null.shape[1]}-dimensional null space; not a regular point")
    tangent = null[:, 0]
    orient = np.array([0.0, 0.0, -1.0, 1.0]) if direction is None else np.asarray(direction, dtype=float)
    if tangent @ orient < 0:
        tangent = -tangent

    ys, arcs, residuals = [y], [0.0], [res0]
    assessments = [first]
    h, s = float(step), 0.0
    end_reason, end_margin = f"max_points = {max_points} reached (the family is still valid there)", ""
    while len(ys) < max_points:
        y_new, res = _correct(problem, y, tangent, h)
        if y_new is None:
            h *= 0.5
            if h < min_step_ratio * step:
                end_reason = f"continuation failed: Newton did not converge for steps down to {h:.3e}"
                break
            continue
        check = assess_orbit(y_new, params, problem)
        if not check.valid:
            y_end, sigma, check_end, name = _locate_end(problem, params, y, tangent, h, check)
            if y_end is not None and sigma > 0:
                ys.append(y_end)
                arcs.append(s + sigma)
                residuals.append(float(np.linalg.norm(problem.residual(y_end))))
                assessments.append(check_end)
            end_margin = name
            end_reason = MARGIN_REASONS[name]
            break
        new_tangent = _tangent(problem.jacobian(y_new), tangent)
        y, tangent, s = y_new, new_tangent, s + h
        ys.append(y)
        arcs.append(s)
        residuals.append(res)
        assessments.append(check)
        h = min(step, 2.0 * h)
    family = TwoImpactFamily(
        params=params,
        unknowns=np.array(ys),
        arclength=np.array(arcs),
        residual=np.array(residuals),
        assessments=assessments,
        end_reason=end_reason,
        end_margin=end_margin,
        step=float(step),
        start=label,
        end_tangent=tangent,
    )
    logger.info(
        "two-impact family from the %s: %d orbits, energy %.6g..%.6g, frequency %.6g..%.6g Hz, "
        "max residual %.3e; end: %s",
        label, len(family), family.energy.min(), family.energy.max(), family.frequency.min(),
        family.frequency.max(), family.residual.max(), end_reason,
    )
    return family


def _locate_end(problem, params, y, tangent, h, bad_check, rel_tol=1e-13):
    """Bisection on the arclength of the last step for the first violated assumption.

    Returns ``(last valid orbit, its arclength from y, its assessment, violated margin name)``.
    """
    lo, hi = 0.0, h
    y_lo, check_lo = None, None
    name = bad_check.violated[0]
    for _ in range(200):
        if hi - lo <= rel_tol * h:
            break
        mid = 0.5 * (lo + hi)
        y_mid, _ = _correct(problem, y, tangent, mid)
        if y_mid is None:  # should not happen inside a step that converged; be conservative
            hi = mid
            continue
        check = assess_orbit(y_mid, params, problem)
        if check.valid:
            lo, y_lo, check_lo = mid, y_mid, check
        else:
            hi, name = mid, check.violated[0]
    return y_lo, lo, check_lo, name


# --------------------------------------------------------------------------- time history


class OrbitTimeHistory(NamedTuple):
    """Full-period time history of a two-impact orbit (all arrays have the shape of ``t``)."""

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    xdot: np.ndarray
    udot: np.ndarray
    force: np.ndarray


def time_history(y, params: ModelParameters, t) -> OrbitTimeHistory:
    """Exact time history of the orbit ``y = (xdot0, udot0, tau1, T1)`` at times ``t``.

    Built from the quarter period ``[0, T1]`` with the symmetries of Section 3.1: the
    mirror ``q(T1 + s) = q(T1 - s)`` (velocities change sign) and the half-period shift
    ``q(t + T/2) = -q(t)``; ``t`` may be any real times (the orbit is ``T = 4 T1``-periodic).
    The contact force is the piecewise-linear law, Eq. (4).
    """
    problem = TwoImpactProblem(params)
    y = TwoImpactProblem._check(y)
    return symmetric_time_history(lambda r: _quarter_state(problem, y, r), y[3], t, params.alpha)


def symmetric_time_history(quarter_state, quarter: float, t, alpha: float) -> OrbitTimeHistory:
    """Full-period time history at times ``t`` from the quarter period ``[0, quarter]``.

    ``quarter_state(r)`` gives the states ``(x, u, xdot, udot)`` at times ``r`` of the
    quarter period (last axis). The NNM symmetries unfold it: the mirror
    ``q(T1 + s) = q(T1 - s)`` (velocities change sign) and the half-period shift
    ``q(t + T/2) = -q(t)``; the contact force is the piecewise-linear law, Eq. (4).
    """
    t = np.asarray(t, dtype=float)
    period = 4.0 * quarter
    s = np.mod(t, period)
    second_half = s >= 0.5 * period
    s = np.where(second_half, s - 0.5 * period, s)
    mirrored = s > quarter
    r = np.where(mirrored, 2.0 * quarter - s, s)
    z = quarter_state(np.clip(r, 0.0, quarter))
    sign_q = np.where(second_half, -1.0, 1.0)
    sign_v = sign_q * np.where(mirrored, -1.0, 1.0)
    x, u = sign_q * z[..., 0], sign_q * z[..., 1]
    xdot, udot = sign_v * z[..., 2], sign_v * z[..., 3]
    return OrbitTimeHistory(t, x, u, xdot, udot, piecewise_contact_force(x, alpha))


# --------------------------------------------------------------------------- datasets


def family_dataset(family: TwoImpactFamily) -> xr.Dataset:
    """The family as a labelled :class:`xarray.Dataset` along the dimension ``point``."""
    y = family.unknowns
    n = len(family)
    one = "1"

    def var(values, long_name, units, **extra):
        return ("point", np.asarray(values, dtype=float), {"long_name": long_name, "units": units, **extra})

    x_max = [a.x_max for a in family.assessments]
    u_at = [a.u_at_x_max for a in family.assessments]
    margin = [a.min_margin for a in family.assessments]
    from nnmstop.exact.stability import stability_variables  # it builds on LinearPhase of this module

    floquet = stability_variables(family.params, ["FR"] * n, np.column_stack([y[:, 2], y[:, 3] - y[:, 2]]))
    ds = xr.Dataset(
        {
            "energy": var(
                family.energy,
                "total energy of the non-smooth (piecewise-linear) model: kinetic + spring potential "
                "+ stop potential alpha/2 (|x|-1)^2, conserved along the orbit",
                one,
            ),
            "frequency": var(family.frequency, "frequency 1/T of the periodic orbit, in Hz of the nondimensional time", "Hz"),
            "period": var(4.0 * y[:, 3], "period T = 4 T1", one),
            "x_max": var(x_max, "maximum of x over the period (x_max - 1 is the penetration into the stop)", one),
            "u_at_x_max": var(u_at, "u at the time of the maximum of x", one),
            "x_turning_point": var(
                [a.margins["final_position"] + 1.0 for a in family.assessments],
                "x(T1) where both velocities vanish (equals x_max unless x peaks earlier during contact)",
                one,
            ),
            "xdot0": var(y[:, 0], "velocity of x at x = u = 0 (t = 0)", one),
            "udot0": var(y[:, 1], "velocity of u at x = u = 0 (t = 0)", one),
            "free_flight_time": var(y[:, 2], "free-flight duration tau1 of the quarter period", one),
            "contact_time": var(y[:, 3] - y[:, 2], "contact duration T1 - tau1 of the quarter period", one),
            "residual": var(
                family.residual, "Euclidean norm of (x(tau1) - 1, xdot(T1), udot(T1))", one
            ),
            "validity_margin": var(
                margin,
                "smallest margin of the assumptions of the two-impact construction "
                "(> 0 inside the family, about 0 at its ends)",
                one,
            ),
            **floquet,
        },
        coords={
            "point": ("point", np.arange(n), {"long_name": "index of the orbit along the family", "units": one}),
            "arclength": var(
                family.arclength, "pseudo-arclength in (xdot0, udot0, tau1, T1) from the first orbit", one
            ),
        },
    )
    ds.attrs = {
        "alpha": family.params.alpha,
        "beta": family.params.beta,
        "delta": family.params.delta,
        "family_start": family.start,
        "end_reason": family.end_reason,
        "end_margin": family.end_margin or "none",
        "continuation_step": family.step,
        "max_residual": float(family.residual.max()),
    }
    return ds


def build_two_impact_dataset(config: dict, output_path: str | Path) -> Path:
    """Compute the exact two-impact NNM1 family and write it to NetCDF.

    Called by the Snakemake rule ``exact_two_impacts``.

    Parameters
    ----------
    config : dict
        With the ``model`` (alpha, beta, delta, eta) and ``exact`` (step, max_points)
        sections of ``config/config.yaml``.
    output_path : str or Path
        NetCDF file to write (atomically, through :func:`nnmstop.netcdf.write_dataset`).

    Returns
    -------
    Path
        The written file.
    """
    for key in ("model", "exact"):
        if key not in config:
            raise ValueError(f"config lacks the section {key!r}")
    params = ModelParameters.from_config(config["model"])
    exact = config["exact"]
    family = follow_family(params, step=float(exact["step"]), max_points=int(exact["max_points"]))
    ds = family_dataset(family)
    summary = (
        "Exact periodic orbits of the non-smooth 2-DOF oscillator with a bilateral elastic stop "
        "(Eqs. 3-4), one impact on each stop per period, built in closed form from the quarter "
        "period (Section 3.1) and followed by pseudo-arclength continuation from the grazing "
        f"orbit. The family ends because {family.end_reason}."
    )
    path = write_dataset(
        ds, output_path, title="NNM1 of the non-smooth system: two impacts per period (exact)",
        summary=summary, keywords="exact solution, piecewise linear",
        metadata=config.get("metadata"),
    )
    logger.info("wrote %s (%d orbits)", path, len(family))
    return path
