"""Floquet stability of HBM orbits from the monodromy matrix of the variational equation.

The method (Magnus steps on a uniform grid, batched exponentials, pairwise product,
multipliers from the invariants of the symplectic matrix, the tolerances and the
reason codes) is described in ``docs/methods/monodromy.md``. :func:`branch_monodromy`
is the entry point used when branch datasets are assembled
(``stability.method: monodromy``); where the HBM orbit's own error decides the verdict it
refines the orbit by shooting (:mod:`nnmstop.hbm.shooting_refinement`). Hill's method stays in
:mod:`nnmstop.hbm.hill`.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np

from nnmstop.floquet import multipliers_from_invariant, transition_matrix
from nnmstop.hbm.hill import halfwave_symmetric, is_reversible
from nnmstop.hbm.shooting_refinement import refined_stability
from nnmstop.models.structure import two_dof_parameters
from nnmstop.models.two_dof import ModelParameters, regularized_contact_stiffness
from nnmstop.netcdf import flag_variable

__all__ = [
    "MonodromySettings",
    "BranchMonodromy",
    "REASONS",
    "variational_step_matrices",
    "transition_matrix",
    "trace_invariants",
    "orbit_monodromy",
    "branch_monodromy",
]

logger = logging.getLogger(__name__)

# Codes of `stability_reason`: why a verdict is resolved or not (dataset flag values).
# 3-5 only where the HBM orbit's error decided (2) and the orbit was refined by shooting.
REASONS = (
    "resolved", "integration_error", "orbit_error", "resolved_refined", "shooting_not_converged", "refined_at_type_change"
)
RESOLVED_REASONS = (0, 3)
# Gauss-Legendre nodes of one step (fractions of the step).
_GAUSS = (0.5 - np.sqrt(3.0) / 6.0, 0.5 + np.sqrt(3.0) / 6.0)
# Matrices of the batched products per chunk: 4 MB an array, about the fastest here (memory traffic).
_CHUNK_MATRICES = 2**15


@dataclass(frozen=True)
class MonodromySettings:
    """Settings of the monodromy method (config section ``stability``).

    Attributes
    ----------
    steps : int
        Magnus steps over the integrated interval (half a period for half-wave
        symmetric orbits, a period otherwise) on the first try; a power of two >= 64.
    max_steps : int
        Largest number of steps: a point whose verdict is decided by the
        integration error is recomputed with twice the steps up to this.
    trace_tol : float
        ``stable`` when ``|mu + 1/mu| <= 2 + trace_tol`` for the non-trivial pair.
    resolution_factor : float
        A verdict is resolved when the distance of ``mu + 1/mu`` to the points where
        the pair changes type exceeds this factor times the error estimates.
    refine : bool
        Refine the orbits whose own error decides the verdict into periodic orbits of
        (7) by shooting, and take the verdict from those
        (:mod:`nnmstop.shooting_refinement`).
    refine_steps, refine_max_steps : int
        Runge-Kutta steps per quarter period of the shooting: first try, and the most
        the steps are doubled to where the integration error decides (powers of two).
    refine_tol : float
        Shooting tolerance: closure of the quarter-period conditions relative to the
        amplitude.
    refine_max_change : float
        Largest relative change of the start state and period from the HBM orbit to the
        refined one; a shooting that goes farther has found another orbit (not converged).
    """

    steps: int = 256
    max_steps: int = 4096
    trace_tol: float = 1e-9
    resolution_factor: float = 2.0
    refine: bool = True
    refine_steps: int = 256
    refine_max_steps: int = 4096
    refine_tol: float = 1e-11
    refine_max_change: float = 1e-2

    def __post_init__(self):
        for name in ("steps", "max_steps"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < 64 or value & (value - 1):
                raise ValueError(f"stability {name} must be a power of two >= 64, got {value!r}")
        if self.max_steps < self.steps:
            raise ValueError(f"stability max_steps ({self.max_steps}) must be >= steps ({self.steps})")
        if not (np.isfinite(self.trace_tol) and self.trace_tol >= 0):
            raise ValueError(f"stability trace_tol must be a finite number >= 0, got {self.trace_tol!r}")
        if not (np.isfinite(self.resolution_factor) and self.resolution_factor >= 1):
            raise ValueError(f"stability resolution_factor must be a finite number >= 1, got {self.resolution_factor!r}")
        if not isinstance(self.refine, (bool, np.bool_)):
            raise ValueError(f"stability refine must be true or false, got {self.refine!r}")
        for name in ("refine_steps", "refine_max_steps"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < 16 or value & (value - 1):
                raise ValueError(f"stability {name} must be a power of two >= 16, got {value!r}")
        if self.refine_max_steps < 2 * self.refine_steps:
            raise ValueError(
                f"stability refine_max_steps ({self.refine_max_steps}) must be >= 2 x refine_steps ({self.refine_steps})"
            )
        if not (np.isfinite(self.refine_tol) and 0 < self.refine_tol <= 1e-6):
            raise ValueError(f"stability refine_tol must be a number in (0, 1e-6], got {self.refine_tol!r}")
        if not (np.isfinite(self.refine_max_change) and 0 < self.refine_max_change <= 0.5):
            raise ValueError(
                f"stability refine_max_change must be a number in (0, 0.5], got {self.refine_max_change!r}"
            )

    @classmethod
    def from_config(cls, stability: dict) -> MonodromySettings:
        """Settings from the (validated) ``stability`` section of the config."""
        keys = (
            "steps", "max_steps", "trace_tol", "resolution_factor",
            "refine", "refine_steps", "refine_max_steps", "refine_tol", "refine_max_change",
        )
        return cls(**{k: stability[k] for k in keys if k in stability})


# --------------------------------------------------------------------------- integrator


def _product(a, b):
    """Products of 4x4 matrices stored entry-first, ``a``, ``b``: (4, 4, m)."""
    return np.einsum("ikm,kjm->ijm", a, b)


def _hamiltonian_exp(omega, norm: float):
    """``exp`` of 4x4 matrices with an even characteristic polynomial, stored entry-first (4, 4, m).

    The Magnus matrices are Hamiltonian (for the mass-weighted symplectic form), so their
    characteristic polynomial is ``l**4 + e2 l**2 + e4`` and, by Cayley-Hamilton,
    ``X**4 = -e2 X**2 - e4 I``: every power is ``u I + v X**2`` or ``(u I + v X**2) X``
    with scalar ``u, v`` from a two-term recurrence. The Taylor series of degree 15 after
    scaling to norm <= 1/2 (truncation ``(1/2)**16 / 16!``, below round-off) is then
    ``a I + b X**2 + (c I + d X**2) X``: two matrix products and scalar work, instead of
    the seven matrix products of a matrix polynomial. ``norm``: the largest row sum of
    ``|omega|`` over the stack. Storing the 16 entries first keeps each product a few
    vector operations over the whole stack.
    """
    squarings = max(0, int(np.ceil(np.log2(norm / 0.5)))) if norm > 0 else 0
    X = omega / 2.0**squarings if squarings else omega
    X2 = _product(X, X)
    p2 = X2[0, 0] + X2[1, 1] + X2[2, 2] + X2[3, 3]  # tr X**2 = -2 e2
    p4 = np.einsum("ijm,jim->m", X2, X2)  # tr X**4 = 2 e2**2 - 4 e4 (Newton's identities, e1 = e3 = 0)
    e2 = -0.5 * p2
    e4 = 0.25 * (0.5 * p2 * p2 - p4)
    u, v = np.ones_like(e2), np.zeros_like(e2)  # X**0 = u I + v X**2
    a, b, c, d = np.ones_like(e2), np.zeros_like(e2), np.ones_like(e2), np.zeros_like(e2)
    factorial = 1.0
    for k in range(1, 8):
        u, v = -e4 * v, u - e2 * v  # X**(2k) = X**(2k-2) X**2
        factorial *= 2 * k - 1
        factorial *= 2 * k
        a += u / factorial
        b += v / factorial
        odd_factor = 1.0 / (factorial * (2 * k + 1))  # 1 / (2k + 1)!
        c += u * odd_factor
        d += v * odd_factor
    result = b * X2
    result += _product(c * np.eye(4)[:, :, None] + d * X2, X)
    result[0, 0] += a
    result[1, 1] += a
    result[2, 2] += a
    result[3, 3] += a
    for _ in range(squarings):
        result = _product(result, result)
    return result


def variational_step_matrices(stiffness_nodes, step, params: ModelParameters):
    """Fourth-order Magnus step matrices of ``Phi' = (A0 + k(t) E) Phi``.

    Parameters
    ----------
    stiffness_nodes : ndarray, shape (..., n, 2)
        ``k = f'(x)`` at the two Gauss-Legendre nodes of each of ``n`` steps.
    step : float or ndarray
        Step length in time, > 0 (broadcast against ``stiffness_nodes.shape[:-1]``, e.g.
        one per orbit as shape ``(n_orbits, 1)``).
    params : ModelParameters

    Returns
    -------
    ndarray, shape (..., n, 4, 4)
        ``exp(Omega_j)``, ``Omega_j = h A(k_mean) + sqrt(3)/12 h**2 (k_2 - k_1) [E, A0]``
        (the commutator ``[A_2, A_1]`` of the two node matrices reduces to that term,
        ``[E, A0] = diag(1, 0, -1, 0)``). ``Omega_j`` is filled entry by entry: eight
        non-zero entries of sixteen.
    """
    b, d = params.beta, params.delta
    k = np.asarray(stiffness_nodes, dtype=float)
    k_mean = 0.5 * (k[..., 0] + k[..., 1])
    k_diff = k[..., 1] - k[..., 0]
    h = np.broadcast_to(np.asarray(step, dtype=float), k_mean.shape).ravel()
    gamma = (np.sqrt(3.0) / 12.0) * h**2 * k_diff.ravel()
    omega = np.zeros((4, 4, h.size))
    omega[0, 0] = gamma
    omega[0, 2] = h
    omega[1, 3] = h
    omega[2, 0] = h * (-(1.0 + b) - k_mean.ravel())
    omega[2, 1] = h * b
    omega[2, 2] = -gamma
    omega[3, 0] = h * (b / d)
    omega[3, 1] = h * (-b / d)
    # Largest row sum of |Omega|, for the scaling of the exponential.
    norm = float(np.abs(omega).sum(axis=1).max()) if h.size else 0.0
    exponential = _hamiltonian_exp(omega, norm)
    return np.ascontiguousarray(np.moveaxis(exponential, 2, 0)).reshape(k_mean.shape + (4, 4))


def _displacement_at_nodes(x_full, H: int, steps: int, halfwave: bool):
    """``x`` at the two Gauss nodes of each step, from its Fourier coefficients.

    The nodes of all steps form two uniform grids shifted by a fraction of a step:
    each is one inverse FFT of the coefficients times a phase ramp (exact, no
    interpolation). ``x_full``: (n_orbits, 2H+1) full-layout coefficients.
    Returns (n_orbits, steps, 2).
    """
    per_period = 2 * steps if halfwave else steps
    samples = max(per_period, 2 * H + 2)
    samples = per_period * int(np.ceil(samples / per_period))
    stride = samples // per_period
    k = np.arange(1, H + 1)
    spec = np.zeros((x_full.shape[0], samples // 2 + 1), dtype=complex)
    out = np.empty((x_full.shape[0], steps, 2))
    for i, c in enumerate(_GAUSS):
        spec[:, 0] = x_full[:, 0] * samples
        ramp = np.exp(1j * k * (2 * np.pi * c * stride / samples))
        spec[:, 1 : H + 1] = 0.5 * samples * (x_full[:, 1 : H + 1] - 1j * x_full[:, H + 1 :]) * ramp
        grid = np.fft.irfft(spec, n=samples, axis=-1)
        out[:, :, i] = grid[:, ::stride][:, :steps]
    return out


def trace_invariants(matrices):
    """Invariant ``s = mu + 1/mu`` of the non-trivial pair and the trivial pair's deviation.

    For a 4x4 symplectic matrix with eigenvalues ``{mu_t, 1/mu_t, mu, 1/mu}`` the
    characteristic polynomial is ``(l**2 - s_t l + 1)(l**2 - s l + 1)``, so ``s_t`` and
    ``s`` are the roots of ``r**2 - a r + (b - 2)``, ``a = tr M``,
    ``b = (a**2 - tr M**2) / 2``. The root nearer 2 is the trivial one
    (``s_t = 2`` exactly for an exact orbit). A negative discriminant (round-off or
    orbit error where the two are close) counts as zero.

    Returns
    -------
    s : ndarray
        Non-trivial invariant.
    trivial_deviation : ndarray
        ``|s_t - 2|``.
    """
    M = np.asarray(matrices)
    a = np.trace(M, axis1=-2, axis2=-1)
    b = 0.5 * (a * a - np.trace(np.matmul(M, M), axis1=-2, axis2=-1))
    half = 0.5 * np.sqrt(np.maximum(a * a - 4.0 * (b - 2.0), 0.0))
    r1, r2 = 0.5 * a + half, 0.5 * a - half
    trivial_first = np.abs(r1 - 2.0) <= np.abs(r2 - 2.0)
    s_t = np.where(trivial_first, r1, r2)
    s = np.where(trivial_first, r2, r1)
    return s, np.abs(s_t - 2.0)


# --------------------------------------------------------------------------- orbits


def _orbit_arrays(system, U_array):
    """Full-layout ``x`` coefficients, ``omega`` and half-wave symmetry of each orbit."""
    parts = system.split(U_array)
    x = system.to_full(parts[0])
    omega = np.sqrt(np.asarray(parts[4], dtype=float))
    if not np.all(omega > 0):
        raise ValueError("omega**2 must be > 0 on every orbit")
    return x, omega, halfwave_symmetric(system, U_array)


def _invariant_with_steps(system, x, omega, halfwave: bool, steps: int):
    """Invariant of the full-period monodromy and trivial deviation, for orbits of one symmetry.

    Half-wave symmetric orbits: ``A(t + T/2) = A(t)`` and the state is odd over a
    half period, so ``M = P**2`` with ``P = Phi(T/2)``; ``N = -P`` has the trivial
    pair at +1 and the non-trivial ``nu`` with ``mu = nu**2``, hence
    ``s = s_N**2 - 2``. Only half a period is integrated and a multiplier near -1
    (``s_N`` near 0) costs no accuracy.
    """
    params = two_dof_parameters(system.structure, "the 2-DOF monodromy")
    span = np.pi if halfwave else 2 * np.pi
    s_all = np.empty(len(x))
    dev_all = np.empty(len(x))
    per_chunk = max(1, _CHUNK_MATRICES // steps)
    for start in range(0, len(x), per_chunk):
        sl = slice(start, start + per_chunk)
        nodes = _displacement_at_nodes(x[sl], system.H, steps, halfwave)
        k = regularized_contact_stiffness(nodes, params)
        h = (span / steps) / omega[sl]
        mats = variational_step_matrices(k, h[:, None], params)
        P = transition_matrix(mats)
        if halfwave:
            s_n, dev_n = trace_invariants(-P)
            s_all[sl] = s_n * s_n - 2.0
            # Deviation carried to the full-period invariant: ds = 2 |s_N| ds_N.
            dev_all[sl] = 2.0 * np.abs(s_n) * dev_n
        else:
            s_all[sl], dev_all[sl] = trace_invariants(P)
    return s_all, dev_all


def _margin(s, halfwave):
    """Distance of ``s`` to the points where the pair can change type.

    Half-wave symmetric orbits change type only at ``mu = 1`` (``s = 2``; ``s >= -2``
    always, see ``_invariant_with_steps``), others also at ``mu = -1`` (``s = -2``).
    """
    to_plus = np.abs(s - 2.0)
    return np.where(halfwave, to_plus, np.minimum(to_plus, np.abs(s + 2.0)))


@dataclass
class BranchMonodromy:
    """Stability of every point of a branch from the monodromy matrix (arrays along the points).

    Attributes
    ----------
    stable : ndarray of bool
        ``|s| <= 2 + trace_tol`` (elliptic non-trivial pair).
    multipliers : ndarray of complex, shape (n, 4)
        ``[1, 1, mu_1, mu_2]``, ``|mu_1| >= |mu_2|`` (trivial pair exactly 1, see
        ``trivial_deviation`` for how far the computed one is).
    invariant : ndarray
        ``s = mu_1 + mu_2`` of the full-period monodromy (``2 cos theta`` for an
        elliptic pair ``exp(+-i theta)``).
    margin : ndarray
        Distance of ``s`` to the type-change points.
    integration_error : ndarray
        ``|s(2N) - s(N)|`` between the last two step counts.
    trivial_deviation : ndarray
        ``|s_t - 2|`` of the trivial pair: the orbit's error seen by the linearization.
    orbit_error : ndarray
        Larger of the orbit's time residual of (7) and ``trivial_deviation``: the
        estimate of how far the orbit's error moves ``s``.
    steps : ndarray of int
        Steps of the stored (finer) integration.
    reason : ndarray of int
        Index in :data:`REASONS`.
    halfwave : ndarray of bool
    settings : MonodromySettings
    seconds_per_point : float
    refined : ndarray of bool
        Orbit refined by shooting (its own error decided the verdict). Where the
        shooting converged, ``stable``, ``multipliers``, ``invariant``, ``margin``,
        ``integration_error`` and ``steps`` are those of the refined orbit.
    refined_frequency_change, refined_energy_change : ndarray
        Relative change of the frequency and of the energy (at ``t = 0``) from the HBM
        orbit to the refined one (0 where not refined or not converged).
    refined_residual : ndarray
        Closure of the shooting conditions relative to the amplitude (0 where not
        refined, 1 where the shooting diverged at once).
    refine_seconds : float
        Time spent refining.
    """

    stable: np.ndarray
    multipliers: np.ndarray
    invariant: np.ndarray
    margin: np.ndarray
    integration_error: np.ndarray
    trivial_deviation: np.ndarray
    orbit_error: np.ndarray
    steps: np.ndarray
    reason: np.ndarray
    halfwave: np.ndarray
    settings: MonodromySettings
    seconds_per_point: float = 0.0
    refined: np.ndarray | None = None
    refined_frequency_change: np.ndarray | None = None
    refined_energy_change: np.ndarray | None = None
    refined_residual: np.ndarray | None = None
    refine_seconds: float = 0.0

    def __post_init__(self):
        n = len(self.reason)
        for name in ("refined_frequency_change", "refined_energy_change", "refined_residual"):
            if getattr(self, name) is None:
                setattr(self, name, np.zeros(n))
        if self.refined is None:
            self.refined = np.zeros(n, dtype=bool)

    @property
    def resolved(self) -> np.ndarray:
        return np.isin(self.reason, RESOLVED_REASONS)

    @property
    def max_multiplier(self) -> np.ndarray:
        return np.abs(self.multipliers[:, 2])

    def data_vars(self) -> dict:
        """Variables for a branch dataset (same names as Hill's for the shared ones)."""
        st = self.settings
        note = (
            "Floquet multipliers from the monodromy matrix of the variational equation of (7) along the HBM orbit "
            f"(4th-order Magnus steps, {2 * st.steps} to {st.max_steps} per integrated interval, checked against half as many), non-trivial pair from the "
            "invariant s = mu + 1/mu of the symplectic matrix, ordered [trivial, trivial, mu_1, mu_2], |mu_1| >= |mu_2|; "
            "where stability_refined = 1 and the shooting converged, from the monodromy of the periodic orbit of (7) "
            f"refined by shooting (8th-order Runge-Kutta, {st.refine_steps} to {st.refine_max_steps} steps per quarter "
            "period, checked against half as many)"
        )
        F = f"{st.resolution_factor:g}"
        reason_attrs = {
            "long_name": "why the stability verdict is or is not resolved: 0 resolved; 1 stability_margin within "
            f"{F} x stability_integration_error at the largest step count; 2 stability_margin within "
            f"{F} x stability_orbit_residual (the HBM orbit's own error; more steps would not resolve it) and the "
            "orbit not refined; 3 resolved on the orbit refined by shooting into a periodic orbit of (7) (the HBM orbit's "
            f"margin was within {F} x its error; stability variables from the refined orbit); 4 the shooting did not "
            f"converge (verdict of the HBM orbit, unresolved); 5 the refined orbit's margin within {F} x its "
            "integration error at the largest step count or below trace_tol: the non-trivial pair sits at +1 (a "
            "stability change, e.g. an energy fold)",
            "units": "1",
            "flag_values": np.arange(len(REASONS), dtype=np.int8),
            "flag_meanings": " ".join(REASONS),
        }
        return {
            "stable": flag_variable(
                "point", self.stable,
                f"orbit linearly stable (1) or unstable (0): |mu + 1/mu| of the non-trivial pair <= 2 + {st.trace_tol:g}",
                "unstable stable", comment=note,
            ),
            "multiplier_real": (("point", "multiplier"), self.multipliers.real, {"long_name": "real part of the Floquet multipliers", "units": "1", "comment": note}),
            "multiplier_imag": (("point", "multiplier"), self.multipliers.imag, {"long_name": "imaginary part of the Floquet multipliers", "units": "1", "comment": note}),
            "max_multiplier": ("point", self.max_multiplier, {"long_name": "largest modulus of the non-trivial Floquet multiplier pair", "units": "1"}),
            "stability_orbit_residual": ("point", self.orbit_error, {"long_name": "estimate of the change of floquet_invariant due to the orbit's error: larger of time_residual and stability_trivial_deviation", "units": "1"}),
            "stability_trivial_deviation": ("point", self.trivial_deviation, {"long_name": "distance of the trivial pair's invariant mu + 1/mu to 2 in the computed monodromy (exactly 0 on an exact orbit)", "units": "1"}),
            "stability_resolved": flag_variable(
                "point", self.resolved,
                "stability verdict resolved (1): stability_margin larger than the error estimates (stability_reason)",
                "unresolved resolved",
            ),
            "stability_reason": ("point", self.reason.astype(np.int8), reason_attrs),
            "floquet_invariant": ("point", self.invariant, {"long_name": "invariant mu + 1/mu of the non-trivial Floquet pair (in [-2, 2] when elliptic)", "units": "1"}),
            "stability_margin": ("point", self.margin, {"long_name": "distance of floquet_invariant to the values where the non-trivial pair changes type (2, and -2 unless half-wave symmetric)", "units": "1"}),
            "stability_integration_error": ("point", self.integration_error, {"long_name": "change of floquet_invariant between the last two step counts of the monodromy integration", "units": "1"}),
            "stability_steps": ("point", self.steps.astype(np.int32), {"long_name": "Magnus steps of the stored monodromy over the integrated interval (half a period if half-wave symmetric); on refined orbits (stability_reason 3-5) Runge-Kutta steps over a quarter period", "units": "1"}),
            "stability_refined": flag_variable(
                "point", self.refined,
                "orbit refined by shooting into a periodic orbit of (7) for its verdict (stability_reason 3-5)",
                "no yes",
            ),
            "stability_refined_frequency_change": ("point", self.refined_frequency_change, {
                "long_name": "relative change of the frequency from the HBM orbit to the shooting-refined orbit "
                "(0 where stability_refined = 0 or stability_reason = 4)", "units": "1"}),
            "stability_refined_energy_change": ("point", self.refined_energy_change, {
                "long_name": "relative change of the energy at t = 0 (start at rest) from the HBM orbit to the "
                "shooting-refined orbit (0 where stability_refined = 0 or stability_reason = 4)", "units": "1"}),
            "stability_refined_residual": ("point", self.refined_residual, {
                "long_name": "closure of the shooting conditions x = u = 0 at a quarter period relative to the "
                "amplitude (0 where stability_refined = 0; 1 where the shooting diverged at once)", "units": "1"}),
        }


def branch_monodromy(system, U_array, settings: MonodromySettings | None = None, time_residual=None) -> BranchMonodromy:
    """Floquet stability of every point of a branch from the monodromy matrix.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    U_array : array_like, shape (n, n_unknowns)
    settings : MonodromySettings, optional
    time_residual : array_like, shape (n,), optional
        Relative time-domain residual of Eq. (7) of each orbit (the ``time_residual``
        of :meth:`HarmonicBalanceSystem.diagnostics`, computed when not given): the
        orbit's own error, which moves ``s`` by about as much (calibration in
        ``docs/methods/monodromy.md``).

    Returns
    -------
    BranchMonodromy
    """
    settings = MonodromySettings() if settings is None else settings
    if not isinstance(settings, MonodromySettings):
        raise ValueError(f"settings must be a MonodromySettings, got {type(settings).__name__}")
    U_array = np.asarray(U_array, dtype=float)
    if U_array.ndim != 2 or U_array.shape[1] != system.n_unknowns:
        raise ValueError(f"U_array must have shape (n, {system.n_unknowns}), got {U_array.shape}")
    if not np.all(np.isfinite(U_array)):
        raise ValueError("U_array must be finite")
    start = time.perf_counter()
    n = len(U_array)
    if time_residual is None:
        time_residual = [system.diagnostics(U)["time_residual"] for U in U_array]
    time_residual = np.asarray(time_residual, dtype=float)
    if time_residual.shape != (n,) or not np.all(np.isfinite(time_residual)) or np.any(time_residual < 0):
        raise ValueError(f"time_residual must be {n} finite numbers >= 0, got shape {time_residual.shape}")
    s = np.zeros(n)
    dev = np.zeros(n)
    err = np.zeros(n)
    steps = np.zeros(n, dtype=int)
    halfwave = np.zeros(n, dtype=bool)
    if n:
        x, omega, halfwave = _orbit_arrays(system, U_array)
        F = settings.resolution_factor
        for hw in (True, False):
            idx = np.flatnonzero(halfwave == hw)
            if not len(idx):
                continue
            N = settings.steps
            coarse, _ = _invariant_with_steps(system, x[idx], omega[idx], hw, N)
            todo = idx
            while len(todo):
                fine, fine_dev = _invariant_with_steps(system, x[todo], omega[todo], hw, 2 * N)
                s[todo], dev[todo], steps[todo] = fine, fine_dev, 2 * N
                err[todo] = np.abs(fine - coarse)
                # More steps where the integration error could decide the verdict and exceeds
                # the orbit's own error (beyond that they cannot make the verdict better), unless
                # s within its error bound stays within F x the orbit's residual: reason 2 (and the
                # refinement) whatever the steps.
                margin = _margin(fine, hw)
                undecided = (margin <= F * err[todo]) & (err[todo] > np.maximum(time_residual[todo], fine_dev))
                undecided &= margin + err[todo] > F * time_residual[todo]
                if 2 * N >= settings.max_steps:
                    break
                todo, coarse, N = todo[undecided], fine[undecided], 2 * N
    orbit_error = np.maximum(time_residual, dev)
    margin = _margin(s, halfwave)
    F = settings.resolution_factor
    reason = np.zeros(n, dtype=np.int8)
    reason[margin <= F * err] = 1
    reason[margin <= F * orbit_error] = 2  # the orbit's error decides whatever the steps
    refinement = _refine(system, U_array, s, margin, err, steps, reason, halfwave, settings)
    multipliers = multipliers_from_invariant(s)
    return BranchMonodromy(
        stable=np.abs(s) <= 2.0 + settings.trace_tol,
        multipliers=multipliers,
        invariant=s,
        margin=margin,
        integration_error=err,
        trivial_deviation=dev,
        orbit_error=orbit_error,
        steps=steps,
        reason=reason,
        halfwave=halfwave,
        settings=settings,
        seconds_per_point=(time.perf_counter() - start) / max(n, 1),
        **refinement,
    )


def _refine(system, U_array, s, margin, err, steps, reason, halfwave, settings: MonodromySettings) -> dict:
    """Shooting refinement of the orbits whose own error decides the verdict (reason 2), in place.

    Applies to time-reversible, half-wave symmetric orbits (all NNM orbits of the
    branches); others keep reason 2. Updates ``s``, ``margin``, ``err``, ``steps`` and
    ``reason`` of the refined orbits and returns the diagnostics for
    :class:`BranchMonodromy`.
    """
    n = len(s)
    out = {"refined": np.zeros(n, dtype=bool)}
    for name in ("refined_frequency_change", "refined_energy_change", "refined_residual"):
        out[name] = np.zeros(n)
    candidates = np.flatnonzero((reason == 2) & halfwave) if settings.refine else np.array([], dtype=int)
    idx = np.array([i for i in candidates if is_reversible(system, U_array[i])], dtype=int)
    if not len(idx):
        return out
    start = time.perf_counter()
    F = settings.resolution_factor
    r = refined_stability(
        system, U_array[idx], settings.refine_steps, settings.refine_max_steps, settings.refine_tol, F,
        settings.refine_max_change, floor=settings.trace_tol,
    )
    ok = r.converged
    done = idx[ok]
    s[done], err[done], steps[done] = r.invariant[ok], r.integration_error[ok], r.steps[ok]
    margin[done] = np.abs(s[done] - 2.0)  # half-wave symmetric: the pair changes type only at +1
    # Error of the refined s: the integration error, and the orbit's closure error (which moves s by
    # about as much, as the HBM orbit's time residual does); a margin below trace_tol is a pair at +1.
    bound = F * np.maximum(err[done], r.residual[ok])  # converged: both finite
    resolved = margin[done] > np.maximum(bound, settings.trace_tol)
    reason[done] = np.where(resolved, 3, 5)
    reason[idx[~ok]] = 4
    out["refined"][idx] = True
    out["refined_residual"][idx] = np.where(np.isfinite(r.residual), r.residual, 1.0)
    out["refined_frequency_change"][done] = r.initial_period[ok] / r.period[ok] - 1.0
    out["refined_energy_change"][done] = r.energy[ok] / r.initial_energy[ok] - 1.0
    out["refine_seconds"] = time.perf_counter() - start
    logger.info(
        "refined %d orbits by shooting in %.2f s: %d resolved, %d at a type change, %d not converged",
        len(idx), out["refine_seconds"], np.sum(reason[idx] == 3), np.sum(reason[idx] == 5), np.sum(reason[idx] == 4),
    )
    return out


def orbit_monodromy(system, U, steps: int = 1024):
    """Full-period monodromy matrix of one HBM orbit (Magnus steps, no symmetry used).

    For checks and diagnostics; :func:`branch_monodromy` works from the invariants.
    """
    x, omega, _ = _orbit_arrays(system, np.asarray(U, dtype=float)[None])
    nodes = _displacement_at_nodes(x, system.H, steps, False)
    params = two_dof_parameters(system.structure, "the 2-DOF monodromy")
    k = regularized_contact_stiffness(nodes, params)
    mats = variational_step_matrices(k, 2 * np.pi / steps / omega[0], params)
    return transition_matrix(mats)[0]
