"""Continuation of the families of exact orbits, through their grazing transitions.

The solutions of the quarter-period equations of one phase sequence form one-parameter
families. :func:`follow_family` is the one continuation of this package's exact orbits:
pseudo-arclength in the unknowns (predictor along the unit tangent of the analytic
Jacobian, Newton corrector to round-off), the step adapted to the changes of energy and
frequency, every orbit checked (:func:`nnmstop.exact.grazing.assess_orbit`) and the end
of the family located by bisection where an assumption first fails. It follows the
two-impact family (:func:`follow_two_impact_family`) and every segment of the exact NNM1
(:func:`follow_branch`, which switches the phase sequence at each grazing transition).
Method notes: ``docs/methods/exact.md``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from nnmstop.exact.grazing import Transition, assess_orbit, classify_boundary, describe_margin, split_start
from nnmstop.exact.problem import SequenceProblem, TwoImpactProblem, first_grazing_orbit, newton
from nnmstop.models.two_dof import ModelParameters, total_energy

__all__ = [
    "FamilySettings",
    "Family",
    "follow_family",
    "follow_two_impact_family",
    "follow_branch",
    "unit_null_vector",
    "tangent_along",
    "determinant_sign",
]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class FamilySettings:
    """Settings of the continuation of a family (config sections ``exact`` and ``exact_multi``).

    Attributes
    ----------
    step : float
        Largest arclength step in the unknowns; halved when Newton fails, doubled after a success.
    max_points : int
        Largest number of orbits (over the whole branch for :func:`follow_branch`).
    energy_max : float
        The continuation stops at the first orbit above this energy (``inf``: no limit).
    max_log_energy_step, max_frequency_step : float
        Largest change of ``ln E`` and of the frequency (Hz) per step (``inf``: no limit).
    grazing_epsilon : float
        Duration of the new phase of the first orbit after a split (:func:`nnmstop.exact.grazing.split_start`).
    min_step : float
        The continuation fails below this step.
    max_segments : int
        Largest number of phase-sequence segments of a branch.
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
        for name in ("step", "grazing_epsilon", "min_step"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        for name in ("energy_max", "max_log_energy_step", "max_frequency_step"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and not np.isnan(v) and v > 0):
                raise ValueError(f"{name} must be a number > 0 (inf for no limit), got {v!r}")
        for name in ("max_points", "max_segments"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {v!r}")

    @classmethod
    def from_config(cls, section: dict) -> FamilySettings:
        """From the ``exact_multi:`` section of the configuration."""
        kw = {k: section[k] for k in section if k in cls.__dataclass_fields__}
        unknown = sorted(set(section) - set(kw))
        if unknown:
            raise ValueError(f"unknown exact_multi settings {unknown}")
        return cls(**kw)


@dataclass
class Family:
    """Orbits of one phase sequence, in continuation order.

    Attributes
    ----------
    problem : SequenceProblem
    unknowns : list of ndarray, then ndarray of shape (n, n_unknowns) once the family is complete
    arclength : list of float
        Pseudo-arclength in the unknowns, from the first orbit.
    residual : list of float
        Euclidean norm of the quarter-period equations.
    assessments : list
        :func:`nnmstop.exact.grazing.assess_orbit` of each orbit.
    branch_point : list of bool
        True where the sign of ``det [J; t^T]`` changed since the previous orbit (a simple
        bifurcation was crossed in between).
    grazing : list of bool
        True for the exactly computed grazing orbit of a transition.
    end_reason : str
        Why the family ends.
    end_margin : str or tuple
        The margin that reached zero at the end ('' when the family did not end on a violation).
    transition : Transition or None
        How the branch goes on after the family (None: it ends here).
    start : str
        Description of the first orbit.
    step : float
        Nominal continuation step.
    end_tangent : ndarray or None
        Unit tangent at the last orbit of the continuation.
    """

    problem: SequenceProblem
    unknowns: list = field(default_factory=list)
    arclength: list = field(default_factory=list)
    residual: list = field(default_factory=list)
    assessments: list = field(default_factory=list)
    branch_point: list = field(default_factory=list)
    grazing: list = field(default_factory=list)
    end_reason: str = ""
    end_margin: str | tuple = ""
    transition: Transition | None = None
    start: str = ""
    step: float = 0.0
    end_tangent: np.ndarray | None = None

    @property
    def sequence(self) -> str:
        """Phase sequence of the family."""
        return self.problem.sequence

    @property
    def params(self) -> ModelParameters:
        """Model parameters."""
        return self.problem.params

    def __len__(self) -> int:
        return len(self.unknowns)

    @property
    def energy(self) -> np.ndarray:
        """Total energy of the piecewise model (the kinetic energy at ``x = u = 0``) of each orbit."""
        y = np.asarray(self.unknowns)
        return total_energy(0.0, 0.0, y[:, 0], y[:, 1], self.params, model="piecewise")

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

    def _freeze(self) -> Family:
        for name in ("unknowns", "arclength", "residual"):
            setattr(self, name, np.array(getattr(self, name)))
        return self


def tangent_along(jac, previous) -> np.ndarray:
    """Unit null vector of ``jac`` oriented like ``previous`` (bordered solve ``[J; previous] t = e_n``)."""
    rhs = np.zeros(jac.shape[1])
    rhs[-1] = 1.0
    t = np.linalg.solve(np.vstack([jac, previous]), rhs)
    return t / np.linalg.norm(t)


def unit_null_vector(jac) -> np.ndarray:
    """Unit null vector of a Jacobian with a one-dimensional null space (sign arbitrary).

    Raises
    ------
    RuntimeError
        If the null space is not one-dimensional (not a regular point of a family).
    """
    null = scipy.linalg.null_space(jac)
    if null.shape[1] != 1:
        raise RuntimeError(f"the Jacobian has a {null.shape[1]}-dimensional null space; not a regular point")
    return null[:, 0]


def determinant_sign(jac, tangent) -> float:
    """Sign of ``det [J; t^T]``: it changes where a simple branch point is crossed."""
    return float(np.sign(np.linalg.det(np.vstack([jac, tangent]))))


def _correct(problem: SequenceProblem, y_prev, tangent, sigma, max_iter=15):
    """Pseudo-arclength corrector; returns the orbit or None.

    Newton on the equations plus ``tangent . (y - y_prev) = sigma`` to round-off. The
    result is refused if it lies farther than ``|sigma| / 2`` from the predictor (a jump to
    another family, e.g. the spurious zero-duration family near a grazing orbit).
    """
    pred = y_prev + sigma * tangent

    def fun(y):
        return np.append(problem.residual(y), tangent @ (y - y_prev) - sigma)

    def jac(y):
        return np.vstack([problem.jacobian(y), tangent])

    y, converged = newton(fun, jac, pred.copy(), tol=1e-13, max_iter=max_iter)
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


def follow_family(
    problem: SequenceProblem,
    y0,
    direction,
    settings: FamilySettings,
    *,
    h0: float | None = None,
    max_points: int | None = None,
    first_grazing: bool = False,
    transitions: bool = True,
    tangent_from: str = "direction",
    start_label: str = "",
    start_violation: float | None = None,
) -> Family:
    """Follow the family of one phase sequence until its assumptions fail.

    Pseudo-arclength continuation (predictor along the unit tangent, Newton corrector to
    round-off) with the step adapted to keep the changes of ``ln E`` and of the frequency
    per step below the settings. Nothing assumes the energy to be monotone along the
    family. At the first invalid orbit, the boundary is located by bisection on the last
    step (relative ``1e-13``) and the last valid orbit is kept: the family is never
    extended past its end. With ``transitions``, the grazing transition there is
    classified (:func:`nnmstop.exact.grazing.classify_boundary`) and its grazing orbit is
    appended when it belongs to this sequence (split, append).

    Parameters
    ----------
    problem : SequenceProblem
    y0 : array_like
        First orbit (residual below ``1e-10``).
    direction : array_like
        Initial direction of the continuation.
    settings : FamilySettings
    h0 : float, optional
        First step (default ``settings.step``).
    max_points : int, optional
        Largest number of orbits of this family (default ``settings.max_points``).
    first_grazing : bool
        Mark the first orbit as a grazing orbit.
    transitions : bool
        Classify the end of the family as a grazing transition.
    tangent_from : {"direction", "null_space"}
        First tangent: the bordered solve ``[J; direction] t = e_n`` (``direction`` close to
        the tangent), or the unit null vector of ``J`` with the sign of ``direction``
        (``direction`` only an orientation).
    start_label : str
        Description of the first orbit, kept in the result.
    start_violation : float, optional
        Refuse a first orbit whose smallest validity margin is below ``-start_violation``.

    Returns
    -------
    Family
    """
    y = problem.check(y0).copy()
    res0 = np.linalg.norm(problem.residual(y))
    if res0 > 1e-10:
        raise ValueError(f"start is not an orbit of {problem.sequence!r} (residual {res0:.3e})")
    first = assess_orbit(problem, y)
    if start_violation is not None and first.min_margin < -start_violation:
        raise ValueError(f"start {y} violates the assumptions {first.violated} of {problem.sequence!r}")
    if tangent_from not in ("direction", "null_space"):
        raise ValueError(f"tangent_from must be 'direction' or 'null_space', got {tangent_from!r}")
    max_points = settings.max_points if max_points is None else int(max_points)
    direction = np.asarray(direction, dtype=float)
    jac = problem.jacobian(y)
    if tangent_from == "null_space":
        tangent = unit_null_vector(jac)
        tangent = -tangent if tangent @ direction < 0 else tangent
    else:
        tangent = tangent_along(jac, direction)
    family = Family(problem, start=start_label, step=float(settings.step))
    family.append(y, 0.0, first, grazing=first_grazing)
    det = determinant_sign(problem.jacobian(y), tangent)
    h = min(settings.step, h0 or settings.step)
    s = 0.0
    energy, freq = problem.energy(y), problem.frequency(y)
    while True:
        if len(family) >= max_points:
            family.end_reason = f"max_points = {max_points} reached (the family is still valid there)"
            break
        if energy > settings.energy_max:
            family.end_reason = f"energy above energy_max = {settings.energy_max:g} (the family is still valid there)"
            break
        if h < settings.min_step:
            family.end_reason = f"continuation failed: no convergence for steps down to {h:.3e}"
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
            _end_family(family, y, tangent, h, s, check, transitions)
            break
        jac = problem.jacobian(y_new)
        new_tangent = tangent_along(jac, tangent)
        new_det = determinant_sign(jac, new_tangent)
        y, tangent, s = y_new, new_tangent, s + h
        family.append(y, s, check, branch_point=new_det != det)
        det, energy, freq = new_det, e_new, f_new
        h = min(settings.step, h * min(2.0, 0.9 / max(ratio, 1e-12)))
    family.end_tangent = tangent
    energies, frequencies = family.energy, family.frequency
    logger.info(
        "%s family%s: %d orbits, energy %.6g..%.6g, frequency %.7g..%.7g Hz, max residual %.2e; end: %s",
        problem.sequence,
        f" from the {start_label}" if start_label else "",
        len(family),
        energies.min(),
        energies.max(),
        frequencies.min(),
        frequencies.max(),
        max(family.residual),
        family.end_reason,
    )
    return family._freeze()


def _end_family(family: Family, y, tangent, h, s, check, transitions: bool) -> None:
    """Locate the end of the family in the last step, keep its last valid orbit and say why it ends."""
    problem = family.problem
    y_lo, sigma, check_lo, check_hi = _locate_boundary(problem, y, tangent, h, check)
    if y_lo is not None and sigma > 0:
        family.append(y_lo, s + sigma, check_lo)
    else:
        y_lo, check_lo = y, family.assessments[-1]
    family.end_margin = check_hi.violated[0]
    if not transitions:
        family.end_reason = describe_margin(problem, family.end_margin)
        return
    try:
        family.transition = classify_boundary(problem, y_lo, check_lo, check_hi)
    except RuntimeError as exc:
        family.end_reason = str(exc)
        return
    tr = family.transition
    family.end_reason = f"{tr.reason}: {tr.kind} {tr.old} -> {tr.new}"
    if tr.grazing_sequence == problem.sequence:
        g = tr.y_graze
        family.append(
            g, family.arclength[-1] + np.linalg.norm(g - family.unknowns[-1]), assess_orbit(problem, g), grazing=True
        )


def follow_two_impact_family(
    params: ModelParameters,
    step: float = 0.02,
    max_points: int = 4000,
    start=None,
    direction=None,
    start_label: str | None = None,
    min_step_ratio: float = 1e-6,
) -> Family:
    """Follow the family of two-impact orbits (Section 3.1) with :func:`follow_family`.

    The problem is :class:`nnmstop.exact.problem.TwoImpactProblem` (unknowns
    ``(xdot0, udot0, tau1, T1)``), the step is only limited by ``step`` (no energy or
    frequency limit) and the family ends, without transition, at its first violated
    assumption (``end_margin``, a key of :data:`nnmstop.exact.grazing.TWO_IMPACT_MARGINS`).

    Parameters
    ----------
    params : ModelParameters
    step : float
        Nominal arclength step (> 0).
    max_points : int
        Maximum number of orbits (>= 2).
    start : array_like, shape (4,), optional
        First orbit; the grazing orbit (:func:`nnmstop.exact.problem.first_grazing_orbit`) by default.
    direction : array_like, shape (4,), optional
        The first tangent has a positive dot product with it; by default the direction of
        increasing contact duration ``T1 - tau1``.
    start_label : str, optional
        Description of the start, kept in the result.
    min_step_ratio : float
        The continuation fails when the step falls below ``min_step_ratio * step``.

    Returns
    -------
    Family
    """
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be a finite number > 0, got {step!r}")
    if int(max_points) != max_points or max_points < 2:
        raise ValueError(f"max_points must be an integer >= 2, got {max_points!r}")
    problem = TwoImpactProblem(params)
    y = first_grazing_orbit(params) if start is None else problem.check(start).copy()
    label = start_label or ("grazing orbit" if start is None else "user-supplied orbit")
    settings = FamilySettings(
        step=float(step),
        max_points=int(max_points),
        energy_max=np.inf,
        max_log_energy_step=np.inf,
        max_frequency_step=np.inf,
        min_step=min_step_ratio * step,
    )
    orient = np.array([0.0, 0.0, -1.0, 1.0]) if direction is None else np.asarray(direction, dtype=float)
    try:
        return follow_family(
            problem,
            y,
            orient,
            settings,
            transitions=False,
            tangent_from="null_space",
            start_label=label,
            start_violation=None if start is None else 1e-9,
        )
    except RuntimeError as exc:  # a singular start
        raise ValueError(f"cannot start the two-impact family at {y}: {exc}") from exc


def _start_after(tr: Transition, params, settings: FamilySettings):
    """First orbit, tangent, first step and grazing flag of the family after a transition."""
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
    problem = SequenceProblem(params, tr.new)
    null = unit_null_vector(problem.jacobian(tr.y_graze))
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


def follow_branch(params: ModelParameters, sequence: str, y0, direction, settings: FamilySettings) -> list:
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
    settings : FamilySettings

    Returns
    -------
    list of Family
        In continuation order; the last one has no transition and says why the branch ends.
    """
    problem = SequenceProblem(params, sequence)
    segments = [follow_family(problem, y0, direction, settings)]
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
        seg = follow_family(
            problem, y1, direction, settings, h0=h0, max_points=settings.max_points - used, first_grazing=graze
        )
        segments.append(seg)
        used += len(seg)
    return segments
