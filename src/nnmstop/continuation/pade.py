r"""Padé approximants of an ANM power series, with a common denominator.

The series ``U(a) = U_0 + sum_{i=1..N} a^i U_i`` converges only up to the nearest
singularity of the branch; its rational representation (Cochelin, Damil & Potier-Ferry
1994) reaches further with the same vectors. The terms are orthogonalized by a QR
factorization, one denominator ``D_{m-1}`` makes ``U_m + d_1 U_{m-1} + ...`` orthogonal to
the earlier directions, and ``P_m(a) = U_0 + sum_i a^i D_{m-1-i}(a) / D_{m-1}(a) U_i``
(:class:`PadeApproximant`, built by :func:`pade_pair` for orders ``N`` and ``N - 1``).
:func:`pade_step_length` takes the step as far as the two approximants agree to the
tolerance relative to the step, before the first positive real pole of their
denominators. Everything runs in the parameter scaled by the series' own step length.
Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PadeApproximant", "pade_pair", "pade_step_length"]


class PadeApproximant:
    """Padé approximant ``P_m`` of a series, built from ``U_1 .. U_m``.

    Parameters
    ----------
    U0 : ndarray
        Constant term.
    terms : ndarray
        Shape ``(m - 1, n)``: the scaled terms ``s_i = a_s^i U_i``, ``i = 1 .. m - 1``.
    d : ndarray
        Denominator coefficients ``d_0 = 1, d_1, .., d_{m-1}`` in the scaled parameter.
    scale : float
        ``a_s``.
    """

    def __init__(self, U0, terms, d, scale: float):
        self.U0 = np.asarray(U0, dtype=float)
        self.terms = np.asarray(terms, dtype=float)
        self.d = np.asarray(d, dtype=float)
        self.scale = float(scale)
        self.order = len(self.d)

    def _weights(self, s, derivative: bool = False):
        """``c_i(s) = s^i D_{m-1-i}(s) / D_{m-1}(s)``, ``i = 1 .. m-1`` (or ``dc_i/ds``).

        ``s`` may be a scalar (result shape ``(m-1,)``) or a 1-D array (``(len(s), m-1)``).
        """
        m = self.order
        s_arr = np.atleast_1d(np.asarray(s, dtype=float))[:, None]
        j = np.arange(m)
        powers = s_arr**j
        partial = np.cumsum(self.d * powers, axis=1)  # D_0(s) .. D_{m-1}(s)
        i = np.arange(1, m)
        den = partial[:, -1:]
        numer = powers[:, i] * partial[:, m - 1 - i]
        if not derivative:
            out = numer / den
        else:
            dpowers = np.zeros_like(powers)
            dpowers[:, 1:] = j[1:] * s_arr ** (j[1:] - 1)
            dpartial = np.cumsum(self.d * dpowers, axis=1)
            dnumer = dpowers[:, i] * partial[:, m - 1 - i] + powers[:, i] * dpartial[:, m - 1 - i]
            out = (dnumer * den - numer * dpartial[:, -1:]) / den**2
        return out[0] if np.ndim(s) == 0 else out

    def __call__(self, a: float, derivative: bool = False):
        """``P_m(a)``, or ``dP_m/da`` with ``derivative=True``."""
        c = self._weights(a / self.scale, derivative)
        if derivative:
            return (c @ self.terms) / self.scale
        return self.U0 + c @ self.terms

    def denominator(self, a):
        """``D_{m-1}(a)``."""
        return np.polynomial.polynomial.polyval(np.asarray(a, dtype=float) / self.scale, self.d)

    def poles(self) -> np.ndarray:
        """Real roots of ``D_{m-1}`` (sorted, in the path parameter ``a``)."""
        coefficients = np.trim_zeros(self.d, "b")
        if len(coefficients) < 2:
            return np.empty(0)
        roots = np.polynomial.polynomial.polyroots(coefficients)
        real = roots[np.abs(roots.imag) <= 1e-10 * np.maximum(np.abs(roots), 1.0)].real
        return np.sort(real) * self.scale

    def first_positive_pole(self) -> float:
        """Smallest positive real root of the denominator (``inf`` when there is none)."""
        poles = self.poles()
        positive = poles[poles > 0]
        return float(positive[0]) if len(positive) else np.inf


def _denominator(R: np.ndarray, m: int) -> np.ndarray:
    """``d_0 = 1, d_1 .. d_{m-1}`` from the triangular factor of the QR of ``[U_1 .. U_N]``.

    ``R[k - 1, i - 1] = alpha_{ik}``; the equations are the vanishing of the component of
    ``U_m + sum_j d_j U_{m-j}`` on ``u*_{m-j}``, ``j = 1 .. m - 1``, solved in that order.
    """
    d = np.zeros(m)
    d[0] = 1.0
    for j in range(1, m):
        k = m - j  # component on u*_k
        # alpha_{m,k} + sum_{l<j} d_l alpha_{m-l,k}, with alpha_{i,k} = R[k-1, i-1]
        acc = R[k - 1, m - 1] + d[1:j] @ R[k - 1, m - 2 : k - 1 : -1]
        d[j] = -acc / R[k - 1, k - 1]
    return d


def pade_pair(series: np.ndarray, scale: float, rcond: float = 1e-13):
    """Padé approximants of orders ``N`` and ``N - 1`` of ``series`` (rows ``U_0 .. U_N``).

    Returns ``(P_N, P_{N-1})``, or ``None`` when one of the terms ``U_1 .. U_{N-1}``
    lies in the span of the previous ones to ``rcond`` (relative to its own norm):
    the Padé construction is then undefined.
    """
    series = np.asarray(series, dtype=float)
    N = len(series) - 1
    if N < 3 or series.shape[1] < N - 1 or not (np.isfinite(scale) and scale > 0):
        return None  # (N - 1 independent terms need as many dimensions)
    scaled = series[1:] * (scale ** np.arange(1, N + 1))[:, None]
    R = np.linalg.qr(scaled.T, mode="r")
    # the part of U_k that is new with respect to U_1 .. U_{k-1}, relative to U_k
    newness = np.abs(np.diag(R))[: N - 1] / np.maximum(np.linalg.norm(scaled[: N - 1], axis=1), 1e-300)
    if not np.all(np.isfinite(R)) or newness.min() <= rcond:
        return None
    U0 = series[0]
    approximants = []
    for m in (N, N - 1):
        d = _denominator(R, m)
        approximants.append(PadeApproximant(U0, scaled[: m - 1], d, scale))
    return tuple(approximants)


def pade_step_length(
    high: PadeApproximant,
    low: PadeApproximant,
    tolerance: float,
    a_start: float,
    max_factor: float = 50.0,
    pole_margin: float = 0.99,
    coarse: int = 32,
    fine: int = 24,
) -> float:
    """Largest ``a >= a_start`` with ``||P_N(a) - P_{N-1}(a)|| <= tolerance ||P_N(a) - U_0||``.

    ``low`` must be built from the leading terms of ``high`` (as :func:`pade_pair` does).
    The ratio is evaluated at once on ``coarse`` geometrically spaced values from
    ``a_start`` to ``min(max_factor * a_start, pole_margin * first positive pole)``
    (poles of either denominator); the interval between the last value meeting the
    criterion and the first one failing it is then refined on ``fine`` equally spaced
    values. Returns ``a_start`` when the criterion fails there already (the caller
    then keeps the series).
    """
    limit = min(max_factor * a_start, pole_margin * high.first_positive_pole(), pole_margin * low.first_positive_pole())
    if not limit > a_start:
        return a_start

    def first_failure(a_values):
        s = a_values / high.scale
        w_high = high._weights(s)
        w_gap = w_high.copy()
        w_gap[:, : low.order - 1] -= low._weights(s)
        step = np.linalg.norm(w_high @ high.terms, axis=1)
        gap = np.linalg.norm(w_gap @ high.terms, axis=1)
        ok = np.isfinite(step) & np.isfinite(gap) & (gap <= tolerance * step)
        failing = np.flatnonzero(~ok)
        return int(failing[0]) if len(failing) else len(a_values)

    grid = a_start * (limit / a_start) ** np.linspace(0.0, 1.0, coarse)
    k = first_failure(grid)
    if k == 0:
        return a_start
    if k == len(grid):
        return float(grid[-1])
    refined = np.linspace(grid[k - 1], grid[k], fine + 2)[1:-1]
    j = first_failure(refined)
    return float(refined[j - 1]) if j > 0 else float(grid[k - 1])
