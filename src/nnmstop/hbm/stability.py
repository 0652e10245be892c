"""Floquet stability of the orbits of a branch of any structure: Hill's method or the monodromy matrix.

:func:`orbit_stability` is the one interface, for every :class:`~nnmstop.models.structure.Structure`
(the paper's oscillator, the finite-element tube, a user's matrices) and what dataset assembly calls:
it dispatches on :attr:`StabilitySettings.method` (config ``stability.method``) to

* ``"monodromy"`` (default): :func:`nnmstop.hbm.monodromy.branch_monodromy`
  (``docs/methods/monodromy.md``), or
* ``"hill"``: :func:`branch_hill`, Hill's method of :mod:`nnmstop.hbm.hill` on every orbit
  (``docs/methods/hill.md``).

Both return an object whose ``data_vars()`` gives the dataset variables as plain arrays: ``stable``,
``multiplier_real``/``multiplier_imag(point, multiplier)``, ``max_multiplier``,
``stability_orbit_residual``, ``stability_resolved`` (and for the monodromy its reason code and
error estimates); their long names and units are in :mod:`nnmstop.catalogue.branch`. Damped and
forced systems (no Hamiltonian structure, no trivial pair) use the general path
:func:`nnmstop.floquet.periodic_floquet`.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field

import numpy as np

from nnmstop.hbm.hill import DEFAULT_TOL, check_harmonics, check_tolerance, floquet
from nnmstop.hbm.monodromy import MonodromySettings, branch_monodromy

__all__ = ["STABILITY_METHODS", "StabilitySettings", "BranchHill", "branch_hill", "orbit_stability"]

STABILITY_METHODS = ("monodromy", "hill")


@dataclass(frozen=True)
class StabilitySettings:
    """How the stability of branch orbits is computed (config section ``stability``).

    Attributes
    ----------
    method : {"monodromy", "hill"}
    hill_tol : float
        Hill's method: stable when the largest non-trivial ``|mu| <= 1 + hill_tol``.
    monodromy : MonodromySettings
        Settings of the monodromy method.
    """

    method: str = "monodromy"
    hill_tol: float = DEFAULT_TOL
    monodromy: MonodromySettings = field(default_factory=MonodromySettings)

    def __post_init__(self):
        if self.method not in STABILITY_METHODS:
            raise ValueError(f"stability.method must be one of {STABILITY_METHODS}, got {self.method!r}")
        check_tolerance(self.hill_tol)
        if not isinstance(self.monodromy, MonodromySettings):
            raise ValueError(f"monodromy must be a MonodromySettings, got {type(self.monodromy).__name__}")


def orbit_stability(system, U_array, settings: StabilitySettings, time_residual=None):
    """Floquet stability of the orbits ``U_array`` of a branch by the method of ``settings``.

    Parameters
    ----------
    system : HarmonicBalanceSystem
        Of any structure: ``N`` degrees of freedom, any stops.
    U_array : array_like, shape (n, n_unknowns)
    settings : StabilitySettings
    time_residual : array_like, shape (n,), optional
        The orbits' time residuals (:meth:`HarmonicBalanceSystem.diagnostics`), if already at hand;
        an orbit whose residual exceeds ``settings.monodromy.max_orbit_residual`` gets no resolved
        verdict of its own (either method).

    Returns
    -------
    BranchMonodromy or BranchHill
        Its ``data_vars()`` are the dataset variables; ``multipliers`` has ``2N`` columns, the trivial
        pair first.

    Examples
    --------
    The 3-DOF example (a grounded chain with one stop), two orbits near rest: every pair elliptic.

    >>> import numpy as np
    >>> from nnmstop.hbm.stages import start_point
    >>> from nnmstop.hbm.system import HarmonicBalanceSystem
    >>> from nnmstop.models.structure import Stop, Structure
    >>> chain = Structure(np.eye(3), [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]],
    ...                   [Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)])
    >>> system = HarmonicBalanceSystem(chain, 8)
    >>> U = np.array([start_point(system, 1, a)[0] for a in (1e-3, 2e-3)])
    >>> result = orbit_stability(system, U, StabilitySettings())
    >>> result.multipliers.shape, result.stable.tolist(), result.resolved.tolist()
    ((2, 6), [True, True], [True, True])
    """
    if not isinstance(settings, StabilitySettings):
        raise ValueError(f"settings must be a StabilitySettings, got {type(settings).__name__}")
    if settings.method == "monodromy":
        return branch_monodromy(system, U_array, settings.monodromy, time_residual=time_residual)
    result = branch_hill(system, U_array, tol=settings.hill_tol)
    if time_residual is None:
        time_residual = [system.diagnostics(U)["time_residual"] for U in np.asarray(U_array, dtype=float)]
    # no verdict of its own on an orbit beyond the calibrated range of the orbit-error estimate
    result.resolved &= np.asarray(time_residual, dtype=float) <= settings.monodromy.max_orbit_residual
    return result


@dataclass
class BranchHill:
    """Stability of every point of a branch by Hill's method (arrays along the points).

    Attributes
    ----------
    stable : ndarray of bool, shape (n,)
    multipliers : ndarray of complex, shape (n, 4)
        Layout of :attr:`nnmstop.hbm.hill.FloquetResult.multipliers`.
    exponents : ndarray of complex, shape (n, 4)
    max_multiplier, orbit_residual, margin, tail_fraction : ndarray, shape (n,)
    resolved : ndarray of bool, shape (n,)
        :attr:`nnmstop.hbm.hill.FloquetResult.resolved` of each point.
    tol : float
    harmonics : int
    method : str
    seconds_per_point : float
        Mean wall time per point.
    """

    stable: np.ndarray
    multipliers: np.ndarray
    exponents: np.ndarray
    max_multiplier: np.ndarray
    orbit_residual: np.ndarray
    margin: np.ndarray
    resolved: np.ndarray
    tail_fraction: np.ndarray
    tol: float
    harmonics: int
    method: str
    seconds_per_point: float = 0.0

    def data_vars(self) -> dict:
        """Variables for a branch dataset, ``{name: (dims, values)}``: dimensions ``point`` and ``multiplier``
        (layout of :attr:`nnmstop.hbm.hill.FloquetResult.multipliers`); complex values split into real and
        imaginary parts (netCDF has no complex type). Long names and units: :mod:`nnmstop.catalogue.branch`.
        """
        return {
            "stable": ("point", self.stable.astype(np.int8)),
            "multiplier_real": (("point", "multiplier"), self.multipliers.real),
            "multiplier_imag": (("point", "multiplier"), self.multipliers.imag),
            "max_multiplier": ("point", self.max_multiplier),
            "stability_orbit_residual": ("point", self.orbit_residual),
            "stability_resolved": ("point", self.resolved.astype(np.int8)),
        }


def branch_hill(
    system,
    U_array,
    harmonics: int | None = None,
    tol: float = DEFAULT_TOL,
    linearization: str = "model",
    method: str = "auto",
    symmetry: bool = True,
    progress=None,
    blas_threads: int | None = 1,
) -> BranchHill:
    """Floquet stability of every point of a branch.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    U_array : array_like, shape (n, n_unknowns)
        Unknown vectors of the points (e.g. from
        :func:`nnmstop.hbm.dataset.dataset_unknowns`).
    harmonics, tol, linearization, method, symmetry
        As in :func:`nnmstop.hbm.hill.floquet`.
    progress : callable, optional
        Called as ``progress(i, n)`` after each point.
    blas_threads : int or None
        Limit of BLAS threads during the loop when :mod:`threadpoolctl` is installed
        (None: leave as is). Otherwise set ``OPENBLAS_NUM_THREADS=1`` in the
        environment (the cost section of docs/methods/hill.md).

    Returns
    -------
    BranchHill
    """
    U_array = np.asarray(U_array, dtype=float)
    if U_array.ndim != 2 or U_array.shape[1] != system.n_unknowns:
        raise ValueError(f"U_array must have shape (n, {system.n_unknowns}), got {U_array.shape}")
    tol = check_tolerance(tol)
    Hp = check_harmonics(harmonics, system.H)
    if blas_threads is not None and (
        not isinstance(blas_threads, (int, np.integer)) or isinstance(blas_threads, bool) or blas_threads < 1
    ):
        raise ValueError(f"blas_threads must be None or an integer >= 1, got {blas_threads!r}")
    n = len(U_array)
    mult = np.empty((n, 2 * system.n_dofs), dtype=complex)
    expo = np.empty((n, 2 * system.n_dofs), dtype=complex)
    stable = np.empty(n, dtype=bool)
    max_mu, resid, margin, tailf = (np.empty(n) for _ in range(4))
    resolved = np.empty(n, dtype=bool)
    methods = set()
    start = time.perf_counter()
    with _blas_thread_limit(blas_threads):
        for i, U in enumerate(U_array):
            r = floquet(system, U, harmonics=Hp, tol=tol, linearization=linearization, method=method, symmetry=symmetry)
            mult[i], expo[i], stable[i] = r.multipliers, r.exponents, r.stable
            max_mu[i], resid[i], margin[i], tailf[i] = r.max_multiplier, r.orbit_residual, r.margin, r.tail_fraction
            resolved[i] = r.resolved
            methods.add(r.method)
            if progress is not None:
                progress(i, n)
    elapsed = time.perf_counter() - start
    return BranchHill(
        stable=stable,
        multipliers=mult,
        exponents=expo,
        max_multiplier=max_mu,
        orbit_residual=resid,
        margin=margin,
        resolved=resolved,
        tail_fraction=tailf,
        tol=tol,
        harmonics=Hp,
        method="+".join(sorted(methods)) if methods else method,
        seconds_per_point=elapsed / max(n, 1),
    )


def _blas_thread_limit(threads):
    """Context limiting the BLAS threads with threadpoolctl when available."""
    if threads is None:
        return contextlib.nullcontext()
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=int(threads), user_api="blas")
