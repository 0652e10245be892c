"""Internal resonances along a one-stop family: which linear mode takes the energy, at which harmonic.

Along the backbone of a nonlinear normal mode the energy grows in the mode the family started from.
In an ``n:1`` internal resonance (a *tongue*) it grows instead in another linear mode ``k`` that
vibrates at the ``n``-th harmonic of the orbit, ``omega_k`` being close to ``n`` times the orbit's
angular frequency (``n`` odd: the symmetric orbits hold odd harmonics only); the frequency of the
orbit stays locked while the energy grows. On the finite-element tube the exact family leaves its
backbone that way a little above grazing (``docs/methods/tube_resonance.md``).

The energy of a one-stop orbit is ``sum_k b_k^2 / 2`` (its modal velocities at ``q = 0``), so the
growth of each mode's share along the family is ``b_k t_k`` (``t`` the family's tangent):
:func:`energy_growth`. :func:`classify_resonances` names, at each orbit, the mode that takes most of
the growth and, when it is not the family's own, the harmonic at which that mode moves
(:func:`dominant_harmonic` of its modal coordinate over one period): ``n >= 3`` is an internal
resonance; ``n = 1`` is the backbone changing shape (the 2-DOF oscillator's second mode takes most of
the growth at high energy, at the orbit's own frequency).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnmstop.continuation.core import unit_tangent
from nnmstop.exact.ndof import OneStopFamily, OneStopProblem, time_history

__all__ = ["energy_growth", "modal_history", "harmonic_content", "Resonances", "classify_resonances"]

#: A mode in internal resonance takes more than this share of the energy growth ...
GROWTH_SHARE = 0.5
#: ... and has more than this fraction of its motion's power in one harmonic.
MONOCHROMATIC = 0.99


def energy_growth(family: OneStopFamily) -> np.ndarray:
    """``dE_k / ds`` of every linear mode ``k`` at every orbit (shape ``(n, N)``), ``s`` along the continuation.

    The tangent at each orbit is the unit null vector of the Jacobian oriented along the chord of its
    neighbours. A family of a single orbit (it ended where it started, its end reason says why) has no
    chord: no growth, zeros.
    """
    problem, y = family.problem, np.asarray(family.unknowns)
    growth = np.zeros((len(y), problem.n))
    if len(y) < 2:
        return growth
    for i in range(len(y)):
        chord = y[min(i + 1, len(y) - 1)] - y[max(i - 1, 0)]
        tangent, _ = unit_tangent(problem, y[i], chord, singular_tol=None)
        growth[i] = y[i, : problem.n] * tangent[: problem.n]
    return growth


def modal_history(problem: OneStopProblem, y, samples: int) -> np.ndarray:
    """Modal coordinates ``Phi^T M q(t)`` of the orbit ``y`` at ``samples`` equally spaced times of one period."""
    t = 4.0 * float(y[-1]) * np.arange(samples) / samples
    q = time_history(problem, y, t).q
    return q @ problem.free._projection.T


def harmonic_content(signal) -> tuple[int, float]:
    """The harmonic (of the sampled period) holding most of the power of a real periodic ``signal``, and the
    fraction of the power (mean excluded) it holds."""
    power = np.abs(np.fft.rfft(np.asarray(signal, dtype=float))) ** 2
    power[0] = 0.0
    n = int(np.argmax(power))
    return n, float(power[n] / power.sum()) if power.sum() > 0 else 0.0


@dataclass(frozen=True)
class Resonances:
    """Per orbit of a one-stop family: ``mode`` (1-based) of the linear mode in internal resonance, 0 on the
    backbone; ``order`` its harmonic ``n`` of the orbit (``n:1``), 0 on the backbone; ``growth_mode`` (1-based)
    the mode that takes most of the energy growth."""

    mode: np.ndarray
    order: np.ndarray
    growth_mode: np.ndarray

    def first(self) -> int | None:
        """Index of the first orbit in internal resonance (None when the family stays on its backbone)."""
        hits = np.flatnonzero(self.mode > 0)
        return int(hits[0]) if hits.size else None


def classify_resonances(family: OneStopFamily) -> Resonances:
    """The internal resonance (or the backbone) of every orbit of ``family`` (module docstring)."""
    problem = family.problem
    growth = energy_growth(family)
    total = growth.sum(axis=1)
    growth_mode = np.argmax(growth * np.where(total < 0, -1.0, 1.0)[:, None], axis=1)
    mode, order = np.zeros(len(growth), dtype=int), np.zeros(len(growth), dtype=int)
    frequency = family.frequency
    for i in np.flatnonzero(growth_mode != family.mode):
        k = int(growth_mode[i])
        if not growth[i, k] / total[i] > GROWTH_SHARE:
            continue
        ratio = problem.free.omega[k] / (2.0 * np.pi * frequency[i])
        samples = 4 * int(np.ceil(ratio + 2))  # resolves the harmonics up to twice the mode's ratio
        n, fraction = harmonic_content(modal_history(problem, family.unknowns[i], samples)[:, k])
        if n >= 3 and fraction > MONOCHROMATIC:
            mode[i], order[i] = k + 1, n
    return Resonances(mode=mode, order=order, growth_mode=growth_mode + 1)
