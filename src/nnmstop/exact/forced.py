r"""Exact periodic responses of the forced, damped structure with the piecewise-linear stop.

``M q'' + C q' + K q + e_c f(q_c) = F cos(Omega t) b`` with one struck stop (degree of freedom ``c``, gap
``g``, stiffness ``alpha``); any other stop of the structure is passive and must stay untouched (checked).
Each phase is linear with harmonic forcing: free flight ``F`` (``K``), contact with the right stop ``R``
(``K + alpha e_c e_c^T``, constant load ``alpha g e_c``) or the left one ``L`` (load ``-alpha g e_c``).
:class:`ForcedPhase` gives its flow in closed form, homogeneous plus particular solution
(``z(t) = z_p(t) + exp(A t) (z(0) - z_p(0))`` with ``exp(A t)`` from the eigenvectors of ``A``), exact to
round-off. Phases ``theta = Omega t`` are the time variable of every response.

Responses covered:

* the non-impacting response (the linear frequency response, :func:`non_impacting_response`), valid while
  ``|q_c| <= g``; its grazing frequencies are located to round-off (:func:`grazing_frequencies`);
* the symmetric responses ``q(theta + pi) = -q(theta)`` with one contact per stop per period
  (:class:`SymmetricContactProblem`): unknowns the state ``z1`` where ``q_c`` enters the right stop, its
  phase ``theta1``, the phase duration ``delta`` of the contact, and ``Omega``; equations ``q_c(z1) = g``,
  ``(q_c(theta1 + delta) - q_c(theta1)) / delta = 0`` (regular at grazing, ``delta -> 0``, where it
  becomes the tangency ``qdot_c = 0``) and ``z(theta1 + pi) = -z1``. The family starts at a grazing
  orbit of the non-impacting response and is followed by the project's pseudo-arclength continuation
  through its folds, each orbit checked (:meth:`SymmetricContactProblem.assess`); the family ends, at a
  located orbit, where an assumption fails, with the reason stored.

Floquet multipliers: the vector field is continuous (the contact force vanishes at the stop), so every
saltation matrix is the identity and the monodromy is the product of the phase exponentials; for the
symmetric responses the half-period map ``-exp(A_F t_F) exp(A_R t_R)`` gives ``nu`` with ``mu = nu**2``.
Method notes: docs/forced.md.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg
import scipy.optimize

from nnmstop.continuation.core import ContinuationStats, unit_tangent
from nnmstop.continuation.newton import bisect_sign_change
from nnmstop.continuation.pseudo_arclength import PseudoArclengthStepper, continue_pseudo_arclength
from nnmstop.exact.follow import RESTART_POINTS, confirm_family_end
from nnmstop.exact.grazing import MarginChecks
from nnmstop.floquet import match_nearest
from nnmstop.models.excitation import Excitation

__all__ = [
    "ForcedPhase",
    "StruckStop",
    "non_impacting_response",
    "grazing_frequencies",
    "SymmetricContactProblem",
    "ContactAssessment",
    "CONTACT_MARGINS",
    "ContactFamily",
    "follow_contact_family",
    "confirm_contact_family_end",
]

#: Largest condition number of the eigenvector matrix of a phase (a nearly defective phase is refused).
MAX_EIGENVECTOR_CONDITION = 1e10
#: Samples per period of the fastest oscillation of a phase in the search of interior extrema.
SAMPLES_PER_PERIOD = 64

#: Why a symmetric one-contact response stops being one, by validity margin.
CONTACT_MARGINS = {
    "contact_duration": "the contact shrinks to zero duration (grazing: the non-impacting response again)",
    "free_duration": "the contact lasts half a period (no free flight left)",
    "leaves_stop": "the stop DOF leaves the stop during the contact (more contacts per period)",
    "early_impact": "the stop DOF reaches a stop during the free flight (more contacts per period)",
    "other_stops": "the degree of freedom of a passive stop reaches its gap (that stop would be struck too)",
}


def _expm1_over(c, delta: float):
    """``expm1(c delta) / delta`` (``c`` at ``delta = 0``), elementwise, without cancellation."""
    if delta == 0:
        return np.asarray(c, dtype=complex)
    return np.expm1(np.asarray(c) * delta) / delta


class ForcedPhase:
    """Closed-form flow of ``M q'' + C q' + K q = g + cos(theta) p`` with ``theta = Omega t``.

    State ``z = (q, qdot)`` (2N), ``z' = A z + B (g + cos(theta) p)``. The particular solution is
    ``z_p(theta) = w + Re(P exp(i theta))`` with ``w = (K^-1 g, 0)`` and ``P = (i Omega - A)^-1 B p``; the
    homogeneous part is ``exp(A t) = V exp(Lambda t) V^-1``.
    """

    def __init__(self, mass, damping, stiffness, constant_load, load):
        mass, damping, stiffness = (np.asarray(a, dtype=float) for a in (mass, damping, stiffness))
        n = mass.shape[0]
        self.n = n
        m_inv = np.linalg.inv(mass)
        self.A = np.block([[np.zeros((n, n)), np.eye(n)], [-m_inv @ stiffness, -m_inv @ damping]])
        self.B = np.vstack([np.zeros((n, n)), m_inv])
        self.load = np.asarray(load, dtype=float)
        self.w = np.concatenate([np.linalg.solve(stiffness, np.asarray(constant_load, dtype=float)), np.zeros(n)])
        self.eigenvalues, self.V = np.linalg.eig(self.A)
        condition = np.linalg.cond(self.V)
        if not condition < MAX_EIGENVECTOR_CONDITION:
            raise ValueError(
                f"a phase is (nearly) defective: its eigenvector matrix has condition number {condition:.3g} "
                "(critical damping of a mode?); its closed-form flow is not computed"
            )
        self.V_inv = np.linalg.inv(self.V)
        self.fastest = float(np.max(np.abs(self.eigenvalues.imag)))

    def amplitude(self, omega: float):
        """``P`` and ``dP/dOmega`` of the particular solution."""
        resolvent = 1j * omega * np.eye(2 * self.n) - self.A
        P = np.linalg.solve(resolvent, self.B @ self.load)
        return P, np.linalg.solve(resolvent, -1j * P)

    def exponential(self, t, minus_one: bool = False):
        """``exp(A t)`` (or ``exp(A t) - I`` without cancellation), real 2N x 2N."""
        factor = np.expm1(self.eigenvalues * t) if minus_one else np.exp(self.eigenvalues * t)
        return ((self.V * factor) @ self.V_inv).real

    def particular(self, P, theta):
        """``z_p`` at the phase(s) ``theta`` (shape ``np.shape(theta) + (2N,)``)."""
        return self.w + np.real(np.multiply.outer(np.exp(1j * np.asarray(theta)), P))

    def states(self, z_s, theta_s: float, omega: float, theta, P=None):
        """States at phases ``theta`` from ``z_s`` at ``theta_s``."""
        P = self.amplitude(omega)[0] if P is None else P
        y = self.V_inv @ (np.asarray(z_s, dtype=float) - self.particular(P, theta_s))
        decay = np.exp(np.multiply.outer((np.asarray(theta, dtype=float) - theta_s) / omega, self.eigenvalues))
        return self.particular(P, theta) + ((decay * y) @ self.V.T).real

    def end_state(self, z_s, theta_s: float, delta: float, omega: float):
        """State after the phase duration ``delta`` and its derivatives.

        Returns ``(z_e, dz_e/dz_s, dz_e/dtheta_s, dz_e/ddelta, dz_e/dOmega)``.
        """
        P, dP = self.amplitude(omega)
        E = self.exponential(delta / omega)
        start = np.asarray(z_s, dtype=float) - self.particular(P, theta_s)
        z_e = self.particular(P, theta_s + delta) + E @ start
        flow = self.A @ (E @ start)
        d_theta = np.real(1j * P * np.exp(1j * (theta_s + delta))) - E @ np.real(1j * P * np.exp(1j * theta_s))
        d_delta = np.real(1j * P * np.exp(1j * (theta_s + delta))) + flow / omega
        d_omega = (
            np.real(dP * np.exp(1j * (theta_s + delta)))
            - E @ np.real(dP * np.exp(1j * theta_s))
            - (delta / omega**2) * flow
        )
        return z_e, E, d_theta, d_delta, d_omega

    def mean_slope(self, z_s, theta_s: float, delta: float, omega: float):
        """``(z(theta_s + delta) - z_s) / delta`` without cancellation (``z'(theta_s)`` at ``delta = 0``)."""
        P = self.amplitude(omega)[0]
        start = np.asarray(z_s, dtype=float) - self.particular(P, theta_s)
        homogeneous = ((self.V * _expm1_over(self.eigenvalues / omega, delta)) @ (self.V_inv @ start)).real
        return np.real(P * np.exp(1j * theta_s) * _expm1_over(1j, delta)) + homogeneous


@dataclass(frozen=True)
class StruckStop:
    """The struck stop of a structure and its passive stops (checked to stay untouched)."""

    dof: int
    gap: float
    stiffness: float
    passive: tuple

    @classmethod
    def of(cls, excitation: Excitation, stop: int = 0) -> StruckStop:
        stops = excitation.structure.stops
        if not 0 <= stop < len(stops):
            raise ValueError(f"stop must index one of the {len(stops)} stops, got {stop!r}")
        s = stops[stop]
        return cls(s.dof, s.gap, s.stiffness, tuple(o for i, o in enumerate(stops) if i != stop))


def _phases(excitation: Excitation, stop: StruckStop) -> dict:
    """The free-flight and contact phases (``L`` is ``R`` with the opposite constant load)."""
    M, K = excitation.structure.dense_matrices()
    C = excitation.damping_matrix
    C = C.toarray() if hasattr(C, "toarray") else np.asarray(C, dtype=float)
    n = M.shape[0]
    if np.any(np.linalg.eigvalsh(K) <= 0):
        raise ValueError("exact forced responses need a positive definite stiffness K (no rigid-body mode)")
    contact = K.copy()
    contact[stop.dof, stop.dof] += stop.stiffness
    load = np.zeros(n)
    load[stop.dof] = stop.stiffness * stop.gap
    return {
        "F": ForcedPhase(M, C, K, np.zeros(n), excitation.load),
        "R": ForcedPhase(M, C, contact, load, excitation.load),
    }


def non_impacting_response(excitation: Excitation, omega) -> np.ndarray:
    """Complex amplitudes ``Q`` (``np.shape(omega) + (N,)``) of the non-impacting response ``Re(Q e^{i theta})``."""
    return _free_amplitudes(_phases(excitation, StruckStop.of(excitation))["F"], omega)


def _free_amplitudes(phase: ForcedPhase, omega) -> np.ndarray:
    omega = np.asarray(omega, dtype=float)
    out = np.array([phase.amplitude(w)[0][: phase.n] for w in omega.ravel()])
    return out.reshape(omega.shape + (phase.n,))


def grazing_frequencies(excitation: Excitation, omega_low: float, omega_high: float, samples: int = 2000) -> list:
    """Angular frequencies in ``[omega_low, omega_high]`` where the non-impacting ``max |q_c|`` equals the gap.

    A sample grid (log-spaced) brackets each crossing; Brent's method locates it to round-off.
    """
    stop = StruckStop.of(excitation)
    phase = _phases(excitation, stop)["F"]
    grid = np.geomspace(omega_low, omega_high, samples)

    def excess(w):
        return abs(_free_amplitudes(phase, w)[stop.dof]) - stop.gap

    values = np.array([excess(w) for w in grid])
    crossings = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
    return [scipy.optimize.brentq(excess, grid[i], grid[i + 1], xtol=1e-15, rtol=1e-15) for i in crossings]


@dataclass(frozen=True)
class ContactAssessment(MarginChecks):
    """Validity margins of a symmetric one-contact response (:data:`CONTACT_MARGINS`), each > 0 when it holds."""

    margins: dict


def _slope_derivative(c, delta: float):
    """``d/ddelta [expm1(c delta) / delta]`` (``c**2 / 2`` at ``delta = 0``), without cancellation."""
    c = np.asarray(c, dtype=complex)
    x = c * delta
    small = np.abs(x) < 1e-3
    series = c * c * (0.5 + x / 3.0 + x * x / 8.0 + x**3 / 30.0)
    if delta == 0:
        return series
    safe = np.where(small, 1.0, x)
    exact = (x * np.exp(x) - np.expm1(x)) / (delta * safe) * c
    return np.where(small, series, exact)


def _extreme_values(phase: ForcedPhase, z_s, theta_s: float, delta: float, omega: float, dof: int):
    """Interior local minima and maxima of ``q_dof`` over the phases ``(theta_s, theta_s + delta)``.

    The closed-form velocity is sampled at :data:`SAMPLES_PER_PERIOD` points per period of the fastest of the
    phase's oscillations and the force; each sign change is refined by Brent's method to round-off.
    """
    return _extreme_values_of(phase, z_s, theta_s, delta, omega, [dof])[0]


def _extreme_values_of(phase: ForcedPhase, z_s, theta_s: float, delta: float, omega: float, dofs) -> list:
    """:func:`_extreme_values` of several DOFs, ``[(minima, maxima) per dof]``, the samples computed once."""
    if not delta > 0:
        return [([], []) for _ in dofs]
    P = phase.amplitude(omega)[0]
    fastest = max(phase.fastest, omega)
    n = SAMPLES_PER_PERIOD * max(1, int(np.ceil(delta / omega * fastest / (2 * np.pi)))) + 1
    theta = np.linspace(theta_s, theta_s + delta, n)
    n_dofs = phase.n
    samples = phase.states(z_s, theta_s, omega, theta, P)
    edge = 1e-12 * max(delta, 1.0)
    out = []
    for dof in dofs:

        def velocity(r, dof=dof):
            return phase.states(z_s, theta_s, omega, r, P)[n_dofs + dof]

        v = samples[:, n_dofs + dof]
        minima, maxima = [], []
        for i in np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:])):
            lo, hi = theta[i], theta[i + 1]
            bracketed = velocity(lo) * velocity(hi) < 0
            r = scipy.optimize.brentq(velocity, lo, hi, xtol=1e-15, rtol=1e-15) if bracketed else lo
            if theta_s + edge < r < theta_s + delta - edge:
                value = phase.states(z_s, theta_s, omega, r, P)[dof]
                (maxima if v[i] > 0 else minima).append(float(value))
        out.append((minima, maxima))
    return out


class SymmetricContactProblem:
    """Symmetric periodic responses with one contact per stop per period, as a continuation problem.

    Unknowns ``y = [z1 (2N), theta1, delta, Omega]``; ``n_unknowns = 2N + 3`` and ``2N + 2`` equations (see the
    module docstring), with ``residual``, ``jacobian`` (analytic) and ``diagnostics`` for the continuation
    driver (:mod:`nnmstop.continuation.driver`).
    """

    def __init__(self, excitation: Excitation):
        self.excitation = excitation
        self.stop = StruckStop.of(excitation)
        self.phases = _phases(excitation, self.stop)
        self.n = excitation.structure.n_dofs
        self.n_unknowns = 2 * self.n + 3
        self.n_equations = 2 * self.n + 2

    def split(self, y):
        y = np.asarray(y, dtype=float)
        return y[: 2 * self.n], float(y[-3]), float(y[-2]), float(y[-1])

    def switch_states(self, y):
        """States entering the right stop (``z1``), leaving it (``z2``) and half a period after ``z1`` (``z3``)."""
        z1, theta1, delta, omega = self.split(y)
        z2 = self.phases["R"].end_state(z1, theta1, delta, omega)[0]
        z3 = self.phases["F"].end_state(z2, theta1 + delta, np.pi - delta, omega)[0]
        return z1, z2, z3

    def residual(self, y):
        z1, theta1, delta, omega = self.split(y)
        c = self.stop.dof
        slope = self.phases["R"].mean_slope(z1, theta1, delta, omega)[c]
        _, _, z3 = self.switch_states(y)
        return np.concatenate([[z1[c] - self.stop.gap, slope], z3 + z1])

    def _slope_row(self, z1, theta1, delta, omega):
        phase, c = self.phases["R"], self.stop.dof
        P, dP = phase.amplitude(omega)
        lam = phase.eigenvalues / omega
        start = z1 - phase.particular(P, theta1)
        project = phase.V_inv @ start

        def homogeneous(factor):
            return (phase.V[c] * factor) @ phase.V_inv

        mean = homogeneous(_expm1_over(lam, delta))
        d_theta = np.real(1j * P[c] * np.exp(1j * theta1) * _expm1_over(1j, delta)) - mean @ np.real(
            1j * P * np.exp(1j * theta1)
        )
        d_delta = np.real(P[c] * np.exp(1j * theta1) * _slope_derivative(1j, delta)) + np.real(
            (phase.V[c] * _slope_derivative(lam, delta)) @ project
        )
        d_omega = (
            np.real(dP[c] * np.exp(1j * theta1) * _expm1_over(1j, delta))
            - mean.real @ np.real(dP * np.exp(1j * theta1))
            + np.real((phase.V[c] * np.exp(lam * delta) * (-lam / omega)) @ project)
        )
        return np.concatenate([mean.real, [d_theta.real, d_delta, d_omega]])

    def jacobian(self, y):
        z1, theta1, delta, omega = self.split(y)
        n2 = 2 * self.n
        J = np.zeros((self.n_equations, self.n_unknowns))
        J[0, self.stop.dof] = 1.0
        J[1] = self._slope_row(z1, theta1, delta, omega)
        z2, E_r, r_theta, r_delta, r_omega = self.phases["R"].end_state(z1, theta1, delta, omega)
        _, E_f, f_theta, f_delta, f_omega = self.phases["F"].end_state(z2, theta1 + delta, np.pi - delta, omega)
        J[2:, :n2] = E_f @ E_r + np.eye(n2)
        J[2:, n2] = E_f @ r_theta + f_theta
        J[2:, n2 + 1] = E_f @ r_delta + f_theta - f_delta
        J[2:, n2 + 2] = E_f @ r_omega + f_omega
        return J

    def half_period_map(self, y) -> np.ndarray:
        """Jacobian ``-exp(A_F t_F) exp(A_R t_R)`` of the half-period map ``z -> -z(theta + pi)`` (saltation = I)."""
        _, _, delta, omega = self.split(y)
        return -self.phases["F"].exponential((np.pi - delta) / omega) @ self.phases["R"].exponential(delta / omega)

    def multipliers(self, y):
        """Multipliers ``mu = nu**2`` of the period and ``nu`` of the half-period map, by decreasing ``|nu|``."""
        nu = np.linalg.eigvals(self.half_period_map(y))
        nu = nu[np.argsort(-np.abs(nu), kind="stable")]
        return nu * nu, nu

    def multiplier_error(self, y) -> float:
        """Error estimate of ``nu``: their difference from the eigenvalues of the half-period map built with
        :func:`scipy.linalg.expm` (a second route to the same matrix exponentials)."""
        _, _, delta, omega = self.split(y)
        second = -scipy.linalg.expm(self.phases["F"].A * ((np.pi - delta) / omega)) @ scipy.linalg.expm(
            self.phases["R"].A * (delta / omega)
        )
        nu = self.multipliers(y)[1]
        return float(np.abs(nu - match_nearest(nu[None], np.linalg.eigvals(second)[None])[0]).max())

    def assess(self, y) -> ContactAssessment:
        """Margins of the assumptions of the construction (each > 0 when it holds), :data:`CONTACT_MARGINS`."""
        z1, theta1, delta, omega = self.split(y)
        z1, z2, _ = self.switch_states(y)
        c, g = self.stop.dof, self.stop.gap
        margins = {"contact_duration": delta, "free_duration": np.pi - delta}
        low, _ = _extreme_values(self.phases["R"], z1, theta1, delta, omega, c)
        margins["leaves_stop"] = min(low) - g if low else np.inf
        low, high = _extreme_values(self.phases["F"], z2, theta1 + delta, np.pi - delta, omega, c)
        margins["early_impact"] = min([g - v for v in high] + [v + g for v in low] + [np.inf])
        if self.stop.passive:
            largest = self.amplitudes(y)
            margins["other_stops"] = min(s.gap - largest[s.dof] for s in self.stop.passive)
        return ContactAssessment({k: float(v) for k, v in margins.items()})

    def amplitudes(self, y) -> np.ndarray:
        """``max |q_j|`` over the period for every DOF (phase ends and interior extrema: exact to round-off)."""
        z1, theta1, delta, omega = self.split(y)
        z1, z2, _ = self.switch_states(y)
        out = np.maximum(np.abs(z1[: self.n]), np.abs(z2[: self.n]))
        for phase, z_s, theta_s, duration in (
            (self.phases["R"], z1, theta1, delta),
            (self.phases["F"], z2, theta1 + delta, np.pi - delta),
        ):
            for j, (low, high) in enumerate(_extreme_values_of(phase, z_s, theta_s, duration, omega, range(self.n))):
                out[j] = max([out[j]] + [abs(v) for v in low + high])
        return out

    def diagnostics(self, y) -> dict:
        """What the continuation driver reports: frequency (Hz), energy at ``z1`` (piecewise law), impacts."""
        z1, _, _, omega = self.split(y)
        M, K = self.excitation.structure.dense_matrices()
        q, v = z1[: self.n], z1[self.n :]
        energy = 0.5 * v @ M @ v + 0.5 * q @ K @ q
        return {"energy": float(energy), "frequency": omega / (2 * np.pi), "impacts_per_period": 2}

    def time_history(self, y, samples: int = 1024) -> dict:
        """``t``, ``q``, ``qdot`` (N, samples), contact force of the struck stop: one period from ``theta1``."""
        z1, theta1, delta, omega = self.split(y)
        z1, z2, _ = self.switch_states(y)
        theta = theta1 + 2 * np.pi * np.arange(samples) / samples
        half = np.mod(theta - theta1, np.pi)
        sign = np.where(theta - theta1 < np.pi, 1.0, -1.0)
        contact = half <= delta
        states = (
            np.where(
                contact[:, None],
                self.phases["R"].states(z1, theta1, omega, theta1 + half),
                self.phases["F"].states(z2, theta1 + delta, omega, theta1 + half),
            )
            * sign[:, None]
        )
        q = states[:, : self.n].T
        x = q[self.stop.dof]
        force = self.stop.stiffness * np.sign(x) * np.maximum(np.abs(x) - self.stop.gap, 0.0)
        return {"t": theta / omega, "theta": theta, "q": q, "qdot": states[:, self.n :].T, "contact_force": force}

    def grazing_start(self, omega: float):
        """The orbit of zero contact duration at a grazing frequency ``omega``: a point of the family."""
        P = self.phases["F"].amplitude(omega)[0]
        theta1 = float(-np.angle(P[self.stop.dof]))
        z1 = self.phases["F"].particular(P, theta1)
        return np.concatenate([z1, [theta1, 0.0, omega]])


@dataclass
class ContactFamily:
    """A continued family of symmetric one-contact responses: unknowns in order, why it ends, cost.

    ``arclength``: pseudo-arclength of each orbit from the first; ``energy``: of each orbit (piecewise law);
    ``end_check``: how the end was confirmed (:func:`confirm_contact_family_end`; "" when it was not asked).
    """

    unknowns: np.ndarray
    end_reason: str
    end_margin: str
    stats: object
    arclength: np.ndarray
    energy: np.ndarray
    end_check: str = ""

    @property
    def step(self) -> float:
        """The longest of the last three steps (pseudo-arclength): what a restart that confirms the end refines."""
        return float(np.max(np.diff(self.arclength[-4:]))) if len(self.arclength) > 1 else 0.0


def follow_contact_family(
    problem: SymmetricContactProblem,
    y0,
    direction,
    settings,
    frequency_range,
    label: str = "exact forced response",
    confirm: bool = False,
    max_points: int | None = None,
) -> ContactFamily:
    """Follow the family through ``y0`` by pseudo-arclength continuation until an assumption fails or the
    frequency leaves ``frequency_range`` (Hz).

    Every orbit is assessed (:meth:`SymmetricContactProblem.assess`); at the first one that breaks an
    assumption, the boundary is located by bisection on the path of the last step
    (:meth:`~nnmstop.continuation.pseudo_arclength.PseudoArclengthStepper.path_through`) to ``1e-12`` of its
    length, and the family ends at the last valid orbit with the reason of :data:`CONTACT_MARGINS`. With
    ``confirm``, that end is confirmed by a restart with a ten times smaller step
    (:func:`confirm_contact_family_end`; ``end_check``), which raises
    :class:`~nnmstop.continuation.confirm.EndNotConfirmed` when it ends elsewhere. ``max_points`` ends the family
    after that many orbits (a restart's bound; the family is still valid there).
    """
    low, high = frequency_range
    count = [0]

    def stop(y, diag):
        count[0] += 1
        if max_points is not None and count[0] >= max_points:
            return f"max_points = {max_points} reached (the family is still valid there)"
        if not low <= diag["frequency"] <= high:
            return f"frequency outside [{low:g}, {high:g}] Hz"
        check = problem.assess(y)
        return "" if check.valid else check.violated[0]

    branch = continue_pseudo_arclength(problem, y0, direction, stop, settings, label=label)
    points = np.array(branch.points)
    arclength = np.array(branch.arclength, dtype=float)
    energy = np.array([d["energy"] for d in branch.diagnostics], dtype=float)
    margin = branch.end_reason if branch.end_reason in CONTACT_MARGINS else ""
    if margin and len(points) >= 2:
        stats = ContinuationStats()
        tangent, _ = unit_tangent(problem, points[-2], points[-1] - points[-2], stats)
        path, length = PseudoArclengthStepper(settings).path_through(problem, points[-2], tangent, points[-1], stats)
        found = bisect_sign_change(
            lambda a: problem.assess(path(a)), 0.0, length, tol=1e-12 * length, side=lambda check: check.valid
        )
        points[-1] = path(found.lo)
        arclength[-1] = arclength[-2] + found.lo
        energy[-1] = problem.diagnostics(points[-1])["energy"]
    reason = CONTACT_MARGINS.get(margin, branch.end_reason)
    family = ContactFamily(points, reason, margin, branch.stats, arclength, energy)
    if confirm:
        family.end_check = confirm_contact_family_end(problem, family, settings, frequency_range, label)
    return family


def confirm_contact_family_end(
    problem: SymmetricContactProblem, family: ContactFamily, settings, frequency_range, label: str
) -> str:
    """Confirm where a contact family ends (:func:`nnmstop.exact.follow.confirm_family_end`): restarted two orbits
    before its end with steps ten times smaller (``initial_step``, ``min_step`` and ``max_step`` of
    ``settings``), it must end on a margin too, at the same orbit to the two runs' location tolerances; a family
    that leaves the frequency range must not meet a margin before its end.

    Raises
    ------
    EndNotConfirmed
        Naming the family and both ends.
    """

    def restart(U, direction, fine_step):
        refine = family.step / fine_step
        fine = replace(
            settings,
            initial_step=settings.initial_step / refine,
            min_step=min(settings.min_step, settings.initial_step / refine),
            max_step=settings.max_step / refine,
        )
        return follow_contact_family(
            problem, U, direction, fine, frequency_range, f"{label} (end check)", max_points=RESTART_POINTS
        )

    return confirm_family_end(family, restart, label)
