"""The exact NNM1 of the 2-DOF oscillator through its grazing transitions (2-DOF only), and its two-impact family.

The solutions of the quarter-period equations of one phase sequence form one-parameter
families. :func:`follow_family` follows one with the continuation every exact family uses
(:func:`nnmstop.exact.follow.continue_exact_family`: the continuation driver, dense
pseudo-arclength steps corrected to round-off, the validity margins of
:func:`nnmstop.exact.grazing.assess_orbit` as events located on the step's path), the step
limited by the changes of energy and frequency; at its end the grazing transition is
classified and :func:`follow_branch` enters the family of the next phase sequence. The phase
sequences with several impacts per stop are implemented for 2-DOF structures only
(:class:`nnmstop.exact.problem.SequenceProblem`). The two-impact family
(:func:`follow_two_impact_family`) is the one-stop family of any structure
(:func:`nnmstop.exact.ndof.follow_one_stop_family`) on the 2-DOF oscillator, returned in the
unknowns of the paper. Method notes: ``docs/methods/exact.md``.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from nnmstop.continuation.dense_arclength import DenseArclengthSettings
from nnmstop.exact import ndof
from nnmstop.exact.follow import (
    RESTART_POINTS,
    ValidityEvents,
    branch_point_flags,
    confirm_family_end,
    continue_exact_family,
)
from nnmstop.exact.grazing import Transition, assess_orbit, classify_boundary, describe_margin, split_start
from nnmstop.exact.ndof import OneStopProblem
from nnmstop.exact.problem import SequenceProblem, TwoImpactProblem
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters

__all__ = [
    "FamilySettings",
    "Family",
    "follow_family",
    "follow_two_impact_family",
    "follow_branch",
    "validity_events",
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
    end_check : str
        How the end was confirmed (:func:`nnmstop.exact.follow.confirm_family_end`; '' when it was not asked).
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
    end_check: str = ""

    @property
    def sequence(self) -> str:
        """Phase sequence of the family."""
        return self.problem.sequence

    @property
    def params(self) -> ModelParameters | None:
        """The paper's parameters when the model was given by them (None for a 2-DOF structure)."""
        return self.problem.params

    @property
    def model(self):
        """The model: :class:`~nnmstop.models.two_dof.ModelParameters` or a 2-DOF structure."""
        return self.problem.model

    def __len__(self) -> int:
        return len(self.unknowns)

    @property
    def energy(self) -> np.ndarray:
        """Total energy of the piecewise model (the kinetic energy at ``x = u = 0``) of each orbit."""
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

    def _freeze(self) -> Family:
        for name in ("unknowns", "arclength", "residual"):
            setattr(self, name, np.array(getattr(self, name)))
        return self


def validity_events(problem: SequenceProblem) -> ValidityEvents:
    """The margins of :func:`nnmstop.exact.grazing.assess_orbit` as continuation events."""
    return ValidityEvents(lambda y: assess_orbit(problem, y), lambda key: describe_margin(problem, key))


def _continuation_settings(settings: FamilySettings) -> DenseArclengthSettings:
    return DenseArclengthSettings(
        step=float(settings.step),
        min_step=float(settings.min_step),
        max_log_energy_step=float(settings.max_log_energy_step),
        max_frequency_step=float(settings.max_frequency_step),
    )


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
    start_label: str = "",
    confirm: bool = False,
) -> Family:
    """Follow the family of one phase sequence until its assumptions fail.

    :func:`nnmstop.exact.follow.continue_exact_family` with the steps of ``settings`` (their
    changes of ``ln E`` and frequency limited); nothing assumes the energy to be monotone along
    the family. At the first invalid orbit the boundary is located on the last step's path
    (relative ``1e-13``) and the last valid orbit is kept: the family is never extended past its
    end. With ``transitions``, the grazing transition there is classified
    (:func:`nnmstop.exact.grazing.classify_boundary`) and its grazing orbit is appended when it
    belongs to this sequence (split, append).

    Parameters
    ----------
    problem : SequenceProblem
    y0 : array_like
        First orbit (residual below ``1e-10``).
    direction : array_like
        Orientation of the first tangent (the tangent solves ``[J; direction] t = e_n``).
    settings : FamilySettings
    h0 : float, optional
        First step (default ``settings.step``).
    max_points : int, optional
        Largest number of orbits of this family (default ``settings.max_points``).
    first_grazing : bool
        Mark the first orbit as a grazing orbit.
    transitions : bool
        Classify the end of the family as a grazing transition.
    start_label : str
        Description of the first orbit, kept in the result.
    confirm : bool
        Confirm the end by a restart with a ten times smaller step and ten times smaller limits of the
        energy and frequency changes (``end_check``); raise
        :class:`~nnmstop.continuation.confirm.EndNotConfirmed` when the restart ends elsewhere.

    Returns
    -------
    Family
    """
    y = problem.check(y0).copy()
    res0 = np.linalg.norm(problem.residual(y))
    if res0 > 1e-10:
        raise ValueError(f"start is not an orbit of {problem.sequence!r} (residual {res0:.3e})")
    max_points = settings.max_points if max_points is None else int(max_points)
    branch = continue_exact_family(
        problem,
        y,
        direction,
        validity_events(problem),
        _continuation_settings(settings),
        max_points=max_points,
        energy_max=settings.energy_max,
        first_step=None if h0 is None else min(h0, settings.step),
        label=f"exact {problem.sequence} family",
    )
    family = Family(problem, start=start_label, step=float(settings.step))
    flags = branch_point_flags(branch)
    for k, (y_k, s_k, check) in enumerate(zip(branch.points, branch.arclength, branch.checks)):
        family.append(y_k, s_k, check, branch_point=bool(flags[k]), grazing=first_grazing and k == 0)
    family.end_reason, family.end_tangent = branch.end_reason, branch.end_tangent
    if branch.end_event is not None:
        _end_family(family, branch.end_event.outside, transitions)
    if confirm:
        family.end_check = confirm_family_end(family, _restart(problem, settings), f"exact {problem.sequence} family")
    _log_family(family)
    return family._freeze()


def _restart(problem: SequenceProblem, settings: FamilySettings):
    """``restart(U, direction, fine_step)``: the family of ``problem`` from ``U`` with the step and its energy and
    frequency limits refined alike, without transition (for :func:`nnmstop.exact.follow.confirm_family_end`)."""

    def restart(U, direction, fine_step):
        refine = settings.step / fine_step
        fine = dataclasses.replace(
            settings,
            step=fine_step,
            max_log_energy_step=settings.max_log_energy_step / refine,
            max_frequency_step=settings.max_frequency_step / refine,
            min_step=min(settings.min_step, fine_step),
        )
        return follow_family(problem, U, direction, fine, max_points=RESTART_POINTS, transitions=False)

    return restart


def _log_family(family: Family) -> None:
    energies, frequencies = family.energy, family.frequency
    logger.info(
        "%s family%s: %d orbits, energy %.6g..%.6g, frequency %.7g..%.7g Hz, max residual %.2e; end: %s",
        family.sequence,
        f" from the {family.start}" if family.start else "",
        len(family),
        energies.min(),
        energies.max(),
        frequencies.min(),
        frequencies.max(),
        max(family.residual),
        family.end_reason,
    )


def _end_family(family: Family, check_hi, transitions: bool) -> None:
    """Say why the family ends at its located boundary; classify the grazing transition there."""
    problem = family.problem
    y_lo, check_lo = family.unknowns[-1], family.assessments[-1]
    family.end_margin = check_hi.violated[0]
    if not transitions:
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
    model,
    step: float = 0.02,
    max_points: int = 4000,
    start=None,
    direction=None,
    start_label: str | None = None,
    min_step_ratio: float = 1e-6,
    confirm: bool = False,
) -> Family:
    """The family of two-impact orbits (Section 3.1): the one-stop family of the 2-DOF oscillator.

    :func:`nnmstop.exact.ndof.follow_one_stop_family` on :func:`nnmstop.models.structure.two_dof_structure`
    (any structure's family, in its modal unknowns), returned in the unknowns of the paper
    ``(xdot0, udot0, tau1, T1)`` (:class:`nnmstop.exact.problem.TwoImpactProblem`). The family ends,
    without transition, at its first violated assumption (``end_margin``, a key of
    :data:`nnmstop.exact.grazing.TWO_IMPACT_MARGINS`).

    Parameters
    ----------
    model : ModelParameters or Structure
        The paper's oscillator, or a 2-DOF structure with one stop on its first degree of freedom and gap 1.
    step : float
        Largest arclength step (> 0; the modal unknowns of the 2-DOF oscillator with ``delta = 1`` are
        a rotation of the velocities, so the lengths are those of the paper's unknowns).
    max_points : int
        Maximum number of orbits (>= 2).
    start : array_like, shape (4,), optional
        First orbit ``(xdot0, udot0, tau1, T1)``; the grazing orbit (first linear mode with x amplitude 1) by default.
    direction : array_like, shape (4,), optional
        The first tangent has a positive dot product with it; by default the direction of
        increasing contact duration ``T1 - tau1``.
    start_label : str, optional
        Description of the start, kept in the result.
    min_step_ratio : float
        The continuation fails when the step falls below ``min_step_ratio * step``.
    confirm : bool
        Confirm the end by a restart with a ten times smaller step (``end_check``, see
        :func:`nnmstop.exact.ndof.follow_one_stop_family`).

    Returns
    -------
    Family
    """
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be a finite number > 0, got {step!r}")
    if int(max_points) != max_points or max_points < 2:
        raise ValueError(f"max_points must be an integer >= 2, got {max_points!r}")
    problem = TwoImpactProblem(model)
    structure = two_dof_structure(model) if problem.params is not None else model
    one_stop = OneStopProblem(structure)
    y0 = None if start is None else _modal_start(problem, one_stop, start)
    orient = None if direction is None else _to_modal(one_stop, direction)
    modal = ndof.follow_one_stop_family(
        structure,
        step=step,
        max_points=max_points,
        start=y0,
        direction=orient,
        min_step_ratio=min_step_ratio,
        confirm=confirm,
    )
    label = start_label or ("grazing orbit" if start is None else "user-supplied orbit")
    family = Family(problem, start=label, step=float(step))
    velocities = modal.initial_velocity
    for k, check in enumerate(modal.assessments):
        y = np.concatenate([velocities[k], modal.unknowns[k, -2:]])
        family.append(y, modal.arclength[k], check, branch_point=bool(modal.branch_point[k]), grazing=k == 0)
    family.end_reason, family.end_margin, family.end_tangent = modal.end_reason, modal.end_margin, modal.end_tangent
    family.end_check = modal.end_check
    return family._freeze()


def _to_modal(one_stop: OneStopProblem, y) -> np.ndarray:
    """``(xdot0, udot0, tau1, T1)`` (or a direction in them) as the one-stop unknowns ``(b, tau1, T1)``."""
    y = np.asarray(y, dtype=float)
    b = one_stop.free.modal_coordinates(np.concatenate([np.zeros(2), y[:2]]))[1]
    return np.concatenate([b, y[2:]])


def _modal_start(problem: TwoImpactProblem, one_stop: OneStopProblem, start) -> np.ndarray:
    """A user's first two-impact orbit, checked (an orbit, its assumptions holding), in the one-stop unknowns."""
    start = problem.check(start)
    residual = np.linalg.norm(problem.residual(start))
    if residual > 1e-10:
        raise ValueError(f"start {start} is not a two-impact orbit (residual {residual:.3e})")
    y0 = _to_modal(one_stop, start)
    check = ndof.assess_orbit(one_stop, y0)
    if check.min_margin < -1e-9:
        raise ValueError(f"start {start} violates the assumptions {check.violated} of the two-impact family")
    return y0


def _start_after(tr: Transition, model, settings: FamilySettings):
    """First orbit, tangent, first step and grazing flag of the family after a transition."""
    if tr.kind in ("split", "append"):
        eps = settings.grazing_epsilon
        problem, y1, index = split_start(model, tr.old, tr.y_graze, tr.phase, tr.t_star, tr.level, eps)
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
    problem = SequenceProblem(model, tr.new)
    null = scipy.linalg.null_space(problem.jacobian(tr.y_graze))
    if null.shape[1] != 1:
        raise RuntimeError(f"after the merge {tr.old} -> {tr.new}: the grazing orbit is not a regular point")
    null = null[:, 0]
    trial = min(1e-4, settings.step)
    stepper = _continuation_settings(settings).stepper()
    valid = []
    for sign in (1.0, -1.0):
        y_t = stepper.correct(problem, tr.y_graze, sign * null, trial)
        valid.append(y_t is not None and assess_orbit(problem, y_t).valid)
    if valid[0] == valid[1]:
        raise RuntimeError(
            f"after the merge {tr.old} -> {tr.new}, {'both' if valid[0] else 'neither'} directions of the "
            f"{tr.new} family are valid orbits; not a generic grazing"
        )
    return problem, tr.y_graze, null if valid[0] else -null, trial, True


def follow_branch(model, sequence: str, y0, direction, settings: FamilySettings, confirm: bool = False) -> list:
    """Follow the exact NNM1 through its grazing transitions.

    Parameters
    ----------
    model : ModelParameters or Structure
        The paper's oscillator or a 2-DOF structure with one stop on its first degree of freedom and gap 1
        (anything else: ValueError naming what is not supported,
        :func:`nnmstop.exact.phases.check_sequence_model`).
    sequence : str
        Phase sequence of the first orbit.
    y0 : array_like
        First orbit.
    direction : array_like
        Initial direction of the continuation in the unknowns of ``sequence``.
    settings : FamilySettings
    confirm : bool
        Confirm the end of every segment (:func:`follow_family`).

    Returns
    -------
    list of Family
        In continuation order; the last one has no transition and says why the branch ends.
    """
    problem = SequenceProblem(model, sequence)
    segments = [follow_family(problem, y0, direction, settings, confirm=confirm)]
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
        if used >= settings.max_points - 1:
            segments[-1].end_reason += "; max_points reached"
            segments[-1].transition = None
            break
        try:
            problem, y1, direction, h0, graze = _start_after(tr, model, settings)
        except RuntimeError as exc:
            segments[-1].end_reason += f"; cannot continue: {exc}"
            segments[-1].transition = None
            break
        seg = follow_family(
            problem,
            y1,
            direction,
            settings,
            h0=h0,
            max_points=settings.max_points - used,
            first_grazing=graze,
            confirm=confirm,
        )
        segments.append(seg)
        used += len(seg)
    return segments
