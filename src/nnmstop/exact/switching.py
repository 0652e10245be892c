r"""Exact periodic orbits over a full period, no symmetry assumed: one-sided stops and unequal gaps.

The quarter-period construction of :mod:`nnmstop.exact.ndof` needs the half-wave symmetry
``q(t + T/2) = -q(t)`` of a bilateral stop; an orbit that strikes one side only (a one-sided stop, or the
nearer of two unequal gaps) has none. Here an orbit is a cyclic sequence of linear phases over one whole
period, each phase a set of active contacts (the half-spaces of the piecewise-linear laws,
:meth:`nnmstop.models.contact.Stop.contacts`): ``M q'' + (K + sum alpha n n^T) q = sum alpha gap n`` in closed
form (:class:`~nnmstop.exact.ndof.PhaseFlow`). Time 0 is where the orbit leaves the first contact of the
sequence (``n . q(0) = gap``, the phase condition), which makes its energy the free flight's,
``(|a|^2 + |b|^2) / 2`` in the scaled modal coordinates ``a = omega Phi^T M q``, ``b = Phi^T M q'`` of the free
flight (:class:`SwitchingProblem`).

Unknowns ``y = (a, b, t_1 .. t_{m-1}, T, sigma)``: the state at ``t = 0``, the switching times and the period,
and an unfolding parameter ``sigma``. Equations: the phase condition, the switching conditions
``n_k . q(t_k) = gap_k`` and periodicity ``(a, b)(T) - (a, b)(0) + sigma (a, b)(0) = 0``: ``2N + m``
equations for ``2N + m + 1`` unknowns. Periodic orbits of a conservative system come in families and the
periodicity equations alone are singular (energy conservation makes one of them redundant): the term
``sigma grad E`` (``grad E = (a, b)`` at ``t = 0``) restores the rank, and since ``E((a, b)(T)) = E((a, b)(0))``
exactly, every solution has ``sigma = 0`` (Munoz-Almaraz et al., Physica D 181 (2003) 1-38, with the term on
the periodicity condition instead of the vector field, so that the phases keep their closed forms). The Jacobian
is exact: transition matrices for the state, vector fields for the times.

:func:`follow_switching_family` follows the family with one impact per active contact from the grazing orbit of
a linear mode at the first contact it reaches (the nearest gap), and, where an orbit of that family grazes
another contact (the other side of unequal gaps), goes on with that contact inserted into the sequence: the
exact NNM family with one impact per active side. Method notes: docs/methods/one_sided_law.md.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from nnmstop.continuation.dense_arclength import DenseArclengthSettings
from nnmstop.continuation.newton import newton_solve, round_off_criterion
from nnmstop.exact.follow import ValidityEvents, branch_point_flags, continue_exact_family, residual_norms
from nnmstop.exact.grazing import MarginChecks
from nnmstop.exact.ndof import PhaseFlow, _interior_extreme
from nnmstop.models.structure import Structure

__all__ = [
    "structure_contacts",
    "SwitchingProblem",
    "SwitchingAssessment",
    "SwitchingFamily",
    "first_grazing",
    "near_grazing_orbit",
    "assess_orbit",
    "follow_switching_family",
    "time_history",
]

logger = logging.getLogger("nnmstop.exact.switching")

#: Contact duration of the first orbit next to the grazing one, as a fraction of the linear period: at the
#: grazing orbit itself two switching times coincide and the equations are singular.
START_CONTACT_FRACTION = 1e-3


def structure_contacts(structure: Structure) -> tuple:
    """Every half-space contact of every stop (:meth:`~nnmstop.models.contact.Stop.contacts`), tagged by stop.

    Raises
    ------
    ValueError
        For a stop whose law is not piecewise linear in the degrees of freedom (the circular clearance).
    """
    return tuple(c for k, stop in enumerate(structure.stops) for c in stop.contacts(k))


def _contact_name(contact, structure) -> str:
    stop = structure.stops[contact.stop]
    if stop.side_sign == 0:
        return f"{stop.label}, {'positive' if contact.side > 0 else 'negative'} side"
    return stop.label


class SwitchingProblem:
    """Residual and exact Jacobian of the full-period equations of one phase sequence.

    Parameters
    ----------
    structure : Structure
        Its stops piecewise linear (every contact of every stop counts: those not in the sequence must stay
        inactive, which :func:`assess_orbit` checks).
    sequence : sequence of frozenset of int
        Active contacts (indices into :func:`structure_contacts`) of each phase, in order from ``t = 0``; two
        consecutive phases (the last and the first included) differ by one contact. The first contact left at
        ``t = 0`` is the one active in the last phase and not in the first.
    """

    def __init__(self, structure: Structure, sequence):
        self.structure = structure
        self.contacts = structure_contacts(structure)
        self.sequence = tuple(frozenset(int(c) for c in phase) for phase in sequence)
        self.n = n = structure.n_dofs
        self.m = m = len(self.sequence)
        if m < 2:
            raise ValueError(f"a phase sequence needs at least two phases, got {m}")
        self.toggles = []  # per switch k = 0 (t = 0) .. m - 1: (contact, entering)
        for k in range(m):
            before, after = self.sequence[k - 1], self.sequence[k]
            changed = before ^ after
            if len(changed) != 1:
                raise ValueError(f"phases {k - 1 if k else m - 1} and {k} must differ by one contact, got {changed}")
            (c,) = changed
            if not 0 <= c < len(self.contacts):
                raise ValueError(f"contact {c} is not one of the structure's {len(self.contacts)} contacts")
            self.toggles.append((c, c in after))
        if self.toggles[0][1]:
            raise ValueError("the orbit must leave a contact at t = 0 (the phase before the first holds it)")
        mass, stiffness = structure.dense_matrices()
        self.mass = mass
        self.normals = np.array([c.normal(n) for c in self.contacts])
        self._flows = {}
        self.free = self.flow(frozenset())
        omega, modes = self.free.omega, self.free.modes
        self._to_state = np.zeros((2 * n, 2 * n))  # (q, v) = T (a, b)
        self._to_state[:n, :n] = modes / omega
        self._to_state[n:, n:] = modes
        self._to_modal = np.zeros((2 * n, 2 * n))  # (a, b) = S (q, v)
        self._to_modal[:n, :n] = omega[:, None] * self.free._projection
        self._to_modal[n:, n:] = self.free._projection
        self.n_unknowns = 2 * n + m + 1

    def flow(self, active) -> PhaseFlow:
        """The closed-form flow of the phase with the contacts ``active`` (cached)."""
        active = frozenset(active)
        if active not in self._flows:
            _, stiffness = self.structure.dense_matrices()
            force = np.zeros(self.n)
            for c in active:
                contact, normal = self.contacts[c], self.normals[c]
                stiffness = stiffness + contact.alpha * np.outer(normal, normal)
                force = force + contact.alpha * contact.gap * normal
            self._flows[active] = PhaseFlow(self.mass, stiffness, force)
        return self._flows[active]

    @property
    def phase_flows(self) -> list:
        return [self.flow(active) for active in self.sequence]

    def check(self, y) -> np.ndarray:
        y = np.asarray(y, dtype=float)
        if y.shape != (self.n_unknowns,):
            raise ValueError(f"unknowns must be (a, b, t_1..t_{self.m - 1}, T, sigma), shape ({self.n_unknowns},)")
        if not np.all(np.isfinite(y)):
            raise ValueError(f"unknowns must be finite, got {y}")
        return y

    def times(self, y) -> np.ndarray:
        """``[0, t_1, .., t_{m-1}, T]``."""
        y = self.check(y)
        return np.concatenate([[0.0], y[2 * self.n : 2 * self.n + self.m]])

    def start_state(self, y) -> np.ndarray:
        """``(q, q')`` at ``t = 0``."""
        return self._to_state @ self.check(y)[: 2 * self.n]

    def unknowns_from_state(self, z0, times, sigma: float = 0.0) -> np.ndarray:
        """``y`` from the state at ``t = 0`` and ``times = (t_1, .., t_{m-1}, T)``."""
        return np.concatenate([self._to_modal @ np.asarray(z0, dtype=float), np.asarray(times, dtype=float), [sigma]])

    def switch_states(self, y) -> list:
        """States at ``0, t_1, .., t_{m-1}, T``."""
        t = self.times(y)
        z = [self.start_state(y)]
        for k, flow in enumerate(self.phase_flows):
            z.append(flow.state(z[-1], t[k + 1] - t[k]))
        return z

    def residual(self, y) -> np.ndarray:
        y = self.check(y)
        z = self.switch_states(y)
        n, m = self.n, self.m
        ab = y[: 2 * n]
        out = np.empty(2 * n + m)
        for k, (c, _) in enumerate(self.toggles):
            out[k] = self.normals[c] @ z[k][:n] - self.contacts[c].gap
        out[m:] = self._to_modal @ z[-1] - ab + y[-1] * ab
        return out

    def jacobian(self, y) -> np.ndarray:
        y = self.check(y)
        z = self.switch_states(y)
        t = self.times(y)
        n, m = self.n, self.m
        ab = y[: 2 * n]
        D = np.zeros((2 * n, self.n_unknowns))
        D[:, : 2 * n] = self._to_state
        J = np.zeros((2 * n + m, self.n_unknowns))
        J[0] = self.normals[self.toggles[0][0]] @ D[:n]
        for k, flow in enumerate(self.phase_flows):
            D = flow.transition(t[k + 1] - t[k]) @ D
            field_end = flow.field(z[k + 1])
            D[:, 2 * n + k] += field_end  # t_{k+1} (T for the last phase)
            if k:
                D[:, 2 * n + k - 1] -= field_end  # t_k
            if k + 1 < m:
                c = self.toggles[k + 1][0]
                J[k + 1] = self.normals[c] @ D[:n]
        J[m:] = self._to_modal @ D
        J[m:, : 2 * n] += (y[-1] - 1.0) * np.eye(2 * n)
        J[m:, -1] = ab
        return J

    def energy(self, y) -> float:
        """Total energy of the non-smooth model: at ``t = 0`` no contact is engaged, ``(|a|^2 + |b|^2) / 2``."""
        ab = self.check(y)[: 2 * self.n]
        return float(0.5 * ab @ ab)

    def period(self, y) -> float:
        return float(self.check(y)[-2])

    def frequency(self, y) -> float:
        """``1 / T`` in Hz of the nondimensional time."""
        return 1.0 / self.period(y)

    @property
    def impacts_per_period(self) -> int:
        """Contacts entered per period."""
        return sum(1 for _, entering in self.toggles if entering)

    def contact_time(self, y) -> float:
        """Time spent with some contact active, per period."""
        durations = np.diff(self.times(y))
        return float(sum(d for d, active in zip(durations, self.sequence) if active))

    def diagnostics(self, y) -> dict:
        return {"energy": self.energy(y), "frequency": self.frequency(y), "impacts_per_period": self.impacts_per_period}

    def state(self, y, t) -> np.ndarray:
        """State at times ``0 <= t <= T`` (shape ``np.shape(t) + (2N,)``)."""
        y = self.check(y)
        times, z = self.times(y), self.switch_states(y)
        t = np.asarray(t, dtype=float)
        out = np.empty(t.shape + (2 * self.n,))
        phase = np.clip(np.searchsorted(times, t, side="right") - 1, 0, self.m - 1)
        for k, flow in enumerate(self.phase_flows):
            here = phase == k
            if np.any(here):
                out[here] = flow.state(z[k], t[here] - times[k])
        return out

    def describe_sequence(self) -> str:
        """The phases in words, e.g. ``free -> one-sided stop (positive side) on q0``."""
        names = []
        for active in self.sequence:
            names.append(" + ".join(_contact_name(self.contacts[c], self.structure) for c in sorted(active)) or "free")
        return " -> ".join(names)


# --------------------------------------------------------------------------- validity


@dataclass(frozen=True)
class SwitchingAssessment(MarginChecks):
    """Validity margins of an orbit of a :class:`SwitchingProblem` (each > 0 when its assumption holds).

    ``("duration", k)``: the duration of phase ``k``; ``("crossing", k)``: the velocity of the toggled contact's
    coordinate through its gap at switch ``k`` (into the contact when entering, out of it when leaving);
    ``("inactive", k, c)``: ``gap_c - max n_c . q`` over phase ``k`` for a contact ``c`` not active there;
    ``("active", k, c)``: ``min n_c . q - gap_c`` over phase ``k`` for a contact active there. ``x_max``: per stop,
    the largest scaled coordinate (beyond the gap: ``> 1``) reached over the orbit, in the stop's own direction.
    """

    margins: dict
    x_max: np.ndarray = field(default_factory=lambda: np.zeros(0))


def _extreme(flow, z0, duration, normal, sign, ends):
    """``sign`` times the largest ``sign n . q`` over a phase (its interior local maxima and the given end values;
    ``sign * -inf`` when there is none)."""
    values = [sign * v for v in ends]
    interior = _interior_extreme(flow, z0, duration, normal, sign)
    if interior is not None:
        values.append(sign * interior[1])
    return sign * max(values, default=-np.inf)


def assess_orbit(problem: SwitchingProblem, y) -> SwitchingAssessment:
    """The margins of :class:`SwitchingAssessment` for the orbit ``y``."""
    y = problem.check(y)
    times, z = problem.times(y), problem.switch_states(y)
    n, margins = problem.n, {}
    reach = np.full(len(problem.contacts), -np.inf)
    for k, (active, flow) in enumerate(zip(problem.sequence, problem.phase_flows)):
        duration = times[k + 1] - times[k]
        margins[("duration", k)] = duration
        c, entering = problem.toggles[k]
        speed = problem.normals[c] @ z[k][n:]
        margins[("crossing", k)] = speed if entering else -speed
        for j, (contact, normal) in enumerate(zip(problem.contacts, problem.normals)):
            # a contact toggled at an end of the phase sits on its gap there: that end is not a margin
            ends = []
            if problem.toggles[k][0] != j:
                ends.append(normal @ z[k][:n])
            if problem.toggles[(k + 1) % problem.m][0] != j:
                ends.append(normal @ z[k + 1][:n])
            if j in active:
                margins[("active", k, j)] = _extreme(flow, z[k], duration, normal, -1.0, ends) - contact.gap
            else:
                highest = _extreme(flow, z[k], duration, normal, 1.0, ends)
                margins[("inactive", k, j)] = contact.gap - highest
            top = _extreme(flow, z[k], duration, normal, 1.0, [normal @ z[k][:n], normal @ z[k + 1][:n]])
            reach[j] = max(reach[j], top)
    x_max = np.zeros(len(problem.structure.stops))
    for j, contact in enumerate(problem.contacts):
        x_max[contact.stop] = max(x_max[contact.stop], reach[j] / contact.gap)
    return SwitchingAssessment({k: float(v) for k, v in margins.items()}, x_max)


def describe_margin(problem: SwitchingProblem, key) -> str:
    """What it means that the margin ``key`` reaches zero."""
    kind, k = key[0], key[1]
    if kind == "duration":
        return f"phase {k} ({problem.describe_sequence().split(' -> ')[k]}) shrinks to nothing"
    if kind == "crossing":
        c, entering = problem.toggles[k]
        name = _contact_name(problem.contacts[c], problem.structure)
        return f"the orbit {'reaches' if entering else 'leaves'} the {name} with zero velocity (grazing)"
    name = _contact_name(problem.contacts[key[2]], problem.structure)
    if kind == "inactive":
        return f"the orbit reaches the {name} during phase {k}, where it is not in contact (grazing: a new impact)"
    return f"the orbit leaves the {name} during phase {k}, where it is in contact"


# --------------------------------------------------------------------------- start and families


def first_grazing(structure: Structure, mode: int = 0) -> tuple[int, float]:
    """``(contact, amplitude)``: the contact that linear mode ``mode`` (no contact) reaches first as its amplitude
    grows, and the modal amplitude (mass-normalized shape) at which it grazes it."""
    problem = SwitchingProblem(structure, [frozenset(), frozenset({0})]) if structure_contacts(structure) else None
    if problem is None:
        raise ValueError("the structure has no contact")
    if not 0 <= mode < problem.n:
        raise ValueError(f"mode must be in [0, {problem.n}), got {mode!r}")
    phi = problem.free.modes[:, mode]
    reach = problem.normals @ phi
    amplitudes = np.array(
        [c.gap / abs(r) if abs(r) > 1e-12 * np.abs(phi).max() else np.inf for c, r in zip(problem.contacts, reach)]
    )
    best = int(np.argmin(amplitudes))
    if not np.isfinite(amplitudes[best]):
        raise ValueError(f"linear mode {mode} moves no stop coordinate: no grazing orbit")
    return best, float(amplitudes[best])


def near_grazing_orbit(structure: Structure, mode: int = 0, fraction: float = START_CONTACT_FRACTION):
    """The first orbit of the family: linear mode ``mode`` grazing its first contact, with a contact of
    ``fraction`` of its period, corrected by Newton with that contact duration held fixed.

    Returns ``(problem, y, grazing)``: the one-contact :class:`SwitchingProblem`, the orbit, and the unknowns of
    the grazing linear orbit itself (contact of zero duration; the equations are singular there).
    """
    contact, amplitude = first_grazing(structure, mode)
    problem = SwitchingProblem(structure, [frozenset(), frozenset({contact})])
    phi, omega = problem.free.modes[:, mode], problem.free.omega[mode]
    phi = phi * np.sign(problem.normals[contact] @ phi)
    period = 2 * np.pi / omega
    delta = fraction * period
    # q = A phi cos(omega (t + delta / 2)): its contact coordinate leaves the gap at t = 0, enters it at T - delta
    grown = amplitude / np.cos(0.5 * omega * delta)
    z0 = np.concatenate([grown * phi * np.cos(0.5 * omega * delta), -grown * omega * phi * np.sin(0.5 * omega * delta)])
    seed = problem.unknowns_from_state(z0, [period - delta, period])
    grazing = problem.unknowns_from_state(np.concatenate([amplitude * phi, np.zeros(problem.n)]), [period, period])
    held = np.zeros(problem.n_unknowns)
    held[2 * problem.n : 2 * problem.n + 2] = (-1.0, 1.0)

    def fun(y):
        return np.append(problem.residual(y), held @ y - delta)

    def jac(y):
        return np.vstack([problem.jacobian(y), held])

    result = newton_solve(fun, jac, seed, tol=0.0, max_iter=30, criterion=round_off_criterion())
    if not result.converged:
        raise ValueError(f"the orbit next to the grazing orbit of linear mode {mode} did not converge")
    return problem, result.y, grazing


@dataclass
class SwitchingFamily:
    """A followed family over one or more phase sequences (segments), arrays along the family.

    Attributes
    ----------
    structure : Structure
    problems : list of SwitchingProblem
        One per segment.
    unknowns : list of ndarray
        Per orbit (lengths differ between segments).
    segment : ndarray of int
    arclength, residual : ndarray
    assessments : list of SwitchingAssessment
    branch_point : ndarray of bool
    end_reason, end_margin : str
    start : str
    step : float
    mode : int
    grazing : ndarray
        Unknowns of the grazing orbit the family starts next to.
    """

    structure: Structure
    problems: list
    unknowns: list
    segment: np.ndarray
    arclength: np.ndarray
    residual: np.ndarray
    assessments: list
    branch_point: np.ndarray
    end_reason: str
    end_margin: str
    start: str = ""
    step: float = 0.0
    mode: int = 0
    grazing: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.unknowns)

    def problem_of(self, i: int) -> SwitchingProblem:
        return self.problems[int(self.segment[i])]

    def _each(self, fn) -> np.ndarray:
        return np.array([fn(self.problem_of(i), y) for i, y in enumerate(self.unknowns)])

    @property
    def energy(self) -> np.ndarray:
        return self._each(lambda p, y: p.energy(y))

    @property
    def period(self) -> np.ndarray:
        return self._each(lambda p, y: p.period(y))

    @property
    def frequency(self) -> np.ndarray:
        return 1.0 / self.period

    @property
    def contact_time(self) -> np.ndarray:
        """Time in contact per period."""
        return self._each(lambda p, y: p.contact_time(y))

    @property
    def unfolding(self) -> np.ndarray:
        """``sigma`` of every orbit (zero to round-off on periodic orbits)."""
        return np.array([y[-1] for y in self.unknowns])

    @property
    def start_state(self) -> np.ndarray:
        """``(q, q')`` at ``t = 0`` (leaving the first contact), shape (n, 2N)."""
        return self._each(lambda p, y: p.start_state(y))

    @property
    def modal_energy(self) -> np.ndarray:
        """Energy of each free-flight mode at ``t = 0``, ``(a_k^2 + b_k^2) / 2``: they add up to the energy."""
        n = self.structure.n_dofs
        return np.array([0.5 * (y[:n] ** 2 + y[n : 2 * n] ** 2) for y in self.unknowns])

    @property
    def stop_impacts(self) -> np.ndarray:
        """Impacts per period on each stop, (n, stops)."""
        out = np.zeros((len(self), len(self.structure.stops)), dtype=int)
        for i in range(len(self)):
            problem = self.problem_of(i)
            for c, entering in problem.toggles:
                out[i, problem.contacts[c].stop] += int(entering)
        return out

    @property
    def x_max(self) -> np.ndarray:
        """Per stop, the largest scaled coordinate over the orbit, (n, stops)."""
        return np.array([a.x_max for a in self.assessments])

    @property
    def sequences(self) -> list:
        return [self.problem_of(i).describe_sequence() for i in range(len(self))]


def _follow_segment(problem, y0, direction, settings, max_points, label):
    events = ValidityEvents(lambda y: assess_orbit(problem, y), lambda key: describe_margin(problem, key))
    return continue_exact_family(problem, y0, direction, events, settings, max_points=max_points, label=label)


def _inserted(problem: SwitchingProblem, y, key, fraction: float):
    """The orbit ``y`` (valid, grazing contact ``c`` in phase ``k``: ``key = ("inactive", k, c)``) seen by the
    sequence with ``c`` inserted in phase ``k`` for a time ``fraction`` of the period around the grazing instant,
    corrected by Newton with that duration held: ``(problem, y)`` of the new sequence, or None when it fails."""
    _, k, c = key
    times, z = problem.times(y), problem.switch_states(y)
    flow, normal = problem.phase_flows[k], problem.normals[c]
    touch = _interior_extreme(flow, z[k], times[k + 1] - times[k], normal, 1.0)
    if touch is None:
        return None
    t_g = times[k] + touch[0]
    delta = fraction * problem.period(y)
    sequence = list(problem.sequence)
    sequence[k + 1 : k + 1] = [problem.sequence[k] | {c}, problem.sequence[k]]
    new = SwitchingProblem(problem.structure, sequence)
    new_times = np.concatenate([times[1 : k + 1], [t_g - 0.5 * delta, t_g + 0.5 * delta], times[k + 1 :]])
    seed = new.unknowns_from_state(z[0], new_times, y[-1])
    held = np.zeros(new.n_unknowns)
    held[2 * new.n + k] -= 1.0
    held[2 * new.n + k + 1] += 1.0
    result = newton_solve(
        lambda u: np.append(new.residual(u), held @ u - delta),
        lambda u: np.vstack([new.jacobian(u), held]),
        seed,
        tol=0.0,
        max_iter=30,
        criterion=round_off_criterion(),
    )
    return (new, result.y) if result.converged else None


def follow_switching_family(
    structure: Structure,
    step: float = 0.02,
    max_points: int = 2000,
    mode: int = 0,
    max_segments: int = 4,
    min_step_ratio: float = 1e-6,
) -> SwitchingFamily:
    """The exact NNM family of linear mode ``mode`` with one impact per active contact, over full periods.

    Starts next to the grazing orbit of the first contact the mode reaches (:func:`near_grazing_orbit`) and is
    followed by pseudo-arclength continuation (:func:`nnmstop.exact.follow.continue_exact_family`) until a
    validity margin fails (:func:`assess_orbit`). Where the failure is a contact not yet struck reached during a
    phase that does not hold it (the other side of unequal gaps, or another one-sided stop), the family goes on
    with that contact inserted (one impact on it), up to ``max_segments`` segments; any other failure (a second
    impact on a contact already struck among them) ends it.

    Parameters
    ----------
    structure : Structure
        Every stop piecewise linear (:func:`structure_contacts`).
    step : float
        Largest pseudo-arclength step in the unknowns.
    max_points : int
        Most orbits per segment.
    mode : int
        Linear mode (0-based) whose grazing orbit starts the family.
    max_segments : int
    min_step_ratio : float

    Returns
    -------
    SwitchingFamily
    """
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be a finite number > 0, got {step!r}")
    problem, y0, grazing = near_grazing_orbit(structure, mode)
    settings = DenseArclengthSettings(step=float(step), min_step=min_step_ratio * float(step))
    direction = np.zeros(problem.n_unknowns)
    direction[2 * problem.n : 2 * problem.n + 2] = (-1.0, 1.0)  # growing contact duration
    problems, unknowns, segment, arclength, assessments, flags = [], [], [], [], [], []
    end_reason, end_margin = "", ""
    offset = 0.0
    while True:
        label = f"switching family, segment {len(problems)} ({problem.describe_sequence()})"
        branch = _follow_segment(problem, y0, direction, settings, max_points, label)
        problems.append(problem)
        points = list(branch.points)
        unknowns += points
        segment += [len(problems) - 1] * len(points)
        arclength += list(offset + np.asarray(branch.arclength, dtype=float))
        offset = arclength[-1]
        assessments += list(branch.checks)
        flags += list(branch_point_flags(branch))
        event = branch.end_event
        end_reason, end_margin = branch.end_reason, "" if event is None else "_".join(map(str, event.key))
        if event is None or event.key[0] != "inactive" or len(problems) >= max_segments:
            break
        if any(event.key[2] in active for active in problem.sequence):
            end_reason += " (a second impact on a contact already struck: not a family with one impact per side)"
            break
        inserted = _inserted(problem, points[-1], event.key, START_CONTACT_FRACTION)
        if inserted is None:
            end_reason += "; the contact reached could not be inserted into the sequence"
            break
        problem, y0 = inserted
        k = event.key[1]
        direction = np.zeros(problem.n_unknowns)
        direction[2 * problem.n + k : 2 * problem.n + k + 2] = (-1.0, 1.0)
    family = SwitchingFamily(
        structure=structure,
        problems=problems,
        unknowns=unknowns,
        segment=np.array(segment, dtype=int),
        arclength=np.array(arclength, dtype=float),
        residual=np.concatenate(
            [residual_norms(p, [u for u, s in zip(unknowns, segment) if s == i]) for i, p in enumerate(problems)]
        ),
        assessments=assessments,
        branch_point=np.array(flags, dtype=bool),
        end_reason=end_reason,
        end_margin=end_margin,
        start=f"next to the grazing orbit of linear mode {mode} (contact of {START_CONTACT_FRACTION:g} of its period)",
        step=float(step),
        mode=int(mode),
        grazing=grazing,
    )
    logger.info(
        "switching family of mode %d: %d orbits in %d segment(s), energy %.6g..%.6g; end: %s",
        mode,
        len(family),
        len(problems),
        family.energy.min(),
        family.energy.max(),
        end_reason,
    )
    return family


def time_history(problem: SwitchingProblem, y, t):
    """``(q, q')`` of the orbit ``y`` at times ``t`` (any real times: taken modulo the period), and the force of
    each stop's piecewise-linear law on its coordinates, per stop (``(stops,) + np.shape(t)`` for stops of one
    coordinate)."""
    period = problem.period(y)
    t = np.mod(np.asarray(t, dtype=float), period)
    z = problem.state(y, t)
    q = z[..., : problem.n]
    forces = []
    for stop in problem.structure.stops:
        coordinate = stop.coordinate_matrix(problem.n) @ np.moveaxis(q, -1, 0)
        forces.append(stop.piecewise_force(coordinate[0] if stop.n_components == 1 else coordinate))
    return z, forces
