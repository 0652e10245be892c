"""When a stage of a regularized branch ends: its condition, its energy bound, the truncation guard, a tongue.

A stage ends at the first stored point that meets its *condition* (:func:`stage_condition`: an energy,
a change of impact regime, the gap-0 limit, an energy fold, a passed ``n:1`` resonance), or, when the
condition never comes, at its *energy bound* (the reason stored, the stages after it skipped). The
:class:`TruncationGuard` refuses orbits that ``H`` harmonics do not resolve: it ends the stage there
(stages) or raises (studies). :class:`TongueWatch` ends a segment where the backbone bends into an
internal resonance tongue (``docs/methods/tube_resonance.md``). :class:`StageStop` checks them in that
order and remembers which one ended the stage. Method notes: ``docs/methods/hbm.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from nnmstop import fourier
from nnmstop.continuation.core import UnresolvedBranchError
from nnmstop.models.structure import Structure, limit_modes

__all__ = [
    "CRITERIA",
    "stage_condition",
    "describe_condition",
    "TruncationGuard",
    "TongueWatch",
    "StageStop",
    "TONGUE",
    "resonance_crossed",
]

#: Kinds of a stage's ``until`` condition.
CRITERIA = (
    "energy_above",
    "impacts_above",
    "impacts_at_most",
    "frequency_within_gap_zero",
    "energy_folds",
    "past_resonance",
)

#: Start of the end reason of a segment that stopped where the backbone bends into a resonance tongue.
TONGUE = "resonance tongue"


def _check_until(until: dict) -> tuple[str, object]:
    if not isinstance(until, dict) or len(until) != 1 or next(iter(until)) not in CRITERIA:
        raise ValueError(f"a stage's 'until' must hold exactly one of {CRITERIA}, got {until!r}")
    ((kind, value),) = until.items()
    return kind, value


def describe_condition(until: dict) -> str:
    """Words for a stage's condition, as its end reason says them when it is met."""
    kind, value = _check_until(until)
    return {
        "energy_above": lambda: f"energy above {value:g}",
        "impacts_above": lambda: f"more than {value} impacts per period",
        "impacts_at_most": lambda: f"at most {value} impacts per period",
        "frequency_within_gap_zero": lambda: f"frequency within {value:g} of the gap-0 linear mode",
        "energy_folds": lambda: f"{value} energy fold(s) passed",
        "past_resonance": lambda: f"past the {value}:1 internal resonance",
    }[kind]()


def stage_condition(until: dict, structure: Structure, mode: int) -> Callable:
    """The condition ``stop(U, diagnostics, system) -> reason`` of a stage's ``until`` mapping.

    ``frequency_within_gap_zero: r`` stops within the relative distance ``r`` of the gap-0 linear
    mode of the same index ``mode`` as the branch (every stop engaged, :func:`limit_modes`);
    ``energy_folds: k`` at the first point past the ``k``-th energy fold of the stage;
    ``past_resonance: n`` at the first point past the ``n:1`` internal resonance, where the
    fundamental harmonic of the first stop's coordinate changes sign and the orbit there has period
    ``T/n`` (:func:`resonance_crossed`). The conditions with a memory are fresh for each call.
    """
    kind, value = _check_until(until)
    if kind == "energy_above":
        return lambda U, d, system: f"energy above {value:g}" if d["energy"] > value else ""
    if kind == "impacts_above":
        return lambda U, d, system: f"more than {value} impacts per period" if d["impacts_per_period"] > value else ""
    if kind == "impacts_at_most":
        return lambda U, d, system: f"at most {value} impacts per period" if d["impacts_per_period"] <= value else ""
    if kind == "frequency_within_gap_zero":
        limit = float(limit_modes(structure, "gap_zero", max(mode, 1))[0][mode - 1] / (2 * np.pi))

        def near_gap_zero(U, d, system):
            gap = abs(d["frequency"] - limit) / limit
            text = f"frequency within {value:g} of the gap-0 linear mode {mode} ({limit:.6g} Hz)"
            return text if gap <= value else ""

        return near_gap_zero
    if kind == "energy_folds":
        return _EnergyFolds(int(value))
    return _PastResonance(int(value))


@dataclass
class _EnergyFolds:
    """Ends past the ``count``-th local extremum of the energy along the stage."""

    count: int
    energies: list = field(default_factory=list)
    folds: int = 0

    def __call__(self, U, d, system) -> str:
        self.energies.append(float(d["energy"]))
        e = self.energies
        if len(e) >= 3 and (e[-2] - e[-3]) * (e[-1] - e[-2]) < 0:
            self.folds += 1
        return f"{self.count} energy fold(s) passed" if self.folds >= self.count else ""


def resonance_crossed(system, U_a, U_b, share: float = 0.5) -> int:
    """``n`` if the fundamental of the first stop's coordinate changes sign from ``U_a`` to ``U_b``, else 0.

    At an ``n:1`` internal resonance the orbit has period ``T/n``: its fundamental harmonic vanishes
    and changes sign along the branch. ``n`` is the smallest ``n >= 2`` whose multiples carry more than
    ``share`` of the mean square of the degrees of freedom at the point of the chord where the
    fundamental vanishes (1 when none does: a sign change that is not a resonance).
    """
    a, b = float(system.reference_amplitude(U_a)), float(system.reference_amplitude(U_b))
    if a * b > 0 or a == b:
        return 0
    U = U_a + (a / (a - b)) * (U_b - U_a)
    cos, sin = fourier.to_cos_sin(np.stack(system.split(U)[: system.n_dofs]), system.H)
    power = np.sum(cos**2 + sin**2, axis=0)[1:]
    harmonic = np.arange(1, system.H + 1)
    total = power.sum()
    for n in range(2, system.H + 1):
        if total > 0 and power[harmonic % n == 0].sum() > share * total:
            return n
    return 1


@dataclass
class _PastResonance:
    """Ends at the first point past the ``n:1`` resonance (:func:`resonance_crossed`)."""

    n: int
    previous: np.ndarray | None = None

    def __call__(self, U, d, system) -> str:
        crossed = self.previous is not None and resonance_crossed(system, self.previous, U) == self.n
        self.previous = np.array(U)
        return f"past the {self.n}:1 internal resonance" if crossed else ""


@dataclass
class TruncationGuard:
    """Stop criterion wrapper that refuses orbits the harmonics do not resolve.

    Called like a stop criterion ``(U, diagnostics) -> reason``. When the truncation indicator
    (``diagnostics["truncation"]``, :meth:`nnmstop.hbm.system.HarmonicBalanceSystem.truncation`) exceeds
    ``limit`` it raises :class:`~nnmstop.continuation.core.UnresolvedBranchError` naming the energy,
    the indicator and ``H``, or, with ``end_branch``, returns that text as the end reason (the
    unresolved point is then the last of the branch and is dropped by the stage). Otherwise it defers
    to ``inner``. ``largest`` keeps the largest indicator seen; ``setting`` is the configuration key of
    ``limit``, for the message.
    """

    system: object
    inner: Callable
    limit: float
    label: str = "NNM1"
    setting: str = "hbm.max_truncation"
    end_branch: bool = False
    largest: float = 0.0
    points: int = 0
    unresolved: bool = False

    def __post_init__(self):
        if not (np.isfinite(self.limit) and 0.0 < self.limit < 1.0):
            raise ValueError(f"{self.setting} must be a number in (0, 1), got {self.limit!r}")

    def __call__(self, U, diag) -> str:
        self.points += 1
        level = float(diag["truncation"])
        self.largest = max(self.largest, level)
        if level > self.limit:
            stops = ", ".join(f"alpha = {a:g}, eta = {e:g}" for a, e in zip(self.system.alphas, self.system.etas))
            text = (
                f"truncation indicator {level:.4g} > {self.setting} = {self.limit:g} at energy "
                f"{diag['energy']:.6g} (frequency {diag['frequency']:.6g} Hz, point {self.points - 1}): H = "
                f"{self.system.H} harmonics do not resolve the stop ({stops}); more harmonics or a larger eta "
                "are needed"
            )
            if not self.end_branch:
                raise UnresolvedBranchError(f"{self.label}: {text}")
            self.unresolved = True
            return f"unresolved: {text}"
        return self.inner(U, diag)

    @property
    def ended_by(self) -> str:
        """``"truncation"`` once an unresolved orbit ended the branch, else ``""``."""
        return "truncation" if self.unresolved else ""


@dataclass
class TongueWatch:
    """Ends a segment where its frequency, rising along the backbone, falls from its maximum.

    The backbone has then bent into an internal resonance tongue, whose frequency stays locked while
    the energy climbs. ``drop`` (1e-6, relative) is far above the continuation's accuracy and far
    below the backbone's frequency rise per step.
    """

    drop: float = 1e-6
    highest: float = -np.inf

    def __call__(self, U, d) -> str:
        frequency = d["frequency"]
        self.highest = max(self.highest, frequency)
        if frequency < self.highest * (1.0 - self.drop):
            return f"{TONGUE}: the frequency fell from its maximum {self.highest:.7g} Hz at E = {d['energy']:.6g}"
        return ""


@dataclass
class StageStop:
    """The stop criterion of one segment of a stage: truncation, condition, energy bound, tongue, in that order.

    ``ended_by`` says which ended it: ``"truncation"``, ``"condition"``, ``"bound"`` or ``"tongue"``.
    """

    system: object
    condition: Callable
    energy_bound: float
    guard_limit: float
    label: str
    tongue: TongueWatch | None = None
    setting: str = "hbm.max_truncation"
    ended_by: str = ""
    guard: TruncationGuard = field(init=False)

    def __post_init__(self):
        if not (np.isfinite(self.energy_bound) and self.energy_bound > 0):
            raise ValueError(
                f"{self.label}: the energy bound of a stage must be finite and > 0, got {self.energy_bound!r}"
            )
        self.guard = TruncationGuard(
            self.system, self._inner, self.guard_limit, self.label, self.setting, end_branch=True
        )

    def _inner(self, U, d) -> str:
        for kind, reason in (
            ("condition", lambda: self.condition(U, d, self.system)),
            (
                "bound",
                lambda: (
                    f"energy above the stage's bound {self.energy_bound:g}" if d["energy"] > self.energy_bound else ""
                ),
            ),
            ("tongue", lambda: self.tongue(U, d) if self.tongue is not None else ""),
        ):
            text = reason()
            if text:
                self.ended_by = kind
                return text
        return ""

    def __call__(self, U, d) -> str:
        reason = self.guard(U, d)
        if self.guard.unresolved:
            self.ended_by = "truncation"
        return reason
