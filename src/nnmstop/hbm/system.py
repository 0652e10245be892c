r"""Harmonic balance formulation of the regularized NNMs (Section 3.2).

The quadratic recast, Eq. (12), of the regularized equations (7)::

    x'' + x + beta (x - u) + f  = 0
    delta u'' + beta (u - x)    = 0
    f - eta x - f z             = 0              (11a)
    z - (f/alpha - x)**2        = 0              (11b)

Every field is a truncated Fourier series in the phase ``theta = omega tau``, Eq. (13)::

    x(theta) = x_0 + sum_{k=1..H} x_c^k cos(k theta) + x_s^k sin(k theta)

stored as the coefficient vector ``[x_0, x_c^1..x_c^H, x_s^1..x_s^H]`` (length
``2H + 1``). With ``D`` the derivative in ``theta`` acting on such vectors
(``(x_c^k, x_s^k) -> (k x_s^k, -k x_c^k)``), time derivatives are
``x' = omega D x`` and ``x'' = omega**2 D**2 x``.

Unknowns ``U = (x, u, f, z, lam, nu)`` with ``lam = omega**2`` (so that the inertia
terms are quadratic, as the ANM needs) and ``nu`` the coefficient of an unfolding
term. The balanced equations ``S(U) = L(U) + Q(U, U) = 0`` are::

    lam D^2 x + (1 + beta) x - beta u + f + nu D x            = 0   (2H+1 rows)
    delta lam D^2 u + beta (u - x) + delta nu D u              = 0   (2H+1 rows)
    f - eta x - [f z]                                          = 0   (2H+1 rows)
    z - [g g],   g = f/alpha - x                               = 0   (2H+1 rows)
    sum_k k x_s^k                                              = 0   (phase: x'(0) = 0)

``[a b]`` is the Galerkin projection of a product onto the first ``H`` harmonics,
computed exactly (no aliasing) with ``M > 3H`` samples per period.

Why the two extra devices. Periodic orbits of an autonomous system come with a free
phase: the phase condition ``x'(0) = 0`` removes it. Periodic orbits of a
conservative system come in one-parameter families at fixed frequency parameters, so
the balanced equations alone are one equation short of a well-posed curve with the
frequency unknown: the unfolding term ``nu D`` is the fictitious damping
``mu M q'`` with ``nu = mu omega``. Multiplying the equations of motion by ``q'`` and
averaging over a period gives ``mu <x'^2 + delta u'^2> = 0``, so ``nu = 0`` on every
periodic orbit; the continuation checks that ``nu`` stays at round-off.

The linear tangent operator and the bilinear form used by the ANM are
:meth:`HarmonicBalanceSystem.jacobian` and
:meth:`HarmonicBalanceSystem.series_products`.
"""

from __future__ import annotations

import numpy as np

from nnmstop.models.two_dof import ModelParameters, regularized_force_and_potential, total_energy

__all__ = ["HarmonicBalanceSystem", "SeriesCache"]


class HarmonicBalanceSystem:
    """Balanced algebraic system of the regularized NNMs with ``H`` harmonics.

    Parameters
    ----------
    params : ModelParameters
    harmonics : int
        Number of harmonics ``H`` (>= 1).
    time_samples : int, optional
        Samples per period for products; 0 (default) picks the smallest power of two
        above ``3H``, which makes every product alias-free.

    Examples
    --------
    >>> from nnmstop.models.two_dof import ModelParameters
    >>> system = HarmonicBalanceSystem(ModelParameters(), harmonics=5, basis="full")
    >>> system.n_unknowns, system.n_equations
    (46, 45)
    >>> HarmonicBalanceSystem(ModelParameters(), harmonics=5).n_unknowns  # cosine basis
    25
    """

    FIELDS = ("x", "u", "f", "z")
    BASES = ("cosine", "full")

    def __init__(self, params: ModelParameters, harmonics: int, time_samples: int = 0, basis: str = "cosine"):
        if not isinstance(harmonics, (int, np.integer)) or isinstance(harmonics, bool) or harmonics < 1:
            raise ValueError(f"harmonics must be an integer >= 1, got {harmonics!r}")
        if basis not in self.BASES:
            raise ValueError(f"basis must be one of {self.BASES}, got {basis!r}")
        minimum_samples = 3 * harmonics + 1
        if time_samples == 0:
            time_samples = int(2 ** np.ceil(np.log2(minimum_samples)))
        if time_samples < minimum_samples:
            raise ValueError(
                f"time_samples must be 0 (automatic) or >= 3H+1 = {minimum_samples} for alias-free "
                f"products, got {time_samples!r}"
            )
        self.params = params
        self.basis = basis
        self.H = int(harmonics)
        self.M = int(time_samples)
        self.nfull = 2 * self.H + 1
        self.full = basis == "full"
        # Coefficients kept per field: all of [x_0, x_c^1..x_c^H, x_s^1..x_s^H], or the
        # cosine part only (orbits symmetric under time reversal, x(-t) = x(t)).
        self.nc = self.nfull if self.full else self.H + 1
        self.k = np.arange(1, self.H + 1, dtype=float)
        nc = self.nc
        self.slices = {name: slice(i * nc, (i + 1) * nc) for i, name in enumerate(self.FIELDS)}
        self.i_lam = 4 * nc
        # The unfolding term and the phase condition exist only in the full basis: in the
        # cosine basis the phase is fixed by the symmetry and nu D x (a sine series) has
        # no component on the balanced cosine equations.
        self.i_nu = 4 * nc + 1 if self.full else None
        self.n_unknowns = 4 * nc + (2 if self.full else 1)
        self.n_equations = 4 * nc + (1 if self.full else 0)
        theta = 2 * np.pi * np.arange(self.M) / self.M
        kt = np.outer(theta, self.k)
        # Synthesis matrix of the kept coefficients: time samples = E @ coefficients.
        blocks = [np.ones((self.M, 1)), np.cos(kt)] + ([np.sin(kt)] if self.full else [])
        self.synthesis = np.hstack(blocks)
        self._d2 = -np.concatenate([[0.0], self.k, self.k])[: self.nc] ** 2
        # ANM products (SeriesCache): transforms as small matrix products, cheaper than
        # the FFT calls at this size once their set-up is counted (same values to ~1e-15)
        self._synthesis_t = np.ascontiguousarray(self.synthesis.T)
        weights = np.full(self.nc, 2.0 / self.M)
        weights[0] = 1.0 / self.M
        self._projection = self.synthesis * weights

    # ------------------------------------------------------------------ Fourier helpers

    def to_full(self, c):
        """Coefficients in the full layout ``[c_0, c_c^1..c_c^H, c_s^1..c_s^H]``."""
        c = np.asarray(c, dtype=float)
        if c.shape[-1] == self.nfull:
            return c
        out = np.zeros(c.shape[:-1] + (self.nfull,))
        out[..., : self.nc] = c
        return out

    def second_derivative(self, c):
        """``d^2/dtheta^2`` of kept-basis coefficient vectors (last axis)."""
        return np.asarray(c, dtype=float) * self._d2

    def derivative(self, c):
        """``d/dtheta`` of coefficient vectors, returned in the full layout."""
        c = self.to_full(c)
        H = self.H
        out = np.empty_like(c)
        out[..., 0] = 0.0
        out[..., 1 : H + 1] = self.k * c[..., H + 1 :]
        out[..., H + 1 :] = -self.k * c[..., 1 : H + 1]
        return out

    def to_time(self, c, samples: int | None = None):
        """Time samples on ``samples`` (default ``M``) equispaced phases of one period.

        ``c`` holds kept-basis or full-layout coefficients on its last axis.
        """
        c = self.to_full(c)
        m = self.M if samples is None else int(samples)
        if m < self.nfull:
            raise ValueError(f"samples must be >= 2H+1 = {self.nfull}, got {m}")
        H = self.H
        spec = np.zeros(c.shape[:-1] + (m // 2 + 1,), dtype=complex)
        spec[..., 0] = c[..., 0] * m
        spec[..., 1 : H + 1] = 0.5 * m * (c[..., 1 : H + 1] - 1j * c[..., H + 1 :])
        return np.fft.irfft(spec, n=m, axis=-1)

    def to_coefficients(self, samples):
        """Galerkin projection of time samples onto the kept basis (first ``H`` harmonics)."""
        samples = np.asarray(samples, dtype=float)
        m = samples.shape[-1]
        spec = np.fft.rfft(samples, axis=-1)
        H = self.H
        out = np.empty(samples.shape[:-1] + (self.nfull,))
        out[..., 0] = spec[..., 0].real / m
        out[..., 1 : H + 1] = 2.0 * spec[..., 1 : H + 1].real / m
        out[..., H + 1 :] = -2.0 * spec[..., 1 : H + 1].imag / m
        return out[..., : self.nc]

    def multiplication_matrix(self, c):
        """Matrix of ``w -> [a w]`` (projected product) for the fixed series ``a = c``."""
        a_t = self.to_time(c)
        # Columns are the projected products of a with each kept basis function.
        return self.to_coefficients((a_t[:, None] * self.synthesis).T).T

    # ------------------------------------------------------------------ unknown vector

    def split(self, U):
        """Views ``(x, u, f, z, lam, nu)`` into an unknown vector (or a stack of them).

        ``nu`` is zero in the cosine basis, which has no unfolding term.
        """
        U = np.asarray(U)
        s = self.slices
        nu = U[..., self.i_nu] if self.full else np.zeros(U.shape[:-1])
        return (U[..., s["x"]], U[..., s["u"]], U[..., s["f"]], U[..., s["z"]], U[..., self.i_lam], nu)

    def pack(self, x, u, f, z, lam, nu=0.0):
        """Assemble an unknown vector from its parts."""
        tail = [lam, nu] if self.full else [lam]
        return np.concatenate([x, u, f, z, tail])

    # ------------------------------------------------------------------ the system

    def residual(self, U):
        """``S(U) = L(U) + Q(U, U)``, length ``n_equations``."""
        p = self.params
        x, u, f, z, lam, nu = self.split(U)
        g = f / p.alpha - x
        f_t, z_t, g_t = self.to_time(np.stack([f, z, g]))
        fz, gg = self.to_coefficients(np.stack([f_t * z_t, g_t * g_t]))
        r_x = lam * self.second_derivative(x) + (1 + p.beta) * x - p.beta * u + f
        r_u = p.delta * lam * self.second_derivative(u) + p.beta * (u - x)
        r_f = f - p.eta * x - fz
        r_z = z - gg
        parts = [r_x, r_u, r_f, r_z]
        if self.full:
            r_x += nu * self.derivative(x)
            r_u += p.delta * nu * self.derivative(u)
            parts.append([np.dot(self.k, x[self.H + 1 :])])
        return np.concatenate(parts)

    def jacobian(self, U):
        """Dense Jacobian ``dS/dU``, shape ``(n_equations, n_unknowns)``."""
        p = self.params
        x, u, f, z, lam, nu = self.split(U)
        nc, s = self.nc, self.slices
        eye = np.eye(nc)
        D2 = np.diag(self._d2)
        g = f / p.alpha - x
        Mz = self.multiplication_matrix(z)
        Mf = self.multiplication_matrix(f)
        Mg = self.multiplication_matrix(g)
        J = np.zeros((self.n_equations, self.n_unknowns))
        rx, ru, rf, rz = (slice(i * nc, (i + 1) * nc) for i in range(4))
        J[rx, s["x"]] = lam * D2 + (1 + p.beta) * eye
        J[rx, s["u"]] = -p.beta * eye
        J[rx, s["f"]] = eye
        J[rx, self.i_lam] = self.second_derivative(x)
        J[ru, s["x"]] = -p.beta * eye
        J[ru, s["u"]] = p.delta * lam * D2 + p.beta * eye
        J[ru, self.i_lam] = p.delta * self.second_derivative(u)
        J[rf, s["x"]] = -p.eta * eye
        J[rf, s["f"]] = eye - Mz
        J[rf, s["z"]] = -Mf
        J[rz, s["x"]] = 2.0 * Mg
        J[rz, s["f"]] = -2.0 / p.alpha * Mg
        J[rz, s["z"]] = eye
        if self.full:
            D1 = self.derivative(eye).T  # column j = D applied to basis vector j
            J[rx, s["x"]] += nu * D1
            J[ru, s["u"]] += p.delta * nu * D1
            J[rx, self.i_nu] = self.derivative(x)
            J[ru, self.i_nu] = p.delta * self.derivative(u)
            J[-1, s["x"].start + self.H + 1 : s["x"].stop] = self.k
        return J

    def series_cache(self, order: int) -> "SeriesCache":
        """Empty :class:`SeriesCache` for the terms ``U_0 .. U_order`` of one ANM series."""
        return SeriesCache(self, order)

    def series_products(self, series, p: int, cache: "SeriesCache | None" = None):
        """``sum_{r=1}^{p-1} Q(U_r, U_{p-r})``: the right-hand side of ANM order ``p``.

        Parameters
        ----------
        series : ndarray or list
            Terms ``U_0, U_1, ...`` (at least ``p``), as the rows of an array (no copy)
            or a list of vectors.
        p : int
            Order of the right-hand side.
        cache : SeriesCache, optional
            Time samples of ``f, z, g`` of the terms already transformed. The ANM
            passes the same cache for the orders ``2 .. N`` of one series, so that each
            term is transformed once; without it every term is transformed here.

        Returns
        -------
        ndarray
            Length ``n_equations``.
        """
        out = np.zeros(self.n_equations)
        if p < 2:
            return out
        series = np.asarray(series, dtype=float)
        if cache is None:
            cache = SeriesCache(self, p - 1)
        cache.fill(series, p)
        nc, delta = self.nc, self.params.delta
        lam = series[1:p, self.i_lam]  # lam_1 .. lam_{p-1}
        right = series[p - 1 : 0 : -1]  # U_{p-1} .. U_1
        # sum_r lam_r D^2 (x, delta u)_{p-r} = D^2 sum_r lam_r (x, delta u)_{p-r}: x and u
        # are adjacent in U, so one product serves both
        xu = lam @ right[:, : 2 * nc]
        np.multiply(xu[:nc], self._d2, out=out[:nc])
        np.multiply(xu[nc:], delta * self._d2, out=out[nc : 2 * nc])
        if self.full:
            nu = series[1:p, self.i_nu]
            nxu = nu @ right[:, : 2 * nc]
            out[:nc] += self.derivative(nxu[:nc])
            out[nc : 2 * nc] += delta * self.derivative(nxu[nc:])
        # channels (f, g | z, g): the two products f z and g g in one sum over the orders
        t = cache.samples
        np.einsum("rkm,rkm->km", t[1:p, :2], t[p - 1 : 0 : -1, 2:], out=cache.products)
        np.matmul(cache.products, self._projection, out=cache.coefficients)
        np.negative(cache.coefficients.ravel(), out=out[2 * nc : 4 * nc])
        return out

    # ------------------------------------------------------------------ starting point

    def linear_mode_guess(self, mode: int, amplitude: float):
        """Unknown vector of linear mode ``mode`` (1 or 2) of the regularized system near rest.

        ``x = amplitude cos(theta)``, ``u`` from the mode shape, ``f = eta x``,
        ``z = (f/alpha - x)**2`` balanced exactly; a Newton correction makes it a
        point of the branch.
        """
        from nnmstop.models.two_dof import linear_modes

        if mode not in (1, 2):
            raise ValueError(f"mode must be 1 or 2, got {mode!r}")
        omega, shapes = linear_modes(self.params, "regularized")
        x = np.zeros(self.nc)
        x[1] = amplitude
        u = shapes[1, mode - 1] * x
        f = self.params.eta * x
        g_t = self.to_time(f / self.params.alpha - x)
        z = self.to_coefficients(g_t * g_t)
        return self.pack(x, u, f, z, omega[mode - 1] ** 2, 0.0)

    # ------------------------------------------------------------------ post-processing

    def frequency_hz(self, U):
        """Frequency ``omega / (2 pi)`` in Hz of the nondimensional time."""
        return np.sqrt(self.split(U)[4]) / (2 * np.pi)

    def time_history(self, U, samples: int = 1024):
        """Samples of one period: dict with ``t, x, u, xdot, udot, f, z``."""
        x, u, f, z, lam, _ = self.split(U)
        omega = np.sqrt(lam)
        fields = np.stack([self.to_full(v) for v in (x, u, f, z)] + [omega * self.derivative(x), omega * self.derivative(u)])
        xs, us, fs, zs, xd, ud = self.to_time(fields, samples)
        t = np.arange(samples) * (2 * np.pi / omega) / samples
        return {"t": t, "x": xs, "u": us, "xdot": xd, "udot": ud, "f": fs, "z": zs}

    def diagnostics(self, U, samples: int | None = None):
        """Physical quantities and error indicators of one HBM orbit.

        Returns a dict with ``energy`` (mean over the period of the total energy of the
        regularized model, contact potential included), ``energy_spread`` (its relative
        variation over the period: zero for an exact orbit), ``frequency``,
        ``time_residual`` (largest residual of the original equations (7) in time, with
        the true root of the cubic for the contact force, relative to the largest
        restoring force), ``force_error`` (largest ``|f_HBM - f(x)|`` relative to
        ``max |f|``), ``impacts_per_period`` and ``truncation`` (share of the mean square
        of ``x''`` and ``f`` carried by the top tenth of the harmonics, the larger one).
        """
        p = self.params
        m = samples or max(16 * self.H, 512)
        h = self.time_history(U, m)
        x, u, f, z, lam, _ = self.split(U)
        f_true, potential = regularized_force_and_potential(h["x"], p)
        energy_t = total_energy(h["x"], h["u"], h["xdot"], h["udot"], p, model="regularized", potential=potential)
        energy = float(np.mean(energy_t))
        xdd = self.to_time(lam * self.second_derivative(x), m)
        restoring = np.abs(h["x"] + p.beta * (h["x"] - h["u"]) + f_true)
        eq_residual = xdd + h["x"] + p.beta * (h["x"] - h["u"]) + f_true
        scale = max(float(np.max(restoring)), 1e-300)
        time_residual = float(np.max(np.abs(eq_residual)) / scale)
        force_error = float(np.max(np.abs(h["f"] - f_true)) / max(float(np.max(np.abs(f_true))), 1e-300))
        return {
            "energy": energy,
            "energy_spread": float((energy_t.max() - energy_t.min()) / energy),
            "frequency": float(self.frequency_hz(U)),
            "time_residual": time_residual,
            "force_error": force_error,
            "impacts_per_period": impacts_per_period(h["x"]),
            "x_max": float(h["x"].max()),
            "u_max": float(h["u"].max()),
            "truncation": self.truncation(U),
        }

    def truncation(self, U) -> float:
        """Truncation indicator of an orbit: :meth:`truncation_indicator` of ``x''`` and ``f``, the larger."""
        x, _, f, _, lam, _ = self.split(np.asarray(U, dtype=float))
        return max(self.truncation_indicator(lam * self.second_derivative(x)), self.truncation_indicator(f))

    def truncation_indicator(self, c, share: float = 0.1):
        """Fraction of the mean square of series ``c`` in the top ``share`` of the harmonics."""
        H = self.H
        c = self.to_full(c)
        power = c[1 : H + 1] ** 2 + c[H + 1 :] ** 2
        # at least two harmonics: orbits with the half-wave symmetry (NNM1, NNM2) have only
        # odd harmonics, so a single top harmonic could be an even one, always zero
        top = max(2, int(np.ceil(share * H)))
        total = power.sum()
        return float(power[-top:].sum() / total) if total > 0 else 0.0


def impacts_per_period(x_samples) -> int:
    """Number of excursions beyond the stops (``x > 1`` or ``x < -1``) in one period.

    Counted on periodic samples as the number of entries into ``x > 1`` plus the
    number of entries into ``x < -1``.
    """
    x = np.asarray(x_samples, dtype=float)
    above = x > 1.0
    below = x < -1.0
    enter_above = np.count_nonzero(above & ~np.roll(above, 1))
    enter_below = np.count_nonzero(below & ~np.roll(below, 1))
    return int(enter_above + enter_below)


class SeriesCache:
    """Time samples of ``f``, ``z`` and ``g = f/alpha - x`` of the terms of one ANM series.

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
        # samples[r] holds f, g, z, g of term r on the M phases: channels 0:2 and 2:4 are
        # the left and right factors of f z and g g
        self.samples = np.empty((order + 1, 4, system.M))
        self.products = np.empty((2, system.M))
        self.coefficients = np.empty((2, system.nc))
        self.filled = 1  # U_0 never enters the products

    def fill(self, series, p: int):
        """Transform the terms ``filled .. p - 1`` of ``series`` (rows or list items)."""
        if p > self.samples.shape[0]:
            raise ValueError(f"cache holds orders up to {self.samples.shape[0] - 1}, order {p - 1} requested")
        if self.filled >= p:
            return
        system = self.system
        s = system.slices
        terms = np.asarray(series[self.filled : p], dtype=float)
        f = terms[:, s["f"]]
        g = f / system.params.alpha - terms[:, s["x"]]
        fields = np.stack([f, g, terms[:, s["z"]]], axis=1)  # (terms, 3, coefficients)
        block = self.samples[self.filled : p]
        np.matmul(fields, system._synthesis_t, out=block[:, :3])
        block[:, 3] = block[:, 1]
        self.filled = p
