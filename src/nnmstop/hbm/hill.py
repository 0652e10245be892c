r"""Floquet stability of an HBM orbit by Hill's method.

The perturbation of an orbit of the regularized equations (7) is a Floquet exponent times a
Fourier series; its Galerkin projection is a quadratic eigenproblem in the exponent, linearized
with the contact slope ``k(t) = f'(x(t))`` of the model on the HBM ``x(t)`` (symmetric, so the
Hamiltonian structure is kept exactly). Two solvers:

* ``"reversible"`` (orbits even in time): a real eigenproblem in ``sigma**2`` of half the size,
  halved again by the half-wave symmetry of the NNMs, with the trivial pair deflated exactly;
* ``"companion"`` (any orbit): the first-order companion form.

The non-trivial pair is picked by the spectral centroid of the eigenvectors. :func:`floquet`
handles one orbit; :func:`nnmstop.hbm.stability.branch_hill` runs it along a branch and builds the
dataset variables. Method notes: ``docs/methods/hill.md``; independent reference:
:mod:`nnmstop.checks.shooting`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eig

from nnmstop import fourier
from nnmstop.models.structure import two_dof_parameters
from nnmstop.models.two_dof import regularized_contact_stiffness, stiffness_matrix

__all__ = [
    "FloquetResult",
    "LINEARIZATIONS",
    "METHODS",
    "DEFAULT_TOL",
    "RESOLUTION_FACTOR",
    "contact_stiffness_series",
    "hill_matrix",
    "is_reversible",
    "is_halfwave_symmetric",
    "halfwave_symmetric",
    "floquet",
    "check_unknowns",
    "check_tolerance",
    "check_harmonics",
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
# the orbit residual (chosen against exact orbits, docs/methods/hill.md).
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
        freely, see docs/methods/hill.md), ``min |mu_1 -+ 1|`` otherwise.
    resolved : bool
        ``margin > 5 orbit_residual``: the verdict does not hinge on the orbit's
        error (a heuristic factor, docs/methods/hill.md).
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


# --------------------------------------------------------------------------- checks


def check_unknowns(system, U):
    """``U`` as one finite unknown vector of ``system`` with ``omega**2 > 0`` (ValueError otherwise)."""
    U = np.asarray(U, dtype=float)
    if U.shape != (system.n_unknowns,):
        raise ValueError(
            f"U must be one unknown vector of length {system.n_unknowns} for this system, got shape {U.shape}"
        )
    if not np.all(np.isfinite(U)):
        raise ValueError("U must be finite")
    lam = system.split(U)[4]
    if not lam > 0:
        raise ValueError(f"omega**2 must be > 0 on a periodic orbit, got {lam!r}")
    return U


def check_harmonics(harmonics, default):
    """Harmonics ``H_p`` of the perturbation: ``default`` for None, else an integer >= 1 (ValueError)."""
    if harmonics is None:
        return int(default)
    if not isinstance(harmonics, (int, np.integer)) or isinstance(harmonics, bool) or harmonics < 1:
        raise ValueError(f"harmonics must be None or an integer >= 1, got {harmonics!r}")
    return int(harmonics)


def check_tolerance(tol):
    """Stability tolerance on ``|mu|`` as a float: a finite number >= 0 (ValueError otherwise)."""
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
        ``"model"``: :func:`nnmstop.models.two_dof.regularized_contact_stiffness` of the HBM
        ``x(t)``; ``"recast"``: ``(eta - 2 f g) / (1 - z - 2 f g / alpha)`` on the HBM
        fields (see docs/methods/hill.md).
    samples : int, optional
        Number of samples (default: 8 per harmonic of the orbit, power of two).

    Returns
    -------
    ndarray, shape (samples,)
    """
    if linearization not in LINEARIZATIONS:
        raise ValueError(f"linearization must be one of {LINEARIZATIONS}, got {linearization!r}")
    U = check_unknowns(system, U)
    n = _grid_size(system.H, system.H) if samples is None else samples
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < system.nfull:
        raise ValueError(f"samples must be an integer >= 2H+1 = {system.nfull}, got {samples!r}")
    p = two_dof_parameters(system.structure, "Hill's method")
    x, _, f, z, _, _ = system.split(U)
    if linearization == "model":
        return regularized_contact_stiffness(system.to_time(x, int(n)), p)
    g = f / p.alpha - x
    f_t, z_t, g_t = system.to_time(np.stack([f, z, g]), int(n))
    fg = f_t * g_t
    return (p.eta - 2.0 * fg) / (1.0 - z_t - 2.0 * fg / p.alpha)


def is_reversible(system, U) -> bool:
    """Whether an orbit is even in time (no sine content in ``x`` and ``u``).

    Always true in the cosine basis; in the full basis, true when the sine
    coefficients are below ``1e-10`` of the largest coefficient.
    """
    if not system.full:
        return True
    U = check_unknowns(system, U)
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
    return bool(halfwave_symmetric(system, check_unknowns(system, U)[None])[0])


def halfwave_symmetric(system, U_array) -> np.ndarray:
    """:func:`is_halfwave_symmetric` for each row of ``U_array`` (shape (n, n_unknowns), checked by the caller)."""
    x, u = (system.to_full(c) for c in system.split(np.asarray(U_array, dtype=float))[:2])
    H = system.H
    even = np.r_[0, np.arange(2, H + 1, 2), H + np.arange(2, H + 1, 2)]
    scale = np.maximum(np.maximum(np.abs(x).max(axis=-1), np.abs(u).max(axis=-1)), 1e-300)
    even_max = np.maximum(np.abs(x[:, even]).max(axis=-1), np.abs(u[:, even]).max(axis=-1))
    return even_max <= HALFWAVE_TOL * scale


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
    U = check_unknowns(system, U)
    Hp = check_harmonics(harmonics, system.H)
    p = two_dof_parameters(system.structure, "Hill's method")
    lam = float(system.split(U)[4])
    a = contact_stiffness_series(system, U, linearization, _grid_size(system.H, Hp))
    m = 2 * Hp + 1
    T = fourier.multiplication_matrix(a, Hp, even, halfwave)
    d2 = -(np.r_[0.0, np.arange(1, Hp + 1), np.arange(1, Hp + 1)] ** 2)
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
    D = fourier.derivative(np.eye(m), Hp).T  # d/dtheta on the full layout, (c_k, s_k) -> (k s_k, -k c_k)
    A = np.zeros((4 * m, 4 * m))
    A[: 2 * m, 2 * m :] = np.eye(2 * m)
    A[2 * m :, : 2 * m] = -op.Kt
    A[2 * m : 3 * m, 2 * m : 3 * m] = -2.0 * D
    A[3 * m :, 3 * m :] = -2.0 * D
    return A


# --------------------------------------------------------------------------- selection helpers


def _spectral_shape(P, H, delta):
    """Centroid ``kappa`` and top-tenth power share of perturbation vectors (columns of ``P``, 2m rows)."""
    m = 2 * H + 1
    px = fourier.complex_amplitudes(P[:m].T, H)
    pu = fourier.complex_amplitudes(P[m : 2 * m].T, H)
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
        op,
        tol,
        "companion",
        mu,
        s,
        kappa[idx] - np.round(kappa[idx]),
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
        op,
        tol,
        "reversible",
        mu,
        exps,
        np.array([0.0, 0.0, kap, -kap]),
        trivial_deviation=0.0,
        pairing_error=0.0,
        tail_fraction=float(tail[j]),
        halfwave=halfwave,
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
        How ``f'(x(t))`` is obtained (docs/methods/hill.md).
    method : {"auto", "reversible", "companion"}
        Eigensolver (docs/methods/hill.md); ``"auto"`` takes ``"reversible"`` for
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
    >>> from nnmstop.hbm.system import HarmonicBalanceSystem
    >>> from nnmstop.models.two_dof import ModelParameters
    >>> from nnmstop.models.structure import two_dof_structure
    >>> system = HarmonicBalanceSystem(two_dof_structure(ModelParameters()), harmonics=8)
    >>> r = floquet(system, system.linear_mode_guess(1, 0.1))
    >>> r.stable, float(r.max_multiplier)
    (True, 1.0)
    """
    tol = check_tolerance(tol)
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
