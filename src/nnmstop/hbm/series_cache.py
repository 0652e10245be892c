"""Time samples of the stop fields of the terms of one ANM series, for the series products.

:meth:`nnmstop.hbm.system.HarmonicBalanceSystem.series_products` sums the quadratic terms
``f z`` and ``g g`` (``g = f/alpha - x``) over the orders of one Asymptotic Numerical Method
series; this cache holds each term's samples on the system's ``M`` phases so that every term is
transformed to the time domain once per series.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from nnmstop.hbm.system import HarmonicBalanceSystem

__all__ = ["SeriesCache"]


class SeriesCache:
    """Time samples of ``f``, ``z`` and ``g = f/alpha - x`` of every stop for the terms of one ANM series.

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
        s = system.n_stops
        # samples[r] holds f, g, z, g of every stop (s channels each) of term r on the M
        # phases: channels 0:2s and 2s:4s are the left and right factors of f z and g g
        self.samples = np.empty((order + 1, 4 * s, system.M))
        self.products = np.empty((2 * s, system.M))
        self.filled = 1  # U_0 never enters the products

    def fill(self, series, p: int):
        """Transform the terms ``filled .. p - 1`` of ``series`` (rows or list items)."""
        if p > self.samples.shape[0]:
            raise ValueError(f"cache holds orders up to {self.samples.shape[0] - 1}, order {p - 1} requested")
        if self.filled >= p:
            return
        system = self.system
        N, s, nc = system.n_dofs, system.n_stops, system.nc
        terms = np.asarray(series[self.filled : p], dtype=float)
        f = terms[:, N * nc : (N + s) * nc].reshape(-1, s, nc)
        x = terms[:, : N * nc].reshape(-1, N, nc)[:, system.stop_dofs] / system.gaps[:, None]
        g = f / system.alphas[:, None] - x
        fields = np.concatenate([f, g, terms[:, (N + s) * nc : (N + 2 * s) * nc].reshape(-1, s, nc)], axis=1)
        block = self.samples[self.filled : p]
        block[:, : 3 * s] = system.to_time(fields)
        block[:, 3 * s :] = block[:, s : 2 * s]
        self.filled = p
