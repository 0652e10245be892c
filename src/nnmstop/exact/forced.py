r"""Exact periodic responses of the forced, damped structure with piecewise-linear stops, no symmetry assumed.

``M q'' + C q' + K q + sum_c alpha_c (n_c . q - g_c)_+ n_c = F cos(Omega t) b``: the sum runs over the
half-space contacts of every stop (:meth:`nnmstop.models.contact.StopSet.contacts`: a bilateral stop has two,
``n = +-e_dof``; a one-sided stop one; a relative stop ``n = +-(e_i - e_j)``; unequal gaps are two one-sided
stops). Between two switches the set of active contacts is fixed and the equation is linear with harmonic
forcing: a **phase**, stiffness ``K + sum_active alpha n n^T`` and constant load ``sum_active alpha g n``, whose
flow :class:`ForcedPhase` gives in closed form, homogeneous plus particular solution
(``z(t) = z_p(t) + exp(A t) (z(0) - z_p(0))`` with ``exp(A t)`` from the eigenvectors of ``A``), exact to
round-off. Phases ``theta = Omega t`` are the time variable of every response. The circular clearance is not
piecewise linear in the degrees of freedom: its structures have no exact response here (ValueError naming
it; the regularized engine applies).

Responses covered:

* the non-impacting response (the linear frequency response, :func:`non_impacting_response`), valid while
  every contact coordinate stays within its gap; its grazing frequencies, where ``max_c |n_c . Q| = g_c``
  (``g / |H(Omega)|`` equals the force), are located to round-off (:func:`grazing_frequencies`);
* the responses with a given **sequence of phases** per period (:class:`ForcedResponseProblem`): unknowns
  the state ``z0`` at the first switch, its phase ``theta0``, the phase durations ``d_0 .. d_{m-2}`` (the
  last one closes the period) and ``Omega``; equations one switching condition per switch and periodicity
  ``z(theta0 + 2 pi) = z0``. The switching condition of a contact entered at one switch and left at the next
  is its mean slope over the contact, ``n . (q(theta_k + d_k) - q(theta_k)) / d_k = 0`` (``expm1``, no
  cancellation): regular as ``d_k -> 0``, where it becomes the tangency ``n . qdot = 0``, so a grazing orbit
  is a regular point of its family; any other switch is ``n . q = g``. Where every law is odd and the
  sequence is its own mirror image half a period later, the **half-wave** reduction ``z(theta0 + pi) = -z0``
  over half a period solves the same orbits in the invariant subspace of the symmetric ones (the paper's
  responses, :class:`SymmetricContactProblem`), and gives the multipliers ``nu`` of the half-period map that
  tell a symmetry breaking from a fold. A family starts at a grazing orbit of the non-impacting response
  (:func:`grazing_problem`: one contact phase of zero duration per grazing contact) and is followed by the
  project's pseudo-arclength continuation through its folds, each orbit checked
  (:meth:`ForcedResponseProblem.assess`); it ends, at a located orbit, where an assumption fails, with the
  reason stored, and that end is confirmed by a restart (:func:`confirm_contact_family_end`).

Floquet multipliers: every contact force ``alpha (n . q - g)`` vanishes on its switching surface
``n . q = g``, so the vector field is continuous across every switch of every law allowed here (bilateral,
one-sided, relative, unequal gaps), every saltation matrix is the identity and the monodromy is the product of
the phase exponentials (``-exp(A_{m-1} t_{m-1}) ... exp(A_0 t_0)`` for the half-period map, ``mu = nu**2``).
Method notes: docs/forced.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import NamedTuple

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
    "Switch",
    "structure_contacts",
    "mirror_contacts",
    "free_phase",
    "non_impacting_response",
    "grazing_frequencies",
    "grazing_contacts",
    "ForcedResponseProblem",
    "SymmetricContactProblem",
    "grazing_problem",
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
#: Contacts whose non-impacting excess ``|n . Q| - g`` is within this fraction of their gap of the largest one
#: graze together (the two sides of a bilateral stop do, exactly).
GRAZING_TOLERANCE = 1e-9
#: Contact duration (in the phase ``Omega t``) of the first contact of the first orbit of a family whose grazing
#: orbit has several contacts grazing at once (a bilateral stop without the half-wave reduction): there each
#: contact can open on its own to first order, the grazing orbit is a singular point of the full-period
#: equations, and the family starts next to it.
NEAR_GRAZING_DURATION = 1e-4

#: Why a response with one contact per struck half-space per period stops being one, by validity margin (the
#: texts of a family with a single contact phase per period or half period; see
#: :attr:`ForcedResponseProblem.margin_reasons` for families with several).
CONTACT_MARGINS = {
    "contact_duration": "the contact shrinks to zero duration (grazing: the non-impacting response again)",
    "free_duration": "the contact lasts half a period (no free flight left)",
    "phase_duration": "two switches meet (the order of the contacts changes)",
    "leaves_stop": "the stop DOF leaves the stop during the contact (more contacts per period)",
    "early_impact": "the stop DOF reaches a stop during the free flight (more contacts per period)",
    "other_stops": "the degree of freedom of a passive stop reaches its gap (that stop would be struck too)",
}


def _expm1_over(c, delta: float):
    """``expm1(c delta) / delta`` (``c`` at ``delta = 0``), elementwise, without cancellation."""
    if delta == 0:
        return np.asarray(c, dtype=complex)
    return np.expm1(np.asarray(c) * delta) / delta


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


# --------------------------------------------------------------------------- contacts and phases


def structure_contacts(structure) -> tuple:
    """Every half-space contact of the structure's stops (:meth:`~nnmstop.models.contact.StopSet.contacts`).

    Raises
    ------
    ValueError
        For a stop whose law is not piecewise linear in the degrees of freedom (the circular clearance): no exact
        response; the regularized one (harmonic balance) applies.
    """
    try:
        return structure.contact.contacts()
    except ValueError as error:
        raise ValueError(f"exact forced responses need piecewise-linear stops: {error}") from None


def mirror_contacts(contacts) -> tuple | None:
    """Index of each contact's mirror image (normal ``-n``, same gap and stiffness), or None where one has none."""
    keys = [(tuple(sorted((d, float(s)) for d, s in c.terms)), float(c.gap), float(c.alpha)) for c in contacts]
    mirror = []
    for c in contacts:
        key = (tuple(sorted((d, -float(s)) for d, s in c.terms)), float(c.gap), float(c.alpha))
        if key not in keys:
            return None
        mirror.append(keys.index(key))
    return tuple(mirror)


class Switch(NamedTuple):
    """A switch of a phase sequence: the contact (index into :func:`structure_contacts`) that is entered or left."""

    contact: int
    entry: bool


def _matrices(excitation: Excitation):
    M, K = excitation.structure.dense_matrices()
    C = excitation.damping_matrix
    C = C.toarray() if hasattr(C, "toarray") else np.asarray(C, dtype=float)
    if np.any(np.linalg.eigvalsh(K) <= 0):
        raise ValueError("exact forced responses need a positive definite stiffness K (no rigid-body mode)")
    return M, C, K


def _contact_phase(excitation: Excitation, matrices, contacts, active) -> ForcedPhase:
    """The phase with the contacts ``active`` (indices into ``contacts``): ``K + sum alpha n n^T``, load
    ``sum alpha g n``."""
    M, C, K = matrices
    n = M.shape[0]
    stiffness, load = K.copy(), np.zeros(n)
    for c in sorted(active):
        normal = contacts[c].normal(n)
        stiffness = stiffness + contacts[c].alpha * np.outer(normal, normal)
        load = load + contacts[c].alpha * contacts[c].gap * normal
    return ForcedPhase(M, C, stiffness, load, excitation.load)


def free_phase(excitation: Excitation) -> ForcedPhase:
    """The free flight (no contact active) of ``excitation``: the phase of the non-impacting response."""
    return _contact_phase(excitation, _matrices(excitation), (), ())


@dataclass(frozen=True)
class StruckStop:
    """The struck stop of a symmetric response (one coordinate, odd law) and the other, passive stops."""

    dof: int
    gap: float
    stiffness: float
    passive: tuple

    @classmethod
    def of(cls, excitation: Excitation, stop: int = 0) -> StruckStop:
        stops = excitation.structure.stops
        if not 0 <= stop < len(stops):
            raise ValueError(f"stop must index one of the {len(stops)} stops, got {stop!r}")
        other = [s.label for s in stops if s.kind != "bilateral"]
        if other:
            raise ValueError(
                "exact forced responses use the half-period symmetry of bilateral stops on one degree of freedom; "
                f"this structure has {', '.join(other)} (exact responses without that symmetry: not yet; the "
                "regularized response applies)"
            )
        s = stops[stop]
        if s.n_components != 1 or not s.odd:
            raise ValueError(
                f"a symmetric response needs an odd law on one coordinate (bilateral or relative on both sides), "
                f"not the {s.label}; ForcedResponseProblem takes any piecewise-linear stop"
            )
        return cls(s.dofs[0], s.gap, s.stiffness, tuple(o for i, o in enumerate(stops) if i != stop))


# --------------------------------------------------------------------------- the non-impacting response


def non_impacting_response(excitation: Excitation, omega) -> np.ndarray:
    """Complex amplitudes ``Q`` (``np.shape(omega) + (N,)``) of the non-impacting response ``Re(Q e^{i theta})``."""
    return _free_amplitudes(free_phase(excitation), omega)


def _free_amplitudes(phase: ForcedPhase, omega) -> np.ndarray:
    omega = np.asarray(omega, dtype=float)
    out = np.array([phase.amplitude(w)[0][: phase.n] for w in omega.ravel()])
    return out.reshape(omega.shape + (phase.n,))


def _normals_and_gaps(excitation: Excitation):
    contacts = structure_contacts(excitation.structure)
    n = excitation.structure.n_dofs
    return np.array([c.normal(n) for c in contacts]), np.array([c.gap for c in contacts])


def grazing_frequencies(excitation: Excitation, omega_low: float, omega_high: float, samples: int = 2000) -> list:
    """Angular frequencies in ``[omega_low, omega_high]`` where the non-impacting response first reaches a stop:
    ``max_c (|n_c . Q(Omega)| - g_c)`` changes sign (``|n_c . Q| = F |H_c(Omega)|``, ``H_c`` the receptance of the
    contact coordinate to the force pattern).

    A sample grid (log-spaced) brackets each crossing; Brent's method locates it to round-off.
    """
    normals, gaps = _normals_and_gaps(excitation)
    phase = free_phase(excitation)
    grid = np.geomspace(omega_low, omega_high, samples)

    def excess(w):
        return float(np.max(np.abs(normals @ _free_amplitudes(phase, w)) - gaps))

    values = np.array([excess(w) for w in grid])
    crossings = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
    return [scipy.optimize.brentq(excess, grid[i], grid[i + 1], xtol=1e-15, rtol=1e-15) for i in crossings]


def grazing_contacts(excitation: Excitation, omega: float) -> list:
    """The contacts the non-impacting response at ``omega`` reaches furthest (within :data:`GRAZING_TOLERANCE` of
    their gaps of the largest excess ``|n . Q| - g``): those that graze at a grazing frequency."""
    normals, gaps = _normals_and_gaps(excitation)
    excess = np.abs(normals @ non_impacting_response(excitation, omega)) - gaps
    return [int(c) for c in np.flatnonzero(excess >= excess.max() - GRAZING_TOLERANCE * gaps)]


# --------------------------------------------------------------------------- responses of a phase sequence


@dataclass(frozen=True)
class ContactAssessment(MarginChecks):
    """Validity margins of a response of a phase sequence (:data:`CONTACT_MARGINS`), each > 0 when it holds."""

    margins: dict


def _extreme_values_of(phase: ForcedPhase, z_s, theta_s: float, delta: float, omega: float, directions) -> list:
    """Interior local minima and maxima of ``direction . q`` over the phases ``(theta_s, theta_s + delta)``, for
    each of ``directions`` (vectors of length N or DOF indices): ``[(minima, maxima) per direction]``.

    The closed-form state is sampled once (the amplitudes of every DOF of a large structure) at
    :data:`SAMPLES_PER_PERIOD` points per period of the fastest of the phase's oscillations and the force; each
    sign change of a velocity is refined by Brent's method to round-off.
    """
    if not delta > 0:
        return [([], []) for _ in directions]
    n_dofs = phase.n
    P = phase.amplitude(omega)[0]
    fastest = max(phase.fastest, omega)
    n = SAMPLES_PER_PERIOD * max(1, int(np.ceil(delta / omega * fastest / (2 * np.pi)))) + 1
    theta = np.linspace(theta_s, theta_s + delta, n)
    samples = phase.states(z_s, theta_s, omega, theta, P)
    edge = 1e-12 * max(delta, 1.0)
    out = []
    for direction in directions:
        if np.ndim(direction) == 0:
            direction = np.eye(n_dofs)[int(direction)]
        direction = np.asarray(direction, dtype=float)

        def velocity(r, direction=direction):
            return phase.states(z_s, theta_s, omega, r, P)[n_dofs:] @ direction

        v = samples[:, n_dofs:] @ direction
        minima, maxima = [], []
        for i in np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:])):
            lo, hi = theta[i], theta[i + 1]
            bracketed = velocity(lo) * velocity(hi) < 0
            r = scipy.optimize.brentq(velocity, lo, hi, xtol=1e-15, rtol=1e-15) if bracketed else lo
            if theta_s + edge < r < theta_s + delta - edge:
                value = phase.states(z_s, theta_s, omega, r, P)[:n_dofs] @ direction
                (maxima if v[i] > 0 else minima).append(float(value))
        out.append((minima, maxima))
    return out


class ForcedResponseProblem:
    """Periodic responses with one sequence of phases per period, as a continuation problem.

    Parameters
    ----------
    excitation : Excitation
        Structure (its stops piecewise linear: every contact of every stop counts, those not in the sequence
        must stay inactive, which :meth:`assess` checks), damping and force.
    sequence : sequence of sets of int
        Active contacts (indices into :func:`structure_contacts`) of each phase, in order from the first switch;
        two consecutive phases (the last and the first, mirrored under ``half_wave``, included) differ by one
        contact. Families from grazing start with an entry: ``[{c}, {}]`` is one contact per period.
    half_wave : bool
        The half-wave reduction: the sequence spans half a period and the orbit closes on ``z(theta0 + pi) =
        -z0`` (every law odd; the second half is the first mirrored).

    Unknowns ``y = [z0 (2N), theta0, d_0 .. d_{m-2}, Omega]`` (``n_unknowns = 2N + m + 1``), ``2N + m``
    equations (module docstring), with ``residual``, an analytic ``jacobian`` and ``diagnostics`` for the
    continuation driver (:mod:`nnmstop.continuation.driver`).

    Examples
    --------
    A one-sided stop on the first mass of a 2-DOF chain, one contact per period from its first grazing orbit:

    >>> import numpy as np
    >>> from nnmstop.models.contact import Stop
    >>> from nnmstop.models.structure import Structure
    >>> from nnmstop.models.excitation import Damping, Excitation, HarmonicForce
    >>> stop = Stop(kind="one_sided", dof=0, side="positive", gap=1.0, stiffness=20.0, eta=0.05)
    >>> chain = Structure(np.eye(2), [[2.0, -1.0], [-1.0, 2.0]], [stop])
    >>> excitation = Excitation(chain, Damping.from_modal_ratios(chain, [0.02, 0.02]), HarmonicForce(0.1, [0]))
    >>> omega = grazing_frequencies(excitation, 0.3, 2.5)[0]
    >>> problem, y0, _ = grazing_problem(excitation, omega)
    >>> problem.n_unknowns, problem.half_wave, float(np.abs(problem.residual(y0)).max()) < 1e-13
    (7, False, True)
    """

    def __init__(self, excitation: Excitation, sequence, half_wave: bool = False):
        self.excitation = excitation
        structure = excitation.structure
        self.n = n = structure.n_dofs
        self.contacts = structure_contacts(structure)
        self.normals = np.array([c.normal(n) for c in self.contacts])
        self.gaps = np.array([c.gap for c in self.contacts])
        self.sequence = tuple(frozenset(int(c) for c in phase) for phase in sequence)
        self.m = m = len(self.sequence)
        if m < 2:
            raise ValueError(f"a phase sequence needs at least two phases, got {m}")
        for phase in self.sequence:
            off = [c for c in phase if not 0 <= c < len(self.contacts)]
            if off:
                raise ValueError(f"contacts {off} are not among the structure's {len(self.contacts)} contacts")
        self.half_wave = bool(half_wave)
        self.mirror = mirror_contacts(self.contacts) if structure.contact.odd else None
        if self.half_wave and self.mirror is None:
            raise ValueError(
                "the half-wave reduction needs odd laws (every stop bilateral, or relative on both sides); "
                f"this structure has {', '.join(s.label for s in structure.stops if not s.odd)}"
            )
        self.span = np.pi if self.half_wave else 2 * np.pi
        self.switches = []
        for k in range(m):
            before = self.sequence[k - 1] if k else self._closing_image(self.sequence[-1])
            changed = before ^ self.sequence[k]
            if len(changed) != 1:
                raise ValueError(f"the phase before phase {k} and phase {k} must differ by one contact, got {changed}")
            (c,) = changed
            self.switches.append(Switch(c, c in self.sequence[k]))
        if not self.switches[0].entry:
            raise ValueError("the sequence must start where a contact is entered (its first phase holds it)")
        self._matrices = _matrices(excitation)
        self._phases = {}
        self.phase_list = [self.phase(active) for active in self.sequence]
        struck = set().union(*self.sequence)
        if self.half_wave:
            struck |= {self.mirror[c] for c in struck}
        self.struck = frozenset(struck)
        self.passive = tuple(c for c in range(len(self.contacts)) if c not in self.struck)
        # phase k is a contact phase of its own (an episode) when it enters a contact at its start and leaves it at
        # its end: its duration shrinks to 0 at grazing, and its end's switching condition is the mean slope
        self.episode = [
            self.switches[k].entry and self._end_switch(k) == Switch(self.switches[k].contact, False) for k in range(m)
        ]
        self.n_unknowns = 2 * n + m + 1
        self.n_equations = 2 * n + m

    # ------------------------------------------------------------------ sequence bookkeeping

    def _closing_image(self, active):
        return frozenset(self.mirror[c] for c in active) if self.half_wave else active

    def _end_switch(self, k: int) -> Switch:
        """The switch at the end of phase ``k`` (the first switch, mirrored under ``half_wave``, for the last)."""
        if k < self.m - 1:
            return self.switches[k + 1]
        first = self.switches[0]
        return Switch(self.mirror[first.contact], first.entry) if self.half_wave else first

    def phase(self, active) -> ForcedPhase:
        """The closed-form phase with the contacts ``active`` (cached)."""
        active = frozenset(active)
        if active not in self._phases:
            self._phases[active] = _contact_phase(self.excitation, self._matrices, self.contacts, active)
        return self._phases[active]

    @property
    def episodes(self) -> int:
        """Contact phases of their own per period (or half period under ``half_wave``)."""
        return int(sum(self.episode))

    @property
    def margin_reasons(self) -> dict:
        """Why a family of this sequence ends, by validity margin (:data:`CONTACT_MARGINS` for one contact phase)."""
        reasons = dict(CONTACT_MARGINS)
        if self.episodes > 1:
            reasons["contact_duration"] = "a contact phase shrinks to zero duration (grazing: fewer contacts)"
            reasons["free_duration"] = "a free flight shrinks to zero duration (two contacts meet)"
        elif not self.half_wave:
            reasons["free_duration"] = "the contact lasts the whole period (no free flight left)"
        if not self.half_wave:
            reasons["leaves_stop"] = "a contact coordinate leaves its stop during the contact (more contacts)"
            reasons["early_impact"] = "a struck contact is reached outside its contact phase (more contacts)"
            reasons["other_stops"] = "a contact of a stop not struck is reached (that stop would be struck too)"
        return reasons

    def describe(self) -> str:
        """The sequence in words, e.g. ``"q0 >= 1 in, q0 >= 1 out (half-wave)"`` or ``"q0 - q1 >= 0.5 in, ..."``."""
        words = []
        for s in self.switches:
            c = self.contacts[s.contact]
            (first, sign), rest = c.terms[0], c.terms[1:]
            coordinate = f"{'-' if sign < 0 else ''}q{first}" + "".join(
                f" {'+' if s > 0 else '-'} q{dof}" for dof, s in rest
            )
            words.append(f"{coordinate} >= {c.gap:g} {'in' if s.entry else 'out'}")
        return ", ".join(words) + (" (half-wave)" if self.half_wave else "")

    # ------------------------------------------------------------------ unknowns and states

    def split(self, y):
        """``z0``, ``theta0``, the ``m`` phase durations (the last one closing the span) and ``Omega``."""
        y = np.asarray(y, dtype=float)
        n2, m = 2 * self.n, self.m
        free = y[n2 + 1 : n2 + m]
        durations = np.concatenate([free, [self.span - free.sum()]])
        return y[:n2], float(y[n2]), durations, float(y[-1])

    def switch_phases(self, y) -> np.ndarray:
        """``theta_k`` of every switch and of the end of the span (``m + 1``)."""
        _, theta0, durations, _ = self.split(y)
        return theta0 + np.concatenate([[0.0], np.cumsum(durations)])

    def switch_states(self, y) -> list:
        """States at every switch and at the end of the span (``m + 1``; the last is ``z0``, or ``-z0`` under
        ``half_wave``, on a solution)."""
        z, theta0, durations, omega = self.split(y)
        states, theta = [z], theta0
        for phase, d in zip(self.phase_list, durations):
            states.append(phase.end_state(states[-1], theta, d, omega)[0])
            theta = theta + d
        return states

    def residual(self, y):
        z0, theta0, durations, omega = self.split(y)
        n, m = self.n, self.m
        out = np.empty(2 * n + m)
        states, theta, thetas = [z0], theta0, [theta0]
        for phase, d in zip(self.phase_list, durations):
            states.append(phase.end_state(states[-1], theta, d, omega)[0])
            theta = theta + d
            thetas.append(theta)
        for k, switch in enumerate(self.switches):
            normal = self.normals[switch.contact]
            if k and self.episode[k - 1]:
                slope = self.phase_list[k - 1].mean_slope(states[k - 1], thetas[k - 1], durations[k - 1], omega)
                out[k] = normal @ slope[:n]
            else:
                out[k] = normal @ states[k][:n] - self.gaps[switch.contact]
        out[m:] = states[-1] + z0 if self.half_wave else states[-1] - z0
        return out

    def _slope_row(self, k: int, z_s, theta_s: float, delta: float, omega: float, normal):
        """Derivatives of the mean slope of ``normal . q`` over phase ``k`` by ``(z_s, theta_s, delta, Omega)``."""
        phase = self.phase_list[k]
        P, dP = phase.amplitude(omega)
        lam = phase.eigenvalues / omega
        start = z_s - phase.particular(P, theta_s)
        project = phase.V_inv @ start
        row = normal @ phase.V[: self.n]
        p_c, dp_c = normal @ P[: self.n], normal @ dP[: self.n]
        mean = (row * _expm1_over(lam, delta)) @ phase.V_inv
        d_theta = np.real(1j * p_c * np.exp(1j * theta_s) * _expm1_over(1j, delta)) - mean @ np.real(
            1j * P * np.exp(1j * theta_s)
        )
        d_delta = np.real(p_c * np.exp(1j * theta_s) * _slope_derivative(1j, delta)) + np.real(
            (row * _slope_derivative(lam, delta)) @ project
        )
        d_omega = (
            np.real(dp_c * np.exp(1j * theta_s) * _expm1_over(1j, delta))
            - mean.real @ np.real(dP * np.exp(1j * theta_s))
            + np.real((row * np.exp(lam * delta) * (-lam / omega)) @ project)
        )
        return mean.real, d_theta.real, d_delta, d_omega

    def jacobian(self, y):
        z0, theta0, durations, omega = self.split(y)
        n, m = self.n, self.m
        n2, i_theta, i_omega = 2 * n, 2 * n, 2 * n + m
        J = np.zeros((self.n_equations, self.n_unknowns))
        # derivatives of the phase and duration of phase k by the unknowns
        d_theta = np.zeros(self.n_unknowns)
        d_theta[i_theta] = 1.0
        D = np.zeros((n2, self.n_unknowns))  # d z_k / d y
        D[:, :n2] = np.eye(n2)
        theta, states, thetas, rows = theta0, [z0], [theta0], [D]
        for k, (phase, d) in enumerate(zip(self.phase_list, durations)):
            d_duration = np.zeros(self.n_unknowns)
            if k < m - 1:
                d_duration[n2 + 1 + k] = 1.0
            else:
                d_duration[n2 + 1 : n2 + m] = -1.0
            z_e, E, e_theta, e_delta, e_omega = phase.end_state(states[-1], theta, d, omega)
            D = E @ D + np.outer(e_theta, d_theta) + np.outer(e_delta, d_duration)
            D[:, i_omega] += e_omega
            states.append(z_e)
            rows.append(D)
            if k < m - 1:
                d_theta = d_theta.copy()
                d_theta[n2 + 1 + k] += 1.0
            theta = theta + d
            thetas.append(theta)
        for k, switch in enumerate(self.switches):
            normal = self.normals[switch.contact]
            if k and self.episode[k - 1]:
                j = k - 1
                dz, dth, ddl, dom = self._slope_row(j, states[j], thetas[j], durations[j], omega, normal)
                J[k] = dz @ rows[j]
                J[k, i_theta] += dth
                J[k, n2 + 1 : n2 + 1 + j] += dth
                J[k, n2 + 1 + j] += ddl  # an episode is never the last phase (the sequence starts with an entry)
                J[k, i_omega] += dom
            else:
                J[k] = normal @ rows[k][:n]
        J[m:] = rows[-1]
        J[m:, :n2] += np.eye(n2) if self.half_wave else -np.eye(n2)
        return J

    # ------------------------------------------------------------------ stability

    def period_map(self, y) -> np.ndarray:
        """Jacobian of the return map over the span: ``exp(A_{m-1} t_{m-1}) ... exp(A_0 t_0)``, negated under
        ``half_wave`` (the half-period map ``z -> -z(theta + pi)``); every saltation matrix is the identity."""
        _, _, durations, omega = self.split(y)
        product = np.eye(2 * self.n)
        for phase, d in zip(self.phase_list, durations):
            product = phase.exponential(d / omega) @ product
        return -product if self.half_wave else product

    def monodromy(self, y) -> np.ndarray:
        """The monodromy matrix over one period."""
        H = self.period_map(y)
        return H @ H if self.half_wave else H

    def multipliers(self, y):
        """Multipliers ``mu`` over one period and ``nu`` of :meth:`period_map`, by decreasing ``|nu|``
        (``mu = nu**2`` under ``half_wave``, else ``mu = nu``)."""
        nu = np.linalg.eigvals(self.period_map(y))
        nu = nu[np.argsort(-np.abs(nu), kind="stable")]
        return (nu * nu if self.half_wave else nu), nu

    def multiplier_error(self, y) -> float:
        """Error estimate of ``nu``: their difference from the eigenvalues of the same map built with
        :func:`scipy.linalg.expm` (a second route to the same matrix exponentials)."""
        _, _, durations, omega = self.split(y)
        second = np.eye(2 * self.n)
        for phase, d in zip(self.phase_list, durations):
            second = scipy.linalg.expm(phase.A * (d / omega)) @ second
        second = -second if self.half_wave else second
        nu = self.multipliers(y)[1]
        return float(np.abs(nu - match_nearest(nu[None], np.linalg.eigvals(second)[None])[0]).max())

    # ------------------------------------------------------------------ validity, amplitudes, orbits

    def _directions(self):
        """Unique contact coordinates up to sign: ``(directions, index and sign of each contact's)``."""
        directions, of = [], []
        for normal in self.normals:
            sign = 1.0 if normal[np.flatnonzero(normal)[0]] > 0 else -1.0
            w = sign * normal
            match = [i for i, u in enumerate(directions) if np.array_equal(u, w)]
            if not match:
                directions.append(w)
            of.append((match[0] if match else len(directions) - 1, sign))
        return directions, of

    def assess(self, y) -> ContactAssessment:
        """Margins of the assumptions of the construction (each > 0 when it holds), :attr:`margin_reasons`.

        Durations of the phases (``contact_duration`` for a contact phase of its own, ``free_duration``,
        ``phase_duration`` for any other); in each phase, every active contact stays beyond its gap
        (``leaves_stop``), every other struck contact within it (``early_impact``), and the contacts never struck
        within theirs (``other_stops``), by the interior extrema of the contact coordinates (closed form, refined
        to round-off) and their values at the phase's ends where the contact does not switch.
        """
        _, _, durations, omega = self.split(y)
        states, thetas = self.switch_states(y), self.switch_phases(y)
        directions, of = self._directions()
        margins = {"contact_duration": np.inf, "free_duration": np.inf}
        if any(not e and a for e, a in zip(self.episode, self.sequence)):
            margins["phase_duration"] = np.inf
        for k, d in enumerate(durations):
            key = "contact_duration" if self.episode[k] else "phase_duration" if self.sequence[k] else "free_duration"
            margins[key] = min(margins[key], float(d))
        leaves, early, other = [], [], []
        for k, (phase, active) in enumerate(zip(self.phase_list, self.sequence)):
            extremes = _extreme_values_of(phase, states[k], thetas[k], durations[k], omega, directions)
            switching = {self.switches[k].contact, self._end_switch(k).contact}
            for c in range(len(self.contacts)):
                i, sign = of[c]
                low, high = extremes[i] if sign > 0 else ([-v for v in extremes[i][1]], [-v for v in extremes[i][0]])
                ends = [] if c in switching else [self.normals[c] @ z[: self.n] for z in (states[k], states[k + 1])]
                g = self.gaps[c]
                if c in active:
                    leaves += [v - g for v in low + ends]
                else:
                    (early if c in self.struck else other).extend(g - v for v in high + ends)
        margins["leaves_stop"] = float(min(leaves, default=np.inf))
        margins["early_impact"] = float(min(early, default=np.inf))
        if self.passive:
            margins["other_stops"] = float(min(other, default=np.inf))
        return ContactAssessment(margins)

    def amplitudes(self, y) -> np.ndarray:
        """``max |q_j|`` over the period for every DOF (phase ends and interior extrema: exact to round-off)."""
        _, _, durations, omega = self.split(y)
        states, thetas = self.switch_states(y), self.switch_phases(y)
        out = np.max(np.abs(np.array(states)[:, : self.n]), axis=0)
        for k, phase in enumerate(self.phase_list):
            extremes = _extreme_values_of(phase, states[k], thetas[k], durations[k], omega, range(self.n))
            for j, (low, high) in enumerate(extremes):
                out[j] = max([out[j]] + [abs(v) for v in low + high])
        return out

    def diagnostics(self, y) -> dict:
        """What the continuation driver reports: frequency (Hz), energy at ``z0`` (piecewise law), impacts."""
        z0, _, _, omega = self.split(y)
        M, _, K = self._matrices
        q, v = z0[: self.n], z0[self.n :]
        energy = 0.5 * v @ M @ v + 0.5 * q @ K @ q
        for c in self.sequence[0] - {self.switches[0].contact}:
            energy += 0.5 * self.contacts[c].alpha * max(self.normals[c] @ q - self.gaps[c], 0.0) ** 2
        entries = sum(s.entry for s in self.switches) * (2 if self.half_wave else 1)
        return {"energy": float(energy), "frequency": omega / (2 * np.pi), "impacts_per_period": int(entries)}

    def time_history(self, y, samples: int = 1024) -> dict:
        """``t``, ``theta``, ``q``, ``qdot`` (N, samples) and the piecewise-linear contact force of every stop
        (``contact_forces``, stops x samples; ``contact_force`` of the first): one period from ``theta0``."""
        z0, theta0, durations, omega = self.split(y)
        states = self.switch_states(y)
        theta = theta0 + 2 * np.pi * np.arange(samples) / samples
        local = np.mod(theta - theta0, self.span)
        sign = np.where(theta - theta0 < self.span, 1.0, -1.0) if self.half_wave else np.ones(samples)
        which = np.searchsorted(np.cumsum(durations)[:-1], local, side="left")
        out = np.empty((samples, 2 * self.n))
        starts = self.switch_phases(y)
        for k, phase in enumerate(self.phase_list):
            pick = which == k
            if np.any(pick):
                out[pick] = phase.states(states[k], starts[k], omega, theta0 + local[pick])
        out *= sign[:, None]
        q = out[:, : self.n].T
        structure = self.excitation.structure
        forces = np.array(
            [np.atleast_2d(s.piecewise_force(s.coordinate_matrix(self.n) @ q))[0] for s in structure.stops]
        )
        return {
            "t": theta / omega,
            "theta": theta,
            "q": q,
            "qdot": out[:, self.n :].T,
            "contact_force": forces[0],
            "contact_forces": forces,
        }

    # ------------------------------------------------------------------ the start at grazing

    def grazing_start(self, omega: float):
        """The orbit of zero contact durations at a grazing frequency ``omega``: the non-impacting response with
        each contact of the sequence entered and left at the phase where its coordinate is largest."""
        free = self.phase(())
        P = free.amplitude(omega)[0]
        peak = {c: float(-np.angle(self.normals[c] @ P[: self.n])) for c in {s.contact for s in self.switches}}
        theta0 = peak[self.switches[0].contact]
        offsets = [np.mod(peak[s.contact] - theta0, self.span) if k else 0.0 for k, s in enumerate(self.switches)]
        z0 = free.particular(P, theta0)
        return np.concatenate([z0, [theta0], np.diff(offsets), [omega]])

    def start_direction(self) -> np.ndarray:
        """The direction of growing contact durations (orients the family away from its grazing orbit)."""
        direction = np.zeros(self.n_unknowns)
        for k in range(self.m - 1):
            if self.episode[k]:
                direction[2 * self.n + 1 + k] = 1.0
        return direction


class SymmetricContactProblem(ForcedResponseProblem):
    """The symmetric responses ``q(theta + pi) = -q(theta)`` with one contact per side of an odd stop per period:
    the half-wave reduction of :class:`ForcedResponseProblem` with the sequence ``[{right}, {}]``.

    Unknowns ``y = [z1 (2N), theta1, delta, Omega]``: the state ``z1`` where ``q_c`` enters the right stop, its
    phase, the phase duration of the contact and ``Omega``; equations ``q_c(z1) = g``, the mean slope of ``q_c``
    over the contact and ``z(theta1 + pi) = -z1``. ``phases["R"]`` and ``phases["F"]`` are the contact and the
    free flight, :attr:`stop` the struck stop (any other is passive and checked to stay untouched).
    """

    def __init__(self, excitation: Excitation, stop: int = 0):
        self.stop = StruckStop.of(excitation, stop)
        contacts = structure_contacts(excitation.structure)
        right = next(i for i, c in enumerate(contacts) if c.stop == stop and c.side == 1)
        super().__init__(excitation, [{right}, set()], half_wave=True)
        self.phases = {"F": self.phase(()), "R": self.phase({right})}

    def half_period_map(self, y) -> np.ndarray:
        """Jacobian ``-exp(A_F t_F) exp(A_R t_R)`` of the half-period map ``z -> -z(theta + pi)`` (saltation = I)."""
        return self.period_map(y)


def grazing_problem(excitation: Excitation, omega: float, use_symmetry: bool = True):
    """The family of responses through the grazing orbit of the non-impacting response at ``omega``.

    Every contact that grazes there (:func:`grazing_contacts`) gets a contact phase of zero duration at the phase
    where its coordinate is largest, in the order of those phases from the lowest-numbered contact, with free
    flight between them. Where every law is odd (each grazing contact's mirror grazes half a period later) and
    ``use_symmetry``, the half-wave reduction over the first half.

    Returns
    -------
    problem : ForcedResponseProblem
    y0 : ndarray
        The grazing orbit (a regular point of the family).
    direction : ndarray
        Of growing contact durations.
    """
    contacts = structure_contacts(excitation.structure)
    grazing = grazing_contacts(excitation, omega)
    Q = non_impacting_response(excitation, omega)
    peak = {c: -np.angle(contacts[c].normal(len(Q)) @ Q) for c in grazing}
    first = grazing[0]
    ordered = sorted(grazing, key=lambda c: np.mod(peak[c] - peak[first], 2 * np.pi) if c != first else -1.0)
    mirror = mirror_contacts(contacts) if excitation.structure.contact.odd else None
    half = bool(use_symmetry and mirror is not None and all(mirror[c] in grazing for c in grazing))
    if half:
        kept = []
        for c in ordered:
            if mirror[c] not in kept:
                kept.append(c)
        ordered = kept
    sequence = [phase for c in ordered for phase in ({c}, set())]
    problem = ForcedResponseProblem(excitation, sequence, half_wave=half)
    y0, direction = problem.grazing_start(omega), problem.start_direction()
    if problem.episodes > 1:
        y0 = _near_grazing_start(problem, y0, direction)
    return problem, y0, direction


def _near_grazing_start(problem: ForcedResponseProblem, y0, direction, iterations: int = 30):
    """The orbit of the family next to a grazing orbit where several contacts graze at once (a symmetric pair):
    every contact duration held at :data:`NEAR_GRAZING_DURATION`, the rest solved by Gauss-Newton (one equation
    more than unknowns, consistent where the contacts open together). Held one at a time, Newton may land on the
    spurious solution where another contact's duration is negative, as the durations open independently to
    first order."""
    held = np.flatnonzero(direction)
    rows = np.eye(problem.n_unknowns)[held]
    y = y0 + NEAR_GRAZING_DURATION * direction
    for _ in range(iterations):
        r = np.concatenate([problem.residual(y), y[held] - NEAR_GRAZING_DURATION])
        if np.linalg.norm(r) <= 1e-13 * max(np.linalg.norm(y), 1.0):
            return y
        J = np.vstack([problem.jacobian(y), rows])
        y = y - np.linalg.lstsq(J, r, rcond=None)[0]
    raise ValueError(
        f"no orbit of the family {problem.describe()} with its contacts opening together next to its grazing orbit "
        f"at Omega = {y0[-1]!r} (Gauss-Newton residual {np.linalg.norm(r):.3g} after {iterations} iterations)"
    )


# --------------------------------------------------------------------------- families


@dataclass
class ContactFamily:
    """A continued family of responses of one phase sequence: unknowns in order, why it ends, cost.

    ``arclength``: pseudo-arclength of each orbit from the first; ``energy``: of each orbit (piecewise law);
    ``end_check``: how the end was confirmed (:func:`confirm_contact_family_end`; "" when it was not asked);
    ``branch_points``: indices of the orbits after which the continuation flagged a simple branch point.
    """

    unknowns: np.ndarray
    end_reason: str
    end_margin: str
    stats: object
    arclength: np.ndarray
    energy: np.ndarray
    end_check: str = ""
    branch_points: list = field(default_factory=list)

    @property
    def step(self) -> float:
        """The longest of the last three steps (pseudo-arclength): what a restart that confirms the end refines."""
        return float(np.max(np.diff(self.arclength[-4:]))) if len(self.arclength) > 1 else 0.0


def follow_contact_family(
    problem: ForcedResponseProblem,
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

    Every orbit is assessed (:meth:`ForcedResponseProblem.assess`); at the first one that breaks an
    assumption, the boundary is located by bisection on the path of the last step
    (:meth:`~nnmstop.continuation.pseudo_arclength.PseudoArclengthStepper.path_through`) to ``1e-12`` of its
    length, and the family ends at the last valid orbit with its reason
    (:attr:`~ForcedResponseProblem.margin_reasons`). With ``confirm``, that end is confirmed by a restart with a
    ten times smaller step (:func:`confirm_contact_family_end`; ``end_check``), which raises
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
    reasons = problem.margin_reasons
    margin = branch.end_reason if branch.end_reason in reasons else ""
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
    reason = reasons.get(margin, branch.end_reason)
    if margin == "contact_duration" and problem.episodes > 1:
        durations = problem.split(points[-1])[2][np.array(problem.episode)]
        if np.all(durations <= 1e-6):  # every contact grazes at once: the non-impacting response again
            reason = CONTACT_MARGINS["contact_duration"]
    family = ContactFamily(points, reason, margin, branch.stats, arclength, energy, "", list(branch.branch_points))
    if confirm:
        family.end_check = confirm_contact_family_end(problem, family, settings, frequency_range, label)
    return family


def confirm_contact_family_end(
    problem: ForcedResponseProblem, family: ContactFamily, settings, frequency_range, label: str
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
