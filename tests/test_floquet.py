"""The multiplier pair from the invariant s = mu + 1/mu (nnmstop.floquet), against closed forms."""

import numpy as np
import pytest

from nnmstop.floquet import multipliers_from_invariant


def test_elliptic_pairs_are_the_rotations_of_their_angle():
    theta = np.linspace(0.0, np.pi, 13)
    mu = multipliers_from_invariant(2.0 * np.cos(theta))
    np.testing.assert_allclose(mu[:, 2], np.exp(1j * theta), atol=1e-15)  # non-negative imaginary part
    np.testing.assert_allclose(mu[:, 3], np.exp(-1j * theta), atol=1e-15)
    np.testing.assert_array_equal(mu[:, :2], 1.0)


@pytest.mark.parametrize("mu_big", [1.0 + 1e-9, 3.0, 1e8, -1.0 - 1e-9, -7.5, -1e12])
def test_hyperbolic_pairs_are_the_real_roots_without_cancellation(mu_big):
    mu = multipliers_from_invariant(mu_big + 1.0 / mu_big)
    assert mu[2].imag == mu[3].imag == 0.0
    assert mu[2].real == pytest.approx(mu_big, rel=1e-12 if abs(mu_big) > 2 else 1e-4)
    assert mu[2].real * mu[3].real == pytest.approx(1.0, rel=1e-15)  # a symplectic pair
    assert abs(mu[2]) >= abs(mu[3])


# --------------------------------------------------------------------------- exponentials and monodromies

import scipy.linalg  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from nnmstop.floquet import (  # noqa: E402
    expm,
    hamiltonian_expm,
    periodic_floquet,
    symplectic_invariants,
)

EPS = np.finfo(float).eps


def _round_off_bound(A, expected):
    """A few ulps of ||exp(A)||, doubled by each squaring of the stack (largest row sum scaled to 1/2)."""
    squarings = max(0, int(np.ceil(np.log2(np.abs(A).sum(axis=-1).max() / 0.5))))
    return 2.0 ** (squarings + 5) * EPS * np.abs(expected).max()


@pytest.mark.parametrize("n", [1, 2, 5, 8, 40])
@pytest.mark.parametrize("scale", [0.01, 1.0, 20.0])
def test_expm_matches_scipy(n, scale):
    """Any real matrices, small (entry-first products) and large (matmul), with and without squarings."""
    A = scale * np.random.default_rng(n).standard_normal((7, n, n)) / np.sqrt(n)
    for a, e in zip(A, expm(A)):
        expected = scipy.linalg.expm(a)
        np.testing.assert_allclose(e, expected, rtol=0, atol=_round_off_bound(A, expected))


def _hamiltonian(N, h, rng, count=6):
    """Magnus generators [[G, h I], [-h B, -G]] of a step h: B symmetric positive definite (a structure's
    stiffness over its mass), G = sqrt(3)/12 h**2 (B_2 - B_1) symmetric."""
    G = rng.standard_normal((count, N, N))
    B = rng.standard_normal((count, N, N))
    G, B = np.sqrt(3.0) / 12.0 * h * h * (G + np.swapaxes(G, 1, 2)), B @ np.swapaxes(B, 1, 2) + N * np.eye(N)
    eye = np.broadcast_to(np.eye(N), (count, N, N))
    return np.block([[G, h * eye], [-h * B, -G]])


@pytest.mark.parametrize("N", [1, 2, 3, 4, 6])
@pytest.mark.parametrize("h", [0.02, 0.3, 3.0])
def test_hamiltonian_expm_matches_scipy(N, h):
    """Cayley-Hamilton (N <= 3) and the Taylor path (N > 3) against scipy's Pade expm; the result is symplectic."""
    X = _hamiltonian(N, h, np.random.default_rng(10 * N))
    E = hamiltonian_expm(X)
    J = np.block([[np.zeros((N, N)), np.eye(N)], [-np.eye(N), np.zeros((N, N))]])
    for x, e in zip(X, E):
        expected = scipy.linalg.expm(x)
        bound = _round_off_bound(X, expected)
        np.testing.assert_allclose(e, expected, rtol=0, atol=bound)
        # an error of at most `bound` per entry moves e^T J e by at most 2 (2N) max|e| bound per entry
        assert np.abs(e.T @ J @ e - J).max() <= 4 * N * np.abs(e).max() * bound


def test_entry_first_layout_is_the_same_numbers():
    X = _hamiltonian(2, 0.3, np.random.default_rng(0))
    np.testing.assert_array_equal(
        np.moveaxis(hamiltonian_expm(np.moveaxis(X, 0, 2), entry_first=True), 2, 0), hamiltonian_expm(X)
    )


def test_exponentials_name_bad_shapes():
    with pytest.raises(ValueError, match="square"):
        expm(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="even size"):
        hamiltonian_expm(np.zeros((3, 3)))


def _rotation(theta):
    """Flow of q'' = -q over a time theta (positive energy), symplectic for J = [[0, 1], [-1, 0]]."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, s], [-s, c]])


def _direct_sum(*blocks):
    """Block-diagonal symplectic matrix in the (q_1..q_N, p_1..p_N) ordering."""
    N = len(blocks)
    out = np.zeros((2 * N, 2 * N))
    for i, b in enumerate(blocks):
        out[np.ix_([i, N + i], [i, N + i])] = b
    return out


def test_invariants_and_krein_signs_of_uncoupled_pairs():
    """A trivial Jordan block at +1, two rotations and a hyperbolic pair, mixed by a symplectic similarity:
    the invariants are 2 cos(theta) and mu + 1/mu; the Krein signs -sign(sin theta) of positive-energy rotations."""
    jordan = np.array([[1.0, 0.7], [0.0, 1.0]])
    hyperbolic = np.diag([3.0, 1.0 / 3.0])
    theta = (2.0, 4.5)  # sin > 0 and sin < 0: opposite Krein signs
    phi = _direct_sum(jordan, _rotation(theta[0]), _rotation(theta[1]), hyperbolic)
    X = _hamiltonian(4, 0.3, np.random.default_rng(5), count=1)[0]
    S = scipy.linalg.expm(X)  # symplectic
    trivial, s, krein = symplectic_invariants((S @ phi @ np.linalg.inv(S))[None])
    assert abs(trivial[0] - 2.0) < 1e-12
    expected = sorted([2 * np.cos(theta[0]), 2 * np.cos(theta[1]), 3.0 + 1.0 / 3.0], reverse=True)
    np.testing.assert_allclose(s[0].real, expected, atol=1e-12)
    assert np.all(s[0].imag == 0)
    signs = dict(zip(np.round(s[0].real, 9), krein[0]))
    assert signs[round(2 * np.cos(theta[0]), 9)] == -1 and signs[round(2 * np.cos(theta[1]), 9)] == 1
    assert signs[round(3.0 + 1.0 / 3.0, 9)] == 0


def test_a_complex_quartet_is_a_complex_invariant():
    """mu = r exp(i phi) with its inverse and conjugates: s = mu + 1/mu and its conjugate, complex."""
    mu = 1.2 * np.exp(0.8j)
    A = np.array([[mu.real, -mu.imag], [mu.imag, mu.real]])  # multiplies q by mu in the complex plane
    phi = np.zeros((6, 6))
    phi[:2, :2], phi[3:5, 3:5] = A, np.linalg.inv(A).T  # (q, p) -> (A q, A^-T p): symplectic
    phi[2, 2] = phi[5, 5] = 1.0
    phi[2, 5] = 0.3
    trivial, s, krein = symplectic_invariants(phi[None])
    assert abs(trivial[0] - 2.0) < 1e-13
    np.testing.assert_allclose(
        sorted(s[0], key=lambda z: z.imag),
        sorted([mu + 1 / mu, np.conj(mu + 1 / mu)], key=lambda z: z.imag),
        atol=1e-12,
    )
    assert np.all(krein == 0)


def test_periodic_floquet_of_a_damped_oscillator():
    """Constant generator: the multipliers exp(lambda T) of q'' + 2 zeta q' + q = 0, lambda the roots of
    lambda**2 + 2 zeta lambda + 1."""
    zeta = 0.05
    A = np.array([[0.0, 1.0], [-1.0, -2 * zeta]])
    T = np.array([2.0, 7.0])
    result = periodic_floquet(lambda systems, t: np.broadcast_to(A, t.shape + (2, 2)), T)
    lam = -zeta + 1j * np.sqrt(1 - zeta**2)
    for mu, period in zip(result.multipliers, T):
        expected = np.exp(np.array([lam, np.conj(lam)]) * period)
        np.testing.assert_allclose(sorted(mu, key=np.angle), sorted(expected, key=np.angle), atol=1e-13)


@pytest.mark.numerics
def test_periodic_floquet_of_a_damped_mathieu_equation_matches_dop853():
    """q'' + c q' + (a + 2 b cos(2 t)) q = 0 in and out of the first instability tongue (period pi): the
    multipliers against the eigenvalues of the monodromy integrated by DOP853, within the error estimate."""
    c = 0.1
    cases = np.array([(1.0, 0.3), (1.0, 0.05), (2.5, 0.4)])  # (a, b): unstable, stable, stable

    def generator(systems, t):
        a, b = cases[systems, 0, None], cases[systems, 1, None]
        out = np.zeros(t.shape + (2, 2))
        out[..., 0, 1] = 1.0
        out[..., 1, 0] = -(a + 2 * b * np.cos(2 * t))
        out[..., 1, 1] = -c
        return out

    result = periodic_floquet(generator, np.full(len(cases), np.pi), steps=64, max_steps=2048, tol=1e-11)
    for i, (a, b) in enumerate(cases):

        def rhs(t, y, a=a, b=b):
            Y = y.reshape(2, 2)
            return (np.array([[0.0, 1.0], [-(a + 2 * b * np.cos(2 * t)), -c]]) @ Y).ravel()

        reference = solve_ivp(rhs, (0, np.pi), np.eye(2).ravel(), method="DOP853", rtol=1e-13, atol=1e-14)
        expected = np.linalg.eigvals(reference.y[:, -1].reshape(2, 2))
        found = result.multipliers[i]
        assert np.abs(np.sort_complex(found) - np.sort_complex(expected)).max() <= result.error[i] + 1e-11
        # Liouville: det = exp(-c T)
        assert abs(np.prod(found) - np.exp(-c * np.pi)) < 1e-10
    assert result.max_multiplier[0] > 1 and np.all(result.max_multiplier[1:] < 1)


def test_periodic_floquet_names_bad_input():
    constant = lambda systems, t: np.zeros(t.shape + (2, 2))  # noqa: E731
    with pytest.raises(ValueError, match="period"):
        periodic_floquet(constant, [-1.0])
    with pytest.raises(ValueError, match="steps"):
        periodic_floquet(constant, [1.0], steps=100)
    with pytest.raises(ValueError, match="generator"):
        periodic_floquet(lambda systems, t: np.zeros((1, 3, 2, 2)), [1.0])
