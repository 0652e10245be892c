"""Stability of a regularized (harmonic-balance) forced response: verdicts, their resolution, located changes.

The multipliers of every point come from the monodromy of the damped variational equation
(:class:`nnmstop.hbm.forced.ForcedLinearization`) with ``steps`` and ``2 steps`` Magnus steps; their change
is the integration error. A verdict (stable: every multiplier inside the unit circle) is **resolved** where
its margin, the distance of the multipliers to the unit circle (``min_i | |mu_i| - 1 |``: the verdict and the
number of multipliers outside, which sets the regime, hold within it), exceeds ``resolution_factor`` times the
larger of the integration error and the orbit's own error (the HBM orbit's ``time_residual``, as for the
NNMs); steps are doubled, up to ``max_steps``, only where the integration error decides an unresolved
verdict. So the precision follows what the verdict needs, and no verdict is claimed where the estimates do
not resolve it.

A change of the number of multipliers outside the unit circle between two points is located on the ANM
step between them (:func:`nnmstop.forced.stability_changes.locate_stability_changes`). A multiplier through
+1 is a symmetry-breaking branch point where the continuation flagged a simple branch point (the full-basis
harmonic balance holds both the symmetric and the asymmetric responses), else a fold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnmstop.continuation.anm import ANMSettings, ANMStepper
from nnmstop.floquet import check_power_of_two, match_nearest
from nnmstop.forced.responses import path_between
from nnmstop.forced.stability_changes import locate_stability_changes, type_branch_points, unstable_count
from nnmstop.hbm.forced import ForcedLinearization

__all__ = [
    "circle_distance",
    "ForcedStabilitySettings",
    "ForcedStability",
    "verdict_stability",
    "regularized_stability",
]


@dataclass(frozen=True)
class ForcedStabilitySettings:
    """Magnus steps of the first try (and twice as many for the error estimate), the most steps, and the factor by
    which a verdict's margin must exceed its error estimates to be resolved (config ``forced.stability``)."""

    steps: int = 128
    max_steps: int = 2048
    resolution_factor: float = 2.0

    def __post_init__(self):
        check_power_of_two("forced.stability.steps", self.steps, 16)
        check_power_of_two("forced.stability.max_steps", self.max_steps, 32)
        if self.max_steps < 2 * self.steps:
            raise ValueError(f"forced.stability.max_steps ({self.max_steps}) must be >= 2 x steps ({self.steps})")
        if not (np.isfinite(self.resolution_factor) and self.resolution_factor >= 1):
            raise ValueError(f"forced.stability.resolution_factor must be >= 1, got {self.resolution_factor!r}")

    @classmethod
    def from_config(cls, spec: dict) -> ForcedStabilitySettings:
        return cls(int(spec["steps"]), int(spec["max_steps"]), float(spec["resolution_factor"]))


@dataclass
class ForcedStability:
    """Per point: multipliers (points, 2N) by decreasing modulus, the verdict's margin, the integration and orbit
    error estimates, the Magnus steps used and whether the verdict is resolved."""

    multipliers: np.ndarray
    margin: np.ndarray
    integration_error: np.ndarray
    orbit_error: np.ndarray
    steps: np.ndarray
    resolved: np.ndarray

    def data_vars(self) -> dict:
        """Dataset variables (metadata: the catalogue)."""
        return {
            "multiplier_error": ("point", self.integration_error),
            "stability_margin": ("point", self.margin),
            "stability_orbit_error": ("point", self.orbit_error),
            "stability_steps": ("point", self.steps.astype(np.int32)),
            "stability_resolved": ("point", self.resolved.astype(np.int8)),
        }


def circle_distance(multipliers) -> np.ndarray:
    """Distance of the multipliers (rows) to the unit circle, ``min_i | |mu_i| - 1 |``: how far the verdict, the
    number of multipliers outside (the regime) and so the located changes are from changing."""
    return np.abs(np.abs(np.asarray(multipliers)) - 1.0).min(axis=-1)


def verdict_stability(linearization: ForcedLinearization, U_array, time_residual, settings: ForcedStabilitySettings):
    """Multipliers of the orbits ``U_array`` at the precision their verdicts need (see the module docstring)."""
    U = np.atleast_2d(np.asarray(U_array, dtype=float))
    n, F = len(U), settings.resolution_factor
    time_residual = np.asarray(time_residual, dtype=float)
    multipliers = np.zeros((n, linearization.A0.shape[0]), dtype=complex)
    error, steps = np.zeros(n), np.zeros(n, dtype=int)
    todo, N = np.arange(n), settings.steps
    coarse = linearization.multipliers(U, N)
    while len(todo):
        fine = linearization.multipliers(U[todo], 2 * N)
        multipliers[todo], steps[todo] = fine, 2 * N
        error[todo] = np.abs(fine - match_nearest(fine, coarse)).max(axis=-1)
        margin = circle_distance(fine)
        orbit = time_residual[todo] * np.maximum(1.0, np.abs(fine[:, 0]))
        # more steps only where the integration error decides the verdict and exceeds the orbit's own error
        undecided = (margin <= F * error[todo]) & (error[todo] > orbit)
        if 4 * N > settings.max_steps:
            break
        todo, coarse, N = todo[undecided], fine[undecided], 2 * N
    margin = circle_distance(multipliers)
    orbit_error = time_residual * np.maximum(1.0, np.abs(multipliers[:, 0]))
    resolved = margin > F * np.maximum(error, orbit_error)
    return ForcedStability(multipliers, margin, error, orbit_error, steps, resolved)


def _common_precision(linearization, U, stability: ForcedStability, time_residual, factor: float):
    """Recompute, in place, the less precise end of every step where the number of unstable multipliers changes
    with the other end's Magnus steps, until the counts of each such pair come from one precision: a change
    is then located at that precision, and one that does not survive it is none."""
    while True:
        counts = np.array([unstable_count(m) for m in stability.multipliers])
        pending = [
            (j, int(max(stability.steps[i], stability.steps[i + 1])))
            for i in np.flatnonzero(np.diff(counts) != 0)
            for j in (i, i + 1)
            if stability.steps[j] < max(stability.steps[i], stability.steps[i + 1])
        ]
        if not pending:
            return
        for j, steps in pending:
            fine = linearization.multipliers(U[j][None], steps)
            coarse = linearization.multipliers(U[j][None], steps // 2)
            stability.multipliers[j], stability.steps[j] = fine[0], steps
            stability.integration_error[j] = np.abs(fine - match_nearest(fine, coarse)).max()
            stability.margin[j] = circle_distance(fine)[0]
            stability.orbit_error[j] = time_residual[j] * max(1.0, np.abs(fine[0, 0]))
            error = max(stability.integration_error[j], stability.orbit_error[j])
            stability.resolved[j] = stability.margin[j] > factor * error


def regularized_stability(system, branch, anm: ANMSettings, settings: ForcedStabilitySettings):
    """:class:`ForcedStability` of every point of ``branch`` and the located stability changes."""
    U = np.asarray(branch.points)
    linearization = ForcedLinearization(system)
    time_residual = np.array([d["time_residual"] for d in branch.diagnostics], dtype=float)
    stability = verdict_stability(linearization, U, time_residual, settings)
    _common_precision(linearization, U, stability, time_residual, settings.resolution_factor)
    stepper = ANMStepper(anm)

    def multipliers_at(i):
        steps = int(max(stability.steps[i], stability.steps[i + 1]))
        return lambda V: linearization.multipliers(V[None], steps)[0]

    changes = locate_stability_changes(
        U,
        stability.multipliers,
        multipliers_at,
        lambda i: path_between(system, stepper, U, i),
        half_period=False,
    )
    # a multiplier through +1 is a fold of the symmetric responses unless the continuation crossed a simple
    # branch point there (sign change of det [J; t^T]: the symmetry-breaking pitchfork of the full basis)
    typed = type_branch_points(changes, branch.branch_points)
    return stability, typed
