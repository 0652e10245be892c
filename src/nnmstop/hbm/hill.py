r"""Floquet stability of an HBM orbit of any structure by Hill's method.

The perturbation of an orbit of the regularized equations of a structure (``N`` degrees of
freedom, any stops; mass-normalized coordinates, :mod:`nnmstop.hbm.variational`) is a Floquet
exponent times a Fourier series; its Galerkin projection is a quadratic eigenproblem in the
exponent, linearized with the contact slopes ``k_i(t) = f_i'(x_i(t))`` of the model on the HBM
orbit (symmetric, so the Hamiltonian structure is kept exactly). Two solvers:

* ``"reversible"`` (orbits even in time): a real eigenproblem in ``sigma**2`` of half the size,
  halved again by the half-wave symmetry of the NNMs, with the trivial pair deflated exactly;
* ``"companion"`` (any orbit): the first-order companion form.

The ``N - 1`` non-trivial pairs are picked by the spectral centroid of the eigenvectors. :func:`floquet`
handles one orbit; :func:`nnmstop.hbm.stability.branch_hill` runs it along a branch and builds the
dataset variables. Method notes: ``docs/methods/hill.md``; independent reference:
:mod:`nnmstop.checks.shooting`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eig

from nnmstop import fourier
from nnmstop.hbm.variational import (
    Linearization,
    check_unknowns,
    dof_coefficients,
    halfwave_symmetric,
    is_halfwave_symmetric,
    is_reversible,
    stop_coefficients,
)

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
# Distance modulo i (theta units) below which two exponents are taken as members of one family.
FAMILY_TOL = 1e-6
# Safety factor of the `resolved` flag: distance of mu_1 to the collision points over
# the orbit residual (chosen against exact orbits, docs/methods/hill.md).
RESOLUTION_FACTOR = 5.0


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class FloquetResult:
    """Floquet multipliers of one periodic orbit.

    Attributes
    ----------
    multipliers : ndarray of complex, shape (2N,)
        ``[trivial, trivial, mu_1, 1/mu_1, mu_2, ...]``: the trivial pair first (exactly
        ``1, 1`` with the reversible solver), then the ``N - 1`` non-trivial pairs by decreasing
        largest modulus, each with the larger in modulus first (``[.., mu_1, mu_2]`` for 2 DOF).
    exponents : ndarray of complex, shape (2N,)
        Centred Floquet exponents ``s`` in units of the nondimensional time, same
        order (``multipliers = exp(s T)``; defined modulo ``i omega``).
    stable : bool
        ``max_multiplier <= 1 + tol``.
    max_multiplier : float
        Largest modulus of the non-trivial pairs.
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
        Largest ``|mu mu' - 1|`` of a non-trivial pair (0 for the reversible solver, where it is exact).
    centroids : ndarray, shape (2N,)
        Spectral centroid ``kappa`` of each selected (centred) eigenvector.
    tail_fraction : float
        Largest share of a non-trivial eigenvector's power in the top tenth of the
        harmonics (small: resolved by ``H_p``).
    halfwave : bool
        Whether the half-wave symmetry was used (reversible solver only).
    margin : float
        Distance of the non-trivial pairs to the points where a pair can change type,
        the smallest over the pairs: ``|mu - 1|`` for half-wave symmetric orbits (their pairs
        cross -1 freely, see docs/methods/hill.md), ``min |mu -+ 1|`` otherwise. (Collisions of
        two pairs are not in it: docs/methods/hill.md.)
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
    """Samples of every stop's ``k_i(t) = f_i'(x_i(t))`` over one period, on ``samples`` equispaced phases.

    For a stop with two coordinates (the circular clearance) the four entries of its Jacobian, in the order of
    :attr:`Linearization.pairs`.

    Parameters
    ----------
    system : HarmonicBalanceSystem
    U : array_like
        Unknown vector of an orbit (cosine or full basis).
    linearization : {"model", "recast"}
        ``"model"``: the model's slope (:meth:`Linearization.contact_stiffness`) on the HBM
        ``x_i(t)``; ``"recast"``: ``(eta - 2 f g) / (1 - z - 2 f g / alpha)`` on the HBM fields of
        each stop, ``g = f / alpha - x`` (see docs/methods/hill.md), ``(eta + kappa f) / (1 + kappa (g + f / alpha))``
        for a one-sided law; stops with one coordinate only.
    samples : int, optional
        Number of samples (default: 8 per harmonic of the orbit, power of two).

    Returns
    -------
    ndarray, shape (P, samples)
        ``P`` the pairs of :attr:`Linearization.pairs` (one per stop with one coordinate).
    """
    if linearization not in LINEARIZATIONS:
        raise ValueError(f"linearization must be one of {LINEARIZATIONS}, got {linearization!r}")
    U = check_unknowns(system, U)
    n = _grid_size(system.H, system.H) if samples is None else samples
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < system.nfull:
        raise ValueError(f"samples must be an integer >= 2H+1 = {system.nfull}, got {samples!r}")
    x = system.to_time(stop_coefficients(system, U[None])[0], int(n))
    if linearization == "model":
        return Linearization.of(system).contact_stiffness(x)
    if system.n_components != system.n_stops:
        raise ValueError(
            "linearization 'recast' is written for stops with one coordinate; a circular clearance needs 'model'"
        )
    blocks = system.split(U)
    N, s = system.n_dofs, system.n_stops
    f_t, z_t = (system.to_time(np.stack(blocks[N + i * s : N + (i + 1) * s]), int(n)) for i in (0, 1))
    alpha, eta = np.asarray(system.alphas)[:, None], np.asarray(system.etas)[:, None]
    fg = f_t * (f_t / alpha - x)
    squared = (eta - 2.0 * fg) / (1.0 - z_t - 2.0 * fg / alpha)
    if system._bilateral:
        return squared
    kappa = system._coefficients[:, None]
    linear = (eta + kappa * f_t) / (1.0 + kappa * (z_t + f_t / alpha))
    return np.where(system._squared[:, None], squared, linear)


@dataclass
class _HillOperator:
    """Pieces of the quadratic Hill problem ``sigma**2 p + 2 sigma D p + Kt p = 0`` (mass-normalized)."""

    Kt: np.ndarray  # (N m, N m)
    H: int
    omega: float
    n_dofs: int
    velocity: np.ndarray  # orbit d/dtheta of z = L^T q on the perturbation layout, (N m,)

    @property
    def m(self):
        return 2 * self.H + 1

    def weights(self):
        """L2 weights of the perturbation coefficients (the mass is the identity), (N m,)."""
        return np.tile(np.r_[1.0, np.full(2 * self.H, 0.5)], self.n_dofs)

    def k_squared(self):
        k = np.arange(1, self.H + 1, dtype=float)
        return np.tile(np.r_[0.0, k * k, k * k], self.n_dofs)


def _orbit_velocity(system, U, H, linearization: Linearization):
    """``d/dtheta`` of ``z = L^T q`` as a perturbation vector with ``H`` harmonics per DOF."""
    Hs = system.H
    h = min(H, Hs)
    q = system.derivative(dof_coefficients(system, U[None])[0])  # (N, 2 Hs + 1)
    z = linearization.mass_factor.T @ q
    v = np.zeros((system.n_dofs, 2 * H + 1))
    v[:, 1 : h + 1] = z[:, 1 : h + 1]
    v[:, H + 1 : H + 1 + h] = z[:, Hs + 1 : Hs + 1 + h]
    return v.ravel()


def _hill_operator(system, U, harmonics, linearization, even, halfwave=False):
    U = check_unknowns(system, U)
    Hp = check_harmonics(harmonics, system.H)
    lam = float(system.split(U)[-2])
    lin = Linearization.of(system)
    slopes = contact_stiffness_series(system, U, linearization, _grid_size(system.H, Hp))
    m = 2 * Hp + 1
    d2 = -(np.r_[0.0, np.arange(1, Hp + 1), np.arange(1, Hp + 1)] ** 2)
    Kt = np.kron(np.eye(system.n_dofs), np.diag(d2)) + np.kron(lin.stiffness / lam, np.eye(m))
    for outer, a in zip(lin.stop_outer, slopes):
        Kt += np.kron(outer / lam, fourier.multiplication_matrix(a, Hp, even, halfwave))
    velocity = _orbit_velocity(system, U, Hp, lin)
    return _HillOperator(Kt=Kt, H=Hp, omega=float(np.sqrt(lam)), n_dofs=system.n_dofs, velocity=velocity)


def hill_matrix(system, U, harmonics: int | None = None, linearization: str = "model"):
    """First-order (companion) Hill matrix ``A`` of an orbit, in the phase ``theta = omega t``.

    Its eigenvalues are the Floquet exponents ``sigma = s / omega`` (all shifts
    ``sigma + i m`` included); eigenvectors are ``[p; sigma p]`` with ``p`` the
    perturbation coefficients of the mass-normalized coordinates ``z = L^T q``, DOF after DOF,
    each in the full layout.

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
    A : ndarray, shape (2 N (2 H_p + 1), 2 N (2 H_p + 1))
    omega : float
    """
    op = _hill_operator(system, U, harmonics, linearization, even=False)
    return _companion(op), op.omega


def _companion(op):
    n = op.n_dofs * op.m
    D = fourier.derivative(np.eye(op.m), op.H).T  # d/dtheta on the full layout, (c_k, s_k) -> (k s_k, -k c_k)
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -op.Kt
    A[n:, n:] = np.kron(np.eye(op.n_dofs), -2.0 * D)
    return A


# --------------------------------------------------------------------------- selection helpers


def _spectral_shape(P, H, n_dofs):
    """Centroid ``kappa`` and top-tenth power share of perturbation vectors (columns of ``P``, N m rows)."""
    m = 2 * H + 1
    power = sum(np.abs(fourier.complex_amplitudes(P[i * m : (i + 1) * m].T, H)) ** 2 for i in range(n_dofs))
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


def _one_per_family(order, sigma, count):
    """The first ``count`` indices of ``order`` whose exponents are of distinct families.

    Two members of one family differ by an integer times ``i`` (up to the truncation error), and the
    problem in ``sigma**2`` holds ``sigma`` and ``-sigma`` as one eigenvalue: a candidate within
    :data:`FAMILY_TOL` of an accepted one (or of its opposite) modulo ``i`` is another member of its family
    (the odd block of a half-wave symmetric orbit has two centred members at ``kappa = +-1``). Should fewer
    than ``count`` families be found, the nearest duplicates fill in.
    """
    picks, duplicates = [], []
    for j in order:
        same = any(
            min(_family_distance(sigma[j], sigma[a]), _family_distance(sigma[j], -sigma[a])) <= FAMILY_TOL
            for a in picks
        )
        (duplicates if same else picks).append(j)
        if len(picks) == count:
            return np.array(picks, dtype=int)
    return np.array((picks + duplicates)[:count], dtype=int)


def _pairs_first(exponents, kappa, tails):
    """Exponent pairs ``s, -s`` ordered by decreasing multiplier modulus, as arrays of ``2 (N - 1)``."""
    order = np.argsort(-np.abs(np.exp(2 * np.pi * exponents.real)), kind="stable")
    s, k = exponents[order], kappa[order]
    return np.ravel(np.column_stack([s, -s])), np.ravel(np.column_stack([k, -k])), float(np.max(tails, initial=0.0))


# --------------------------------------------------------------------------- solvers


def _solve_companion(op, tol):
    A = _companion(op)
    N = op.n_dofs
    sigma, V = eig(A, overwrite_a=True, check_finite=False)
    kappa, tail = _spectral_shape(V[: N * op.m], op.H, N)
    # Centred candidates: |kappa| <= 1/2, plus a margin for truncation; at least the 2N needed.
    order = np.argsort(np.abs(kappa), kind="stable")
    n_central = int(np.count_nonzero(np.abs(kappa) <= 0.75))
    cand = list(order[: min(max(n_central, 2 * N), 4 * N)])
    centred = sigma + 1j * np.round(kappa)
    # Trivial pair: the two centred exponents closest to 0; then each pair's member of larger real
    # part with the smallest |kappa|, and its partner nearest to the family of its opposite.
    trivial = sorted(cand, key=lambda j: abs(centred[j]))[:2]
    rest = [j for j in cand if j not in trivial]
    firsts, seconds = [], []
    for _ in range(N - 1):
        fresh = [j for j in rest if all(_family_distance(sigma[j], sigma[a]) > FAMILY_TOL for a in firsts + seconds)]
        n1 = min(fresh or rest, key=lambda j: (round(abs(kappa[j]), 6), -sigma[j].real))
        rest.remove(n1)
        n2 = min(rest, key=lambda j: (_family_distance(sigma[j], -sigma[n1]), abs(kappa[j])))
        rest.remove(n2)
        if np.exp(2 * np.pi * centred[n2].real) > np.exp(2 * np.pi * centred[n1].real):
            n1, n2 = n2, n1
        firsts.append(n1)
        seconds.append(n2)
    order = np.argsort([-centred[j].real for j in firsts], kind="stable")
    idx = np.array(trivial + [j for i in order for j in (firsts[i], seconds[i])])
    s = centred[idx]
    mu = np.exp(2 * np.pi * s)
    return _result(
        op,
        tol,
        "companion",
        mu,
        s,
        kappa[idx] - np.round(kappa[idx]),
        trivial_deviation=float(np.max(np.abs(mu[:2] - 1.0))),
        pairing_error=float(np.max(np.abs(mu[2::2] * mu[3::2] - 1.0), initial=0.0)),
        tail_fraction=float(np.max(tail[idx[2::2]], initial=0.0)),
        halfwave=False,
    )


def _reversible_problem(op, halfwave):
    """The real problem in ``mu = sigma**2`` of a reversible orbit, its trivial pair deflated.

    Returns ``(HSH, h, ci, si, nc)``: the deflated matrix (its first row and column hold the
    trivial pair), the Householder vector, the cosine and sine entries kept and their count.
    """
    m, Hp, N = op.m, op.H, op.n_dofs
    # Retained harmonics: all, or the odd ones only (half-wave symmetric orbit).
    ks = np.arange(1, Hp + 1, 2) if halfwave else np.arange(0, Hp + 1)
    ks_pos = ks[ks > 0]
    ci = np.concatenate([i * m + ks for i in range(N)])  # cosine entries of each DOF (index k is c_k, 0 the mean)
    si = np.concatenate([i * m + Hp + ks_pos for i in range(N)])  # sine entries s_k
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
    kk = np.tile(ks_pos, N).astype(float)  # harmonic of each sine entry
    row = np.searchsorted(ks, ks_pos)
    cos_of_sin = np.concatenate([i * len(ks) + row for i in range(N)])  # position of c_k in the cosine block
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
    return SH - 2.0 * np.outer(h, h @ SH), h, ci, si, nc


def _solve_reversible(op, tol, halfwave):
    HSH, h, ci, si, nc = _reversible_problem(op, halfwave)
    mu_sq, Y = eig(HSH[1:, 1:], check_finite=False)
    # Back to eigenvectors of S: z = H [alpha; y], alpha = (HSH)[0, 1:] y / mu.
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = (HSH[0, 1:] @ Y) / mu_sq
    alpha = np.where(np.isfinite(alpha), alpha, 0.0)
    Z = np.vstack([alpha, Y])
    Z = Z - 2.0 * np.outer(h, h @ Z)
    sigma = np.sqrt(mu_sq.astype(complex))
    P = np.zeros((op.n_dofs * op.m, len(sigma)), dtype=complex)
    P[ci] = Z[:nc]
    P[si] = Z[nc:] * sigma
    kappa, tail = _spectral_shape(P, op.H, op.n_dofs)
    # Centred members: smallest |kappa| (<= 1/2 with all harmonics; <= 1 within the odd block, whose
    # members are 2i apart; the shift below centres them either way), one per family.
    order = np.lexsort((-sigma.real, np.round(np.abs(kappa), 6)))
    picks = _one_per_family(order, sigma, op.n_dofs - 1)
    s = sigma[picks] + 1j * np.round(kappa[picks])
    kap = kappa[picks] - np.round(kappa[picks])
    flip = s.real < 0  # larger multiplier first
    s, kap = np.where(flip, -s, s), np.where(flip, -kap, kap)
    pairs, centroids, tail_fraction = _pairs_first(s, kap, tail[picks])
    exps = np.concatenate([[0.0, 0.0], pairs]).astype(complex)
    mu = np.exp(2 * np.pi * exps)
    mu[:2] = 1.0
    return _result(
        op,
        tol,
        "reversible",
        mu,
        exps,
        np.concatenate([[0.0, 0.0], centroids]),
        trivial_deviation=0.0,
        pairing_error=0.0,
        tail_fraction=tail_fraction,
        halfwave=halfwave,
    )


def _result(op, tol, method, mu, sigma, kappa, trivial_deviation, pairing_error, tail_fraction, halfwave):
    larger = mu[2::2]  # the larger member of each non-trivial pair
    max_mu = float(np.max(np.abs(mu[2:]), initial=1.0))
    residual = _orbit_residual(op)
    distance = np.abs(larger - 1.0) if halfwave else np.minimum(np.abs(larger - 1.0), np.abs(larger + 1.0))
    margin = float(np.min(distance, initial=np.inf))
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
