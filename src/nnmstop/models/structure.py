"""A linear structure with bilateral elastic stops: the input of the harmonic-balance engine.

``M q'' + K q + sum_i e_i F_i(q_{d_i}) = 0``: mass and stiffness matrices of ``N`` degrees of
freedom, and stops, each acting on one degree of freedom ``d_i`` with its gap, stiffness and
regularization ``eta``. The paper's two-DOF oscillator is :func:`two_dof_structure`.

(Minimal stand-in written by the engine branch; the finite-element branch owns this module.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnmstop.models.two_dof import ModelParameters

__all__ = ["Stop", "Structure", "two_dof_structure"]


@dataclass(frozen=True)
class Stop:
    """A bilateral elastic stop on degree of freedom ``dof``: gap, stiffness and regularization ``eta``."""

    dof: int
    gap: float
    stiffness: float
    eta: float

    def __post_init__(self):
        if not isinstance(self.dof, (int, np.integer)) or isinstance(self.dof, bool) or self.dof < 0:
            raise ValueError(f"stop dof must be an integer >= 0, got {self.dof!r}")
        for name in ("gap", "stiffness", "eta"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"stop {name} must be finite and > 0, got {value!r}")
        if self.eta >= self.stiffness:
            raise ValueError(f"stop eta must be smaller than its stiffness, got eta={self.eta!r} >= {self.stiffness!r}")


@dataclass(frozen=True, eq=False)
class Structure:
    """Mass and stiffness matrices (``N x N``, dense or scipy.sparse) and the stops."""

    mass: object
    stiffness: object
    stops: tuple

    def __post_init__(self):
        n = self.mass.shape[0]
        for name in ("mass", "stiffness"):
            shape = getattr(self, name).shape
            if shape != (n, n):
                raise ValueError(f"{name} must be square {n} x {n}, got shape {shape}")
        object.__setattr__(self, "stops", tuple(self.stops))
        if not self.stops:
            raise ValueError("a structure needs at least one stop")
        for stop in self.stops:
            if stop.dof >= n:
                raise ValueError(f"stop on dof {stop.dof} is off the structure's {n} degrees of freedom")
        if len(set(self.stop_dofs)) != len(self.stops):
            raise ValueError(f"at most one stop per degree of freedom, got dofs {self.stop_dofs}")

    @property
    def n_dofs(self) -> int:
        """Number of degrees of freedom ``N``."""
        return int(self.mass.shape[0])

    @property
    def stop_dofs(self) -> tuple:
        """Degree of freedom of each stop, in the order of ``stops``."""
        return tuple(int(stop.dof) for stop in self.stops)


def two_dof_structure(params: ModelParameters) -> Structure:
    """The paper's oscillator: ``diag(1, delta)``, ``[[1+beta, -beta], [-beta, beta]]``, a stop on x, gap 1."""
    b = params.beta
    return Structure(
        mass=np.diag([1.0, params.delta]),
        stiffness=np.array([[1.0 + b, -b], [-b, b]]),
        stops=(Stop(dof=0, gap=1.0, stiffness=params.alpha, eta=params.eta),),
    )
