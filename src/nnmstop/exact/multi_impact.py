"""Exact NNM1 of the non-smooth system with any number of impacts per period.

Generalization of the quarter-period construction of Section 3.1 (:mod:`nnmstop.exact.two_impact`)
to orbits made of any sequence of linear phases, each solved in closed form by
:class:`nnmstop.exact.two_impact.LinearPhase`:

* ``F``, free flight, ``|x| <= 1`` (Eq. 8);
* ``R``, contact with the right stop, ``x >= 1`` (Eq. 9);
* ``L``, contact with the left stop, ``x <= -1`` (Eq. 9 mirrored: force ``(-alpha, 0)``).

Symmetry class and the quarter period
-------------------------------------
Eqs. (3)-(4) are invariant under ``q -> -q`` and under time reversal. The NNM1 orbits
followed here (those of Section 3.1, and those of the regularized NNM1, whose harmonic
balance solution has only odd cosine harmonics) have both symmetries:

* time reversal about the *origin crossing*: ``q(0) = (0, 0)`` gives ``q(-t) = -q(t)``;
* time reversal about the *turning point*: ``qdot(T1) = (0, 0)`` gives ``q(T1 + s) = q(T1 - s)``.

Together they give ``q(t + 2 T1) = -q(t)``, so the period is ``T = 4 T1`` and the quarter
period ``[0, T1]`` decides the whole orbit (:func:`time_history`). Every orbit of the
class is therefore a *phase sequence* such as ``"FLFR"``, read along the quarter period
from the origin (always free flight) to the turning point, with unknowns::

    y = (xdot0, udot0, d_1, ..., d_n)        (n phase durations, T1 = sum d_k)

and ``n + 1`` equations (:class:`MultiImpactProblem`)::

    x(end of phase k) = +1 or -1,  k = 1..n-1   (exact event times of the closed-form flows)
    xdot(T1) = 0,  udot(T1) = 0                 (the turning point)

so the solutions form one-parameter families, followed by pseudo-arclength continuation
with the analytic Jacobian (transition matrices of the phases, exact). For ``"FR"`` this
is exactly :class:`nnmstop.exact.two_impact.TwoImpactProblem`.

Impact count
------------
Counted like the regularized branches (excursions beyond ``|x| > 1`` per period): a
contact phase ending at the turning point is one excursion per half period, every
other contact phase of the quarter appears twice per half period (at ``t`` and
``-t``), so ``impacts = 2 (c0 + 2 m)`` with ``c0 = 1`` if the last phase is a
contact and ``m`` the number of the other contact phases. An odd number of impacts
per stop means the turning point lies in a stop.

Validity and grazing transitions
--------------------------------
A solution of the equations is an orbit of Eqs. (3)-(4) only if every phase has a
positive duration, ``|x| <= 1`` during free flight, ``x >= 1`` (``x <= -1``) in
contact with the right (left) stop, and x crosses the stops in the right direction
(:func:`assess_orbit`; all margins > 0). When a margin reaches zero along a family,
the continuation is stopped at an accurately located boundary and the phase sequence
is switched there (a *grazing transition*); the grazing orbit is computed exactly
(:func:`grazing_orbit`: the simpler sequence plus ``x(t*) = +-1`` and ``xdot(t*) = 0``):

* an interior extremum of x in a phase reaches a stop tangentially: the phase is split,
  ``F -> F R F`` (or ``F L F``: a new impact), ``R -> R F R`` (x leaves the stop
  briefly);
* the turning point reaches a stop: a phase is appended (``...F -> ...F R``, or
  ``...R -> ...R F``);
* a phase duration shrinks to zero: the phase is removed and its neighbours merged (an
  impact disappears, or two contacts merge into one), the reverse of the above.

Near a grazing orbit the durations of the longer sequence behave like the square root
of the distance along the family, and the Jacobian of the longer sequence is singular
there (a spurious family of "virtual" solutions with a zero-duration phase crosses the
physical one). The longer family is therefore entered at a small but finite duration of
its new phase (:func:`split_start`) and the grazing orbit itself is stored with the
simpler sequence. Any other kind of violation, or a transition that cannot be
continued, ends the branch with its reason recorded.

Symmetry of each regime
-----------------------
Every segment below has the full symmetry of the class (both time reversals, hence
``q(t + T/2) = -q(t)``; reduction to the quarter period); they differ in where the
turning point lies. In a stop (``FR``, ``FL``, ``FLFR``, ``FRFL``, ``FRFLFR``): an odd
number of impacts per stop, the contact around the turning point being symmetric about
it. In free flight (``FLF``, ``FRFLF``): an even number, the contacts coming in pairs
mirrored about the turning point. A sequence and its mirror (R and L swapped) are the
same orbit half a period later. The symmetry-breaking branches born at the 3:1 and 5:1
internal resonances are not followed: the continuation crosses those simple branch
points (flagged by the sign of ``det [J; t]``) and stays on the symmetric NNM1, as the
regularized continuation in the cosine basis does.

What happens for the paper values (alpha = 30, beta = 1, delta = 1)
------------------------------------------------------------------
Energies along each segment, in continuation order (turning points of the energy in
between), and why it ends::

    impacts  sequence  energy along the segment                       end
    2        FR        0.691 -> 0.675 -> 55.94                        x grazes x = -1 in free flight -> FLFR
    6        FLFR      55.94 -> 56.15 -> 7.191 (3:1) -> 18.72          the contact around the turning point
                                                                      vanishes -> FLF
    4        FLF       18.72 -> 4.751 -> 1466                         the free flight around the turning point
                                                                      vanishes, the two L contacts merge -> FL
    2        FL        1466 -> 3538                                   x grazes x = +1 in free flight -> FRFL
    6        FRFL      3538 -> 3754 -> 3598                           the turning point leaves the stop x = -1
                                                                      (the contact splits) -> FRFLF
    8        FRFLF     3598 -> 2424 -> 2515                           the turning point reaches x = +1 -> FRFLFR
    10       FRFLFR    2515 -> 242.7 (5:1) -> 2835 -> 2658            the L contact vanishes -> FRFR
    6        FRFR      2658 -> 322.2 -> 383.2                         the free flight between the two R contacts
                                                                      vanishes -> FR
    2        FR        383.2 -> energy_max (1.5e5)                    still valid: the high-energy orbits of
                                                                      :func:`nnmstop.exact.two_impact.high_energy_orbit`

(``3:1``, ``5:1``: a branch point at the least energy of the segment, the internal
resonances with NNM2 of the paper.) Every segment ends exactly at a grazing orbit, so
the exact NNM1 is one continuous curve from the grazing orbit to ``energy_max``; the
``segment_*`` attributes of the dataset record these ends as computed.
"""

from __future__ import annotations

import argparse
import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg
import scipy.optimize
import xarray as xr

from nnmstop.netcdf import write_dataset
from nnmstop.exact.two_impact import LinearPhase, MarginChecks, OrbitTimeHistory, interior_extrema, symmetric_time_history
from nnmstop.exact.stability import stability_variables
from nnmstop.models.two_dof import ModelParameters, mass_matrix, stiffness_matrix, total_energy

__all__ = [
    "PHASE_NAMES",
    "check_sequence",
    "impacts_per_period",
    "MultiImpactProblem",
    "OrbitAssessment",
    "Transition",
    "Segment",
    "ContinuationSettings",
    "assess_orbit",
    "grazing_orbit",
    "split_start",
    "merge_seed",
    "describe_margin",
    "classify_boundary",
    "follow_segment",
    "follow_branch",
    "time_history",
    "from_two_impact_unknowns",
    "branch_dataset",
    "build_multi_impact_dataset",
    "compare_with_regularized",
    "format_comparison",
]

logger = logging.getLogger(__name__)

#: The linear phases and what they mean.
PHASE_NAMES = {
    "F": "free flight, |x| <= 1 (Eq. 8)",
    "R": "contact with the right stop, x >= 1 (Eq. 9)",
    "L": "contact with the left stop, x <= -1 (Eq. 9 mirrored)",
}
_SIDE = {"R": 1.0, "L": -1.0}
#: A phase shorter than this fraction of the quarter period at the end of a family is the
#: phase that vanishes there (see :func:`classify_boundary`).
_TINY_DURATION = 1e-5


def check_sequence(sequence: str) -> str:
    """Validate a quarter-period phase sequence and return it.

    A sequence starts with ``F`` (the quarter period starts at the origin) and
    alternates free flight with contact phases (``R`` or ``L``): x can only reach a
    stop from free flight.

    Raises
    ------
    ValueError
        If the sequence is empty, holds other letters, does not start with ``F`` or has
        two consecutive contact or free-flight phases.
    """
    if not isinstance(sequence, str) or not sequence:
        raise ValueError(f"a phase sequence is a non-empty string of F, R, L; got {sequence!r}")
    bad = sorted(set(sequence) - set(PHASE_NAMES))
    if bad:
        raise ValueError(f"phase sequence {sequence!r} holds unknown phases {bad}; use F, R, L")
    if sequence[0] != "F":
        raise ValueError(f"phase sequence {sequence!r} must start with free flight F (x = 0 at t = 0)")
    for a, b in zip(sequence, sequence[1:]):
        if (a == "F") == (b == "F"):
            raise ValueError(
                f"phase sequence {sequence!r}: {a}{b} is impossible, free flight and contact phases alternate"
            )
    return sequence


def impacts_per_period(sequence: str) -> int:
    """Excursions beyond ``|x| > 1`` per period of the orbit with this quarter-period sequence.

    ``2 (c0 + 2 m)``: ``c0 = 1`` if the last phase is a contact (one excursion per half
    period around the turning point), ``m`` the number of the other contact phases
    (each seen twice per half period, at ``t`` and ``-t``).

    Examples
    --------
    >>> impacts_per_period("FR"), impacts_per_period("FLFR"), impacts_per_period("FLF")
    (2, 6, 4)
    """
    check_sequence(sequence)
    contacts = sum(p != "F" for p in sequence)
    last = sequence[-1] != "F"
    return 2 * (int(last) + 2 * (contacts - int(last)))


def _phase(params: ModelParameters, kind: str) -> LinearPhase:
    if kind == "F":
        return LinearPhase.free_flight(params)
    side = _SIDE[kind]
    return LinearPhase(mass_matrix(params), stiffness_matrix(params, params.alpha), np.array([side * params.alpha, 0.0]))


# --------------------------------------------------------------------------- the algebraic problem


class MultiImpactProblem:
    """Residual and analytic Jacobian of the quarter-period equations of a phase sequence.

    Parameters
    ----------
    params : ModelParameters
        Only ``alpha``, ``beta`` and ``delta`` matter.
    sequence : str
        Phase sequence, see :func:`check_sequence`.

    Notes
    -----
    Unknowns ``y = (xdot0, udot0, d_1, ..., d_n)``; ``z_0 = (0, 0, xdot0, udot0)`` and
    ``z_k = flow_k(d_k) z_{k-1}``. The flows are affine in the state, so
    ``dz_k/dy = E_k(d_k) dz_{k-1}/dy + f_k(z_k) e_{d_k}`` with ``E_k`` the exact
    transition matrix and ``f_k`` the vector field of phase k.
    """

    def __init__(self, params: ModelParameters, sequence: str):
        self.params = params
        self.sequence = check_sequence(sequence)
        self.n_phases = len(sequence)
        self.n_unknowns = self.n_phases + 2
        self.phases = tuple(_phase(params, kind) for kind in sequence)
        # level of x at the end of phase k (k = 0..n-2): the stop shared with phase k+1
        self.levels = tuple(_SIDE[b] if b != "F" else _SIDE[a] for a, b in zip(sequence, sequence[1:]))

    def __repr__(self) -> str:
        return f"MultiImpactProblem({self.sequence!r})"

    @property
    def impacts_per_period(self) -> int:
        """Excursions beyond the stops per period (:func:`impacts_per_period`)."""
        return impacts_per_period(self.sequence)

    def check(self, y) -> np.ndarray:
        """``y`` as a float array, after checking its shape and finiteness."""
        y = np.asarray(y, dtype=float)
        if y.shape != (self.n_unknowns,):
            raise ValueError(
                f"unknowns of {self.sequence!r} are (xdot0, udot0, d_1..d_{self.n_phases}), "
                f"expected shape ({self.n_unknowns},), got {y.shape}"
            )
        if not np.all(np.isfinite(y)):
            raise ValueError(f"unknowns must be finite, got {y}")
        return y

    def switch_states(self, y) -> np.ndarray:
        """States ``z_0`` (origin) ... ``z_n`` (turning point), shape ``(n + 1, 4)``."""
        y = self.check(y)
        z = np.empty((self.n_phases + 1, 4))
        z[0] = (0.0, 0.0, y[0], y[1])
        for k, phase in enumerate(self.phases):
            z[k + 1] = phase.state(z[k], y[2 + k])
        return z

    def _residual_from(self, z) -> np.ndarray:
        switches = [z[k + 1, 0] - level for k, level in enumerate(self.levels)]
        return np.array([*switches, z[-1, 2], z[-1, 3]])

    def residual(self, y) -> np.ndarray:
        """Switching conditions ``x(end of phase k) - level_k`` then ``xdot(T1)``, ``udot(T1)``."""
        return self._residual_from(self.switch_states(y))

    def state_derivatives(self, y) -> list:
        """Exact ``dz_k / dy`` for ``k = 0..n``, each of shape ``(4, n + 2)``."""
        z = self.switch_states(y)
        d = np.zeros((4, self.n_unknowns))
        d[2, 0] = d[3, 1] = 1.0
        out = [d]
        for k, phase in enumerate(self.phases):
            d = phase.transition(y[2 + k]) @ d
            d[:, 2 + k] = phase.field(z[k + 1])
            out.append(d)
        return out

    def jacobian(self, y) -> np.ndarray:
        """Analytic ``(n + 1) x (n + 2)`` Jacobian of :meth:`residual`."""
        dz = self.state_derivatives(y)
        rows = [dz[k + 1][0] for k in range(self.n_phases - 1)]
        return np.vstack([*rows, dz[-1][2], dz[-1][3]])

    def energy(self, y) -> float:
        """Total energy: the kinetic energy at the origin ``x = u = 0``."""
        y = self.check(y)
        return float(total_energy(0.0, 0.0, y[0], y[1], self.params, model="piecewise"))

    def quarter(self, y) -> float:
        """Quarter period ``T1 = sum d_k``."""
        return float(np.sum(self.check(y)[2:]))

    def frequency(self, y) -> float:
        """``1 / (4 T1)``, in Hz of the nondimensional time."""
        return 1.0 / (4.0 * self.quarter(y))

    def quarter_state(self, y, t) -> np.ndarray:
        """State at times ``0 <= t <= T1`` of the quarter period, shape ``np.shape(t) + (4,)``."""
        y = self.check(y)
        z = self.switch_states(y)
        t = np.asarray(t, dtype=float)
        starts = np.concatenate([[0.0], np.cumsum(y[2:])])
        k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, self.n_phases - 1)
        out = np.empty(t.shape + (4,))
        for j in np.unique(k):
            sel = k == j
            out[sel] = self.phases[j].state(z[j], t[sel] - starts[j])
        return out


# --------------------------------------------------------------------------- validity


@dataclass(frozen=True)
class OrbitAssessment(MarginChecks):
    """Validity margins of a quarter-period orbit (all > 0 for an orbit of Eqs. (3)-(4)).

    Attributes
    ----------
    margins : dict
        ``(kind, k) -> value``. Kinds: ``"duration"`` (``d_k``), ``"switch"`` (velocity of x
        across the stop at the end of phase k, signed to be > 0 when x crosses in the right
        direction), ``"interior"`` (distance of the interior extrema of x in phase k to the
        nearest forbidden side of a stop), ``"turning"`` (distance of ``x(T1)`` to the
        boundary of its phase region, k = n - 1). ``inf`` when there is nothing to check.
    extrema : dict
        ``k -> (time, level)`` of the interior extremum of phase k giving its margin.
    x_max : float
        Maximum of ``|x|`` over the orbit (= maximum of x over the period, by symmetry).
    u_at_x_max : float
        u at the time of the maximum of x over the period.
    x_turning : float
        ``x(T1)``, where both velocities vanish.
    """

    margins: dict
    extrema: dict
    x_max: float
    u_at_x_max: float
    x_turning: float



def assess_orbit(problem: MultiImpactProblem, y) -> OrbitAssessment:
    """Check the assumptions of the phase sequence for the orbit ``y``.

    Margins (> 0 when the assumption holds), for each phase ``k``:

    * ``("duration", k)`` = ``d_k``;
    * ``("switch", k)`` (not for the last phase) = velocity of x at the end of phase k,
      signed so that it is > 0 when x enters (leaves) the stop when it should;
    * ``("interior", k)`` = smallest distance of the interior extrema of x to the
      forbidden side: ``1 - |x|`` in free flight, ``x - 1`` in contact with the right
      stop, ``-1 - x`` with the left one (``inf`` without interior extremum);
    * ``("turning", n - 1)`` = the same distance for ``x(T1)``.

    Since x is continuous and the phase ends lie on the stops (or at the origin), x stays
    in the region of each phase if and only if these margins are positive. By the
    symmetries of the orbit, the quarter period decides for the whole period.
    """
    y = problem.check(y)
    z = problem.switch_states(y)
    seq = problem.sequence
    margins, extrema = {}, {}
    best_x, best_t = -np.inf, 0.0
    start = 0.0
    for k, kind in enumerate(seq):
        d = y[2 + k]
        margins[("duration", k)] = d
        if k < problem.n_phases - 1:
            nxt = seq[k + 1]
            side = _SIDE[nxt] if nxt != "F" else _SIDE[kind]
            # entering a stop: x moves outwards (side * xdot > 0); leaving: inwards
            margins[("switch", k)] = side * z[k + 1, 2] * (1.0 if nxt != "F" else -1.0)
        times, states = interior_extrema(problem.phases[k], z[k], d)
        if kind == "F":
            dist = 1.0 - np.abs(states[:, 0])
        else:
            dist = _SIDE[kind] * states[:, 0] - 1.0
        if dist.size:
            j = int(np.argmin(dist))
            margins[("interior", k)] = float(dist[j])
            extrema[k] = (float(times[j]), float(np.sign(states[j, 0])))
        else:
            margins[("interior", k)] = np.inf
        cand = np.concatenate([np.abs(states[:, 0]), [abs(z[k + 1, 0])]])
        cand_t = np.concatenate([start + times, [start + max(d, 0.0)]])
        i = int(np.argmax(cand))
        if cand[i] > best_x:
            best_x, best_t = float(cand[i]), float(cand_t[i])
        start += max(d, 0.0)
    last = seq[-1]
    xt = float(z[-1, 0])
    margins[("turning", problem.n_phases - 1)] = 1.0 - abs(xt) if last == "F" else _SIDE[last] * xt - 1.0
    q = problem.quarter_state(y, np.array([min(best_t, problem.quarter(y))]))[0]
    u_at = float(np.sign(q[0]) * q[1]) if q[0] != 0 else float(q[1])
    return OrbitAssessment({k: float(v) for k, v in margins.items()}, extrema, best_x, u_at, xt)


def describe_margin(problem: MultiImpactProblem, key, level: float | None = None) -> str:
    """Plain-language meaning of the margin ``key`` of :func:`assess_orbit` reaching zero.

    ``level`` (+1 or -1) names the stop grazed during a free flight, when known.
    """
    kind, k = key
    seq = problem.sequence
    phase = seq[k]
    last = k == problem.n_phases - 1
    where = f"phase {k + 1} ({phase}{', around the turning point' if last else ''}) of {seq}"
    stop = {"R": "the stop x = 1", "L": "the stop x = -1"}
    if kind == "duration":
        if phase != "F":
            gone = "that impact disappears" if last else "those impacts (one at t, one at -t) disappear"
            return f"the contact with {stop[phase]}, {where}, shrinks to zero duration: {gone}"
        if last:
            return (f"the free flight {where} shrinks to zero: the two contacts with {stop[seq[k - 1]]} on either "
                    "side of the turning point merge into one")
        return f"the free flight {where} shrinks to zero: the contacts with {stop[seq[k - 1]]} on either side merge"
    if kind == "switch":
        return f"x crosses the stop with zero velocity at the end of {where}"
    if kind == "interior":
        if phase == "F":
            side = f"the stop x = {level:+g}" if level is not None else "a stop"
            return f"x grazes {side} during the free flight {where}: new impacts (at t and -t)"
        return f"x comes back to {stop[phase]} tangentially during the contact {where}: the contact splits in two"
    where = f"phase {k + 1} ({phase}) of {seq}"
    if phase == "F":
        side = f"the stop x = {level:+g}" if level is not None else "a stop"
        return f"the turning point of the free flight {where} reaches {side}: a new impact around the turning point"
    return (f"the turning point of the contact {where} comes back to {stop[phase]}: x leaves the stop around the "
            "turning point and the contact splits in two")


# --------------------------------------------------------------------------- grazing orbits and transitions


def _newton(fun, jac, y, tol=1e-14, max_iter=40):
    """Newton iteration to round-off; returns ``(y, converged)``."""
    converged = False
    for _ in range(max_iter):
        try:
            dy = np.linalg.solve(jac(y), -fun(y))
        except np.linalg.LinAlgError:
            return y, False
        y = y + dy
        if not np.all(np.isfinite(y)):
            return y, False
        if converged:
            break
        converged = np.linalg.norm(dy) <= tol * (1.0 + np.linalg.norm(y))
    return y, converged


def grazing_orbit(problem: MultiImpactProblem, y_seed, phase: int, level: float, t_seed: float | None = None):
    """Orbit of the sequence whose x grazes ``x = level`` in phase ``phase``.

    With ``t_seed`` (interior grazing): unknowns ``(y, t*)``, equations the quarter-period
    equations plus ``x(t*) = level`` and ``xdot(t*) = 0`` at local time ``t*`` of the
    phase. Without (turning-point grazing, last phase only): the equations plus
    ``x(T1) = level`` (``xdot(T1) = 0`` already holds). Both systems are square and
    regular at a generic grazing orbit; Newton converges to round-off.

    Returns
    -------
    y : ndarray
        The grazing orbit.
    t_star : float
        Local time of the tangency in the phase (its duration for a turning-point grazing).

    Raises
    ------
    RuntimeError
        If Newton does not converge.
    """
    y_seed = problem.check(y_seed)
    n = problem.n_unknowns
    ph = problem.phases[phase]
    if t_seed is None:
        if phase != problem.n_phases - 1:
            raise ValueError("a turning-point grazing is in the last phase")

        def fun(v):
            z = problem.switch_states(v)
            return np.append(problem._residual_from(z), z[-1, 0] - level)

        def jac(v):
            return np.vstack([problem.jacobian(v), problem.state_derivatives(v)[-1][0]])

        y, ok = _newton(fun, jac, y_seed)
        t_star = float(y[2 + phase]) if ok else np.nan
    else:

        def fun(v):
            z = problem.switch_states(v[:n])
            zs = ph.state(z[phase], v[n])
            return np.concatenate([problem._residual_from(z), [zs[0] - level, zs[2]]])

        def jac(v):
            y_ = v[:n]
            z = problem.switch_states(y_)
            dz = problem.state_derivatives(y_)[phase]
            zs = ph.state(z[phase], v[n])
            ds = ph.transition(v[n]) @ dz
            fs = ph.field(zs)
            top = np.hstack([problem.jacobian(y_), np.zeros((n - 1, 1))])
            return np.vstack([top, np.append(ds[0], fs[0]), np.append(ds[2], fs[2])])

        v, ok = _newton(fun, jac, np.append(y_seed, t_seed))
        y, t_star = v[:n], float(v[n])
    if not ok or np.linalg.norm(problem.residual(y)) > 1e-10:
        raise RuntimeError(
            f"no grazing orbit of {problem.sequence!r} found in phase {phase + 1} at x = {level:+g} "
            f"near the seed {y_seed}"
        )
    return y, t_star


def split_start(params: ModelParameters, sequence: str, y_graze, phase: int, t_star, level, epsilon: float):
    """First orbit of the longer sequence after a grazing in ``phase`` of ``sequence``.

    The grazing phase is split at the tangency (local time ``t_star``) by a new phase of
    duration ``epsilon``: ``F -> F R F`` (``F L F``) or ``R -> R F R`` (``L -> L F L``)
    for an interior grazing; for a turning-point grazing (``t_star`` equal to the phase
    duration) the new phase is appended. The orbit is then solved by Newton with the new
    duration fixed to ``epsilon`` (the natural parameter of the new family near the
    grazing: the other durations vary like its square).

    Returns
    -------
    problem : MultiImpactProblem
        The longer sequence.
    y : ndarray
        Its orbit with the new phase of duration ``epsilon``.
    index : int
        Index of the new duration in ``y``.
    """
    old = MultiImpactProblem(params, sequence)
    y_graze = old.check(y_graze)
    kind = sequence[phase]
    new_kind = ("R" if level > 0 else "L") if kind == "F" else "F"
    d = list(y_graze[2:])
    at_end = phase == old.n_phases - 1 and abs(t_star - d[phase]) <= 1e-9 * max(1.0, d[phase])
    if at_end:
        seq = sequence + new_kind
        d_new = d[:phase] + [d[phase] - epsilon, epsilon]
        index = 2 + phase + 1
    else:
        seq = sequence[: phase + 1] + new_kind + sequence[phase:]
        d_new = d[:phase] + [t_star - 0.5 * epsilon, epsilon, d[phase] - t_star - 0.5 * epsilon] + d[phase + 1 :]
        index = 2 + phase + 1
    problem = MultiImpactProblem(params, seq)
    e = np.zeros(problem.n_unknowns)
    e[index] = 1.0
    y0 = np.concatenate([y_graze[:2], d_new])

    def fun(v):
        return np.append(problem.residual(v), v[index] - epsilon)

    def jac(v):
        return np.vstack([problem.jacobian(v), e])

    y, ok = _newton(fun, jac, y0)
    if not ok or np.linalg.norm(problem.residual(y)) > 1e-10:
        raise RuntimeError(f"no orbit of {seq!r} with a new phase of duration {epsilon:g} near the grazing orbit")
    return problem, y, index


def merge_seed(sequence: str, y, phase: int):
    """Seed of the shorter sequence when phase ``phase`` of ``sequence`` shrinks to zero.

    Returns ``(shorter sequence, seed unknowns, grazing phase, level, local time of the
    tangency or None for the turning point)``.

    Raises
    ------
    ValueError
        If the phase cannot disappear generically (the first phase, or a free flight
        between the two different stops).
    """
    n = len(sequence)
    d = list(np.asarray(y, dtype=float)[2:])
    if phase == 0:
        raise ValueError("the first free flight cannot vanish (x = 0 at its start)")
    kind = sequence[phase]
    if phase == n - 1:
        prev = sequence[phase - 1]
        level = _SIDE[kind] if kind != "F" else _SIDE[prev]
        d_short = d[: phase - 1] + [d[phase - 1] + d[phase]]
        return sequence[:-1], np.concatenate([y[:2], d_short]), phase - 1, level, None
    before, after = sequence[phase - 1], sequence[phase + 1]
    if before != after:
        raise ValueError(f"phase {phase + 1} of {sequence!r} lies between {before} and {after}; it cannot vanish")
    level = _SIDE[kind] if kind != "F" else _SIDE[before]
    merged = d[phase - 1] + d[phase] + d[phase + 1]
    t_star = d[phase - 1] + 0.5 * d[phase]
    short = sequence[:phase] + sequence[phase + 2 :]
    d_short = d[: phase - 1] + [merged] + d[phase + 2 :]
    return short, np.concatenate([y[:2], d_short]), phase - 1, level, t_star


@dataclass
class Transition:
    """A grazing transition between two phase sequences.

    Attributes
    ----------
    kind : str
        ``"split"`` (a phase appears inside another), ``"append"`` (at the turning point),
        ``"merge"`` (a phase vanishes).
    old, new : str
        Sequences before and after.
    margin : tuple
        The margin of the old sequence that reached zero.
    reason : str
        Plain-language description.
    grazing_sequence : str
        The (shorter) sequence in which the grazing orbit is computed.
    y_graze : ndarray
        The grazing orbit (unknowns of ``grazing_sequence``).
    t_star : float
        Local time of the tangency in the grazing phase.
    phase : int
        Grazing phase (index in ``grazing_sequence``).
    level : float
        Stop grazed, +1 or -1.
    """

    kind: str
    old: str
    new: str
    margin: tuple
    reason: str
    grazing_sequence: str
    y_graze: np.ndarray
    t_star: float
    phase: int
    level: float


# --------------------------------------------------------------------------- continuation


@dataclass(frozen=True)
class ContinuationSettings:
    """Settings of the pseudo-arclength continuation of the phase-sequence families.

    Attributes
    ----------
    step : float
        Largest arclength step in the unknowns ``(xdot0, udot0, d_1..d_n)``.
    max_points : int
        Largest number of orbits over the whole branch.
    energy_max : float
        The branch stops at the first orbit above this energy.
    max_log_energy_step, max_frequency_step : float
        Largest change of ``ln E`` and of the frequency (Hz) per step (the step is adapted).
    grazing_epsilon : float
        Duration of the new phase of the first orbit after a split (:func:`split_start`).
    min_step : float
        The continuation fails below this step.
    max_segments : int
        Largest number of phase-sequence segments.
    """

    step: float = 0.02
    max_points: int = 20000
    energy_max: float = 1.5e5
    max_log_energy_step: float = 0.02
    max_frequency_step: float = 2e-5
    grazing_epsilon: float = 1e-3
    min_step: float = 1e-10
    max_segments: int = 40

    def __post_init__(self):
        for name in ("step", "energy_max", "max_log_energy_step", "max_frequency_step", "grazing_epsilon", "min_step"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        for name in ("max_points", "max_segments"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {v!r}")

    @classmethod
    def from_config(cls, section: dict) -> "ContinuationSettings":
        """From the ``exact_multi:`` section of the configuration."""
        kw = {k: section[k] for k in section if k in cls.__dataclass_fields__}
        unknown = sorted(set(section) - set(kw))
        if unknown:
            raise ValueError(f"unknown exact_multi settings {unknown}")
        return cls(**kw)


@dataclass
class Segment:
    """Orbits of one phase sequence along the branch, in continuation order.

    Attributes
    ----------
    problem : MultiImpactProblem
    unknowns : list of ndarray
    arclength : list of float
        Pseudo-arclength in the unknowns of the sequence, from the first orbit of the segment.
    residual : list of float
        Euclidean norm of the quarter-period equations.
    assessments : list of OrbitAssessment
    branch_point : list of bool
        True where the sign of ``det [J; t^T]`` changed since the previous orbit (a simple
        bifurcation was crossed in between).
    grazing : list of bool
        True for the exactly computed grazing orbit of a transition.
    end_reason : str
    transition : Transition or None
        How the branch goes on after the segment (None: the branch ends here).
    """

    problem: MultiImpactProblem
    unknowns: list = field(default_factory=list)
    arclength: list = field(default_factory=list)
    residual: list = field(default_factory=list)
    assessments: list = field(default_factory=list)
    branch_point: list = field(default_factory=list)
    grazing: list = field(default_factory=list)
    end_reason: str = ""
    transition: Transition | None = None

    @property
    def sequence(self) -> str:
        """Phase sequence of the segment."""
        return self.problem.sequence

    def __len__(self) -> int:
        return len(self.unknowns)

    @property
    def energy(self) -> np.ndarray:
        """Total energy of each orbit."""
        return np.array([self.problem.energy(y) for y in self.unknowns])

    @property
    def frequency(self) -> np.ndarray:
        """Frequency 1/T (Hz of the nondimensional time) of each orbit."""
        return np.array([self.problem.frequency(y) for y in self.unknowns])

    def append(self, y, s, check, branch_point=False, grazing=False):
        """Add an orbit (its residual is recomputed)."""
        y = self.problem.check(y)
        self.unknowns.append(y.copy())
        self.arclength.append(float(s))
        self.residual.append(float(np.linalg.norm(self.problem.residual(y))))
        self.assessments.append(check)
        self.branch_point.append(bool(branch_point))
        self.grazing.append(bool(grazing))


def _tangent(jac, previous) -> np.ndarray:
    """Unit null vector of ``jac`` oriented like ``previous``."""
    rhs = np.zeros(jac.shape[1])
    rhs[-1] = 1.0
    t = np.linalg.solve(np.vstack([jac, previous]), rhs)
    return t / np.linalg.norm(t)


def _null_vector(jac) -> np.ndarray:
    null = scipy.linalg.null_space(jac)
    if null.shape[1] != 1:
        raise RuntimeError(f"the Jacobian has a {null.shape[1]}-dimensional null space; not a regular point")
    return null[:, 0]


def _det_sign(jac, tangent) -> float:
    return float(np.sign(np.linalg.det(np.vstack([jac, tangent]))))


def _correct(problem: MultiImpactProblem, y_prev, tangent, sigma, max_iter=15):
    """Pseudo-arclength corrector; returns the orbit or None.

    Newton on the equations plus ``tangent . (y - y_prev) = sigma`` to round-off. The
    result is refused if it lies farther than ``|sigma| / 2`` from the predictor (a jump to
    another family, e.g. the spurious zero-duration family near a grazing orbit).
    """
    pred = y_prev + sigma * tangent
    y = pred.copy()
    converged = False
    for _ in range(max_iter):
        f = np.append(problem.residual(y), tangent @ (y - y_prev) - sigma)
        try:
            dy = np.linalg.solve(np.vstack([problem.jacobian(y), tangent]), -f)
        except np.linalg.LinAlgError:
            return None
        y = y + dy
        if not np.all(np.isfinite(y)):
            return None
        if converged:
            break
        converged = np.linalg.norm(dy) <= 1e-13 * (1.0 + np.linalg.norm(y))
    if not converged or np.linalg.norm(problem.residual(y)) > 1e-10:
        return None
    if np.linalg.norm(y - pred) > 0.5 * abs(sigma) + 1e-13:
        return None
    return y


def _locate_boundary(problem, y, tangent, h, bad, rel_tol=1e-13):
    """Bisection on the arclength of the last step for the first violated margin.

    Returns ``(last valid orbit or None, its arclength from y, its assessment, assessment of
    the nearest invalid orbit found)``.
    """
    lo, hi = 0.0, h
    y_lo, check_lo, check_hi = None, None, bad
    for _ in range(200):
        if hi - lo <= rel_tol * h:
            break
        mid = 0.5 * (lo + hi)
        y_mid = _correct(problem, y, tangent, mid)
        if y_mid is None:
            hi = mid
            continue
        check = assess_orbit(problem, y_mid)
        if check.valid:
            lo, y_lo, check_lo = mid, y_mid, check
        else:
            hi, check_hi = mid, check
    return y_lo, lo, check_lo, check_hi


def classify_boundary(problem: MultiImpactProblem, y_valid, check_valid, check_invalid) -> Transition:
    """The grazing transition at the end of a family (see the module docstring).

    Durations vanishing take precedence (a phase disappears), then interior grazings (a
    phase is split), then the turning point reaching a stop (a phase is appended).

    Raises
    ------
    RuntimeError
        If the violation is not one of these generic transitions, or the grazing orbit
        cannot be computed.
    """
    seq = problem.sequence
    violated = check_invalid.violated
    params = problem.params
    # A vanishing duration d drags the margins of the neighbouring switches (~ d) and
    # extrema (~ d**2) to zero with it; the latter reach round-off first, so a duration
    # that is tiny at the boundary decides even if it is not (yet) the violated margin.
    y_valid = problem.check(y_valid)
    tiny = [("duration", k) for k in range(problem.n_phases) if y_valid[2 + k] < _TINY_DURATION * problem.quarter(y_valid)]
    violated = tiny + [key for key in violated if key[0] != "duration"] if tiny else violated
    for kind in ("duration", "interior", "turning"):
        keys = [key for key in violated if key[0] == kind]
        if keys:
            break
    else:
        raise RuntimeError(
            f"{seq}: the family ends where {', '.join(describe_margin(problem, k) for k in violated)}; "
            "not a generic grazing transition"
        )
    if len(keys) > 1:
        raise RuntimeError(
            f"{seq}: simultaneous violations {keys} ({'; '.join(describe_margin(problem, k) for k in keys)}); "
            "a codimension-two transition, not handled"
        )
    key = keys[0]
    k = key[1]
    if kind == "duration":
        short, seed, phase, level, t_seed = merge_seed(seq, y_valid, k)
        short_problem = MultiImpactProblem(params, short)
        y_g, t_star = grazing_orbit(short_problem, seed, phase, level, t_seed)
        reason = describe_margin(problem, key)
        return Transition("merge", seq, short, key, reason, short, y_g, t_star, phase, level)
    if kind == "interior":
        source = check_valid.extrema.get(k) or check_invalid.extrema.get(k)
        if source is None:
            raise RuntimeError(f"{seq}: {reason}, but its extremum was not located")
        t_seed, sign = source
        level = sign if seq[k] == "F" else _SIDE[seq[k]]
        y_g, t_star = grazing_orbit(problem, y_valid, k, level, t_seed)
        new_kind = ("R" if level > 0 else "L") if seq[k] == "F" else "F"
        new = seq[: k + 1] + new_kind + seq[k:]
        reason = describe_margin(problem, key, level)
        return Transition("split", seq, new, key, reason, seq, y_g, t_star, k, level)
    level = np.sign(check_valid.x_turning) if seq[-1] == "F" else _SIDE[seq[-1]]
    y_g, t_star = grazing_orbit(problem, y_valid, k, level, None)
    new_kind = ("R" if level > 0 else "L") if seq[-1] == "F" else "F"
    reason = describe_margin(problem, key, level)
    return Transition("append", seq, seq + new_kind, key, reason, seq, y_g, t_star, k, level)


def follow_segment(
    problem: MultiImpactProblem,
    y0,
    tangent,
    settings: ContinuationSettings,
    h0: float | None = None,
    max_points: int | None = None,
    first_grazing: bool = False,
) -> Segment:
    """Follow the family of one phase sequence until its assumptions fail.

    Pseudo-arclength continuation (predictor along the unit tangent, Newton corrector to
    round-off) with the step adapted to keep the changes of ``ln E`` and of the frequency
    per step below the settings. At the first invalid orbit, the boundary is located by
    bisection on the last step (relative ``1e-13``), the last valid orbit is kept and the
    transition is classified (:func:`classify_boundary`); its grazing orbit is appended
    to the segment when it belongs to this sequence (split, append).

    Parameters
    ----------
    problem : MultiImpactProblem
    y0 : array_like
        First orbit (residual below ``1e-10``).
    tangent : array_like
        Initial direction (normalized here; its null-space projection is used).
    settings : ContinuationSettings
    h0 : float, optional
        First step (default ``settings.step``); doubles after each success up to ``step``.
    max_points : int, optional
        Largest number of orbits of this segment (default ``settings.max_points``).
    first_grazing : bool
        Mark the first orbit as a grazing orbit.

    Returns
    -------
    Segment
    """
    y = problem.check(y0).copy()
    res0 = np.linalg.norm(problem.residual(y))
    if res0 > 1e-10:
        raise ValueError(f"start is not an orbit of {problem.sequence!r} (residual {res0:.3e})")
    max_points = settings.max_points if max_points is None else int(max_points)
    tangent = _tangent(problem.jacobian(y), np.asarray(tangent, dtype=float))
    seg = Segment(problem)
    seg.append(y, 0.0, assess_orbit(problem, y), grazing=first_grazing)
    det = _det_sign(problem.jacobian(y), tangent)
    h = min(settings.step, h0 or settings.step)
    s = 0.0
    energy, freq = problem.energy(y), problem.frequency(y)
    while True:
        if len(seg) >= max_points:
            seg.end_reason = "max_points reached (the family is still valid there)"
            break
        if energy > settings.energy_max:
            seg.end_reason = f"energy above energy_max = {settings.energy_max:g} (the family is still valid there)"
            break
        if h < settings.min_step:
            seg.end_reason = f"continuation failed: no convergence for steps down to {h:.3e}"
            break
        y_new = _correct(problem, y, tangent, h)
        if y_new is None:
            h *= 0.5
            continue
        e_new, f_new = problem.energy(y_new), problem.frequency(y_new)
        ratio = max(
            abs(np.log(e_new / energy)) / settings.max_log_energy_step,
            abs(f_new - freq) / settings.max_frequency_step,
        )
        if ratio > 2.0:
            h *= 0.9 / ratio
            continue
        check = assess_orbit(problem, y_new)
        if not check.valid:
            y_lo, sigma, check_lo, check_hi = _locate_boundary(problem, y, tangent, h, check)
            if y_lo is not None and sigma > 0:
                seg.append(y_lo, s + sigma, check_lo)
            else:
                y_lo, check_lo = y, seg.assessments[-1]
            try:
                seg.transition = classify_boundary(problem, y_lo, check_lo, check_hi)
            except RuntimeError as exc:
                seg.end_reason = str(exc)
                break
            tr = seg.transition
            seg.end_reason = f"{tr.reason}: {tr.kind} {tr.old} -> {tr.new}"
            if tr.grazing_sequence == problem.sequence:
                g = tr.y_graze
                seg.append(g, seg.arclength[-1] + np.linalg.norm(g - seg.unknowns[-1]), assess_orbit(problem, g),
                           grazing=True)
            break
        jac = problem.jacobian(y_new)
        new_tangent = _tangent(jac, tangent)
        new_det = _det_sign(jac, new_tangent)
        y, tangent, s = y_new, new_tangent, s + h
        seg.append(y, s, check, branch_point=new_det != det)
        det, energy, freq = new_det, e_new, f_new
        h = min(settings.step, h * min(2.0, 0.9 / max(ratio, 1e-12)))
    logger.info(
        "segment %s: %d orbits, energy %.6g..%.6g, frequency %.7g..%.7g Hz, max residual %.2e; end: %s",
        problem.sequence, len(seg), seg.energy.min(), seg.energy.max(), seg.frequency.min(), seg.frequency.max(),
        max(seg.residual), seg.end_reason,
    )
    return seg


def _start_after(tr: Transition, params, settings: ContinuationSettings):
    """First orbit, tangent, first step and grazing flag of the segment after a transition."""
    if tr.kind in ("split", "append"):
        eps = settings.grazing_epsilon
        problem, y1, index = split_start(params, tr.old, tr.y_graze, tr.phase, tr.t_star, tr.level, eps)
        if problem.sequence != tr.new:  # pragma: no cover - consistency of the two constructions
            raise RuntimeError(f"split of {tr.old} gave {problem.sequence}, expected {tr.new}")
        check = assess_orbit(problem, y1)
        if not check.valid:
            raise RuntimeError(
                f"the first orbit of {tr.new} after the grazing violates "
                f"{[describe_margin(problem, k) for k in check.violated]}"
            )
        direction = np.zeros(problem.n_unknowns)
        direction[index] = 1.0
        return problem, y1, direction, eps, False
    problem = MultiImpactProblem(params, tr.new)
    null = _null_vector(problem.jacobian(tr.y_graze))
    trial = min(1e-4, settings.step)
    valid = []
    for sign in (1.0, -1.0):
        y_t = _correct(problem, tr.y_graze, sign * null, trial)
        valid.append(y_t is not None and assess_orbit(problem, y_t).valid)
    if valid[0] == valid[1]:
        raise RuntimeError(
            f"after the merge {tr.old} -> {tr.new}, {'both' if valid[0] else 'neither'} directions of the "
            f"{tr.new} family are valid orbits; not a generic grazing"
        )
    return problem, tr.y_graze, null if valid[0] else -null, trial, True


def follow_branch(params: ModelParameters, sequence: str, y0, direction, settings: ContinuationSettings) -> list:
    """Follow the exact NNM1 through its grazing transitions.

    Parameters
    ----------
    params : ModelParameters
    sequence : str
        Phase sequence of the first orbit.
    y0 : array_like
        First orbit.
    direction : array_like
        Initial direction of the continuation in the unknowns of ``sequence``.
    settings : ContinuationSettings

    Returns
    -------
    list of Segment
        In continuation order; the last one has no transition and says why the branch ends.
    """
    problem = MultiImpactProblem(params, sequence)
    segments = [follow_segment(problem, y0, direction, settings)]
    used = len(segments[0])
    seen = set()
    while segments[-1].transition is not None:
        tr = segments[-1].transition
        signature = (tr.kind, tr.old, tr.new, tuple(np.round(tr.y_graze[:2], 8)))
        if signature in seen:
            segments[-1].end_reason += "; the same transition was met before (a loop), stopping"
            segments[-1].transition = None
            break
        seen.add(signature)
        if len(segments) >= settings.max_segments:
            segments[-1].end_reason += f"; max_segments = {settings.max_segments} reached"
            segments[-1].transition = None
            break
        if used >= settings.max_points:
            segments[-1].end_reason += "; max_points reached"
            segments[-1].transition = None
            break
        try:
            problem, y1, direction, h0, graze = _start_after(tr, params, settings)
        except RuntimeError as exc:
            segments[-1].end_reason += f"; cannot continue: {exc}"
            segments[-1].transition = None
            break
        seg = follow_segment(problem, y1, direction, settings, h0=h0, max_points=settings.max_points - used,
                             first_grazing=graze)
        segments.append(seg)
        used += len(seg)
    return segments


# --------------------------------------------------------------------------- time history


def time_history(params: ModelParameters, sequence: str, y, t) -> OrbitTimeHistory:
    """Exact time history of the orbit ``y`` of ``sequence`` at any times ``t``.

    Built from the quarter period ``[0, T1]`` with the two time reversals of the symmetry
    class (module docstring): ``q(T1 + s) = q(T1 - s)`` (velocities reversed) and
    ``q(t + T/2) = -q(t)``; the orbit is ``T = 4 T1``-periodic. The contact force is the
    piecewise-linear law, Eq. (4).

    Returns
    -------
    nnmstop.exact.two_impact.OrbitTimeHistory
    """
    problem = MultiImpactProblem(params, sequence)
    y = problem.check(y)
    return symmetric_time_history(lambda r: problem.quarter_state(y, r), problem.quarter(y), t, params.alpha)


# --------------------------------------------------------------------------- datasets


def from_two_impact_unknowns(y) -> np.ndarray:
    """Unknowns of ``"FR"`` from those of :class:`nnmstop.exact.two_impact.TwoImpactProblem`.

    ``(xdot0, udot0, tau1, T1)`` -> ``(xdot0, udot0, tau1, T1 - tau1)``; works on the last axis.
    """
    y = np.asarray(y, dtype=float)
    if y.shape[-1] != 4:
        raise ValueError(f"two-impact unknowns are (xdot0, udot0, tau1, T1), got shape {y.shape}")
    out = y.copy()
    out[..., 3] = y[..., 3] - y[..., 2]
    return out


def _two_impact_unknowns(ds: xr.Dataset) -> np.ndarray:
    """``(xdot0, udot0, tau1, T1 - tau1)`` of every orbit of a two-impact dataset (the FR unknowns)."""
    quarter = ds["period"].values / 4.0  # exact: a power of two
    tau1 = ds["free_flight_time"].values
    return np.column_stack([ds["xdot0"].values, ds["udot0"].values, tau1, quarter - tau1])


def _var(values, long_name, units="1", dtype=float, **extra):
    return ("point", np.asarray(values, dtype=dtype), {"long_name": long_name, "units": units, **extra})


_LONG_NAMES = {
    "energy": (
        "total energy of the non-smooth (piecewise-linear) model: kinetic + spring potential + stop potential "
        "alpha/2 (|x|-1)^2, conserved along the orbit"
    ),
    "frequency": "frequency 1/T of the periodic orbit, in Hz of the nondimensional time",
    "period": "period T = 4 T1 (T1: quarter period, from the origin to the turning point)",
    "x_max": "maximum of x over the period (x_max - 1 is the penetration into the stop)",
    "u_at_x_max": "u at the time of the maximum of x",
    "x_turning_point": "x(T1) at the turning point, where both velocities vanish",
    "xdot0": "velocity of x at x = u = 0 (t = 0)",
    "udot0": "velocity of u at x = u = 0 (t = 0)",
    "free_flight_time": "total free-flight duration in the quarter period (tau1 for two impacts per period)",
    "contact_time": "total contact duration in the quarter period (T1 - tau1 for two impacts per period)",
    "residual": "Euclidean norm of the quarter-period equations (switching conditions, xdot(T1), udot(T1))",
    "validity_margin": (
        "smallest margin of the assumptions of the phase sequence (> 0 inside a segment, about 0 at its "
        "grazing transitions)"
    ),
}


def branch_dataset(two_impacts: xr.Dataset, segments: list, params: ModelParameters) -> xr.Dataset:
    """The exact NNM1: the two-impact dataset followed by the continuation segments.

    Parameters
    ----------
    two_impacts : xarray.Dataset
        The two-impact family (:func:`nnmstop.exact.two_impact.family_dataset`); its values are copied
        unchanged as the first points.
    segments : list of Segment
        The continuation from its last orbit (:func:`follow_branch`). Orbits of a first
        ``"FR"`` segment duplicate the end of ``two_impacts`` (to the bisection tolerance)
        and are left out.
    params : ModelParameters

    Returns
    -------
    xarray.Dataset
        Dimension ``point``; every variable has ``long_name`` and ``units``.
    """
    n0 = two_impacts.sizes["point"]
    fr = MultiImpactProblem(params, "FR")
    y_two = _two_impact_unknowns(two_impacts)
    contact = two_impacts["contact_time"].values
    cols = {name: list(two_impacts[name].values) for name in _LONG_NAMES}
    seq_col = ["FR"] * n0
    durations = [y[2:] for y in y_two]
    segment_col = [0] * n0
    impacts = [2 if c > 0 else 0 for c in contact]
    grazing = [0] * n0
    grazing[0] = int(contact[0] == 0.0)  # the family starts at the grazing orbit
    tangent = np.zeros(4)
    branch_points, det = [0], None
    for k in range(n0):  # bordered-Jacobian sign along the two-impact part too
        jac = fr.jacobian(y_two[k])
        ref = y_two[min(k + 1, n0 - 1)] - y_two[max(k - 1, 0)]
        tangent = _tangent(jac, ref if np.linalg.norm(ref) > 0 else _null_vector(jac))
        sign = _det_sign(jac, tangent)
        if det is not None:
            branch_points.append(int(sign != det))
        det = sign
    arclength = list(two_impacts["arclength"].values)
    summaries = [
        f"FR: 2 impacts per period, energy {two_impacts['energy'].values.min():.6g} to "
        f"{two_impacts['energy'].values.max():.6g}, from the grazing orbit; ends where "
        f"{two_impacts.attrs.get('end_reason', 'the two-impact family ends')} (results/exact/nnm1_two_impacts.nc)"
    ]
    index = 0
    s_offset = arclength[-1]
    for number, seg in enumerate(segments):
        rows = list(range(len(seg)))
        if number == 0:
            if seg.sequence != "FR":
                raise ValueError(f"the continuation of the two-impact family must start with FR, got {seg.sequence}")
            # its first orbit is the last two-impact orbit; its grazing orbit, when located within
            # round-off of that orbit (the two-impact family already ended there), is not repeated
            rows = [j for j in rows[1:] if np.linalg.norm(seg.unknowns[j] - y_two[-1]) > 1e-9 * (1 + np.linalg.norm(y_two[-1]))]
            if seg.grazing[-1] and not rows:
                grazing[-1] = 1
        else:
            index += 1
        problem = seg.problem
        for j in rows:
            y, check = seg.unknowns[j], seg.assessments[j]
            is_free = np.array([c == "F" for c in seg.sequence])
            cols["energy"].append(problem.energy(y))
            cols["frequency"].append(problem.frequency(y))
            cols["period"].append(4.0 * problem.quarter(y))
            cols["x_max"].append(check.x_max)
            cols["u_at_x_max"].append(check.u_at_x_max)
            cols["x_turning_point"].append(check.x_turning)
            cols["xdot0"].append(y[0])
            cols["udot0"].append(y[1])
            cols["free_flight_time"].append(float(np.sum(y[2:][is_free])))
            cols["contact_time"].append(float(np.sum(y[2:][~is_free])))
            cols["residual"].append(seg.residual[j])
            cols["validity_margin"].append(check.min_margin)
            seq_col.append(seg.sequence)
            durations.append(y[2:])
            segment_col.append(index)
            impacts.append(problem.impacts_per_period)
            grazing.append(int(seg.grazing[j]))
            branch_points.append(int(seg.branch_point[j]))
            arclength.append(s_offset + seg.arclength[j])
        s_offset = arclength[-1]
        energies = np.array(cols["energy"])[np.array(segment_col) == index]
        text = (
            f"{seg.sequence}: {problem.impacts_per_period} impacts per period, energy {energies.min():.6g} to "
            f"{energies.max():.6g} ({energies[0]:.6g} -> {energies[-1]:.6g}); ends: {seg.end_reason}"
        )
        if number == 0:
            source = "the points of" if not rows else "starts with"
            summaries[0] = text + f" ({source} results/exact/nnm1_two_impacts.nc)"
        else:
            summaries.append(text)
    n = len(seq_col)
    data = {name: _var(cols[name], long_name) for name, long_name in _LONG_NAMES.items()}
    # "Hz" of the nondimensional time (the long name says so): a unit UDUNITS knows, as CF asks.
    data["frequency"][2]["units"] = "Hz"
    data["impacts_per_period"] = _var(
        impacts, "number of excursions of x beyond the stops (|x| > 1) per period", dtype=np.int32
    )
    data["phase_sequence"] = (
        "point",
        np.array(seq_col, dtype=object),
        {
            "long_name": (
                "linear phases of the quarter period from the origin to the turning point: F free flight, "
                "R contact with the stop x = 1, L contact with the stop x = -1 (the orbit -q, half a period "
                "later, has R and L swapped)"
            ),
            "units": "1",
        },
    )
    data.update(stability_variables(params, seq_col, durations))
    data["n_phases"] = _var([len(s) for s in seq_col], "number of linear phases in the quarter period", dtype=np.int32)
    data["segment"] = _var(
        segment_col, "index of the phase-sequence segment (0: the two-impact family)", dtype=np.int32
    )
    data["grazing"] = _var(
        grazing,
        "1 for an exactly computed grazing orbit (a transition between phase sequences, or the start)",
        dtype=np.int8,
    )
    data["branch_point"] = _var(
        branch_points,
        "1 where the sign of det [J; t] changed since the previous orbit (a simple bifurcation was crossed)",
        dtype=np.int8,
    )
    ds = xr.Dataset(
        data,
        coords={
            "point": ("point", np.arange(n), {"long_name": "index of the orbit along the branch", "units": "1"}),
            "arclength": _var(
                arclength,
                "pseudo-arclength in the unknowns (xdot0, udot0, phase durations) of each segment, accumulated "
                "from the first orbit (a length in different unknowns on each segment)",
            ),
        },
    )
    ds.attrs = {
        "alpha": params.alpha,
        "beta": params.beta,
        "delta": params.delta,
        "two_impact_points": n0,
        "segments": len(summaries),
        **{f"segment_{k}": text for k, text in enumerate(summaries)},
        "end_reason": segments[-1].end_reason if segments else two_impacts.attrs.get("end_reason", ""),
        "max_residual": float(np.max(cols["residual"])),
    }
    return ds


def build_multi_impact_dataset(config: dict, two_impact_path: str | Path, output_path: str | Path) -> Path:
    """Continue the exact NNM1 past the two-impact family and write the whole branch.

    Called by the Snakemake rule ``exact_nnm1``. Reads the two-impact family (rule
    ``exact_two_impacts``), continues from its last orbit through every grazing
    transition (:func:`follow_branch`) and writes the two-impact points unchanged
    followed by the continuation.

    For the paper values, the segments and why each one ends are listed in the module
    docstring; the dataset records them in its ``segment_*`` attributes.

    Parameters
    ----------
    config : dict
        With the ``model`` and ``exact_multi`` sections.
    two_impact_path : str or Path
        NetCDF of the two-impact family.
    output_path : str or Path
        NetCDF file to write (atomically).

    Returns
    -------
    Path
    """
    for key in ("model", "exact_multi"):
        if key not in config:
            raise ValueError(f"config lacks the section {key!r}")
    params = ModelParameters.from_config(config["model"])
    settings = ContinuationSettings.from_config(config["exact_multi"])
    with xr.open_dataset(two_impact_path) as ds:
        two = ds.load()
    for name in ("alpha", "beta", "delta"):
        if not np.isclose(float(two.attrs[name]), getattr(params, name), rtol=1e-14, atol=0):
            raise ValueError(
                f"{two_impact_path}: {name} = {two.attrs[name]} differs from the configuration ({getattr(params, name)}); "
                "rebuild the two-impact dataset"
            )
    if two.attrs.get("end_margin") != "opposite_stop":
        logger.warning("the two-impact family ends on %r, not on the opposite stop", two.attrs.get("end_margin"))
    y = _two_impact_unknowns(two)
    if len(y) < 2:
        raise ValueError(f"{two_impact_path} holds fewer than two orbits")
    segments = follow_branch(params, "FR", y[-1], y[-1] - y[-2], settings)
    ds = branch_dataset(two, segments, params)
    summary = (
        "Exact NNM1 of the non-smooth 2-DOF oscillator with a bilateral elastic stop (Eqs. 3-4) with any number "
        "of impacts per period: symmetric orbits built in closed form from the quarter period as sequences of "
        "linear phases (free flight, contact with either stop) whose switching times are exact event times, "
        "followed by pseudo-arclength continuation through the grazing transitions where impacts appear or "
        f"disappear. The first {two.sizes['point']} points are results/exact/nnm1_two_impacts.nc unchanged. "
        f"The branch ends: {ds.attrs['end_reason']}."
    )
    path = write_dataset(
        ds, output_path, title="NNM1 of the non-smooth system: all impact regimes (exact)",
        summary=summary, keywords="exact solution, piecewise linear, grazing bifurcation",
        metadata=config.get("metadata"),
    )
    logger.info("wrote %s (%d orbits, %d segments)", path, ds.sizes["point"], ds.attrs["segments"])
    return path


# --------------------------------------------------------------------------- comparison with the regularized NNM1


def _runs(impacts) -> list:
    """Maximal runs of equal impact counts: list of (count, start, stop)."""
    impacts = np.asarray(impacts)
    edges = np.flatnonzero(np.diff(impacts)) + 1
    starts = np.concatenate([[0], edges])
    stops = np.concatenate([edges, [impacts.size]])
    return [(int(impacts[a]), int(a), int(b)) for a, b in zip(starts, stops)]


def _monotone_pieces(energy) -> list:
    """Index ranges ``[a, b]`` (inclusive) on which ``energy`` is monotone."""
    d = np.sign(np.diff(energy))
    pieces, a = [], 0
    for i in range(1, d.size):
        if d[i] != d[i - 1] and d[i] != 0:
            pieces.append((a, i))
            a = i
    pieces.append((a, energy.size - 1))
    return [(a, b) for a, b in pieces if b > a]


def _check_branch_variables(name: str, ds: xr.Dataset) -> None:
    """Refuse a branch dataset that cannot be compared (missing variables, bad energies)."""
    missing = [v for v in ("energy", "frequency", "impacts_per_period") if v not in ds]
    if missing:
        raise ValueError(f"the {name} dataset lacks {missing}")
    for v in ("energy", "frequency"):
        values = np.asarray(ds[v].values, dtype=float)
        if not np.all(np.isfinite(values) & (values > 0)):
            raise ValueError(f"the {name} dataset's {v!r} must be finite and > 0 everywhere (it is matched in ln E)")


def _exact_frequency_at(ex, fx, er, fr) -> np.ndarray:
    """Exact frequency at each regularized energy of a regime (NaN where none covers it).

    Interpolated linearly in ``ln E`` on every piece of the exact regime that is monotone
    in energy and covers ``E``; of several candidates (energy folds), the one nearest to
    the regularized frequency is kept.
    """
    pieces = []
    for a, b in _monotone_pieces(ex):
        order = np.argsort(ex[a : b + 1])
        energy = ex[a : b + 1][order]
        pieces.append((energy[0], energy[-1], np.log(energy), fx[a : b + 1][order]))
    out = np.full(er.size, np.nan)
    for k, (e, f) in enumerate(zip(er, fr)):
        cands = [np.interp(np.log(e), le, fp) for lo, hi, le, fp in pieces if lo <= e <= hi]
        if cands:
            out[k] = min(cands, key=lambda c: abs(c - f))
    return out


def compare_with_regularized(exact_ds: xr.Dataset, regularized_ds: xr.Dataset) -> list:
    """Frequency of the regularized NNM1 against the exact one at matched energy, per impact regime.

    Both branches are cut into *regimes*, maximal runs of points with the same number of
    impacts per period, and the regimes are paired in branch order (longest common
    subsequence of the impact counts; the single grazing orbit at the start of the exact
    branch and the linear regime of the regularized one have no partner). For each
    regularized point of a regime whose energy lies within the energy range of its exact
    partner, the exact frequency is interpolated (linearly in ``ln E``) on every piece of
    the exact regime that is monotone in energy and covers that energy; the piece of
    nearest frequency is kept (the regimes are not monotone in energy). Regularized points
    outside every such piece have no partner: they are counted (``unmatched``), not compared.

    Parameters
    ----------
    exact_ds : xarray.Dataset
        Exact branch (:func:`build_multi_impact_dataset`): ``energy``, ``frequency``,
        ``impacts_per_period`` along ``point``, and ``phase_sequence`` if available.
    regularized_ds : xarray.Dataset
        Regularized branch (``results/hbm/nnm1.nc``): ``energy``, ``frequency``,
        ``impacts_per_period``.

    Returns
    -------
    list of dict
        One per paired regime: ``impacts``, ``exact_sequence``, ``exact_energy`` and
        ``regularized_energy`` (ranges), ``matched`` (number of regularized points
        compared), ``max_abs_error`` (Hz) and the regularized energy where it occurs
        (``energy_at_max``), ``median_abs_error``, ``mean_error`` (regularized minus exact,
        Hz), ``max_rel_error``; the exact and regularized energy and frequency ranges.
        The metrics are NaN for a regime with no matched point. The per-point data behind
        them: ``exact_points`` and ``regularized_points`` (index ranges ``(start, stop)``
        of the regime in each dataset), ``unmatched`` (regularized points of the regime
        not compared) and ``points``, a dict of arrays over the matched points:
        ``index`` (point of the regularized dataset), ``energy``, ``frequency``,
        ``exact_frequency``, ``error`` (regularized minus exact, Hz), ``rel_error``
        (``error`` over the exact frequency).

    Raises
    ------
    ValueError
        If a dataset lacks one of the variables above, or holds an energy or frequency
        that is not finite and positive.
    """
    import difflib

    for name, ds in (("exact", exact_ds), ("regularized", regularized_ds)):
        _check_branch_variables(name, ds)
    e_x, f_x = exact_ds["energy"].values, exact_ds["frequency"].values
    e_r, f_r = regularized_ds["energy"].values, regularized_ds["frequency"].values
    runs_x = [r for r in _runs(exact_ds["impacts_per_period"].values) if r[2] - r[1] > 1]
    runs_r = [r for r in _runs(regularized_ds["impacts_per_period"].values) if r[2] - r[1] > 1]
    seq_x = exact_ds["phase_sequence"].values if "phase_sequence" in exact_ds else None
    matcher = difflib.SequenceMatcher(a=[r[0] for r in runs_x], b=[r[0] for r in runs_r], autojunk=False)
    rows = []
    for block in matcher.get_matching_blocks():
        for i in range(block.size):
            cx, ax, bx = runs_x[block.a + i]
            cr, ar, br = runs_r[block.b + i]
            ex, fx = e_x[ax:bx], f_x[ax:bx]
            er, fr = e_r[ar:br], f_r[ar:br]
            f_exact = _exact_frequency_at(ex, fx, er, fr)
            keep = np.isfinite(f_exact)
            err = fr[keep] - f_exact[keep]
            rel = err / f_exact[keep]
            n = int(keep.sum())
            worst = int(np.argmax(np.abs(err))) if n else 0
            rows.append(
                {
                    "impacts": cx,
                    "exact_sequence": "/".join(dict.fromkeys(seq_x[ax:bx])) if seq_x is not None else "",
                    "exact_energy": (float(ex.min()), float(ex.max())),
                    "regularized_energy": (float(er.min()), float(er.max())),
                    "exact_frequency": (float(fx.min()), float(fx.max())),
                    "regularized_frequency": (float(fr.min()), float(fr.max())),
                    "matched": n,
                    "max_abs_error": float(np.abs(err).max()) if n else np.nan,
                    "energy_at_max": float(er[keep][worst]) if n else np.nan,
                    "median_abs_error": float(np.median(np.abs(err))) if n else np.nan,
                    "mean_error": float(err.mean()) if n else np.nan,
                    "max_rel_error": float(np.abs(rel).max()) if n else np.nan,
                    "exact_points": (ax, bx),
                    "regularized_points": (ar, br),
                    "unmatched": int(er.size - n),
                    "points": {
                        "index": np.arange(ar, br)[keep],
                        "energy": er[keep],
                        "frequency": fr[keep],
                        "exact_frequency": f_exact[keep],
                        "error": err,
                        "rel_error": rel,
                    },
                }
            )
    return rows


def format_comparison(rows: list) -> str:
    """The rows of :func:`compare_with_regularized` as a plain-text table."""
    head = (
        f"{'impacts':>7} {'exact':>7} {'exact energy':>17} {'regularized energy':>19} {'n':>4} "
        f"{'max|df| Hz':>10} {'at E':>8} {'median|df|':>10} {'mean df':>9} {'max|df|/f':>9}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['impacts']:>7d} {r['exact_sequence']:>7} {r['exact_energy'][0]:>8.4g}-{r['exact_energy'][1]:<8.4g} "
            f"{r['regularized_energy'][0]:>9.4g}-{r['regularized_energy'][1]:<9.4g} {r['matched']:>4d} "
            f"{r['max_abs_error']:>10.2e} {r['energy_at_max']:>8.4g} {r['median_abs_error']:>10.2e} "
            f"{r['mean_error']:>9.1e} {r['max_rel_error']:>9.2e}"
        )
    lines.append("df = regularized - exact frequency at the regularized energy (Hz of the nondimensional time)")
    return "\n".join(lines)


def main(argv=None) -> None:
    """Command line: ``python -m nnmstop.exact.multi_impact compare EXACT.nc REGULARIZED.nc``."""
    parser = argparse.ArgumentParser(prog="python -m nnmstop.exact.multi_impact", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    cmp_ = sub.add_parser("compare", help="regularization error of the frequency per impact regime")
    cmp_.add_argument("exact", help="exact branch, e.g. results/exact/nnm1.nc")
    cmp_.add_argument("regularized", help="regularized branch, e.g. results/hbm/nnm1.nc")
    args = parser.parse_args(argv)
    with xr.open_dataset(args.exact) as ex, xr.open_dataset(args.regularized) as reg:
        rows = compare_with_regularized(ex.load(), reg.load())
    print(format_comparison(rows))


if __name__ == "__main__":
    main()
