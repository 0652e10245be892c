r"""Floquet stability of the regularized NNM orbits: Hill's method on the HBM orbit.

The linearized equations
------------------------
About a periodic orbit ``(x(t), u(t))`` of the regularized equations (7), a
perturbation ``y = (y_x, y_u)`` obeys::

    M y'' + K y + [k(t) y_x, 0] = 0,      M = diag(1, delta),   K = stiffness_matrix(params),

with ``k(t) = f'(x(t))`` the slope of the contact force along the orbit. By default
(``linearization="model"``) ``k`` is :func:`nnmstop.model.regularized_contact_stiffness`
evaluated on the HBM ``x(t)``. Why this choice rather than the Jacobian of the
quadratic recast:

* it is the linearization of the equations of motion (7) themselves, the ones the
  independent check :func:`monodromy` integrates, so Hill's method and the
  monodromy matrix converge to the same multipliers;
* ``k(t)`` is a function of time only, so its Galerkin multiplication matrix is
  symmetric (in the L2 inner product of the coefficients) and the truncated Hill
  problem keeps the Hamiltonian (gyroscopic) structure of the conservative system
  *exactly*: its spectrum is symmetric under ``s -> -s`` and ``s -> conj(s)``, so a
  non-trivial multiplier pair on the unit circle stays on it whatever the
  truncation, and the verdict does not rest on a tolerance that would have to
  absorb truncation errors. The exact Galerkin linearization of the recast (Schur
  complement of the HBM Jacobian on ``f`` and ``z``) is not symmetric: elliptic
  pairs then drift off the unit circle by the truncation error, which at the stiff
  orbits of the branches (HBM time residual up to 2e-2 at H = 100) is far above
  round-off.

``linearization="recast"`` uses instead the pointwise slope implied by the recast,
``k = (eta - 2 f g) / (1 - z - 2 f g / alpha)``, ``g = f/alpha - x``, on the HBM
fields ``f, z, g`` (also symmetric). It converges to the same limit but much more
slowly: its denominator is small in contact (down to ``eps``) and amplifies the
truncation error of ``f`` and ``z``. On the H = 100 NNM1 branch it changes the
verdict at 112 of 723 points where ``"model"`` matches exact orbits; it is kept as
a diagnostic only.

Hill's method
-------------
In the phase ``theta = omega t`` the perturbation is ``y = exp(sigma theta) p(theta)``
(``s = sigma omega`` is the Floquet exponent in time units, the multiplier is
``exp(s T) = exp(2 pi sigma)``) with ``p`` a Fourier series of ``H_p`` harmonics in
the full layout ``[p_0, p_c^1..p_c^Hp, p_s^1..p_s^Hp]`` (``x`` then ``u``). With
``D`` the ``theta``-derivative of such vectors, the Galerkin projection is the
quadratic eigenproblem (divided by ``omega**2``)::

    L(sigma) p = [sigma**2 I + 2 sigma D + Kt] p = 0,
    Kt = D**2 + M^-1 (K (x) I + E (x) T_k) / omega**2,

``T_k`` the Galerkin matrix of ``w -> k w`` (Toeplitz in the Fourier coefficients of
``k`` up to harmonic ``2 H_p``, computed on a grid of at least 8 samples per orbit
harmonic), ``E`` the selector of ``y_x``.

Two solvers (``method``):

``"companion"``
    the first-order linearization ``A [p; sigma p] = sigma [p; sigma p]`` of size
    ``4 (2 H_p + 1)`` (:func:`hill_matrix`), solved by :func:`scipy.linalg.eig`.
    General (any orbit), used as a cross-check.
``"reversible"`` (default for time-reversible orbits, i.e. cosine-basis ones)
    the orbit is even in time, so ``T_k`` and ``D**2`` keep the parity of the cosine
    (``c``) and sine (``s``) parts and ``D`` swaps them. With ``p_s = sigma w`` the
    quadratic problem becomes *linear in* ``mu = sigma**2``::

        [[Kc, 0], [2 Dsc, Ks]] [p_c; w] = -mu [[I, 2 Dcs], [0, I]] [p_c; w],

    a standard eigenproblem of half the size, ``2 (2 H_p + 1)`` (8 times cheaper),
    whose eigenvalue ``mu`` gives the pair ``+-sqrt(mu)``. Its matrix is real, so a
    simple real ``mu < 0`` (an elliptic pair) stays exactly real: the pair is
    exactly on the unit circle, and instability shows as ``mu > 0`` (real pair) or
    a complex ``mu`` (period-doubling type pair, multipliers on the negative axis).

    Half-wave symmetry. The NNMs also satisfy ``(x, u)(t + T/2) = -(x, u)(t)``
    (odd harmonics only; the contact force is odd), so ``k(t)`` is ``T/2``-periodic
    (even harmonics only) and the Hill problem splits into odd-harmonic and
    even-harmonic perturbations. Each block holds a member of every exponent
    family (a shift by ``i`` moves an eigenvector by one harmonic, from one block
    to the other), so the odd block alone gives all the multipliers, with half the
    unknowns again: size ``2 H_p`` (200 at ``H_p = 100``, 64 times less work than the
    companion problem). Consequence for the physics: within a block, members are
    ``2i`` apart, so the non-trivial pair can only collide, and lose stability, at
    ``+1``; its passages through ``-1`` (seen on both branches) are crossings of
    the two blocks, which do not interact. Used when :func:`is_halfwave_symmetric`.

The trivial pair (reversible solver)
------------------------------------
An autonomous conservative system has a double multiplier +1 (time shift and
family); its Floquet vector is the orbit velocity ``v = (x', u')``, a sine series,
so in the ``mu`` problem it is the single eigenvalue ``mu = 0`` with eigenvector
``(0, v)``. On an HBM orbit ``Kt v`` is not exactly 0 but a residual of the order
of the orbit's error, which splits the pair by its square root. The reversible
solver removes that inconsistency by a rank-two update of the sine block,
symmetric in the L2 inner product (so the structure above is kept), that makes
``Ks v = 0`` exactly, then deflates the known eigenpair ``(0, (0, v))`` by a
Householder similarity. The remaining spectrum has no trivial exponent left, so
no trivial/non-trivial ambiguity remains even where the non-trivial multiplier is
close to +1 (next to bifurcations) or where the trivial eigenvectors are
ill-determined (flat frequency-energy curve, ``dT/dE ~ 0``, all along the NNM1
impact regime). The update has the size of the orbit's own error, reported as
``orbit_residual = ||Kt v|| / ||D**2 v||``; the trivial multipliers are then
exactly ``[1, 1]``. The companion solver keeps the raw problem and reports the
trivial pair it finds (the two centred exponents closest to 0), whose distance to
+1 (``trivial_deviation``) measures the same inconsistency.

Selecting the non-trivial exponents
-----------------------------------
Each true exponent ``sigma`` appears with all its shifts ``sigma + i m`` (eigenvector
shifted by ``m`` harmonics), and truncation adds inaccurate eigenvalues whose
eigenvectors pile up at the highest harmonics. For each eigenvector the *spectral
centroid* ``kappa = sum_k k |P_k|**2 / sum_k |P_k|**2`` over the complex harmonics
``P_k`` (``k = -H_p..H_p``, mass-weighted over the two dofs) moves by ``-m`` under
the shift, so in each family exactly one member has ``|kappa| <= 1/2``: the one
whose Fourier content is centred on harmonic 0 (the criterion of Lazarus & Thomas,
2010). It stays reliable at large ``H_p``: badly converged eigenvalues have
``|kappa|`` of the order of ``H_p``, far from 0, so increasing ``H_p`` only adds
far-off candidates, and it does not depend on the size of the exponents (an
exponent near ``i Omega_2 / omega = 2.6 i`` is kept as such, not folded into a
strip). The non-trivial pair is the candidate with the smallest ``|kappa|`` and its
Hamiltonian partner (``-sigma``; in the reversible solver both come from the same
``mu``). The exponents are returned centred: ``sigma + i round(kappa)``. The share
of the selected eigenvector's power in the top tenth of the harmonics
(``tail_fraction``) tells whether ``H_p`` resolves it.

Accuracy and the ``resolved`` flag
----------------------------------
Hill's method is only as good as the orbit it linearizes about. Along the H = 100
branches the HBM time residual reaches 1e-2 in the multi-impact regimes of NNM1;
there the multipliers carry an error of that order (they converge to those of
the exact orbits when the same points are recomputed with 200 and 300
harmonics). ``margin`` is the distance of ``mu_1`` to the collision point(s) where
the pair can change type and ``orbit_residual`` the size of the orbit's error in
the linearized operator; ``resolved = margin > 5 orbit_residual``. The factor was
calibrated on the whole H = 100 NNM1 branch against exact periodic orbits of (7)
(:func:`refine_orbit` + :func:`monodromy`): the 75 points where the verdicts
differ all have ``margin < 4.4 orbit_residual``; 221 of 716 points are then
flagged unresolved, mostly the ten-impact orbits (energy 240 to 2800). It is a
heuristic, not a bound.

Stability tolerance
-------------------
``stable = max |mu| <= 1 + tol`` over the non-trivial pair, default ``tol = 1e-6``.
Because the Hill problem is exactly Hamiltonian-structured (and, in the reversible
solver, elliptic pairs are exactly on the unit circle), ``tol`` only has to absorb
round-off (about ``1e-12`` at ``H_p = 100``). An orbit flagged stable with
``1 < |mu| <= 1 + 1e-6`` would need more than ``1e6`` periods to grow by a factor
e; that only happens in a sliver next to a bifurcation, whose location is anyway
known only to the accuracy of the orbit.

Independent check
-----------------
:func:`monodromy` integrates (7) and its variational equations over one period
(DOP853, tight tolerances); the eigenvalues of the monodromy matrix are the
multipliers. Started from the HBM state (:func:`orbit_initial_state`) it inherits
the HBM error, amplified over the period on unstable orbits;
:func:`refine_orbit` first makes the start state an exact periodic orbit of (7)
by shooting, which gives reference multipliers.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import eig

from .datasets import flag_variable
from .model import (
    ModelParameters,
    regularized_contact_force,
    regularized_contact_stiffness,
    stiffness_matrix,
)

__all__ = [
    "FloquetResult",
    "MonodromyResult",
    "BranchStability",
    "LINEARIZATIONS",
    "METHODS",
    "DEFAULT_TOL",
    "contact_stiffness_series",
    "hill_matrix",
    "is_reversible",
    "is_halfwave_symmetric",
    "floquet",
    "orbit_initial_state",
    "monodromy",
    "refine_orbit",
    "branch_stability",
]

LINEARIZATIONS = ("model", "recast")
METHODS = ("auto", "reversible", "companion")
DEFAULT_TOL = 1e-6
# Relative size of sine coefficients below which a full-basis orbit is taken as
# time-reversible.
REVERSIBLE_TOL = 1e-10
# Relative size of even harmonics below which an orbit is taken as half-wave symmetric.
HALFWAVE_TOL = 1e-7
# Safety factor of the `resolved` flag: distance of mu_1 to the collision points over
# the orbit residual (calibrated on the H = 100 NNM1 branch, see the module docstring).
RESOLUTION_FACTOR = 5.0


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class FloquetResult:
    """Floquet multipliers of one periodic orbit.

    Attributes
    ----------
    multipliers : ndarray of complex, shape (4,)
        ``[trivial, trivial, mu_1, mu_2]``: the trivial pair first (exactly ``1, 1``
        with the reversible solver), then the non-trivial pair, ``mu_1`` the larger
        in modulus (``mu_1 mu_2 = 1``).
    exponents : ndarray of complex, shape (4,)
        Centred Floquet exponents ``s`` in units of the nondimensional time, same
        order (``multipliers = exp(s T)``; defined modulo ``i omega``).
    stable : bool
        ``max_multiplier <= 1 + tol``.
    max_multiplier : float
        Largest modulus of the non-trivial pair.
    tol : float
        Tolerance used for ``stable``.
    period : float
        Period ``T`` of the orbit.
    method : str
        ``"reversible"`` or ``"companion"``.
    harmonics : int
        Number of harmonics ``H_p`` of the perturbation.
    orbit_residual : float
        ``||Kt v|| / ||D**2 v||`` for the orbit velocity ``v``: how far the HBM orbit
        is from solving the linearized equations' time-shift mode (its error).
    trivial_deviation : float
        ``max |mu - 1|`` over the trivial pair as computed (0 for the reversible
        solver, which makes it exact).
    pairing_error : float
        ``|mu_1 mu_2 - 1|`` (0 for the reversible solver, where it is exact).
    centroids : ndarray, shape (4,)
        Spectral centroid ``kappa`` of each selected (centred) eigenvector.
    tail_fraction : float
        Share of the non-trivial eigenvector's power in the top tenth of the
        harmonics (small: resolved by ``H_p``).
    halfwave : bool
        Whether the half-wave symmetry was used (reversible solver only).
    margin : float
        Distance of ``mu_1`` to the points where the non-trivial pair can change
        type: ``|mu_1 - 1|`` for half-wave symmetric orbits (their pair crosses -1
        freely, see the module docstring), ``min |mu_1 -+ 1|`` otherwise.
    resolved : bool
        ``margin > 5 orbit_residual``: the verdict does not hinge on the orbit's
        error (calibrated against exact orbits, module docstring).
    """

    multipliers: np.ndarray
    exponents: np.ndarray
    stable: bool
    max_multiplier: float
    tol: float
    period: float
    method: str
    harmonics: int
    orbit_residual: float
    trivial_deviation: float
    pairing_error: float
    centroids: np.ndarray
    tail_fraction: float
    halfwave: bool
    margin: float
    resolved: bool


@dataclass(frozen=True)
class MonodromyResult:
    """Monodromy matrix of the regularized equations (7) over one period.

    Attributes
    ----------
    matrix : ndarray, shape (4, 4)
        ``dz(T)/dz(0)`` for the state ``z = (x, u, xdot, udot)``.
    multipliers : ndarray of complex, shape (4,)
        Its eigenvalues, sorted by decreasing modulus.
    final_state : ndarray, shape (4,)
        The state after one period.
    closure : float
        ``|z(T) - z(0)| / |z(0)|``: how periodic the start state is for (7).
    """

    matrix: np.ndarray
    multipliers: np.ndarray
    final_state: np.ndarray
    closure: float


@dataclass
class BranchStability:
    """Stability of every point of a branch (arrays along the points).

    Attributes
    ----------
    stable : ndarray of bool, shape (n,)
    multipliers : ndarray of complex, shape (n, 4)
        Layout of :attr:`FloquetResult.multipliers`.
    exponents : ndarray of complex, shape (n, 4)
    max_multiplier, orbit_residual, margin, tail_fraction : ndarray, shape (n,)
    resolved : ndarray of bool, shape (n,)
        :attr:`FloquetResult.resolved` of each point.
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
        """Variables for a branch dataset, ``{name: (dims, values, attrs)}``.

        Dimensions ``point`` and ``multiplier`` (0..3, layout of
        :attr:`FloquetResult.multipliers`); complex values are split into real and
        imaginary parts (netCDF has no complex type).
        """
        note = (
            f"Floquet multipliers by Hill's method ({self.method} solver, {self.harmonics} harmonics on the "
            f"perturbation), ordered [trivial, trivial, mu_1, mu_2], |mu_1| >= |mu_2|"
        )
        return {
            "stable": flag_variable(
                "point",
                self.stable,
                f"orbit linearly stable (1) or unstable (0): largest |multiplier| of the non-trivial pair <= 1 + {self.tol:g}",
                "unstable stable",
                comment=note,
            ),
            "multiplier_real": (("point", "multiplier"), self.multipliers.real, {"long_name": "real part of the Floquet multipliers", "units": "1", "comment": note}),
            "multiplier_imag": (("point", "multiplier"), self.multipliers.imag, {"long_name": "imaginary part of the Floquet multipliers", "units": "1", "comment": note}),
            "max_multiplier": ("point", self.max_multiplier, {"long_name": "largest modulus of the non-trivial Floquet multiplier pair", "units": "1"}),
            "stability_orbit_residual": (
                "point",
                self.orbit_residual,
                {"long_name": "relative residual of the orbit velocity in the linearized equations (accuracy of the orbit for the stability analysis)", "units": "1"},
            ),
            "stability_resolved": flag_variable(
                "point",
                self.resolved,
                f"stability verdict resolved (1): distance of mu_1 to the collision point(s) > {RESOLUTION_FACTOR:g} x stability_orbit_residual",
                "unresolved resolved",
            ),
        }


# --------------------------------------------------------------------------- checks


def _check_unknowns(system, U):
    U = np.asarray(U, dtype=float)
    if U.shape != (system.n_unknowns,):
        raise ValueError(f"U must be one unknown vector of length {system.n_unknowns} for this system, got shape {U.shape}")
    if not np.all(np.isfinite(U)):
        raise ValueError("U must be finite")
    lam = system.split(U)[4]
    if not lam > 0:
        raise ValueError(f"omega**2 must be > 0 on a periodic orbit, got {lam!r}")
    return U


def _check_harmonics(harmonics, default):
    if harmonics is None:
        return int(default)
    if not isinstance(harmonics, (int, np.integer)) or isinstance(harmonics, bool) or harmonics < 1:
        raise ValueError(f"harmonics must be None or an integer >= 1, got {harmonics!r}")
    return int(harmonics)


def _check_tol(tol):
    if not (isinstance(tol, (int, float, np.floating)) and np.isfinite(tol) and tol >= 0):
        raise ValueError(f"tol must be a finite number >= 0, got {tol!r}")
    return float(tol)


# --------------------------------------------------------------------------- Hill operator


def _grid_size(harmonics_orbit, harmonics_perturbation):
    """Samples for the Fourier coefficients of ``k(t)`` up to harmonic ``2 H_p``.

    At least 8 samples per harmonic of the orbit (``k`` is a steep function of a
    series of ``H`` harmonics, its spectrum extends well beyond ``H``) and more than
    ``4 H_p`` (no wrap-around of the Toeplitz indices); a power of two.
    """
    need = max(8 * harmonics_orbit, 4 * harmonics_perturbation + 1, 64)
    return int(2 ** np.ceil(np.log2(need)))


def contact_stiffness_series(system, U, linearization: str = "model", samples: int | None = None):
    """Samples of ``k(t) = f'(x(t))`` over one period, on ``samples`` equispaced phases.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    U : array_like
        Unknown vector of an orbit (cosine or full basis).
    linearization : {"model", "recast"}
        ``"model"``: :func:`nnmstop.model.regularized_contact_stiffness` of the HBM
        ``x(t)``; ``"recast"``: ``(eta - 2 f g) / (1 - z - 2 f g / alpha)`` on the HBM
        fields (see the module docstring).
    samples : int, optional
        Number of samples (default: 8 per harmonic of the orbit, power of two).

    Returns
    -------
    ndarray, shape (samples,)
    """
    if linearization not in LINEARIZATIONS:
        raise ValueError(f"linearization must be one of {LINEARIZATIONS}, got {linearization!r}")
    U = _check_unknowns(system, U)
    n = _grid_size(system.H, system.H) if samples is None else samples
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < system.nfull:
        raise ValueError(f"samples must be an integer >= 2H+1 = {system.nfull}, got {samples!r}")
    p = system.params
    x, _, f, z, _, _ = system.split(U)
    if linearization == "model":
        return regularized_contact_stiffness(system.to_time(x, int(n)), p)
    g = f / p.alpha - x
    f_t, z_t, g_t = system.to_time(np.stack([f, z, g]), int(n))
    fg = f_t * g_t
    return (p.eta - 2.0 * fg) / (1.0 - z_t - 2.0 * fg / p.alpha)


def _real_multiplication_matrix(a_samples, harmonics, even: bool, halfwave: bool = False):
    """Galerkin matrix of ``w -> [a w]`` on the full real layout with ``harmonics`` harmonics.

    Built from the complex Fourier coefficients ``a_n`` (``|n| <= 2 H``) of the
    samples: Toeplitz ``T[k, l] = a_{k-l}`` on complex harmonics ``-H..H``, changed
    to the ``[c_0, c_c^k, c_s^k]`` layout. ``even`` drops the (round-off) odd part of
    ``a`` in time, so that the matrix keeps the cosine/sine parity exactly;
    ``halfwave`` drops its (round-off) odd harmonics, so that it keeps the parity of
    the harmonic numbers.
    """
    H = harmonics
    n = a_samples.shape[-1]
    spec = np.fft.fft(a_samples) / n
    if even:
        spec = spec.real.astype(complex)
    if halfwave:
        spec[1::2] = 0.0
    k = np.arange(-H, H + 1)
    T = spec[(k[:, None] - k[None, :]) % n]  # rows/columns ordered by k = -H..H
    i0 = H
    pos = i0 + np.arange(1, H + 1)
    neg = i0 - np.arange(1, H + 1)
    # Columns: complex harmonics of the real basis functions 1, cos(l t), sin(l t).
    TQ = np.empty((2 * H + 1, 2 * H + 1), dtype=complex)
    TQ[:, 0] = T[:, i0]
    TQ[:, 1 : H + 1] = 0.5 * (T[:, pos] + T[:, neg])
    TQ[:, H + 1 :] = -0.5j * (T[:, pos] - T[:, neg])
    # Rows: real coefficients from complex ones, c_k = P_k + P_-k, s_k = i (P_k - P_-k).
    R = np.empty_like(TQ)
    R[0] = TQ[i0]
    R[1 : H + 1] = TQ[pos] + TQ[neg]
    R[H + 1 :] = 1j * (TQ[pos] - TQ[neg])
    return R.real


def _derivative_matrix(harmonics):
    """``d/dtheta`` on the full real layout: ``(c_k, s_k) -> (k s_k, -k c_k)``."""
    H = harmonics
    k = np.arange(1, H + 1, dtype=float)
    D = np.zeros((2 * H + 1, 2 * H + 1))
    D[1 : H + 1, H + 1 :] = np.diag(k)
    D[H + 1 :, 1 : H + 1] = -np.diag(k)
    return D


def is_reversible(system, U) -> bool:
    """Whether an orbit is even in time (no sine content in ``x`` and ``u``).

    Always true in the cosine basis; in the full basis, true when the sine
    coefficients are below ``1e-10`` of the largest coefficient.
    """
    if not system.full:
        return True
    U = _check_unknowns(system, U)
    x, u = system.split(U)[:2]
    H = system.H
    scale = max(np.max(np.abs(x)), np.max(np.abs(u)), 1e-300)
    odd = max(np.max(np.abs(x[H + 1 :])), np.max(np.abs(u[H + 1 :])))
    return bool(odd <= REVERSIBLE_TOL * scale)


def is_halfwave_symmetric(system, U) -> bool:
    """Whether an orbit has the half-wave symmetry ``(x, u)(t + T/2) = -(x, u)(t)``.

    True when the even harmonics (mean included) of ``x`` and ``u`` are below
    ``1e-7`` of the largest coefficient. The contact force being odd, the symmetric
    orbits form an invariant subspace of the HBM system (``x, u, f`` odd harmonics,
    ``z`` even ones); continued branches keep it up to round-off drift (about
    ``2e-10`` along the H = 100 NNM1 branch).
    """
    U = _check_unknowns(system, U)
    x, u = (system.to_full(c) for c in system.split(U)[:2])
    H = system.H
    even = np.r_[0, np.arange(2, H + 1, 2), H + np.arange(2, H + 1, 2)]
    scale = max(np.max(np.abs(x)), np.max(np.abs(u)), 1e-300)
    return bool(max(np.max(np.abs(x[even])), np.max(np.abs(u[even]))) <= HALFWAVE_TOL * scale)


@dataclass
class _HillOperator:
    """Pieces of the quadratic Hill problem ``sigma**2 p + 2 sigma D p + Kt p = 0``."""

    Kt: np.ndarray  # (2m, 2m)
    H: int
    omega: float
    delta: float
    velocity: np.ndarray  # orbit d/dtheta of (x, u) on the perturbation layout, (2m,)

    @property
    def m(self):
        return 2 * self.H + 1

    def weights(self):
        """L2 (mass) weights of the perturbation coefficients, (2m,)."""
        w = np.r_[1.0, np.full(2 * self.H, 0.5)]
        return np.concatenate([w, self.delta * w])

    def k_squared(self):
        k = np.arange(1, self.H + 1, dtype=float)
        k2 = np.r_[0.0, k * k, k * k]
        return np.concatenate([k2, k2])


def _orbit_velocity(system, U, H):
    """``d/dtheta`` of ``(x, u)`` as a perturbation vector with ``H`` harmonics."""
    x, u = system.split(U)[:2]
    Hs = system.H
    h = min(H, Hs)
    out = []
    for c in (x, u):
        full = system.derivative(system.to_full(c))
        v = np.zeros(2 * H + 1)
        v[1 : h + 1] = full[1 : h + 1]
        v[H + 1 : H + 1 + h] = full[Hs + 1 : Hs + 1 + h]
        out.append(v)
    return np.concatenate(out)


def _hill_operator(system, U, harmonics, linearization, even, halfwave=False):
    U = _check_unknowns(system, U)
    Hp = _check_harmonics(harmonics, system.H)
    p = system.params
    lam = float(system.split(U)[4])
    a = contact_stiffness_series(system, U, linearization, _grid_size(system.H, Hp))
    m = 2 * Hp + 1
    T = _real_multiplication_matrix(a, Hp, even, halfwave)
    d2 = -np.r_[0.0, np.arange(1, Hp + 1), np.arange(1, Hp + 1)] ** 2
    K = stiffness_matrix(p)
    eye = np.eye(m)
    Kt = np.empty((2 * m, 2 * m))
    Kt[:m, :m] = np.diag(d2) + (K[0, 0] * eye + T) / lam
    Kt[:m, m:] = (K[0, 1] / lam) * eye
    Kt[m:, :m] = (K[1, 0] / (p.delta * lam)) * eye
    Kt[m:, m:] = np.diag(d2) + (K[1, 1] / (p.delta * lam)) * eye
    return _HillOperator(Kt=Kt, H=Hp, omega=float(np.sqrt(lam)), delta=p.delta, velocity=_orbit_velocity(system, U, Hp))


def hill_matrix(system, U, harmonics: int | None = None, linearization: str = "model"):
    """First-order (companion) Hill matrix ``A`` of an orbit, in the phase ``theta = omega t``.

    Its eigenvalues are the Floquet exponents ``sigma = s / omega`` (all shifts
    ``sigma + i m`` included); eigenvectors are ``[p; sigma p]`` with ``p`` the
    perturbation coefficients ``[p_x; p_u]`` in the full layout.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    U : array_like
        Unknown vector of the orbit.
    harmonics : int, optional
        Harmonics ``H_p`` of the perturbation (default: those of the orbit). The
        contact stiffness is always taken from the whole orbit.
    linearization : {"model", "recast"}

    Returns
    -------
    A : ndarray, shape (4 (2 H_p + 1), 4 (2 H_p + 1))
    omega : float
    """
    op = _hill_operator(system, U, harmonics, linearization, even=False)
    return _companion(op), op.omega


def _companion(op):
    m, Hp = op.m, op.H
    D = _derivative_matrix(Hp)
    A = np.zeros((4 * m, 4 * m))
    A[: 2 * m, 2 * m :] = np.eye(2 * m)
    A[2 * m :, : 2 * m] = -op.Kt
    A[2 * m : 3 * m, 2 * m : 3 * m] = -2.0 * D
    A[3 * m :, 3 * m :] = -2.0 * D
    return A


# --------------------------------------------------------------------------- selection helpers


def _complex_harmonics(P, H):
    """Complex harmonic amplitudes (``k = -H..H``) of real-layout coefficients (last axis)."""
    c0 = P[..., :1]
    c = P[..., 1 : H + 1]
    s = P[..., H + 1 :]
    pos = 0.5 * (c - 1j * s)
    neg = 0.5 * (c + 1j * s)
    return np.concatenate([neg[..., ::-1], c0, pos], axis=-1)


def _spectral_shape(P, H, delta):
    """Centroid ``kappa`` and top-tenth power share of perturbation vectors (columns of ``P``, 2m rows)."""
    m = 2 * H + 1
    px = _complex_harmonics(P[:m].T, H)
    pu = _complex_harmonics(P[m : 2 * m].T, H)
    power = np.abs(px) ** 2 + delta * np.abs(pu) ** 2
    k = np.arange(-H, H + 1)
    total = power.sum(axis=1)
    total = np.where(total > 0, total, 1.0)
    top = max(1, int(np.ceil(0.1 * H)))
    tail = power[:, np.abs(k) > H - top].sum(axis=1) / total
    return power @ k / total, tail


def _family_distance(a, b):
    """Distance between exponents ``a`` and ``b`` (``theta`` units) modulo ``i``."""
    d = a - b
    return np.abs(d.real) + np.abs(d.imag - np.round(d.imag))


def _orbit_residual(op):
    w = op.weights()
    r = op.Kt @ op.velocity
    scale = np.sqrt(np.sum(w * (op.k_squared() * op.velocity) ** 2))
    return float(np.sqrt(np.sum(w * r * r)) / scale) if scale > 0 else 0.0


# --------------------------------------------------------------------------- solvers


def _solve_companion(op, tol):
    A = _companion(op)
    sigma, V = eig(A, overwrite_a=True, check_finite=False)
    kappa, tail = _spectral_shape(V[: 2 * op.m], op.H, op.delta)
    # Centred candidates: |kappa| <= 1/2, plus a margin for truncation; at least 4.
    order = np.argsort(np.abs(kappa), kind="stable")
    n_central = int(np.count_nonzero(np.abs(kappa) <= 0.75))
    cand = list(order[: min(max(n_central, 4), 8)])
    centred = sigma + 1j * np.round(kappa)
    # Trivial pair: the two centred exponents closest to 0.
    trivial = sorted(cand, key=lambda j: abs(centred[j]))[:2]
    rest = [j for j in cand if j not in trivial]
    n1 = min(rest, key=lambda j: (round(abs(kappa[j]), 6), -sigma[j].real))
    n2 = min((j for j in rest if j != n1), key=lambda j: (_family_distance(sigma[j], -sigma[n1]), abs(kappa[j])))
    idx = np.array(trivial + [n1, n2])
    s = centred[idx]
    mu = np.exp(2 * np.pi * s)
    if abs(mu[3]) > abs(mu[2]):
        idx[[2, 3]] = idx[[3, 2]]
        s, mu = s[[0, 1, 3, 2]], mu[[0, 1, 3, 2]]
    return _result(
        op, tol, "companion", mu, s, kappa[idx] - np.round(kappa[idx]),
        trivial_deviation=float(np.max(np.abs(mu[:2] - 1.0))),
        pairing_error=float(abs(mu[2] * mu[3] - 1.0)),
        tail_fraction=float(tail[idx[2]]),
        halfwave=False,
    )


def _solve_reversible(op, tol, halfwave):
    m, Hp = op.m, op.H
    # Retained harmonics: all, or the odd ones only (half-wave symmetric orbit).
    ks = np.arange(1, Hp + 1, 2) if halfwave else np.arange(0, Hp + 1)
    ks_pos = ks[ks > 0]
    ci = np.concatenate([ks, m + ks])  # cosine entries of x then u (index k is c_k, 0 is the mean)
    si = np.concatenate([Hp + ks_pos, m + Hp + ks_pos])  # sine entries s_k
    nc, ns = len(ci), len(si)
    Kc = op.Kt[np.ix_(ci, ci)]
    Ks = op.Kt[np.ix_(si, si)].copy()
    # Consistency update of the sine block: Ks v = 0 exactly, symmetric in the L2 weights.
    v = op.velocity[si]
    ws = op.weights()[si]
    r = Ks @ v
    c = float(v @ (ws * v))
    if not c > 0:
        raise ValueError("the orbit has zero velocity: not a periodic orbit")
    wv, wr = ws * v, ws * r
    Ks -= (np.outer(r, wv) + np.outer(v, wr)) / c - (float(v @ wr) / c**2) * np.outer(v, wv)
    # D maps s_k to c_k with factor k, c_k to s_k with -k: Dcs = k, Dsc = -Dcs^T.
    kk = np.concatenate([ks_pos, ks_pos]).astype(float)  # harmonic of each sine entry
    row = np.searchsorted(ks, ks_pos)
    cos_of_sin = np.concatenate([row, len(ks) + row])  # position of c_k in the cosine block
    # S = -[[Kc - 4 Dcs Dsc, -2 Dcs Ks], [2 Dsc, Ks]]  (eigenvalue mu = sigma**2)
    n = nc + ns
    S = np.zeros((n, n))
    S[:nc, :nc] = -Kc
    S[cos_of_sin, cos_of_sin] -= 4.0 * kk * kk
    S[cos_of_sin, nc:] = 2.0 * kk[:, None] * Ks
    S[nc + np.arange(ns), cos_of_sin] = 2.0 * kk
    S[nc:, nc:] = -Ks
    # Deflate the exact eigenpair (0, (0, v)) by a Householder similarity.
    e = np.zeros(n)
    e[nc:] = v / np.linalg.norm(v)
    h = e.copy()
    h[0] += 1.0  # e[0] = 0, so h != 0 and H e = -e_0
    h /= np.linalg.norm(h)
    SH = S - 2.0 * np.outer(S @ h, h)
    HSH = SH - 2.0 * np.outer(h, h @ SH)
    mu_sq, Y = eig(HSH[1:, 1:], check_finite=False)
    # Back to eigenvectors of S: z = H [alpha; y], alpha = (HSH)[0, 1:] y / mu.
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = (HSH[0, 1:] @ Y) / mu_sq
    alpha = np.where(np.isfinite(alpha), alpha, 0.0)
    Z = np.vstack([alpha, Y])
    Z = Z - 2.0 * np.outer(h, h @ Z)
    sigma = np.sqrt(mu_sq.astype(complex))
    P = np.zeros((2 * m, len(sigma)), dtype=complex)
    P[ci] = Z[:nc]
    P[si] = Z[nc:] * sigma
    kappa, tail = _spectral_shape(P, Hp, op.delta)
    # Centred member: smallest |kappa| (<= 1/2 with all harmonics; <= 1 within the odd
    # block, whose members are 2i apart; the shift below centres it either way).
    order = np.lexsort((-sigma.real, np.round(np.abs(kappa), 6)))
    j = order[0]
    s = sigma[j] + 1j * np.round(kappa[j])
    kap = kappa[j] - np.round(kappa[j])
    if s.real < 0:  # larger multiplier first
        s, kap = -s, -kap
    exps = np.array([0.0, 0.0, s, -s], dtype=complex)
    mu = np.exp(2 * np.pi * exps)
    mu[:2] = 1.0
    return _result(
        op, tol, "reversible", mu, exps, np.array([0.0, 0.0, kap, -kap]),
        trivial_deviation=0.0, pairing_error=0.0, tail_fraction=float(tail[j]), halfwave=halfwave,
    )


def _result(op, tol, method, mu, sigma, kappa, trivial_deviation, pairing_error, tail_fraction, halfwave):
    max_mu = float(np.max(np.abs(mu[2:])))
    residual = _orbit_residual(op)
    margin = float(abs(mu[2] - 1.0) if halfwave else min(abs(mu[2] - 1.0), abs(mu[2] + 1.0)))
    return FloquetResult(
        multipliers=mu,
        exponents=sigma * op.omega,
        stable=bool(max_mu <= 1.0 + tol),
        max_multiplier=max_mu,
        tol=float(tol),
        period=float(2 * np.pi / op.omega),
        method=method,
        harmonics=int(op.H),
        orbit_residual=residual,
        trivial_deviation=trivial_deviation,
        pairing_error=pairing_error,
        centroids=np.asarray(kappa, dtype=float),
        tail_fraction=tail_fraction,
        halfwave=bool(halfwave),
        margin=margin,
        resolved=bool(margin > RESOLUTION_FACTOR * residual),
    )


# --------------------------------------------------------------------------- Floquet


def floquet(
    system,
    U,
    harmonics: int | None = None,
    tol: float = DEFAULT_TOL,
    linearization: str = "model",
    method: str = "auto",
    symmetry: bool = True,
) -> FloquetResult:
    """Floquet multipliers of one HBM orbit by Hill's method.

    Parameters
    ----------
    system : HarmonicBalanceSystem
        The system of the orbit (cosine or full basis).
    U : array_like
        Unknown vector of the orbit.
    harmonics : int, optional
        Harmonics ``H_p`` of the perturbation (default: those of the orbit).
    tol : float
        Stability tolerance on the modulus of the non-trivial multipliers (>= 0).
    linearization : {"model", "recast"}
        How ``f'(x(t))`` is obtained (module docstring).
    method : {"auto", "reversible", "companion"}
        Eigensolver (module docstring); ``"auto"`` takes ``"reversible"`` for
        time-reversible orbits (:func:`is_reversible`) and ``"companion"`` otherwise.
    symmetry : bool
        With the reversible solver, use the half-wave symmetry of the orbit when it
        has it (:func:`is_halfwave_symmetric`): half the unknowns again.

    Returns
    -------
    FloquetResult

    Raises
    ------
    ValueError
        On a bad argument, or ``method="reversible"`` for an orbit that is not
        time-reversible.

    Examples
    --------
    >>> from nnmstop.hbm import HarmonicBalanceSystem
    >>> from nnmstop.model import ModelParameters
    >>> from nnmstop.models.structure import two_dof_structure
    >>> system = HarmonicBalanceSystem(two_dof_structure(ModelParameters()), harmonics=8)
    >>> r = floquet(system, system.linear_mode_guess(1, 0.1))
    >>> r.stable, float(r.max_multiplier)
    (True, 1.0)
    """
    tol = _check_tol(tol)
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if linearization not in LINEARIZATIONS:
        raise ValueError(f"linearization must be one of {LINEARIZATIONS}, got {linearization!r}")
    reversible = is_reversible(system, U)
    if method == "auto":
        method = "reversible" if reversible else "companion"
    if method == "reversible" and not reversible:
        raise ValueError("method='reversible' needs a time-reversible orbit (no sine content in x and u)")
    if method == "companion":
        return _solve_companion(_hill_operator(system, U, harmonics, linearization, even=False), tol)
    halfwave = bool(symmetry) and is_halfwave_symmetric(system, U)
    op = _hill_operator(system, U, harmonics, linearization, even=True, halfwave=halfwave)
    return _solve_reversible(op, tol, halfwave)


# --------------------------------------------------------------------------- monodromy


def orbit_initial_state(system, U):
    """State ``(x, u, xdot, udot)`` of an HBM orbit at ``t = 0`` and its period ``T``."""
    U = _check_unknowns(system, U)
    x, u, _, _, lam, _ = system.split(U)
    omega = float(np.sqrt(lam))
    xf, uf = system.to_full(x), system.to_full(u)
    H = system.H
    k = np.arange(1, H + 1)
    state = np.array(
        [
            xf[0] + xf[1 : H + 1].sum(),
            uf[0] + uf[1 : H + 1].sum(),
            omega * np.dot(k, xf[H + 1 :]),
            omega * np.dot(k, uf[H + 1 :]),
        ]
    )
    return state, 2 * np.pi / omega


def _check_params(params):
    if not isinstance(params, ModelParameters):
        raise ValueError(f"params must be a ModelParameters, got {type(params).__name__}")


def _check_state(state0):
    z0 = np.asarray(state0, dtype=float)
    if z0.shape != (4,) or not np.all(np.isfinite(z0)):
        raise ValueError(f"state0 must be 4 finite numbers (x, u, xdot, udot), got {state0!r}")
    return z0


def _check_period(period):
    if not (np.isfinite(period) and period > 0):
        raise ValueError(f"period must be finite and > 0, got {period!r}")
    return float(period)


def _variational_flow(params: ModelParameters, z0, t_end, rtol, atol):
    """State and fundamental matrix of (7) at ``t_end`` (DOP853).

    The regularized force is the admissible root of the cubic; instead of solving the
    cubic at every evaluation, the integrated displacement of the first mass is the
    branch coordinate ``y = x - f/alpha`` (``= -g`` of :mod:`nnmstop.model`), from
    which the exact rational parametrization gives, with ``s = c - y**2``,
    ``c = 1 - eps``::

        x = y + eps y / s,   f = eta y / s,   f'(x) = eta (c + y**2) / (s**2 + eps (c + y**2)),
        dy/dt = xdot / (dx/dy),   dx/dy = 1 + eps (c + y**2) / s**2.

    This is the same force as :func:`nnmstop.model.regularized_contact_force` (the
    start ``y`` is taken from it), evaluated in closed form: it makes the integration
    an order of magnitude faster. The variational equations are those of the
    original coordinates ``(x, u, xdot, udot)``.
    """
    b, d = params.beta, params.delta
    eta, eps = params.eta, params.eps
    c = 1.0 - eps
    sqrt_c = float(np.sqrt(c))

    def parts(y):
        ay = abs(y)
        s = (sqrt_c - ay) * (sqrt_c + ay)  # c - y**2 without cancellation in the subtraction
        q = c + y * y
        return s, q

    def rhs(t, w):
        y, u, xd, ud = w[0], w[1], w[2], w[3]
        s, q = parts(y)
        x = y + eps * y / s
        f = eta * y / s
        kx = eta * q / (s * s + eps * q)
        dxdy = 1.0 + eps * q / (s * s)
        phi = w[4:].reshape(4, 4)
        out = np.empty(20)
        out[0] = xd / dxdy
        out[1] = ud
        out[2] = -(1.0 + b) * x + b * u - f
        out[3] = b * (x - u) / d
        dphi = out[4:].reshape(4, 4)
        dphi[0] = phi[2]
        dphi[1] = phi[3]
        dphi[2] = -(1.0 + b + kx) * phi[0] + b * phi[1]
        dphi[3] = (b / d) * (phi[0] - phi[1])
        return out

    x0 = float(z0[0])
    y0 = x0 - float(regularized_contact_force(np.array([x0]), params)[0]) / params.alpha
    w0 = np.concatenate([[y0], z0[1:], np.eye(4).ravel()])
    sol = solve_ivp(rhs, (0.0, float(t_end)), w0, method="DOP853", rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"variational integration failed: {sol.message}")
    wT = sol.y[:, -1]
    s, _ = parts(wT[0])
    zT = np.array([wT[0] + eps * wT[0] / s, wT[1], wT[2], wT[3]])
    return zT, wT[4:].reshape(4, 4).copy(), rhs


def monodromy(params: ModelParameters, state0, period, rtol: float = 1e-12, atol: float = 1e-12) -> MonodromyResult:
    """Monodromy matrix of the regularized equations (7) by direct integration.

    Integrates ``z = (x, u, xdot, udot)`` and the variational equations
    ``Phi' = J(z) Phi``, ``Phi(0) = I``, over one period with DOP853; the contact
    force and its slope are those of :mod:`nnmstop.model` (true root of the cubic,
    evaluated through its exact rational parametrization, see
    :func:`_variational_flow`).

    Parameters
    ----------
    params : ModelParameters
    state0 : array_like, shape (4,)
        Start state, e.g. from :func:`orbit_initial_state` (or :func:`refine_orbit`).
    period : float
        Integration time (> 0).
    rtol, atol : float
        Tolerances of :func:`scipy.integrate.solve_ivp`.

    Returns
    -------
    MonodromyResult
    """
    _check_params(params)
    z0 = _check_state(state0)
    period = _check_period(period)
    if not (rtol > 0 and atol > 0):
        raise ValueError(f"rtol and atol must be > 0, got {rtol!r}, {atol!r}")
    zT, Phi, _ = _variational_flow(params, z0, period, rtol, atol)
    mu = np.linalg.eigvals(Phi)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    closure = float(np.linalg.norm(zT - z0) / max(np.linalg.norm(z0), 1e-300))
    return MonodromyResult(matrix=Phi, multipliers=mu, final_state=zT, closure=closure)


def refine_orbit(params: ModelParameters, state0, period, tol: float = 1e-11, max_iter: int = 20, rtol: float = 1e-12, atol: float = 1e-12):
    """Exact time-reversible periodic orbit of (7) near an HBM orbit, by shooting.

    A time-reversible orbit that starts at rest (``xdot = udot = 0``) is at rest
    again at ``T/2``. Keeping ``x(0)`` fixed (the period is nearly flat along parts of
    the branches, so fixing ``T`` would be ill-conditioned there), Newton's method
    on ``(u(0), T)`` solves ``xdot(T/2) = udot(T/2) = 0``.

    Parameters
    ----------
    params : ModelParameters
    state0 : array_like, shape (4,)
        Start state ``(x, u, 0, 0)`` (velocities must vanish: cosine-basis orbit).
    period : float
        Period guess.
    tol : float
        Convergence tolerance on the half-period velocities relative to the peak
        velocity scale ``|x(0)| 2 pi / T``.

    Returns
    -------
    state : ndarray, shape (4,)
    period : float

    Raises
    ------
    ValueError
        If the start velocities are not zero.
    RuntimeError
        If Newton's method does not converge.
    """
    _check_params(params)
    z = _check_state(state0).copy()
    T = _check_period(period)
    scale = max(abs(z[0]), abs(z[1]), 1e-300)
    if abs(z[2]) > 1e-8 * scale * 2 * np.pi / T or abs(z[3]) > 1e-8 * scale * 2 * np.pi / T:
        raise ValueError(f"state0 must start at rest (xdot = udot = 0) for a time-reversible orbit, got {state0!r}")
    z[2:] = 0.0
    for _ in range(max_iter):
        zh, Phi, rhs = _variational_flow(params, z, T / 2, rtol, atol)
        r = zh[2:]
        if np.max(np.abs(r)) <= tol * scale * 2 * np.pi / T:
            return z, T
        # d(xdot, udot)(T/2) / d(u0, T): Phi column of u0; accelerations at T/2 times 1/2.
        acc = np.array([-(1 + params.beta) * zh[0] + params.beta * zh[1] - float(regularized_contact_force(np.array([zh[0]]), params)[0]),
                        params.beta * (zh[0] - zh[1]) / params.delta])
        J = np.column_stack([Phi[2:, 1], 0.5 * acc])
        du, dT = np.linalg.solve(J, -r)
        z[1] += du
        T += dT
    raise RuntimeError(f"shooting did not converge in {max_iter} iterations (half-period velocities {r})")


# --------------------------------------------------------------------------- branches


def branch_stability(
    system,
    U_array,
    harmonics: int | None = None,
    tol: float = DEFAULT_TOL,
    linearization: str = "model",
    method: str = "auto",
    symmetry: bool = True,
    progress=None,
    blas_threads: int | None = 1,
) -> BranchStability:
    """Floquet stability of every point of a branch.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    U_array : array_like, shape (n, n_unknowns)
        Unknown vectors of the points (e.g. from
        :func:`nnmstop.branches.dataset_unknowns`).
    harmonics, tol, linearization, method, symmetry
        As in :func:`floquet`.
    progress : callable, optional
        Called as ``progress(i, n)`` after each point.
    blas_threads : int or None
        Limit of BLAS threads during the loop when :mod:`threadpoolctl` is installed
        (None: leave as is). Otherwise set ``OPENBLAS_NUM_THREADS=1`` in the
        environment (see Notes).

    Returns
    -------
    BranchStability

    Notes
    -----
    One dense eigenproblem per point: size ``2 H_p`` for half-wave symmetric
    orbits (200 at ``H_p = 100``, about 0.03 s a point), ``2 (2 H_p + 1) - 1`` for
    other reversible ones, ``4 (2 H_p + 1)`` with the companion solver. LAPACK's
    Hessenberg QR is sequential: on a shared machine oversubscribed BLAS threads
    slow it down by an order of magnitude (0.6 s instead of 0.05 s a point measured
    here), hence ``blas_threads=1``; split long branches between processes
    instead.
    """
    U_array = np.asarray(U_array, dtype=float)
    if U_array.ndim != 2 or U_array.shape[1] != system.n_unknowns:
        raise ValueError(f"U_array must have shape (n, {system.n_unknowns}), got {U_array.shape}")
    tol = _check_tol(tol)
    Hp = _check_harmonics(harmonics, system.H)
    if blas_threads is not None and (not isinstance(blas_threads, (int, np.integer)) or isinstance(blas_threads, bool) or blas_threads < 1):
        raise ValueError(f"blas_threads must be None or an integer >= 1, got {blas_threads!r}")
    n = len(U_array)
    mult = np.empty((n, 4), dtype=complex)
    expo = np.empty((n, 4), dtype=complex)
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
    return BranchStability(
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
