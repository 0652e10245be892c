"""Floquet theory of linear periodic systems ``y' = A(t) y``: monodromy matrices and multipliers.

Map (method notes: ``docs/methods/monodromy.md``):

* batched matrix exponentials: :func:`expm` (any square matrices: Taylor polynomial after
  scaling, then squarings) and :func:`hamiltonian_expm` (matrices with an even characteristic
  polynomial, such as the Magnus generators of a conservative structure: Cayley-Hamilton);
* :func:`gauss_nodes`, :func:`magnus_generators`, :func:`transition_matrix`,
  :func:`magnus_monodromy`: fourth-order Magnus steps from the generator at the two
  Gauss-Legendre nodes of each step, and their ordered product;
* :func:`periodic_floquet`: monodromy matrices and multipliers of any periodic linear system
  (damped, forced, non-Hamiltonian) from a callable generator, with an error estimate by step
  doubling;
* :func:`symplectic_invariants`, :func:`multipliers_from_invariant`: the multipliers of a
  symplectic monodromy from the invariants ``s = mu + 1/mu`` of its pairs (well conditioned at
  the trivial double multiplier +1 of a conservative autonomous system, where the eigenvalues
  are not).

Arrays of matrices are stacked on the leading axes, ``(..., n, n)``, as in numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "expm",
    "hamiltonian_expm",
    "oscillator_expm",
    "COMMUTATOR_FREE_WEIGHTS",
    "gauss_nodes",
    "magnus_generators",
    "transition_matrix",
    "magnus_monodromy",
    "PeriodicFloquet",
    "periodic_floquet",
    "check_power_of_two",
    "match_nearest",
    "PairInvariants",
    "symplectic_inverse",
    "symplectic_invariants",
    "multipliers_from_invariant",
]

#: Gauss-Legendre nodes of one step, as fractions of the step (fourth-order Magnus).
GAUSS = (0.5 - np.sqrt(3.0) / 6.0, 0.5 + np.sqrt(3.0) / 6.0)
#: Magnus generators are scaled to this norm before their series is summed: degree 15 then
#: truncates at ``(1/2)**16 / 16!``, below round-off.
_SCALED_NORM = 0.5
_TAYLOR_DEGREE = 15
#: Largest matrix size whose batched products run entry-first (``(n, n, m)``, one vector
#: operation per entry over the stack); above it ``matmul`` on ``(m, n, n)`` is faster.
_ENTRY_FIRST_MAX = 7
#: Largest number of degrees of freedom for which :func:`hamiltonian_expm` uses Cayley-Hamilton
#: (``N`` products of ``2N x 2N`` matrices); above it the Taylor polynomial (6 products) is cheaper
#: and the characteristic polynomial's coefficients lose accuracy.
CAYLEY_HAMILTON_MAX_DOF = 3


# --------------------------------------------------------------------------- batched products


class _Stack:
    """A stack of ``m`` square ``n x n`` matrices, entry-first ``(n, n, m)`` or matrix-first ``(m, n, n)``."""

    def __init__(self, data, entry_first: bool):
        self.data = data
        self.entry_first = entry_first

    @classmethod
    def of(cls, matrices, entry_first: bool):
        """A stack on ``matrices`` given entry-first (``entry_first``) or not, in the faster layout for its size."""
        n = matrices.shape[0] if entry_first else matrices.shape[-1]
        fast = n <= _ENTRY_FIRST_MAX
        if fast == entry_first:
            return cls(matrices, fast)
        return cls(np.ascontiguousarray(np.moveaxis(matrices, *((0, 2) if fast else (2, 0)))), fast)

    def layout(self, entry_first: bool):
        """The data in the layout asked for."""
        if entry_first == self.entry_first:
            return self.data
        return np.ascontiguousarray(np.moveaxis(self.data, *((2, 0) if self.entry_first else (0, 2))))

    def new(self, data):
        return _Stack(data, self.entry_first)

    def __matmul__(self, other):
        if self.entry_first:
            return self.new(np.einsum("ikm,kjm->ijm", self.data, other.data))
        return self.new(np.matmul(self.data, other.data))

    def scaled(self, factors):
        """Each matrix times its scalar (``factors``: (m,) or a scalar), a new stack."""
        factors = np.asarray(factors)
        return self.new(self.data * (factors if self.entry_first or not factors.ndim else factors[:, None, None]))

    def add_identity(self, factors):
        """``self + factors I`` in place (``factors``: (m,) or scalar)."""
        for i in range(self.data.shape[0] if self.entry_first else self.data.shape[-1]):
            if self.entry_first:
                self.data[i, i] += factors
            else:
                self.data[:, i, i] += factors
        return self

    def trace(self):
        return np.trace(self.data, axis1=0, axis2=1) if self.entry_first else np.trace(self.data, axis1=1, axis2=2)

    def trace_of_product(self, other):
        """``tr(self @ other)`` without the product."""
        if self.entry_first:
            return np.einsum("ijm,jim->m", self.data, other.data)
        return np.einsum("mij,mji->m", self.data, other.data)

    def norm(self) -> float:
        """Largest row sum of ``|A|`` over the stack."""
        if not self.data.size:
            return 0.0
        return float(np.abs(self.data).sum(axis=1 if self.entry_first else 2).max())


def _squarings(norm: float) -> int:
    return max(0, int(np.ceil(np.log2(norm / _SCALED_NORM)))) if norm > 0 else 0


def _square(stack: _Stack, squarings: int) -> _Stack:
    for _ in range(squarings):
        stack = stack @ stack
    return stack


def _as_stack(matrices, entry_first: bool, even: bool = False):
    """Checked input of the exponentials as a :class:`_Stack` (and the shape to return)."""
    A = np.asarray(matrices, dtype=float)
    square = A.ndim >= 2 and (A.shape[0] == A.shape[1] if entry_first else A.shape[-1] == A.shape[-2])
    n = A.shape[0] if entry_first else A.shape[-1] if A.ndim else 0
    if not square or (even and n % 2):
        layout = "(n, n, ...)" if entry_first else "(..., n, n)"
        size = "of even size " if even else ""
        raise ValueError(f"square matrices {size}of shape {layout} needed, got {A.shape}")
    flat = A.reshape((n, n, -1) if entry_first else (-1, n, n))
    return _Stack.of(flat, entry_first), A.shape


def _taylor_exp(X: _Stack) -> _Stack:
    """Degree-15 Taylor polynomial of a stack of norm <= 1/2, by Paterson-Stockmeyer.

    ``T(X) = B_0 + X^4 (B_1 + X^4 (B_2 + X^4 B_3))``, ``B_j = sum_i X^i / (4j + i)!``: six products.
    """
    powers = [None, X, X @ X]
    powers.append(powers[2] @ X)
    powers.append(powers[2] @ powers[2])
    factorials = np.cumprod(np.r_[1.0, np.arange(1.0, _TAYLOR_DEGREE + 1)])

    def block(j):
        out = powers[1].scaled(1.0 / factorials[4 * j + 1])
        for i in (2, 3):
            out.data += powers[i].data / factorials[4 * j + i]
        return out.add_identity(1.0 / factorials[4 * j])

    result = block(3)
    for j in (2, 1, 0):
        result = powers[4] @ result
        result.data += block(j).data
    return result


def expm(matrices, entry_first: bool = False):
    """``exp`` of a stack of square matrices (any real matrices).

    The whole stack is scaled by one power of two to norm <= 1/2 (largest row sum), the
    degree-15 Taylor polynomial is summed (truncation ``(1/2)**16 / 16!``, below round-off)
    and squared back. The error is a few ulps of ``||exp(A)||`` times ``2**squarings``.

    Parameters
    ----------
    matrices : ndarray, shape (..., n, n), or (n, n, ...) with ``entry_first``
    entry_first : bool
        Layout of the input and of the result: the matrix entries first (the fast layout of
        small matrices, ``n <= 7``) or last.

    Returns
    -------
    ndarray, same shape

    Examples
    --------
    >>> import numpy as np
    >>> float(expm(np.array([[0.0, 1.0], [-1.0, 0.0]]))[0, 1].round(12))  # a rotation by 1 rad: sin(1)
    0.841470984808
    """
    stack, shape = _as_stack(matrices, entry_first)
    squarings = _squarings(stack.norm())
    result = _square(_taylor_exp(stack.scaled(2.0**-squarings)), squarings)
    return result.layout(entry_first).reshape(shape)


def hamiltonian_expm(matrices, entry_first: bool = False):
    """``exp`` of a stack of ``2N x 2N`` matrices whose characteristic polynomial is even.

    Hamiltonian matrices (``J X`` symmetric) have such polynomials, and so have the Magnus
    generators of a conservative structure. For ``N <=`` :data:`CAYLEY_HAMILTON_MAX_DOF`, with
    ``Y = X**2`` (after scaling to norm <= 1/2) and ``q(mu) = mu**N + c_1 mu**(N-1) + ... + c_N``
    the polynomial with ``q(Y) = 0`` (Cayley-Hamilton; ``c_k`` from the traces of the powers of ``Y``
    by Newton's identities), every power of ``Y`` is a combination of ``I, Y, .., Y**(N-1)`` with
    scalars from a recurrence, so the degree-15 series ``sum Y**k/(2k)! + (sum Y**k/(2k+1)!) X`` costs
    ``N`` matrix products. Larger ``N``: :func:`expm`'s Taylor polynomial.

    Parameters
    ----------
    matrices : ndarray, shape (..., 2N, 2N), or (2N, 2N, ...) with ``entry_first``
    entry_first : bool
        As in :func:`expm`.

    Returns
    -------
    ndarray, same shape
    """
    stack, shape = _as_stack(matrices, entry_first, even=True)
    n = stack.data.shape[0] if stack.entry_first else stack.data.shape[-1]
    if n // 2 > CAYLEY_HAMILTON_MAX_DOF or not stack.entry_first:
        return expm(matrices, entry_first)
    squarings = _squarings(stack.norm())
    result = _square(_cayley_hamilton_exp(stack, n // 2, 2.0**-squarings), squarings)
    return result.layout(entry_first).reshape(shape)


def _cayley_hamilton_exp(X: _Stack, N: int, scale: float) -> _Stack:
    """Degree-15 series of ``exp(scale X)`` for ``X`` with an even characteristic polynomial (``N`` products).

    ``X`` is entry-first (``2N <=`` the entry-first limit). ``scale`` (a power of two bringing the norm to
    <= 1/2) is folded into ``Y = (scale X)**2`` and into the scalar coefficients of the odd part, so ``X``
    itself is not copied. The combinations of the powers of ``Y`` are one ``einsum`` each (several times
    faster than broadcast products over the stack).
    """
    n, m = 2 * N, X.data.shape[-1]
    Y = np.empty((max(N - 1, 1), n, n, m))  # Y[j - 1] = (scale X)**(2j), j = 1 .. N - 1
    np.einsum("ikm,kjm->ijm", X.data, X.data, out=Y[0])
    if scale != 1.0:
        Y[0] *= scale * scale
    for j in range(1, N - 1):
        np.einsum("ikm,kjm->ijm", Y[j - 1], Y[0], out=Y[j])
    # power sums of the N eigenvalues of Y (each a double eigenvalue): P_k = tr(Y**k) / 2
    P = [None] + [0.5 * np.trace(Y[k - 1]) for k in range(1, N)]
    P.append(0.5 * (np.einsum("ijm,jim->m", Y[N - 2], Y[0]) if N > 1 else np.trace(Y[0])))
    c = [None]
    for k in range(1, N + 1):  # Newton's identities
        c.append(-(P[k] + sum(c[i] * P[k - i] for i in range(1, k))) / k)
    top_row = np.array([c[N - i] for i in range(N)])  # Y**N = -sum_i c_(N-i) Y**i
    u = np.zeros((N, m))  # Y**j = sum_i u[i] Y**i, starting from j = 0
    u[0] = 1.0
    even, odd = u.copy(), u.copy()  # sum Y**k / (2k)! and sum Y**k / (2k+1)!
    factorial = 1.0
    for k in range(1, (_TAYLOR_DEGREE + 1) // 2):
        top = u[N - 1].copy()
        u[1:] = u[:-1].copy()
        u[0] = 0.0
        u -= top_row * top
        factorial *= (2 * k - 1) * (2 * k)
        even += u / factorial
        odd += u / (factorial * (2 * k + 1))
    odd *= scale  # (sum Y**k / (2k+1)!) (scale X)

    def combination(coefficients):
        out = np.einsum("kijm,km->ijm", Y[: N - 1], coefficients[1:]) if N > 1 else np.zeros((n, n, m))
        out.reshape(n * n, m)[:: n + 1] += coefficients[0]
        return out

    result = np.einsum("ikm,kjm->ijm", combination(odd), X.data)
    result += combination(even)
    return X.new(result)


def oscillator_expm(stiffness, a):
    """``exp([[0, a I], [-a B, 0]])`` for symmetric ``B`` (a stack, ``(..., N, N)``), in closed form.

    The exponent squares to ``-a**2 B`` on both diagonal blocks, so with ``B = V diag(lambda) V^T``
    and ``mu = a**2 lambda`` the exponential is ``[[V c V^T, a V s V^T], [-a V (lambda s) V^T, V c V^T]]``,
    ``c = cos(sqrt(mu))``, ``s = sin(sqrt(mu)) / sqrt(mu)`` (``cosh``, ``sinh`` for ``mu < 0``): one
    symmetric eigendecomposition and three products of ``N x N`` matrices, no squarings however stiff
    ``B`` is. These are the exponentials of the commutator-free Magnus steps of a structure
    (:func:`nnmstop.hbm.monodromy.commutator_free_step_matrices`).

    Parameters
    ----------
    stiffness : ndarray, shape (..., N, N)
        Symmetric.
    a : float or ndarray
        Broadcast against ``stiffness.shape[:-2]``.

    Returns
    -------
    ndarray, shape (..., 2N, 2N)
    """
    B = np.asarray(stiffness, dtype=float)
    lam, V = np.linalg.eigh(B)
    a = np.asarray(a, dtype=float)[..., None]
    mu = a * a * lam
    root = np.sqrt(np.abs(mu))
    safe = np.where(root > 0, root, 1.0)
    c = np.where(mu >= 0, np.cos(root), np.cosh(root))
    s = np.where(root > 0, np.where(mu >= 0, np.sin(root), np.sinh(root)) / safe, 1.0)
    Vt = np.swapaxes(V, -1, -2)
    N = B.shape[-1]
    out = np.empty(B.shape[:-2] + (2 * N, 2 * N))
    out[..., :N, :N] = (V * c[..., None, :]) @ Vt
    out[..., N:, N:] = out[..., :N, :N]
    out[..., :N, N:] = (V * (a * s)[..., None, :]) @ Vt
    out[..., N:, :N] = (V * (-a * lam * s)[..., None, :]) @ Vt
    return out


#: Weights of the fourth-order commutator-free Magnus method (Blanes and Moan, 2006): a step is
#: ``exp(h (b_2 A_1 + b_1 A_2)) exp(h (b_1 A_1 + b_2 A_2))`` (the right one first), ``A_j`` at the Gauss nodes.
COMMUTATOR_FREE_WEIGHTS = (0.25 + np.sqrt(3.0) / 6.0, 0.25 - np.sqrt(3.0) / 6.0)


# --------------------------------------------------------------------------- Magnus steps


def gauss_nodes(period, steps: int):
    """Times of the two Gauss-Legendre nodes of each of ``steps`` uniform steps over ``[0, period]``.

    Parameters
    ----------
    period : float or array_like, shape (...)
    steps : int

    Returns
    -------
    ndarray, shape (..., steps, 2)
    """
    h = np.asarray(period, dtype=float)[..., None, None] / steps
    return h * (np.arange(steps)[:, None] + np.array(GAUSS))


def magnus_generators(generator_nodes, step):
    """Fourth-order Magnus generators ``h/2 (A_1 + A_2) + sqrt(3)/12 h**2 [A_2, A_1]`` of each step.

    Parameters
    ----------
    generator_nodes : ndarray, shape (..., steps, 2, n, n)
        ``A`` at the two Gauss nodes of each step (:func:`gauss_nodes`).
    step : float or array_like
        Step length ``h``, broadcast against ``generator_nodes.shape[:-3]`` (e.g. one per system as
        shape ``(n_systems, 1)``).

    Returns
    -------
    ndarray, shape (..., steps, n, n)
    """
    A = np.asarray(generator_nodes, dtype=float)
    h = np.asarray(step, dtype=float)[..., None, None]
    A1, A2 = A[..., 0, :, :], A[..., 1, :, :]
    return 0.5 * h * (A1 + A2) + (np.sqrt(3.0) / 12.0) * h * h * (A2 @ A1 - A1 @ A2)


def transition_matrix(step_matrices):
    """Ordered product ``M_{n-1} ... M_1 M_0`` along axis -3, pairwise (a tree of batched products).

    The monodromy (or a part of it) from the step maps of a one-step integrator (Magnus steps,
    Runge-Kutta steps of :mod:`nnmstop.hbm.shooting_refinement`).
    """
    mats = np.asarray(step_matrices)
    while mats.shape[-3] > 1:
        if mats.shape[-3] % 2:
            pad = np.broadcast_to(np.eye(mats.shape[-1]), mats.shape[:-3] + (1,) + mats.shape[-2:])
            mats = np.concatenate([mats, pad], axis=-3)
        mats = np.matmul(mats[..., 1::2, :, :], mats[..., 0::2, :, :])
    return mats[..., 0, :, :]


def magnus_monodromy(generator_nodes, step):
    """Transition matrix over all steps of ``y' = A(t) y`` by fourth-order Magnus steps.

    ``generator_nodes`` (..., steps, 2, n, n) and ``step`` as in :func:`magnus_generators`; each step's
    exponential by :func:`expm`. Returns ``(..., n, n)``.
    """
    return transition_matrix(expm(magnus_generators(generator_nodes, step)))


# --------------------------------------------------------------------------- any periodic system


@dataclass
class PeriodicFloquet:
    """Monodromy matrices and Floquet multipliers of periodic linear systems (arrays along the systems).

    Attributes
    ----------
    monodromy : ndarray, shape (n_systems, n, n)
        ``Phi(T)`` from the finer of the last two step counts.
    multipliers : ndarray of complex, shape (n_systems, n)
        Eigenvalues of ``monodromy`` by decreasing modulus.
    max_multiplier : ndarray, shape (n_systems,)
        Largest modulus.
    error : ndarray, shape (n_systems,)
        Largest change of a multiplier between the last two step counts (matched nearest to
        nearest): about 15 times the error of the kept values (fourth order).
    steps : ndarray of int, shape (n_systems,)
        Magnus steps of the kept monodromy.
    """

    monodromy: np.ndarray
    multipliers: np.ndarray
    max_multiplier: np.ndarray
    error: np.ndarray
    steps: np.ndarray


def check_power_of_two(name: str, value, minimum: int) -> int:
    """``value`` as an int if it is a power of two >= ``minimum`` (ValueError naming ``name`` otherwise)."""
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < minimum or value & (value - 1):
        raise ValueError(f"{name} must be a power of two >= {minimum}, got {value!r}")
    return int(value)


def _eigenvalues_by_modulus(matrices):
    mu = np.linalg.eigvals(matrices)
    return np.take_along_axis(mu, np.argsort(-np.abs(mu), axis=-1, kind="stable"), axis=-1)


def periodic_floquet(generator, period, steps: int = 256, max_steps: int = 4096, tol: float = 1e-10):
    """Floquet multipliers of ``y' = A(t) y`` with ``A(t + T) = A(t)``, for many systems at once.

    Any generator: damped and forced structures (``A = [[0, I], [-M^-1 K_t(t), -M^-1 C]]``, no
    trivial multiplier), or conservative ones when their structure is not to be used. Each system is
    integrated over its period by :func:`magnus_monodromy` with ``steps`` and ``2 steps`` uniform steps;
    where the multipliers moved by more than ``tol`` (relative to ``max(1, |mu|)``), the steps are
    doubled again, up to ``max_steps``.

    Parameters
    ----------
    generator : callable
        ``generator(systems, t)``: ``systems`` an integer array of ``k`` indices into ``period``,
        ``t`` of shape ``(k, m)`` times in ``[0, T)`` of each; returns ``A`` at those times, shape
        ``(k, m, n, n)``.
    period : array_like, shape (n_systems,)
        Periods ``T > 0``.
    steps, max_steps : int
        Powers of two, ``16 <= steps``, ``2 steps <= max_steps``.
    tol : float
        Target of the error estimate (> 0).

    Returns
    -------
    PeriodicFloquet

    Examples
    --------
    A damped oscillator ``q'' + 2 zeta q' + q = 0``: multipliers ``exp(lambda T)``, ``|lambda| = 1``.

    >>> import numpy as np
    >>> zeta = 0.05
    >>> A = np.array([[0.0, 1.0], [-1.0, -2 * zeta]])
    >>> result = periodic_floquet(lambda systems, t: np.broadcast_to(A, t.shape + (2, 2)), [2 * np.pi])
    >>> bool(np.allclose(result.max_multiplier, np.exp(-zeta * 2 * np.pi), rtol=1e-12))
    True
    """
    period = np.atleast_1d(np.asarray(period, dtype=float))
    if period.ndim != 1 or not np.all(np.isfinite(period) & (period > 0)):
        raise ValueError(f"period must be finite numbers > 0, one per system, got {period!r}")
    steps = check_power_of_two("steps", steps, 16)
    max_steps = check_power_of_two("max_steps", max_steps, 16)
    if max_steps < 2 * steps:
        raise ValueError(f"max_steps ({max_steps}) must be >= 2 x steps ({steps})")
    if not (np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}")

    def monodromy(systems, n_steps):
        t = gauss_nodes(period[systems], n_steps).reshape(len(systems), 2 * n_steps)
        A = np.asarray(generator(systems, t), dtype=float)
        if A.ndim != 4 or A.shape[:2] != t.shape or A.shape[2] != A.shape[3]:
            raise ValueError(f"generator(systems, t) must return shape {t.shape} + (n, n), got {A.shape}")
        nodes = A.reshape(len(systems), n_steps, 2, *A.shape[2:])
        return magnus_monodromy(nodes, (period[systems] / n_steps)[:, None])

    todo = np.arange(len(period))
    coarse = _eigenvalues_by_modulus(monodromy(todo, steps))
    N = 2 * steps
    result = None
    while True:
        phi = monodromy(todo, N)
        fine = _eigenvalues_by_modulus(phi)
        error = np.abs(fine - match_nearest(fine, coarse)).max(axis=-1)
        if result is None:
            result = PeriodicFloquet(phi, fine, np.abs(fine[:, 0]), error, np.full(len(period), N))
        else:
            result.monodromy[todo], result.multipliers[todo], result.error[todo] = phi, fine, error
            result.max_multiplier[todo], result.steps[todo] = np.abs(fine[:, 0]), N
        again = error > tol * np.maximum(1.0, np.abs(fine[:, 0]))
        if not again.any() or 2 * N > max_steps:
            return result
        todo, coarse, N = todo[again], fine[again], 2 * N


def match_nearest(reference, values):
    """``values`` reordered along the last axis to match ``reference`` nearest to nearest (greedy)."""
    out = np.empty_like(values)
    free = np.ones(values.shape, dtype=bool)
    rows = np.arange(values.shape[0])
    for j in range(values.shape[-1]):
        distance = np.where(free, np.abs(values - reference[:, j, None]), np.inf)
        pick = np.argmin(distance, axis=-1)
        out[:, j] = values[rows, pick]
        free[rows, pick] = False
    return out


# --------------------------------------------------------------------------- symplectic monodromy


def symplectic_inverse(matrices):
    """``Phi^-1 = J^T Phi^T J`` of symplectic ``2N x 2N`` matrices (``J = [[0, I], [-I, 0]]`` or a multiple)."""
    phi = np.asarray(matrices)
    N = phi.shape[-1] // 2
    A, B, C, D = phi[..., :N, :N], phi[..., :N, N:], phi[..., N:, :N], phi[..., N:, N:]
    T = np.swapaxes
    return np.concatenate(
        [np.concatenate([T(D, -1, -2), -T(B, -1, -2)], -1), np.concatenate([-T(C, -1, -2), T(A, -1, -2)], -1)], -2
    )


def symplectic_invariants(matrices):
    """Pair invariants ``s = mu + 1/mu`` of symplectic matrices with a trivial pair at +1.

    The eigenvalues of ``W = Phi + Phi^-1`` are the ``s`` of the pairs, each twice. Unlike the
    multipliers themselves they are well conditioned where a pair meets +1: the trivial Jordan block
    at +1 (``s - 2 = (mu - 1)**2 / mu``), and a pair changing type there. ``Phi^-1`` is
    ``J^T Phi^T J`` (no inversion). The ``2N`` eigenvalues are paired nearest to nearest, each ``s`` is
    the mean of its pair.

    Parameters
    ----------
    matrices : ndarray, shape (k, 2N, 2N)
        Symplectic for ``J = [[0, I], [-I, 0]]`` (or a multiple of it).

    Returns
    -------
    trivial : ndarray, shape (k,)
        The invariant nearest 2 (exactly 2 for the trivial pair of an exact orbit).
    invariants : ndarray of complex, shape (k, N - 1)
        The other ``N - 1``: real in ``[-2, 2]`` for an elliptic pair, real outside for a hyperbolic
        one, complex for a quartet; by decreasing real part.
    krein : ndarray of int, shape (k, N - 1)
        For elliptic pairs (real ``|s| < 2``) the sign of ``x^T J Phi x`` on their invariant plane
        (definite there): two elliptic pairs can leave the unit circle where they meet only if their
        signs differ (Krein). 0 for the others.
    """
    phi = np.asarray(matrices, dtype=float)
    k, n = phi.shape[0], phi.shape[-1]
    N = n // 2
    values, vectors = np.linalg.eig(phi + symplectic_inverse(phi))
    first, second = _pairs(values)
    rows = np.arange(k)[:, None]
    s = 0.5 * (values[rows, first] + values[rows, second])
    trivial_at = np.argmin(np.abs(s - 2.0), axis=-1)
    keep = np.ones((k, N), dtype=bool)
    keep[np.arange(k), trivial_at] = False
    others = s[keep].reshape(k, N - 1)
    plane = np.take_along_axis(vectors, first[keep].reshape(k, N - 1)[:, None, :], axis=-1)  # (k, n, N - 1)
    real_larger = np.linalg.norm(plane.real, axis=1) >= np.linalg.norm(plane.imag, axis=1)
    x = np.where(real_larger[:, None], plane.real, plane.imag)
    image = phi @ x  # J (Phi x) = (lower half, -upper half)
    form = np.sum(x[:, :N] * image[:, N:], axis=1) - np.sum(x[:, N:] * image[:, :N], axis=1)
    elliptic = (others.imag == 0) & (np.abs(others.real) < 2.0)
    krein = np.where(elliptic, np.sign(form), 0).astype(int)
    order = np.argsort(-others.real, axis=-1, kind="stable")
    return (
        s[np.arange(k), trivial_at].real,
        np.take_along_axis(others, order, axis=-1),
        np.take_along_axis(krein, order, axis=-1),
    )


@dataclass
class PairInvariants:
    """Full-period invariants of the non-trivial pairs of a set of orbits (arrays along the orbits).

    Attributes
    ----------
    s : ndarray of complex, shape (n, N - 1)
        ``mu + 1/mu`` of each non-trivial pair of the full-period monodromy, by decreasing largest
        multiplier modulus, then decreasing real part.
    integrated : ndarray of complex, shape (n, N - 1)
        The same pairs' invariants of the integrated map (``-Phi(T/2)`` for half-wave symmetric
        orbits, ``s`` otherwise).
    krein : ndarray of int, shape (n, N - 1)
        Krein sign of the elliptic pairs of the integrated map (0 for the others).
    trivial_deviation : ndarray, shape (n,)
        ``|s_t - 2|`` of the trivial pair of the full-period monodromy.
    """

    s: np.ndarray
    integrated: np.ndarray
    krein: np.ndarray
    trivial_deviation: np.ndarray

    @classmethod
    def of(cls, matrices, halfwave: bool) -> PairInvariants:
        """From the integrated maps: ``Phi(T/2)`` of half-wave symmetric orbits, else ``Phi(T)``.

        Half-wave symmetric orbits: ``Phi(T) = P**2``, ``P = Phi(T/2)``; ``-P`` has the trivial pair at
        +1 and the non-trivial ``nu`` with ``mu = nu**2``, hence ``s = sigma**2 - 2`` from the invariants
        ``sigma`` of ``-P``, and ``s_t - 2 = (sigma_t - 2)(sigma_t + 2)``. A pair near ``mu = -1``
        (``sigma`` near 0) costs no accuracy.
        """
        trivial, sigma, krein = symplectic_invariants(-matrices if halfwave else matrices)
        if halfwave:
            s = sigma * sigma - 2.0
            deviation = np.abs(trivial - 2.0) * np.abs(trivial + 2.0)
        else:
            s, deviation = sigma, np.abs(trivial - 2.0)
        largest = np.abs(multipliers_from_invariant(s)[..., 2])
        order = np.lexsort((-s.real, -np.round(largest, 12)), axis=-1)
        take = lambda a: np.take_along_axis(a, order, axis=-1)  # noqa: E731
        return cls(take(s), take(sigma), take(krein), deviation)

    def select(self, index) -> PairInvariants:
        return PairInvariants(self.s[index], self.integrated[index], self.krein[index], self.trivial_deviation[index])

    def assign(self, index, other: PairInvariants):
        for name in ("s", "integrated", "krein", "trivial_deviation"):
            getattr(self, name)[index] = getattr(other, name)

    @classmethod
    def empty(cls, n: int, pairs: int) -> PairInvariants:
        return cls(
            np.zeros((n, pairs), dtype=complex),
            np.zeros((n, pairs), dtype=complex),
            np.zeros((n, pairs), dtype=int),
            np.zeros(n),
        )

    def stable(self, trace_tol: float):
        """Every non-trivial pair elliptic to within ``trace_tol``: ``|Im s|`` at most, ``|Re s| <= 2 + trace_tol``.

        (Where two pairs sit at +1 together, a type change, the pairing of the four nearly equal eigenvalues
        of ``W`` can leave round-off imaginary parts, about 1e-13, on their invariants.)
        """
        return np.all((np.abs(self.s.imag) <= trace_tol) & (np.abs(self.s.real) <= 2.0 + trace_tol), axis=-1)

    def margin(self, halfwave, tol: float = 0.0):
        """Distance of the invariants to where the verdict can change, and the pair that sets it.

        Stable orbits (every pair elliptic): the nearest of ``s = 2`` (a pair meeting +1), ``s = -2``
        unless half-wave symmetric (whose pairs cross -1 without changing type: ``s >= -2``), and the
        invariant of another elliptic pair of opposite Krein sign (they can leave the circle as a
        quartet where they meet; pairs of equal sign cannot). Unstable orbits: the largest distance
        of an unstable pair's ``s`` to the elliptic segment ``[-2, 2]`` (every one would have to come
        back for the verdict to change). Half-wave symmetric orbits meet as pairs of the half-period
        map: their distance ``|sigma_i - sigma_j| (|sigma_i| + |sigma_j|)`` is ``|s_i - s_j|`` there. An
        invariant within ``tol`` of the real axis counts as real (as in :meth:`stable`).

        Returns
        -------
        margin : ndarray, shape (n,)
        critical : ndarray of int, shape (n,)
            Index of the pair that sets it.
        """
        s, sigma, halfwave = self.s, self.integrated, np.asarray(halfwave)[:, None]
        if not s.shape[-1]:  # one degree of freedom: only the trivial pair
            return np.full(len(s), np.inf), np.zeros(len(s), dtype=int)
        elliptic = (np.abs(s.imag) <= tol) & (np.abs(s.real) <= 2.0)
        to_type_change = np.where(halfwave, np.abs(s - 2.0), np.minimum(np.abs(s - 2.0), np.abs(s + 2.0)))
        meet = np.where(
            halfwave[..., None],
            np.abs(sigma[:, :, None] - sigma[:, None, :]) * (np.abs(sigma[:, :, None]) + np.abs(sigma[:, None, :])),
            np.abs(s[:, :, None] - s[:, None, :]),
        )
        opposite = (self.krein[:, :, None] * self.krein[:, None, :]) < 0
        to_quartet = np.where(opposite, meet, np.inf).min(axis=-1)
        outside = np.abs(s - np.clip(s.real, -2.0, 2.0))
        stable = np.all(elliptic, axis=-1)
        per_pair = np.where(stable[:, None], np.minimum(to_type_change, to_quartet), -np.where(elliptic, -1.0, outside))
        critical = np.argmin(per_pair, axis=-1)
        margin = np.abs(np.take_along_axis(per_pair, critical[:, None], axis=-1)[:, 0])
        return margin, critical

    def change_from(self, other: PairInvariants):
        """Largest change of a pair's ``s`` from ``other`` (the same orbits; pairs matched nearest to nearest)."""
        if not self.s.shape[-1]:
            return np.zeros(len(self.s))
        return np.abs(self.s - match_nearest(self.s, other.s)).max(axis=-1)

    def multipliers(self):
        """``[1, 1, mu_1, 1/mu_1, mu_2, ...]`` (n, 2N), pairs in the order of ``s``."""
        pairs = multipliers_from_invariant(self.s)[..., 2:].reshape(len(self.s), -1)
        return np.concatenate([np.ones((len(self.s), 2), dtype=complex), pairs], axis=-1)


def _pairs(values):
    """Indices ``(first, second)`` (k, N) pairing the ``2N`` eigenvalues of each row nearest to nearest."""
    k, n = values.shape
    free = np.ones((k, n), dtype=bool)
    rows = np.arange(k)
    first = np.empty((k, n // 2), dtype=int)
    second = np.empty((k, n // 2), dtype=int)
    for p in range(n // 2):
        i = np.argmax(free, axis=-1)
        free[rows, i] = False
        distance = np.where(free, np.abs(values - values[rows, i][:, None]), np.inf)
        j = np.argmin(distance, axis=-1)
        free[rows, j] = False
        first[:, p], second[:, p] = i, j
    return first, second


def multipliers_from_invariant(s):
    """``[1, 1, mu_1, mu_2]`` from ``s = mu + 1/mu`` (``|mu_1| >= |mu_2|``, ``mu_1 mu_2 = 1``).

    Elliptic pair (real ``|s| <= 2``): ``mu_1 = s/2 + i sqrt(1 - s**2/4)`` (non-negative imaginary
    part) and its conjugate; hyperbolic pair (real ``|s| > 2``): the root of larger modulus computed
    without cancellation, the other its inverse; complex ``s`` (a quartet ``mu, 1/mu`` and their
    conjugates, which come from ``conj(s)``): the root of larger modulus of ``mu**2 - s mu + 1``.

    Parameters
    ----------
    s : float, complex or array_like

    Returns
    -------
    ndarray of complex, shape ``np.shape(s) + (4,)``
    """
    s = np.asarray(s)
    sr = s.real.astype(float)
    complex_s = np.iscomplexobj(s) & (s.imag != 0)
    out = np.ones(s.shape + (4,), dtype=complex)
    elliptic = np.abs(sr) <= 2.0
    root = np.sqrt(np.abs(0.25 * sr * sr - 1.0))
    big = 0.5 * sr + np.where(sr < 0, -1.0, 1.0) * root
    mu = np.where(elliptic, 0.5 * sr + 1j * root, big).astype(complex)
    if np.any(complex_s):
        sc = s.astype(complex)
        discriminant = np.sqrt(0.25 * sc * sc - 1.0)
        plus, minus = 0.5 * sc + discriminant, 0.5 * sc - discriminant
        mu = np.where(complex_s, np.where(np.abs(plus) >= np.abs(minus), plus, minus), mu)
    out[..., 2] = mu
    out[..., 3] = np.where(elliptic & ~complex_s, np.conj(mu), 1.0 / np.where(mu == 0, 1.0, mu))
    return out
