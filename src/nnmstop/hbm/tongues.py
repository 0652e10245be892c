"""Passing an internal resonance tongue: from the backbone below it onto the backbone beyond it.

Where the backbone of an NNM meets the tongue of an ``n:1`` internal resonance with a higher mode it
bends into the tongue (an avoided crossing, not a branch point), whose frequency stays locked while
the energy climbs over decades. :func:`over_the_tongue` jumps it: a predictor along the backbone below,
corrected by Newton, lands on the backbone beyond, which is followed back to its energy fold at the
tongue. :func:`joined_segments` makes the segments of a stage one branch. Method and measurements:
``docs/methods/tube_resonance.md``.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np

from nnmstop import fourier
from nnmstop.continuation.anm import ANMSettings, continue_anm
from nnmstop.continuation.core import Branch, ContinuationError, ContinuationStats, newton_correct

__all__ = ["PassedResonance", "over_the_tongue", "joined_segments"]

logger = logging.getLogger("nnmstop.hbm.tongues")


@dataclass
class PassedResonance:
    """An internal resonance tongue that the backbone was continued over.

    ``frequency`` and ``energy``: the frequency maximum of the segment that bent into the tongue;
    ``harmonic``: the harmonic whose amplitude grew most between the backbone below the tongue
    and that maximum (the harmonic of the other mode that the tongue locks, e.g. 17 for
    17 f1 = f3); ``landing_frequency``: frequency where the predictor over the tongue was
    corrected onto the backbone beyond it.
    """

    frequency: float
    energy: float
    harmonic: int
    landing_frequency: float


def _amplitudes(system, U) -> np.ndarray:
    """Root-sum-square over the degrees of freedom of the amplitude of each harmonic 0..H."""
    cos, sin = fourier.to_cos_sin(np.stack(system.split(U)[: system.n_dofs]), system.H)
    return np.sqrt(np.sum(cos**2 + sin**2, axis=0))


def _landing(system, start, chord, length: float, f_peak: float, margin: float, settings: ANMSettings):
    """The shortest predictor from ``start`` along ``chord`` whose Newton correction lands beyond the tongue."""
    # the shortest jump that lands beyond the tongue: the backbone there may hold narrower tongues
    # (higher-order resonances) that a longer one would jump into
    for _ in range(12):
        try:
            # a guess too far off diverges: Newton reports it, the overflow on the way says nothing more
            with np.errstate(over="ignore", invalid="ignore"):
                guess, _ = newton_correct(
                    system, start + length * chord, chord, ContinuationStats(), tol=0.01 * settings.newton_threshold
                )
        except (ContinuationError, np.linalg.LinAlgError):
            guess = None
        if guess is not None and system.frequency_hz(guess) > f_peak * (1.0 + margin):
            return guess
        length *= 2.0
    return None


def over_the_tongue(system, segment: Branch, settings: ANMSettings, margin: float, label: str):
    """The tongue at the end of ``segment`` passed: the resonance, and a start point and direction beyond it.

    The predictor is the chord of the backbone at the last two stored points whose frequency is
    below the tongue's by ``margin`` (relative), from the last of them, of growing length (the
    chord's, doubled until it works); each guess is corrected by Newton in the hyperplane orthogonal
    to the chord and accepted once its frequency exceeds the tongue's by ``margin``. The curve through
    the landing point is followed back (decreasing frequency) to its energy fold within ``margin`` of
    the tongue's frequency: the next segment starts just past that fold, so that the fold is one of
    its points.

    Raises
    ------
    ContinuationError
        If no guess lands beyond the tongue, or the curve beyond has no energy fold at it.
    """
    points = np.array(segment.points)
    frequency = np.array([d["frequency"] for d in segment.diagnostics])
    peak = int(np.argmax(frequency))
    f_peak = float(frequency[peak])
    below = np.flatnonzero(frequency[:peak] < f_peak * (1.0 - margin))
    if below.size < 2:
        raise ContinuationError(f"{label}: too few points below the resonance tongue at {f_peak:.7g} Hz")
    a = int(below[-1])
    chord = points[a] - points[a - 1]
    chord /= np.linalg.norm(chord)
    harmonic = int(np.argmax((_amplitudes(system, points[peak]) - _amplitudes(system, points[a]))[2:])) + 2
    length = float(np.linalg.norm(points[a] - points[a - 1]))
    landing = _landing(system, points[a], chord, length, f_peak, margin, settings)
    if landing is None:
        raise ContinuationError(f"{label}: no predictor over the resonance tongue at {f_peak:.7g} Hz landed beyond it")
    resonance = PassedResonance(
        frequency=f_peak,
        energy=float(segment.diagnostics[peak]["energy"]),
        harmonic=harmonic,
        landing_frequency=float(system.frequency_hz(landing)),
    )
    logger.info(
        "%s: resonance tongue at %.7g Hz (harmonic %d) passed, landed at %.7g Hz",
        label,
        f_peak,
        harmonic,
        resonance.landing_frequency,
    )
    back = continue_anm(
        system,
        landing,
        -chord,
        _BackToTheFold(f_peak, margin, resonance, system.diagnostics(landing)["energy"]),
        settings,
        label=f"{label} back to the tongue",
    )
    if back.end_reason != "energy fold passed":
        raise ContinuationError(f"{label}: the backbone beyond the tongue has no energy fold at it ({back.end_reason})")
    return resonance, back.points[-1], -back.end_tangent


@dataclass
class _BackToTheFold:
    """Stop criterion of the way back from the landing point to the energy fold at the tongue."""

    f_peak: float
    margin: float
    resonance: PassedResonance
    landing_energy: float
    lowest: float = np.inf

    def __call__(self, U, diagnostics) -> str:
        near_tongue = diagnostics["frequency"] < self.f_peak * (1.0 + self.margin)
        # folds of narrower tongues higher up the backbone (higher-order resonances) are passed
        if diagnostics["energy"] > self.lowest and near_tongue:
            return "energy fold passed"
        self.lowest = diagnostics["energy"]
        if diagnostics["frequency"] < self.f_peak * (1.0 - self.margin):
            return "below the tongue"
        beyond = diagnostics["frequency"] > self.resonance.landing_frequency * (1.0 + self.margin)
        if beyond or diagnostics["energy"] > 2 * self.landing_energy:
            return "away from the tongue"
        return ""


def joined_segments(segments) -> Branch:
    """The segments as one branch: step indices made unique, flags moved, ``segment`` of every point."""
    joined = Branch()
    joined.segment = []
    offset = 0
    for k, segment in enumerate(segments):
        start = len(joined.points)
        for U, step, diagnostics in zip(segment.points, segment.step, segment.diagnostics):
            joined.add(U, offset + step, diagnostics)
            joined.segment.append(k)
        # a flag at a segment's start point would pair it with the previous segment's last point
        joined.branch_points += [start + i for i in segment.branch_points if i > 0]
        offset += max(segment.step) + 1
        for field in dataclasses.fields(joined.stats):
            setattr(joined.stats, field.name, getattr(joined.stats, field.name) + getattr(segment.stats, field.name))
    if len(segments) == 1:
        joined.end_reason = segments[0].end_reason
    else:
        joined.end_reason = "; ".join(f"segment {k}: {segment.end_reason}" for k, segment in enumerate(segments))
    joined.end_tangent = segments[-1].end_tangent
    return joined
