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

from nnmstop.floquet import (
    CAYLEY_HAMILTON_MAX_DOF,
    COMMUTATOR_FREE_WEIGHTS,
    GAUSS,
    PairInvariants,
    check_power_of_two,
    hamiltonian_expm,
    oscillator_expm,
    transition_matrix,
)
from nnmstop.hbm.shooting_refinement import explicit_steps, refinable, refined_stability
from nnmstop.hbm.variational import Linearization, halfwave_symmetric, is_reversible, stop_coefficients

__all__ = [
    "MonodromySettings",
    "BranchMonodromy",
    "variational_generators",
    "variational_step_matrices",
    "commutator_free_step_matrices",
    "integrated_monodromy",
    "orbit_monodromy",
    "branch_monodromy",
]

logger = logging.getLogger(__name__)

# Codes of `stability_reason` (their meanings: the catalogue, nnmstop.catalogue.branch) that are resolved
# verdicts; 3-5 only where the HBM orbit's error decided (2) and the orbit was refined by shooting.
RESOLVED_REASONS = (0, 3)
#: Default of :attr:`MonodromySettings.max_orbit_residual`: above the largest time residual (0.043) of the
#: orbits on which the orbit-error estimate was calibrated.
MAX_ORBIT_RESIDUAL = 0.05
# Entries of the batched step matrices per chunk (4 MB an array: 2**15 matrices of 4 x 4), about the
# fastest here (memory traffic).
_CHUNK_ENTRIES = 2**19


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
    max_orbit_residual : float
        Largest ``time_residual`` of an orbit whose own verdict can be resolved: the estimate
        "the orbit's error moves ``s`` by about its time residual" was calibrated on orbits whose
        residuals reach 0.043 (the paper's H = 100 branches; ``docs/methods/monodromy.md``); an
        orbit above this gets reason 2 whatever its margin, and is refined.
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
    max_orbit_residual: float = MAX_ORBIT_RESIDUAL

    def __post_init__(self):
        for name in ("steps", "max_steps"):
            check_power_of_two(f"stability {name}", getattr(self, name), 64)
        if self.max_steps < self.steps:
            raise ValueError(f"stability max_steps ({self.max_steps}) must be >= steps ({self.steps})")
        if not (np.isfinite(self.trace_tol) and self.trace_tol >= 0):
            raise ValueError(f"stability trace_tol must be a finite number >= 0, got {self.trace_tol!r}")
        if not (np.isfinite(self.resolution_factor) and self.resolution_factor >= 1):
            raise ValueError(
                f"stability resolution_factor must be a finite number >= 1, got {self.resolution_factor!r}"
            )
        if not isinstance(self.refine, (bool, np.bool_)):
            raise ValueError(f"stability refine must be true or false, got {self.refine!r}")
        for name in ("refine_steps", "refine_max_steps"):
            check_power_of_two(f"stability {name}", getattr(self, name), 16)
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
        if not (np.isfinite(self.max_orbit_residual) and 0 < self.max_orbit_residual <= 1):
            raise ValueError(
                f"stability max_orbit_residual must be a number in (0, 1], got {self.max_orbit_residual!r}"
            )

    @classmethod
    def from_config(cls, stability: dict) -> MonodromySettings:
        """Settings from the (validated) ``stability`` section of the config."""
        keys = (
            "steps",
            "max_steps",
            "trace_tol",
            "resolution_factor",
            "refine",
            "refine_steps",
            "refine_max_steps",
            "refine_tol",
            "refine_max_change",
            "max_orbit_residual",
        )
        return cls(**{k: stability[k] for k in keys if k in stability})


# --------------------------------------------------------------------------- integrator


def chunk_orbits(n_states: int, steps: int) -> int:
    """Orbits per chunk of the batched step matrices: about :data:`_CHUNK_ENTRIES` entries."""
    return max(1, _CHUNK_ENTRIES // (steps * n_states * n_states))


def variational_generators(linearization: Linearization, stiffness_nodes, step, balance: float = 1.0):
    """Fourth-order Magnus generators of ``z'' + B(t) z = 0`` in the coordinates ``(z, z' / balance)``, entry-first.

    With ``A_j = [[0, I], [-B_j, 0]]`` at the two Gauss nodes, ``B_j = B_0 + sum_i k_ij w_i w_i^T``, the
    step's generator ``h/2 (A_1 + A_2) + sqrt(3)/12 h**2 [A_2, A_1]`` is
    ``[[G, h I], [-h B_mean, -G]]`` with ``G = sqrt(3)/12 h**2 (B_2 - B_1)`` (symmetric): Hamiltonian,
    so its exponential is symplectic and :func:`nnmstop.floquet.hamiltonian_expm` applies. In the
    balanced coordinates the off-diagonal blocks are ``h balance I`` and ``-h B_mean / balance``: with
    ``balance**2 ~ ||B||`` the norm, hence the squarings of the exponential, follow the fastest
    frequency ``sqrt(||B||)`` instead of ``||B||``.

    Parameters
    ----------
    linearization : Linearization
    stiffness_nodes : ndarray, shape (s, ..., 2)
        ``k_i = f_i'(x_i)`` of each stop at the two Gauss nodes of each step.
    step : float or ndarray
        Step length, broadcast against ``stiffness_nodes.shape[1:-1]``.
    balance : float

    Returns
    -------
    ndarray, shape (2N, 2N, ...)
        The entries first (the layout of :func:`~nnmstop.floquet.hamiltonian_expm` with ``entry_first``).
    """
    k = np.asarray(stiffness_nodes, dtype=float)
    N = linearization.n_dofs
    batch = k.shape[1:-1]
    h = np.broadcast_to(np.asarray(step, dtype=float), batch)
    outer = linearization.stop_outer
    out = np.empty((2 * N, 2 * N) + batch)
    out[:N, :N] = np.tensordot(outer, k[..., 1] - k[..., 0], axes=(0, 0))
    out[:N, :N] *= (np.sqrt(3.0) / 12.0) * h * h
    out[N:, N:] = -out[:N, :N]
    out[N:, :N] = np.tensordot(outer, 0.5 * (k[..., 0] + k[..., 1]), axes=(0, 0))
    out[N:, :N] += linearization.stiffness.reshape((N, N) + (1,) * len(batch))
    out[N:, :N] *= -h / balance
    out[:N, N:] = 0.0
    for i in range(N):
        out[i, N + i] = h * balance
    return out


def variational_step_matrices(linearization: Linearization, stiffness_nodes, step):
    """Magnus step maps ``exp(Omega_j)`` of the variational equation in the coordinates ``(z, z')``.

    Arguments as in :func:`variational_generators`; returns ``(..., 2N, 2N)``. (The integration of
    :func:`branch_monodromy` keeps the balanced coordinates, whose monodromy is similar.)
    """
    k = np.asarray(stiffness_nodes, dtype=float)
    balance = _balance(linearization, k)
    mats = np.moveaxis(
        hamiltonian_expm(variational_generators(linearization, k, step, balance), True), (0, 1), (-2, -1)
    )
    N = linearization.n_dofs
    mats[..., :N, N:] /= balance  # exp(Omega) = T exp(Omega_balanced) T^-1, T = diag(I, balance I)
    mats[..., N:, :N] *= balance
    return mats


def _balance(linearization: Linearization, k) -> float:
    """``sqrt`` of the largest row sum of ``|B|`` over the stop slopes ``k`` (at least 1)."""
    largest = np.abs(linearization.stiffness).sum(axis=1)
    outer = linearization.outer_bound
    k_max = np.abs(k).reshape(len(k), -1).max(axis=1) if k.size else np.zeros(len(k))
    return float(np.sqrt(max(1.0, (largest + k_max @ outer).max())))


def _displacement_at_nodes(x_full, H: int, steps: int, halfwave: bool):
    """``x`` at the two Gauss nodes of each step, from its Fourier coefficients.

    The nodes of all steps form two uniform grids shifted by a fraction of a step:
    each is one inverse FFT of the coefficients times a phase ramp (exact, no
    interpolation). ``x_full``: (rows, 2H+1) full-layout coefficients.
    Returns (rows, steps, 2).
    """
    per_period = 2 * steps if halfwave else steps
    samples = max(per_period, 2 * H + 2)
    samples = per_period * int(np.ceil(samples / per_period))
    stride = samples // per_period
    k = np.arange(1, H + 1)
    spec = np.zeros((x_full.shape[0], samples // 2 + 1), dtype=complex)
    out = np.empty((x_full.shape[0], steps, 2))
    for i, c in enumerate(GAUSS):
        spec[:, 0] = x_full[:, 0] * samples
        ramp = np.exp(1j * k * (2 * np.pi * c * stride / samples))
        spec[:, 1 : H + 1] = 0.5 * samples * (x_full[:, 1 : H + 1] - 1j * x_full[:, H + 1 :]) * ramp
        grid = np.fft.irfft(spec, n=samples, axis=-1)
        out[:, :, i] = grid[:, ::stride][:, :steps]
    return out


def _stiffness_at_nodes(linearization: Linearization, x_full, H: int, steps: int, halfwave: bool):
    """``k_i`` of every stop at the Gauss nodes: ``x_full`` (n, s, 2H+1) -> (s, n, steps, 2)."""
    n, s = x_full.shape[:2]
    nodes = _displacement_at_nodes(x_full.reshape(n * s, -1), H, steps, halfwave).reshape(n, s, steps, 2)
    return linearization.contact_stiffness(np.moveaxis(nodes, 1, 0))


def integrated_monodromy(linearization: Linearization, x_full, omega, H: int, steps: int, span: float):
    """Transition matrices over ``span`` of phase from ``t = 0`` (balanced coordinates), for a chunk of orbits.

    ``x_full`` (n, s, 2H+1): the stop coordinates' coefficients; ``span``: ``pi`` (half-wave
    symmetric orbits) or ``2 pi``. Returns ``(n, 2N, 2N)``, similar to the physical ones.
    """
    k = _stiffness_at_nodes(linearization, x_full, H, steps, span < 2 * np.pi)
    h = (span / steps) / np.asarray(omega, dtype=float)
    if linearization.n_dofs > CAYLEY_HAMILTON_MAX_DOF:
        return transition_matrix(commutator_free_step_matrices(linearization, k, h[:, None]))
    generators = variational_generators(linearization, k, h[:, None], _balance(linearization, k))
    step_maps = hamiltonian_expm(generators, entry_first=True)
    return transition_matrix(np.ascontiguousarray(np.moveaxis(step_maps, (0, 1), (-2, -1))))


def commutator_free_step_matrices(linearization: Linearization, stiffness_nodes, step):
    """Fourth-order commutator-free Magnus step maps of ``z'' + B(t) z = 0`` in ``(z, z')``, for many DOF.

    Each step is ``exp(h (b_2 A_1 + b_1 A_2)) exp(h (b_1 A_1 + b_2 A_2))``
    (:data:`~nnmstop.floquet.COMMUTATOR_FREE_WEIGHTS`): two exponents without the commutator term, each
    ``[[0, h/2 I], [-h/2 B', 0]]`` with a symmetric ``B' = B_0 + 2 sum_i (b k_i1 + b' k_i2) w_i w_i^T``,
    exponentiated in closed form (:func:`~nnmstop.floquet.oscillator_expm`: one eigendecomposition of
    ``B'``, no squarings however stiff the structure). Arguments as in :func:`variational_generators`;
    returns ``(..., 2N, 2N)``.
    """
    k = np.asarray(stiffness_nodes, dtype=float)
    b1, b2 = COMMUTATOR_FREE_WEIGHTS
    half = 0.5 * np.broadcast_to(np.asarray(step, dtype=float), k.shape[1:-1])
    first = oscillator_expm(linearization.stiffness_at(2.0 * (b1 * k[..., 0] + b2 * k[..., 1])), half)
    second = oscillator_expm(linearization.stiffness_at(2.0 * (b2 * k[..., 0] + b1 * k[..., 1])), half)
    return second @ first


# --------------------------------------------------------------------------- orbits


def _orbit_arrays(system, U_array):
    """Stop coordinates' coefficients (n, s, 2H+1), ``omega`` and half-wave symmetry of each orbit."""
    omega = np.sqrt(np.asarray(system.split(U_array)[-2], dtype=float))
    if not np.all(omega > 0):
        raise ValueError("omega**2 must be > 0 on every orbit")
    return stop_coefficients(system, U_array), omega, halfwave_symmetric(system, U_array)


def _invariants_with_steps(linearization, x, omega, H: int, halfwave: bool, steps: int) -> PairInvariants:
    """:class:`PairInvariants` of orbits of one symmetry from ``steps`` Magnus steps over the integrated interval."""
    span = np.pi if halfwave else 2 * np.pi
    out = PairInvariants.empty(len(x), linearization.n_dofs - 1)
    per_chunk = chunk_orbits(2 * linearization.n_dofs, steps)
    for start in range(0, len(x), per_chunk):
        sl = slice(start, start + per_chunk)
        P = integrated_monodromy(linearization, x[sl], omega[sl], H, steps, span)
        out.assign(sl, PairInvariants.of(P, halfwave))
    return out


@dataclass
class BranchMonodromy:
    """Stability of every point of a branch from the monodromy matrix (arrays along the points).

    Attributes
    ----------
    stable : ndarray of bool
        Every non-trivial pair elliptic, ``|s| <= 2 + trace_tol``.
    multipliers : ndarray of complex, shape (n, 2N)
        ``[1, 1, mu_1, 1/mu_1, mu_2, 1/mu_2, ...]``, pairs by decreasing largest modulus, within a
        pair the larger first (trivial pair exactly 1, see ``trivial_deviation`` for how far the
        computed one is). For the 2-DOF oscillator ``[1, 1, mu_1, mu_2]``.
    invariant : ndarray
        ``s = mu + 1/mu`` of the full-period monodromy for the pair that sets the margin (its
        real part for a quartet; ``2 cos theta`` for an elliptic pair ``exp(+-i theta)``).
    margin : ndarray
        Distance of the invariants to where the verdict can change (:meth:`PairInvariants.margin`).
    integration_error : ndarray
        Largest ``|s(2N) - s(N)|`` of a pair between the last two step counts.
    trivial_deviation : ndarray
        ``|s_t - 2|`` of the trivial pair: the orbit's error seen by the linearization.
    orbit_error : ndarray
        Larger of the orbit's time residual of (7) and ``trivial_deviation``: the
        estimate of how far the orbit's error moves ``s``.
    steps : ndarray of int
        Steps of the stored (finer) integration.
    reason : ndarray of int
        Code of ``stability_reason`` (meanings in :mod:`nnmstop.catalogue.branch`): 0 resolved,
        1 integration error, 2 the orbit's own error, 3 resolved on the refined orbit, 4 shooting not
        converged, 5 refined orbit at a type change.
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
    invariants : PairInvariants
        All pairs' invariants.
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
    invariants: PairInvariants | None = None

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
        """Largest modulus of the non-trivial multipliers; 1 (the trivial pair) for a structure of one DOF, which
        has none."""
        if self.multipliers.shape[1] <= 2:
            return np.ones(len(self.multipliers))
        return np.abs(self.multipliers[:, 2])

    def data_vars(self) -> dict:
        """Variables for a branch dataset, ``{name: (dims, values)}`` (same names as Hill's for the shared ones;
        long names and units: :mod:`nnmstop.catalogue.branch`, ``STABILITY_VARIABLES``).

        A structure of one degree of freedom has no non-trivial pair: no ``floquet_invariant`` and no
        ``stability_margin`` (its verdict cannot change).
        """
        point, flag = ("point",), np.int8
        out = {
            "stable": (point, self.stable.astype(flag)),
            "multiplier_real": (("point", "multiplier"), self.multipliers.real),
            "multiplier_imag": (("point", "multiplier"), self.multipliers.imag),
            "max_multiplier": (point, self.max_multiplier),
            "stability_orbit_residual": (point, self.orbit_error),
            "stability_trivial_deviation": (point, self.trivial_deviation),
            "stability_resolved": (point, self.resolved.astype(flag)),
            "stability_reason": (point, self.reason.astype(flag)),
            "floquet_invariant": (point, self.invariant),
            "stability_margin": (point, self.margin),
            "stability_integration_error": (point, self.integration_error),
            "stability_steps": (point, self.steps.astype(np.int32)),
            "stability_refined": (point, self.refined.astype(flag)),
            "stability_refined_frequency_change": (point, self.refined_frequency_change),
            "stability_refined_energy_change": (point, self.refined_energy_change),
            "stability_refined_residual": (point, self.refined_residual),
        }
        if self.multipliers.shape[1] <= 2:
            del out["floquet_invariant"], out["stability_margin"]
        return out


def branch_monodromy(system, U_array, settings: MonodromySettings | None = None, time_residual=None) -> BranchMonodromy:
    """Floquet stability of every point of a branch from the monodromy matrix.

    Parameters
    ----------
    system : HarmonicBalanceSystem
        Of any structure (:class:`~nnmstop.models.structure.Structure`).
    U_array : array_like, shape (n, n_unknowns)
    settings : MonodromySettings, optional
    time_residual : array_like, shape (n,), optional
        Relative time-domain residual of the equations of motion of each orbit (the
        ``time_residual`` of :meth:`HarmonicBalanceSystem.diagnostics`, computed when not given):
        the orbit's own error, which moves ``s`` by about as much (calibration in
        ``docs/methods/monodromy.md``).

    Returns
    -------
    BranchMonodromy
    """
    start = time.perf_counter()
    settings, U_array, time_residual = _checked(system, U_array, settings, time_residual)
    n = len(U_array)
    linearization = Linearization.of(system)
    found = PairInvariants.empty(n, system.n_dofs - 1)
    err = np.zeros(n)
    steps = np.zeros(n, dtype=int)
    halfwave = np.zeros(n, dtype=bool)
    if n:
        x, omega, halfwave = _orbit_arrays(system, U_array)
        for hw in (True, False):
            idx = np.flatnonzero(halfwave == hw)
            if len(idx):
                integration = _integrate(linearization, x[idx], omega[idx], system.H, hw, time_residual[idx], settings)
                found.assign(idx, integration[0])
                err[idx], steps[idx] = integration[1:]
    trivial_deviation = found.trivial_deviation.copy()  # the HBM orbit's, also where refined
    orbit_error = np.maximum(time_residual, trivial_deviation)
    margin, _ = found.margin(halfwave, settings.trace_tol)
    F = settings.resolution_factor
    reason = np.zeros(n, dtype=np.int8)
    reason[margin <= F * err] = 1
    reason[margin <= F * orbit_error] = 2  # the orbit's error decides whatever the steps
    # beyond the calibrated range of the estimate the orbit's error decides whatever the margin
    beyond = time_residual > settings.max_orbit_residual
    reason[beyond] = 2
    if beyond.any():
        logger.warning(
            "%d of %d orbits have a time residual above max_orbit_residual = %g (largest %.3g): their own verdicts "
            "are not resolved%s",
            beyond.sum(),
            n,
            settings.max_orbit_residual,
            time_residual.max(),
            " (refined by shooting where it converges)" if settings.refine else "",
        )
    refinement = _refine(system, U_array, found, err, steps, reason, halfwave, settings)
    margin, critical = found.margin(halfwave, settings.trace_tol)
    return BranchMonodromy(
        stable=found.stable(settings.trace_tol),
        multipliers=found.multipliers(),
        invariant=np.take_along_axis(found.s.real, critical[:, None], axis=-1)[:, 0]
        if found.s.shape[1]
        else np.full(n, 2.0),
        margin=margin,
        integration_error=err,
        trivial_deviation=trivial_deviation,
        orbit_error=orbit_error,
        steps=steps,
        reason=reason,
        halfwave=halfwave,
        settings=settings,
        seconds_per_point=(time.perf_counter() - start) / max(n, 1),
        invariants=found,
        **refinement,
    )


def _checked(system, U_array, settings, time_residual):
    """The arguments of :func:`branch_monodromy` checked (ValueError naming the bad one), residuals computed."""
    settings = MonodromySettings() if settings is None else settings
    if not isinstance(settings, MonodromySettings):
        raise ValueError(f"settings must be a MonodromySettings, got {type(settings).__name__}")
    U_array = np.asarray(U_array, dtype=float)
    if U_array.ndim != 2 or U_array.shape[1] != system.n_unknowns:
        raise ValueError(f"U_array must have shape (n, {system.n_unknowns}), got {U_array.shape}")
    if not np.all(np.isfinite(U_array)):
        raise ValueError("U_array must be finite")
    n = len(U_array)
    if time_residual is None:
        time_residual = [system.diagnostics(U)["time_residual"] for U in U_array]
    time_residual = np.asarray(time_residual, dtype=float)
    if time_residual.shape != (n,) or not np.all(np.isfinite(time_residual)) or np.any(time_residual < 0):
        raise ValueError(f"time_residual must be {n} finite numbers >= 0, got shape {time_residual.shape}")
    return settings, U_array, time_residual


def _integrate(linearization, x, omega, H: int, halfwave: bool, time_residual, settings: MonodromySettings):
    """PairInvariants of orbits of one symmetry with ``steps`` and ``2 steps``, more where the integration decides.

    Returns the :class:`PairInvariants` of the finer of the last two step counts, the integration error
    (change between them) and that step count, per orbit.
    """
    F = settings.resolution_factor
    n = len(x)
    found, err, used = PairInvariants.empty(n, linearization.n_dofs - 1), np.zeros(n), np.zeros(n, dtype=int)
    N = settings.steps
    coarse = _invariants_with_steps(linearization, x, omega, H, halfwave, N)
    todo = np.arange(n)
    while len(todo):
        fine = _invariants_with_steps(linearization, x[todo], omega[todo], H, halfwave, 2 * N)
        found.assign(todo, fine)
        used[todo] = 2 * N
        err[todo] = fine.change_from(coarse)
        # More steps where the integration error could decide the verdict and exceeds the orbit's
        # own error (beyond that they cannot make the verdict better), unless s within its error
        # bound stays within F x the orbit's residual: reason 2 (and the refinement) whatever the steps.
        margin, _ = fine.margin(np.full(len(todo), halfwave), settings.trace_tol)
        residual = time_residual[todo]
        undecided = (margin <= F * err[todo]) & (err[todo] > np.maximum(residual, fine.trivial_deviation))
        undecided &= margin + err[todo] > F * residual
        if 2 * N >= settings.max_steps:
            break
        todo, coarse, N = todo[undecided], fine.select(undecided), 2 * N
    return found, err, used


def _refine(system, U_array, found: PairInvariants, err, steps, reason, halfwave, settings: MonodromySettings) -> dict:
    """Shooting refinement of the orbits whose own error decides the verdict (reason 2), in place.

    Applies to time-reversible, half-wave symmetric orbits (all NNM orbits of the branches); others
    keep reason 2. Updates ``found``, ``err``, ``steps`` and ``reason`` of the refined orbits and returns
    the diagnostics for :class:`BranchMonodromy`.
    """
    n = len(reason)
    out = {"refined": np.zeros(n, dtype=bool)}
    for name in ("refined_frequency_change", "refined_energy_change", "refined_residual"):
        out[name] = np.zeros(n)
    candidates = np.flatnonzero((reason == 2) & halfwave) if settings.refine else np.array([], dtype=int)
    idx = np.array([i for i in candidates if is_reversible(system, U_array[i])], dtype=int)
    if len(idx) and not refinable(system.structure):
        logger.warning(
            "%d orbits not refined: the shooting refinement integrates bilateral stops on one degree of freedom "
            "only; their verdicts stay the HBM orbits' (reason 2)",
            len(idx),
        )
        return out
    if not len(idx):
        return out
    # the explicit integrator must resolve the stiffest mode at two levels of steps at least
    period = 2 * np.pi / np.sqrt(np.asarray(system.split(U_array[idx])[-2], dtype=float))
    needed = explicit_steps(system.structure, period)
    stiff = 2 * needed > settings.refine_max_steps
    if stiff.any():
        logger.warning(
            "%d orbits not refined: the structure's stiffest mode needs %d Runge-Kutta steps a quarter period "
            "(h omega_max <= 0.25), above refine_max_steps / 2 = %d; their verdicts stay the HBM orbits' (reason 2)",
            stiff.sum(), needed.max(), settings.refine_max_steps // 2,
        )
        idx, needed = idx[~stiff], needed[~stiff]
    if not len(idx):
        return out
    start = time.perf_counter()
    F = settings.resolution_factor
    r = refined_stability(
        system,
        U_array[idx],
        max(settings.refine_steps, int(needed.max())),
        settings.refine_max_steps,
        settings.refine_tol,
        F,
        settings.refine_max_change,
        floor=settings.trace_tol,
    )
    ok = r.converged
    done = idx[ok]
    found.assign(done, r.invariants.select(ok))
    err[done], steps[done] = r.integration_error[ok], r.steps[ok]
    margin, _ = r.invariants.select(ok).margin(np.ones(len(done), dtype=bool), settings.trace_tol)
    # Error of the refined s: the integration error, and the orbit's closure error (which moves s by
    # about as much, as the HBM orbit's time residual does); a margin below trace_tol is a pair at +1.
    bound = F * np.maximum(err[done], r.residual[ok])  # converged: both finite
    resolved = margin > np.maximum(bound, settings.trace_tol)
    reason[done] = np.where(resolved, 3, 5)
    reason[idx[~ok]] = 4
    out["refined"][idx] = True
    out["refined_residual"][idx] = np.where(np.isfinite(r.residual), r.residual, 1.0)
    out["refined_frequency_change"][done] = r.initial_period[ok] / r.period[ok] - 1.0
    out["refined_energy_change"][done] = r.energy[ok] / r.initial_energy[ok] - 1.0
    out["refine_seconds"] = time.perf_counter() - start
    logger.info(
        "refined %d orbits by shooting in %.2f s: %d resolved, %d at a type change, %d not converged "
        "(%d of them on a singular Newton system: an orbit whose period is a multiple of its own, at an n:1 "
        "branch point)",
        len(idx),
        out["refine_seconds"],
        np.sum(reason[idx] == 3),
        np.sum(reason[idx] == 5),
        np.sum(reason[idx] == 4),
        np.sum(r.singular),
    )
    return out


def orbit_monodromy(system, U, steps: int = 1024):
    """Full-period monodromy matrix of one HBM orbit in the coordinates ``(dq, dq')`` (no symmetry used).

    For checks and diagnostics; :func:`branch_monodromy` works from the invariants.
    """
    linearization = Linearization.of(system)
    x, omega, _ = _orbit_arrays(system, np.asarray(U, dtype=float)[None])
    k = _stiffness_at_nodes(linearization, x, system.H, steps, False)
    mats = variational_step_matrices(linearization, k, 2 * np.pi / steps / omega[0])
    return linearization.to_physical(transition_matrix(mats)[0])
