r"""Truncated Fourier series in the phase ``theta``: the one owner of the coefficient layouts.

A field ``x(theta) = x_0 + sum_{k=1..H} x_c^k cos(k theta) + x_s^k sin(k theta)`` is stored in
one of three layouts, all on the last axis of an array:

* **full**: ``[x_0, x_c^1..x_c^H, x_s^1..x_s^H]`` (length ``2H + 1``), the harmonic-balance layout;
* **cosine** (kept basis of time-reversal symmetric orbits): ``[x_0, x_c^1..x_c^H]`` (length
  ``H + 1``), the full layout with the sines left out;
* **cos/sin pair** (the datasets' ``<field>_cos``/``<field>_sin`` over ``harmonic = 0..H``):
  ``cos = [x_0, x_c^1..x_c^H]``, ``sin = [0, x_s^1..x_s^H]``.

Synthesis is on a uniform grid of one period (inverse real FFT, :func:`to_time`), or at given
phases (:class:`PhaseSynthesis`, :func:`fields_at_phases`); :func:`to_coefficients` is the
Galerkin projection of uniform samples onto the first ``H`` harmonics, exact for a series of
at most ``H`` harmonics sampled at ``2H + 1`` or more phases.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = [
    "BASES",
    "coefficient_count",
    "to_full",
    "derivative",
    "second_derivative_factors",
    "to_time",
    "to_coefficients",
    "synthesis_matrix",
    "multiplication_matrix",
    "product_matrix",
    "product_matrix_of_spectrum",
    "complex_amplitudes",
    "to_cos_sin",
    "from_cos_sin",
    "PhaseSynthesis",
    "fields_at_phases",
]

#: Kept bases: ``"cosine"`` (``H + 1`` coefficients) or ``"full"`` (``2H + 1``).
BASES = ("cosine", "full")


def _check_harmonics(harmonics) -> int:
    if not isinstance(harmonics, (int, np.integer)) or isinstance(harmonics, bool) or harmonics < 1:
        raise ValueError(f"harmonics must be an integer >= 1, got {harmonics!r}")
    return int(harmonics)


def coefficient_count(harmonics: int, basis: str = "full") -> int:
    """Number of coefficients of one field: ``2H + 1`` (full) or ``H + 1`` (cosine)."""
    H = _check_harmonics(harmonics)
    if basis not in BASES:
        raise ValueError(f"basis must be one of {BASES}, got {basis!r}")
    return 2 * H + 1 if basis == "full" else H + 1


def to_full(c, harmonics: int) -> np.ndarray:
    """Coefficients (last axis) in the full layout; cosine-layout input gets zero sines."""
    c = np.asarray(c, dtype=float)
    H = _check_harmonics(harmonics)
    if c.shape[-1] == 2 * H + 1:
        return c
    if c.shape[-1] != H + 1:
        raise ValueError(
            f"coefficients must have H+1 = {H + 1} (cosine) or 2H+1 = {2 * H + 1} (full) entries "
            f"on their last axis, got {c.shape[-1]}"
        )
    out = np.zeros(c.shape[:-1] + (2 * H + 1,))
    out[..., : H + 1] = c
    return out


def derivative(c, harmonics: int) -> np.ndarray:
    """``d/dtheta`` of coefficient vectors (last axis), in the full layout.

    ``(x_c^k, x_s^k) -> (k x_s^k, -k x_c^k)``; the mean drops.
    """
    c = to_full(c, harmonics)
    H = int(harmonics)
    k = np.arange(1, H + 1, dtype=float)
    out = np.empty_like(c)
    out[..., 0] = 0.0
    out[..., 1 : H + 1] = k * c[..., H + 1 :]
    out[..., H + 1 :] = -k * c[..., 1 : H + 1]
    return out


def second_derivative_factors(harmonics: int, basis: str = "full") -> np.ndarray:
    """Diagonal of ``d^2/dtheta^2`` in a kept basis: ``[0, -1, .., -H^2(, -1, .., -H^2)]``."""
    n = coefficient_count(harmonics, basis)
    k = np.arange(1, int(harmonics) + 1, dtype=float)
    return -(np.concatenate([[0.0], k, k])[:n] ** 2)


def to_time(c, harmonics: int, samples: int) -> np.ndarray:
    """Values on ``samples`` equispaced phases ``theta_j = 2 pi j / samples`` of one period.

    ``c`` holds cosine- or full-layout coefficients on its last axis; ``samples >= 2H + 1``.
    """
    c = np.asarray(c, dtype=float)
    H = _check_harmonics(harmonics)
    m = int(samples)
    if c.shape[-1] not in (H + 1, 2 * H + 1):
        to_full(c, H)  # the error names the allowed lengths
    if m < 2 * H + 1:
        raise ValueError(f"samples must be >= 2H+1 = {2 * H + 1}, got {samples!r}")
    spec = np.zeros(c.shape[:-1] + (m // 2 + 1,), dtype=complex)
    spec.real[..., 0] = c[..., 0] * m
    spec.real[..., 1 : H + 1] = (0.5 * m) * c[..., 1 : H + 1]
    if c.shape[-1] == 2 * H + 1:  # (the cosine layout has no sines)
        spec.imag[..., 1 : H + 1] = (-0.5 * m) * c[..., H + 1 :]
    return np.fft.irfft(spec, n=m, axis=-1)


def to_coefficients(samples, harmonics: int) -> np.ndarray:
    """Full-layout coefficients of the first ``H`` harmonics of uniform samples (last axis).

    The samples are at ``theta_j = 2 pi j / m`` over one period, ``m >= 2H + 1`` (then a
    series of at most ``H`` harmonics is recovered exactly: the inverse of :func:`to_time`).
    """
    samples = np.asarray(samples, dtype=float)
    H = _check_harmonics(harmonics)
    m = samples.shape[-1]
    if m < 2 * H + 1:
        raise ValueError(f"need at least 2H+1 = {2 * H + 1} samples per period, got {m}")
    spec = np.fft.rfft(samples, axis=-1)
    out = np.empty(samples.shape[:-1] + (2 * H + 1,))
    out[..., 0] = spec[..., 0].real / m
    out[..., 1 : H + 1] = 2.0 * spec[..., 1 : H + 1].real / m
    out[..., H + 1 :] = -2.0 * spec[..., 1 : H + 1].imag / m
    return out


def synthesis_matrix(harmonics: int, samples: int, basis: str = "full") -> np.ndarray:
    """Matrix ``E`` with ``values = E @ coefficients`` on ``samples`` equispaced phases.

    Shape ``(samples, coefficient_count(harmonics, basis))``; columns ``1, cos(k theta)``
    and, in the full basis, ``sin(k theta)``.
    """
    coefficient_count(harmonics, basis)
    theta = 2 * np.pi * np.arange(int(samples)) / int(samples)
    kt = np.outer(theta, np.arange(1, int(harmonics) + 1, dtype=float))
    blocks = [np.ones((int(samples), 1)), np.cos(kt)] + ([np.sin(kt)] if basis == "full" else [])
    return np.hstack(blocks)


def to_cos_sin(c, harmonics: int) -> tuple[np.ndarray, np.ndarray]:
    """The cos/sin pair over harmonics ``0..H`` of cosine- or full-layout coefficients."""
    full = to_full(c, harmonics)
    H = int(harmonics)
    sin = np.concatenate([np.zeros(full.shape[:-1] + (1,)), full[..., H + 1 :]], axis=-1)
    return full[..., : H + 1], sin


def from_cos_sin(cos, sin) -> np.ndarray:
    """Full-layout coefficients of a cos/sin pair over harmonics ``0..H`` (``sin[..., 0]`` is ignored)."""
    cos, sin = np.asarray(cos, dtype=float), np.asarray(sin, dtype=float)
    if cos.shape != sin.shape or cos.shape[-1] < 2:
        raise ValueError(f"cos and sin must have the same shape with >= 2 harmonics, got {cos.shape} and {sin.shape}")
    return np.concatenate([cos, sin[..., 1:]], axis=-1)


class PhaseSynthesis:
    """Series of cos/sin pairs over harmonics ``0..H`` evaluated at given phases.

    Parameters
    ----------
    theta : array_like, shape (n,)
        Phases in radians (``omega t``).
    harmonics : int
        ``H``.

    Examples
    --------
    >>> import numpy as np
    >>> at = PhaseSynthesis([0.0, np.pi / 2], harmonics=1)
    >>> at.values([1.0, 2.0], [0.0, 3.0]).round(12)  # 1 + 2 cos(theta) + 3 sin(theta)
    array([3., 4.])
    """

    def __init__(self, theta, harmonics: int):
        self.k = np.arange(_check_harmonics(harmonics) + 1)
        arguments = np.outer(np.asarray(theta, dtype=float), self.k)
        self.cos, self.sin = np.cos(arguments), np.sin(arguments)

    def values(self, cos, sin) -> np.ndarray:
        """The series at the phases."""
        return self.cos @ cos + self.sin @ sin

    def theta_derivative(self, cos, sin) -> np.ndarray:
        """``d/dtheta`` of the series at the phases."""
        cos, sin = np.asarray(cos), np.asarray(sin)
        return self.cos @ (self.k * sin) - self.sin @ (self.k * cos)


def fields_at_phases(theta, omega: float, series: dict, velocities=("x", "u"), synthesis=None) -> dict:
    """Several fields of one orbit at the phases ``theta = omega t``.

    ``series`` maps each field name to its cos/sin pair over harmonics ``0..H``; the result
    has each field and, for the names in ``velocities``, its time derivative ``<name>dot``
    (``omega d/dtheta``). ``synthesis``: ``PhaseSynthesis(theta, H)`` when the caller keeps it
    (it depends only on the phases and ``H``; several orbits on the same phases share it).
    """
    pairs = {name: (np.asarray(c), np.asarray(s)) for name, (c, s) in series.items()}
    harmonics = {c.shape[-1] - 1 for c, _ in pairs.values()}
    if len(harmonics) != 1:
        raise ValueError(f"all fields must have the same number of harmonics, got {sorted(harmonics)}")
    H = harmonics.pop()
    if synthesis is None:
        at = PhaseSynthesis(theta, H)
    elif synthesis.cos.shape != (np.size(theta), H + 1):
        raise ValueError(
            f"the synthesis is for {synthesis.cos.shape[0]} phases and {synthesis.cos.shape[1] - 1} harmonics, "
            f"the fields have {np.size(theta)} phases and {H} harmonics"
        )
    else:
        at = synthesis
    out = {}
    for name, (c, s) in pairs.items():
        out[name] = at.values(c, s)
        if name in velocities:
            out[name + "dot"] = omega * at.theta_derivative(c, s)
    return out


def multiplication_matrix(a_samples, harmonics: int, even: bool = False, halfwave: bool = False) -> np.ndarray:
    """Galerkin matrix of ``w -> [a w]`` on the full layout with ``harmonics`` harmonics, for uniform samples of ``a``.

    Built from the complex Fourier coefficients ``a_n`` (``|n| <= 2 H``) of the samples
    (:func:`product_matrix_of_spectrum`). ``even`` drops the (round-off) odd part of ``a`` in time, so that
    the matrix keeps the cosine/sine parity exactly; ``halfwave`` drops its (round-off) odd harmonics, so
    that it keeps the parity of the harmonic numbers.
    """
    spec = np.fft.fft(a_samples) / a_samples.shape[-1]
    if even:
        spec = spec.real.astype(complex)
    if halfwave:
        spec[1::2] = 0.0
    return product_matrix_of_spectrum(spec, harmonics)


def product_matrix(c, harmonics: int) -> np.ndarray:
    """Galerkin matrix of ``w -> [c w]`` (full layout, ``2H + 1`` square) for a series ``c`` of ``H`` harmonics.

    ``c`` holds cosine- or full-layout coefficients. The product of two series of ``H`` harmonics has
    ``2H``; the matrix keeps its first ``H`` exactly (no sampling, no aliasing): the same numbers as
    projecting the product of their samples on ``M > 3H`` phases, to round-off.

    Examples
    --------
    >>> c = np.array([0.5, 1.0, 0.0])  # 0.5 + cos(theta), cosine layout, H = 2
    >>> w = np.array([0.0, 0.0, 0.0, 0.0, 2.0])  # 2 sin(2 theta), full layout
    >>> product_matrix(c, 2) @ w  # sin(theta) + sin(2 theta) (+ sin(3 theta), beyond H)
    array([0., 0., 0., 1., 1.])
    """
    H = int(harmonics)
    amplitudes = complex_amplitudes(to_full(c, H), H)  # a_n, n = -H..H
    spec = np.zeros(4 * H + 1, dtype=complex)  # a_n at index n mod (4H + 1), |n| <= 2H
    spec[: H + 1], spec[-H:] = amplitudes[H:], amplitudes[:H]
    return product_matrix_of_spectrum(spec, H)


@functools.lru_cache(maxsize=8)
def _sum_and_difference_indices(H: int, n: int):
    k = np.arange(H + 1)
    return (k[:, None] + k[None, :]) % n, (k[:, None] - k[None, :]) % n


def product_matrix_of_spectrum(spec, harmonics: int) -> np.ndarray:
    """Galerkin matrix of ``w -> [a w]`` (full layout) from the complex coefficients of ``a``.

    ``spec[n mod len(spec)]`` is the coefficient ``a_n`` of ``exp(i n theta)`` of a real ``a``, for every
    ``|n| <= 2H`` (``len(spec) >= 4H + 1``, or an FFT of more samples). Harmonics ``m`` and ``j`` of the
    product and of ``w`` couple through ``a_{m+j}`` and ``a_{m-j}`` only (Toeplitz plus Hankel): with
    ``P = a_{m+j}``, ``D = a_{m-j}`` (``m, j = 0..H``), the cosine-cosine block is ``Re D + Re P``, sine-cosine
    ``-(Im D + Im P)``, cosine-sine ``Im D - Im P`` and sine-sine ``Re D - Re P``, the mean's row halved.
    """
    H = int(harmonics)
    spec = np.asarray(spec)
    if len(spec) < 4 * H + 1:
        raise ValueError(f"need the coefficients a_n for |n| <= 2H = {2 * H}, got {len(spec)} entries")
    plus_index, minus_index = _sum_and_difference_indices(H, len(spec))
    plus, minus = spec[plus_index], spec[minus_index]
    out = np.empty((2 * H + 1, 2 * H + 1))
    cos, sin = slice(0, H + 1), slice(H + 1, 2 * H + 1)
    out[cos, cos] = minus.real + plus.real
    out[sin, cos] = -(minus.imag[1:] + plus.imag[1:])
    out[cos, sin] = minus.imag[:, 1:] - plus.imag[:, 1:]
    out[sin, sin] = minus.real[1:, 1:] - plus.real[1:, 1:]
    out[0] *= 0.5
    return out


def complex_amplitudes(P, H: int) -> np.ndarray:
    """Complex harmonic amplitudes (``k = -H..H``) of full-layout coefficients (last axis)."""
    c0 = P[..., :1]
    c = P[..., 1 : H + 1]
    s = P[..., H + 1 :]
    pos = 0.5 * (c - 1j * s)
    neg = 0.5 * (c + 1j * s)
    return np.concatenate([neg[..., ::-1], c0, pos], axis=-1)
