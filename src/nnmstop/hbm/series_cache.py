"""Time samples of the stop fields of the terms of one ANM series, for the series products.

:meth:`nnmstop.hbm.system.HarmonicBalanceSystem.series_products` sums the quadratic terms
``f z`` and ``g g`` (``g = f/alpha - x``) of every stop component over the orders of one Asymptotic
Numerical Method series; this cache holds each term's samples on the system's ``M`` phases so that
every term is transformed to the time domain once per series.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from nnmstop.hbm.system import HarmonicBalanceSystem

__all__ = ["SeriesCache"]


class SeriesCache:
    """Time samples of ``f``, ``z`` and ``g = f/alpha - x`` of every stop component for the terms of one ANM series.

    Preallocated for the terms ``U_0 .. U_order`` and filled in order as
    :meth:`HarmonicBalanceSystem.series_products` needs them, so that each term is
    transformed to the time domain once per series and the sums over the orders read
    slices of one array.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    order : int
        Highest order ``N`` of the series.
    """

    def __init__(self, system: HarmonicBalanceSystem, order: int):
        self.system = system
        m = system.n_components
        # samples[r] holds f, g, z, g of every stop component (m channels each; z of its stop) of term r on
        # the M phases: channels 0:2m and 2m:4m are the left and right factors of f z and g g
        self.samples = np.empty((order + 1, 4 * m, system.M))
        self.products = np.empty((2 * m, system.M))
        self.filled = 1  # U_0 never enters the products

    def fill(self, series, p: int):
        """Transform the terms ``filled .. p - 1`` of ``series`` (rows or list items)."""
        if p > self.samples.shape[0]:
            raise ValueError(f"cache holds orders up to {self.samples.shape[0] - 1}, order {p - 1} requested")
        if self.filled >= p:
            return
        system = self.system
        N, s, m, nc = system.n_dofs, system.n_stops, system.n_components, system.nc
        terms = np.asarray(series[self.filled : p], dtype=float)
        f = terms[:, N * nc : (N + m) * nc].reshape(-1, m, nc)
        x = np.moveaxis(system.stop_coordinates(np.moveaxis(terms[:, : N * nc].reshape(-1, N, nc), 1, 0)), 0, 1)
        g = f / system._component_alphas[:, None] - x
        z = terms[:, (N + m) * nc : (N + m + s) * nc].reshape(-1, s, nc)
        if not system._bilateral:
            z = z[:, system.contact.owner]
        fields = np.concatenate([f, g, z], axis=1)
        block = self.samples[self.filled : p]
        block[:, : 3 * m] = system.to_time(fields)
        block[:, 3 * m :] = block[:, m : 2 * m]
        self.filled = p
