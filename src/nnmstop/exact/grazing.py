"""Validity of an exact orbit and the grazing transitions between phase sequences.

A solution of the quarter-period equations is an orbit of Eqs. (3)-(4) only while every
phase has a positive duration, x stays in the region of each phase and crosses the stops
in the right direction: :func:`assess_orbit` gives one margin per assumption (> 0 when it
holds). Where a margin reaches zero along a family, an impact appears or disappears: the
grazing orbit is computed exactly (:func:`locate_grazing_orbit`), the transition is
classified (:func:`classify_boundary`) and the family of the new sequence is entered
(:func:`split_start`, :func:`merge_seed`). Method notes: ``docs/methods/exact.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnmstop.exact.phases import STOP_SIDE, LinearPhase, interior_extrema
from nnmstop.exact.problem import SequenceProblem, TwoImpactProblem, newton
from nnmstop.exact.sequences import merged_sequence, split_sequence

__all__ = [
    "TWO_IMPACT_MARGINS",
    "MarginChecks",
    "OrbitAssessment",
    "TwoImpactAssessment",
    "assess_orbit",
    "describe_margin",
    "locate_grazing_orbit",
    "split_start",
    "merge_seed",
    "Transition",
    "classify_boundary",
]

#: Why a two-impact orbit stops being admissible, for each margin of a :class:`TwoImpactAssessment`.
TWO_IMPACT_MARGINS = {
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
#: A phase shorter than this fraction of the quarter period at the end of a family is the
#: phase that vanishes there (see :func:`classify_boundary`).
_TINY_DURATION = 1e-5


class MarginChecks:
    """Verdicts on a ``margins`` dict (an assumption holds when its margin is > 0)."""

    margins: dict

    @property
    def valid(self) -> bool:
        """All assumptions hold strictly."""
        return all(m > 0 for m in self.margins.values())

    @property
    def violated(self) -> list:
        """Names of the violated assumptions, most violated first."""
        bad = [k for k, m in self.margins.items() if not m > 0]
        return sorted(bad, key=lambda k: self.margins[k])

    @property
    def min_margin(self) -> float:
        """Smallest finite margin (``inf`` when none is finite)."""
        finite = [m for m in self.margins.values() if np.isfinite(m)]
        return float(min(finite)) if finite else np.inf


@dataclass(frozen=True)
class OrbitAssessment(MarginChecks):
    """Validity margins of an orbit of a phase sequence (all > 0 for an orbit of Eqs. (3)-(4)).

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


@dataclass(frozen=True)
class TwoImpactAssessment(MarginChecks):
    """Validity margins of a two-impact orbit, named after their meaning (:data:`TWO_IMPACT_MARGINS`).

    Attributes
    ----------
    margins : dict
        Margin name -> value (``inf`` when the corresponding extremum does not exist).
    x_max, t_x_max, u_at_x_max : float
        Maximum of x over the orbit, the time of the quarter period where it occurs, and u then.
    """

    margins: dict
    x_max: float
    t_x_max: float
    u_at_x_max: float


def assess_orbit(problem: SequenceProblem, y):
    """Check the assumptions of the phase sequence of ``problem`` for the orbit ``y``.

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
    symmetries of the orbit, the quarter period decides for the whole period. Extrema are
    located exactly (closed-form velocity, Brent's method,
    :func:`nnmstop.exact.phases.interior_extrema`).

    For a :class:`nnmstop.exact.problem.TwoImpactProblem` the same conditions come as the
    named margins of a :class:`TwoImpactAssessment` (see :data:`TWO_IMPACT_MARGINS`).

    Returns
    -------
    OrbitAssessment or TwoImpactAssessment
    """
    if isinstance(problem, TwoImpactProblem):
        return _assess_two_impact(problem, y)
    y = problem.check(y)
    d_k = problem.durations(y)
    z = problem.switch_states(y)
    seq = problem.sequence
    margins, extrema = {}, {}
    best_x, best_t = -np.inf, 0.0
    start = 0.0
    for k, kind in enumerate(seq):
        d = d_k[k]
        margins[("duration", k)] = d
        if k < problem.n_phases - 1:
            nxt = seq[k + 1]
            side = STOP_SIDE[nxt] if nxt != "F" else STOP_SIDE[kind]
            # entering a stop: x moves outwards (side * xdot > 0); leaving: inwards
            margins[("switch", k)] = side * z[k + 1, 2] * (1.0 if nxt != "F" else -1.0)
        times, states = interior_extrema(problem.phases[k], z[k], d)
        if kind == "F":
            dist = 1.0 - np.abs(states[:, 0])
        else:
            dist = STOP_SIDE[kind] * states[:, 0] - 1.0
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
    margins[("turning", problem.n_phases - 1)] = 1.0 - abs(xt) if last == "F" else STOP_SIDE[last] * xt - 1.0
    q = problem.quarter_state(y, np.array([min(best_t, problem.quarter(y))]))[0]
    u_at = float(np.sign(q[0]) * q[1]) if q[0] != 0 else float(q[1])
    return OrbitAssessment({k: float(v) for k, v in margins.items()}, extrema, best_x, u_at, xt)


def _extrema(phase: LinearPhase, z0, duration: float):
    """Interior local extrema of x of a phase: (times, values, is_max), classified by the
    sign of the acceleration."""
    times, states = interior_extrema(phase, z0, duration)
    if times.size == 0:
        return times, np.empty(0), np.empty(0, dtype=bool)
    return times, states[:, 0], phase.field(states)[:, 2] < 0


def _assess_two_impact(problem: TwoImpactProblem, y) -> TwoImpactAssessment:
    """The margins of :data:`TWO_IMPACT_MARGINS`: free-flight and contact times, entry velocity,
    ``1 -`` the largest interior maximum of x in free flight (``early_impact``), ``1 +`` its
    smallest value (``opposite_stop``), the smallest interior minimum of x in contact ``- 1``
    (``leaves_stop``) and ``x(T1) - 1`` (``final_position``)."""
    y = problem.check(y)
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
    u_max = float(problem.quarter_state(y, np.array([t_max]))[0, 1])
    return TwoImpactAssessment({name: float(v) for name, v in margins.items()}, float(cand_x[k]), t_max, u_max)


def describe_margin(problem: SequenceProblem, key, level: float | None = None) -> str:
    """Plain-language meaning of the margin ``key`` of :func:`assess_orbit` reaching zero.

    ``level`` (+1 or -1) names the stop grazed during a free flight, when known.
    """
    if isinstance(key, str):
        return TWO_IMPACT_MARGINS[key]
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
            return (
                f"the free flight {where} shrinks to zero: the two contacts with {stop[seq[k - 1]]} on either "
                "side of the turning point merge into one"
            )
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
    return (
        f"the turning point of the contact {where} comes back to {stop[phase]}: x leaves the stop around the "
        "turning point and the contact splits in two"
    )


def locate_grazing_orbit(problem: SequenceProblem, y_seed, phase: int, level: float, t_seed: float | None = None):
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
            return np.append(problem.residual_from_states(z), z[-1, 0] - level)

        def jac(v):
            return np.vstack([problem.jacobian(v), problem.state_derivatives(v)[-1][0]])

        y, ok = newton(fun, jac, y_seed)
        t_star = float(problem.durations(y)[phase]) if ok else np.nan
    else:

        def fun(v):
            z = problem.switch_states(v[:n])
            zs = ph.state(z[phase], v[n])
            return np.concatenate([problem.residual_from_states(z), [zs[0] - level, zs[2]]])

        def jac(v):
            y_ = v[:n]
            z = problem.switch_states(y_)
            dz = problem.state_derivatives(y_)[phase]
            zs = ph.state(z[phase], v[n])
            ds = ph.transition(v[n]) @ dz
            fs = ph.field(zs)
            top = np.hstack([problem.jacobian(y_), np.zeros((n - 1, 1))])
            return np.vstack([top, np.append(ds[0], fs[0]), np.append(ds[2], fs[2])])

        v, ok = newton(fun, jac, np.append(y_seed, t_seed))
        y, t_star = v[:n], float(v[n])
    if not ok or np.linalg.norm(problem.residual(y)) > 1e-10:
        raise RuntimeError(
            f"no grazing orbit of {problem.sequence!r} found in phase {phase + 1} at x = {level:+g} "
            f"near the seed {y_seed}"
        )
    return y, t_star


def split_start(model, sequence: str, y_graze, phase: int, t_star, level, epsilon: float):
    """First orbit of the longer sequence after a grazing in ``phase`` of ``sequence``.

    The grazing phase is split at the tangency (local time ``t_star``) by a new phase of
    duration ``epsilon`` (:func:`nnmstop.exact.sequences.split_sequence`); for a
    turning-point grazing (``t_star`` equal to the phase duration) the new phase is
    appended. The orbit is then solved by Newton with the new duration fixed to
    ``epsilon`` (the natural parameter of the new family near the grazing: the other
    durations vary like its square).

    Returns
    -------
    problem : SequenceProblem
        The longer sequence.
    y : ndarray
        Its orbit with the new phase of duration ``epsilon``.
    index : int
        Index of the new duration in ``y``.
    """
    old = SequenceProblem(model, sequence)
    y_graze = old.check(y_graze)
    d = list(y_graze[2:])
    at_end = phase == old.n_phases - 1 and abs(t_star - d[phase]) <= 1e-9 * max(1.0, d[phase])
    seq = split_sequence(sequence, phase, level, at_end)
    if at_end:
        d_new = d[:phase] + [d[phase] - epsilon, epsilon]
    else:
        d_new = d[:phase] + [t_star - 0.5 * epsilon, epsilon, d[phase] - t_star - 0.5 * epsilon] + d[phase + 1 :]
    index = 2 + phase + 1
    problem = SequenceProblem(model, seq)
    e = np.zeros(problem.n_unknowns)
    e[index] = 1.0
    y0 = np.concatenate([y_graze[:2], d_new])

    def fun(v):
        return np.append(problem.residual(v), v[index] - epsilon)

    def jac(v):
        return np.vstack([problem.jacobian(v), e])

    y, ok = newton(fun, jac, y0)
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
    short = merged_sequence(sequence, phase)
    d = list(np.asarray(y, dtype=float)[2:])
    kind = sequence[phase]
    if phase == len(sequence) - 1:
        level = STOP_SIDE[kind] if kind != "F" else STOP_SIDE[sequence[phase - 1]]
        d_short = d[: phase - 1] + [d[phase - 1] + d[phase]]
        return short, np.concatenate([y[:2], d_short]), phase - 1, level, None
    level = STOP_SIDE[kind] if kind != "F" else STOP_SIDE[sequence[phase - 1]]
    merged = d[phase - 1] + d[phase] + d[phase + 1]
    t_star = d[phase - 1] + 0.5 * d[phase]
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


def classify_boundary(problem: SequenceProblem, y_valid, check_valid, check_invalid) -> Transition:
    """The grazing transition at the end of a family (see ``docs/methods/exact.md``).

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
    model = problem.model
    # A vanishing duration d drags the margins of the neighbouring switches (~ d) and
    # extrema (~ d**2) to zero with it; the latter reach round-off first, so a duration
    # that is tiny at the boundary decides even if it is not (yet) the violated margin.
    y_valid = problem.check(y_valid)
    small = _TINY_DURATION * problem.quarter(y_valid)
    tiny = [("duration", k) for k in range(problem.n_phases) if y_valid[2 + k] < small]
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
        short_problem = SequenceProblem(model, short)
        y_g, t_star = locate_grazing_orbit(short_problem, seed, phase, level, t_seed)
        reason = describe_margin(problem, key)
        return Transition("merge", seq, short, key, reason, short, y_g, t_star, phase, level)
    if kind == "interior":
        source = check_valid.extrema.get(k) or check_invalid.extrema.get(k)
        if source is None:
            raise RuntimeError(f"{seq}: {describe_margin(problem, key)}, but its extremum was not located")
        t_seed, sign = source
        level = sign if seq[k] == "F" else STOP_SIDE[seq[k]]
        y_g, t_star = locate_grazing_orbit(problem, y_valid, k, level, t_seed)
        new = split_sequence(seq, k, level, at_end=False)
        reason = describe_margin(problem, key, level)
        return Transition("split", seq, new, key, reason, seq, y_g, t_star, k, level)
    level = np.sign(check_valid.x_turning) if seq[-1] == "F" else STOP_SIDE[seq[-1]]
    y_g, t_star = locate_grazing_orbit(problem, y_valid, k, level, None)
    reason = describe_margin(problem, key, level)
    return Transition(
        "append", seq, split_sequence(seq, k, level, at_end=True), key, reason, seq, y_g, t_star, k, level
    )
