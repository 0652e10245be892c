"""Fixtures of the atlas tests: the paper's oscillator, damping ratio 0.01 on both modes, force on u."""

import numpy as np
import pytest

from nnmstop.models.excitation import Damping, Excitation, HarmonicForce
from nnmstop.models.structure import two_dof_structure
from nnmstop.models.two_dof import ModelParameters


def oscillator(force: float = 0.1, zeta: float = 0.01, alpha: float = 30.0, eta: float = 0.1) -> Excitation:
    structure = two_dof_structure(ModelParameters(alpha=alpha, eta=eta))
    return Excitation(structure, Damping.from_modal_ratios(structure, [zeta, zeta]), HarmonicForce(force, [1]))


WINDOW_HZ = (0.05, 0.35)


@pytest.fixture(scope="session")
def response_at():
    """The exact one-parameter response of the oscillator at a force (cached per force): its pieces."""
    from nnmstop.forced.responses import exact_response

    cache = {}

    def pieces(force: float, zeta: float = 0.01, window=WINDOW_HZ):
        key = (force, zeta, window)
        if key not in cache:
            cache[key] = exact_response(oscillator(force, zeta), window)
        return cache[key]

    return pieces


def located(pieces, kind: str) -> list:
    """The located changes of ``kind`` of an exact response: ``(unknowns, omega)``."""
    return [(c.U, float(c.U[-1])) for p in pieces for c in p.changes if c.kind == kind]


def frequencies_hz(points) -> np.ndarray:
    return np.sort([omega / (2 * np.pi) for _, omega in points])


def partial_difference(function, point, k: int, h=1e-6):
    """The derivative of ``function`` in ``point[k]`` by a central difference (relative step ``h``)."""
    point = np.asarray(point, dtype=float)
    step = h * max(1.0, abs(point[k]))
    up, down = point.copy(), point.copy()
    up[k] += step
    down[k] -= step
    return (function(up) - function(down)) / (2 * step)


def central_differences(function, point, h=1e-6) -> np.ndarray:
    """The Jacobian of ``function`` at ``point`` by central differences (relative steps ``h``), columns last."""
    return np.stack([partial_difference(function, point, k, h) for k in range(len(point))], axis=-1)
