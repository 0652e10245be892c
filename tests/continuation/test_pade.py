"""Padé approximants of the ANM series (nnmstop.continuation.pade) and the Padé-ANM continuation.

Checked against closed forms (a rational function is reproduced exactly, its poles
found; a function with a pole stops the step before it) and, on the HBM system,
against the plain-series ANM and the Newton pseudo-arclength baseline on the same
branches.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml
from test_continuation import (
    CASES,
    PARAMS,
    QUIET,
    TOLERANCE,
    distance_to_polyline,
    fep,
    same_branch_gap,
    start_point,
)

from nnmstop.config import ConfigError, validate_config
from nnmstop.continuation.anm import ANMSettings, continue_anm, step_length
from nnmstop.continuation.core import relative_residual
from nnmstop.continuation.pade import pade_pair, pade_step_length
from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings, continue_pseudo_arclength
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import two_dof_structure

# --------------------------------------------------------------------------- closed forms


def rational_series(N, n, roots, seed=0):
    """Taylor terms of ``f(a) = B_0 + (sum_{i=1}^{N-1} a^i B_i) / q(a)``, ``q`` monic at 0 with ``roots``.

    Returns the terms ``U_0 .. U_N`` and ``f`` itself.
    """
    rng = np.random.default_rng(seed)
    q = np.real(np.poly(roots)[::-1])
    q /= q[0]  # ascending coefficients, q(0) = 1
    B = rng.standard_normal((N, n))
    U = np.zeros((N + 1, n))
    U[0] = B[0]
    for i in range(1, N + 1):  # q (f - B_0) = numerator, power by power
        U[i] = (B[i] if i < N else 0.0) - sum(q[j] * U[i - j] for j in range(1, min(i, len(q) - 1) + 1) if i - j >= 1)

    def f(a):
        return B[0] + sum(a**i * B[i] for i in range(1, N)) / np.polynomial.polynomial.polyval(a, q)

    return U, f


def test_rational_function_is_reproduced_exactly():
    N = 8
    roots = [1.3, -0.7, 2.0 + 1.0j, 2.0 - 1.0j, 5.0, -3.0, 4.0]  # degree N - 1
    U, f = rational_series(N, n=30, roots=roots)
    for scale in (0.5, 1.0):  # the approximant does not depend on the scaling of a
        high, low = pade_pair(U, scale)
        assert high.order == N and low.order == N - 1
        # beyond the radius of convergence of the series (1.3) too, even past the pole
        for a in (0.3, 1.0, 1.25, 1.4, 2.5, -0.5):
            assert np.linalg.norm(high(a) - f(a)) <= 1e-10 * np.linalg.norm(f(a))
        np.testing.assert_allclose(high.poles(), [-3.0, -0.7, 1.3, 4.0, 5.0], rtol=1e-8)
        assert high.first_positive_pole() == pytest.approx(1.3, rel=1e-10)
        # derivative against a central difference of the closed form
        a, h = 0.8, 1e-6
        fd = (f(a + h) - f(a - h)) / (2 * h)
        assert np.linalg.norm(high(a, derivative=True) - fd) <= 1e-7 * np.linalg.norm(fd)
    # the plain series cannot go past its radius 1.3: the Taylor polynomial is far off at 1.4
    taylor = sum(1.4**i * U[i] for i in range(N + 1))
    assert np.linalg.norm(taylor - f(1.4)) > 0.1 * np.linalg.norm(f(1.4))


def pole_series(N, r, n=30, seed=2):
    """Terms of ``f(a) = Re sum_j w_j a / (1 - a / r_j)`` with one real positive pole, ``r``.

    The other poles (6 negative, 9 complex pairs, moduli 1.2 r to 3 r) make ``f``
    more than the approximant can represent exactly; the ``w_j`` are random vectors
    in ``n >= N - 1`` dimensions (the construction needs ``N - 1`` independent terms).
    """
    rng = np.random.default_rng(seed)
    moduli = np.linspace(1.2, 3.0, 9) * r
    angles = np.linspace(0.4, 2.6, 9)
    complex_poles = moduli * np.exp(1j * angles)
    poles = np.concatenate([[r], -np.linspace(1.3, 3.0, 6) * r, complex_poles, complex_poles.conj()])
    w = rng.standard_normal((len(poles), n)) + 1j * rng.standard_normal((len(poles), n))
    w[:7] = w[:7].real
    w[16:] = w[7:16].conj()
    k = np.arange(N + 1)
    U = np.real(np.einsum("jk,jn->kn", poles[:, None] ** (1.0 - k[None, :]), w))
    U[0] = 0.0

    def f(a):
        return np.real(((a / (1 - a / poles))[:, None] * w).sum(axis=0))

    return U, f


@pytest.mark.parametrize("r", [0.8, 2.0])
def test_step_stops_before_a_pole(r):
    N, tolerance = 20, 1e-8
    U, f = pole_series(N, r)
    a_series = step_length(U, tolerance)
    assert a_series < r  # the plain series stays within its radius of convergence
    high, low = pade_pair(U, a_series)
    a_pade = pade_step_length(high, low, tolerance, a_series)
    # the rational representation goes further, strictly before the pole ...
    assert a_series < a_pade < r
    assert 0 < high.first_positive_pole() == pytest.approx(r, rel=1e-3)  # not exact: f is not rational of that degree
    # ... and is as accurate there as the criterion promises, relative to the step
    for a in np.linspace(0.0, a_pade, 9)[1:]:
        err = np.linalg.norm(high(a) - f(a))
        assert err <= 10 * tolerance * np.linalg.norm(f(a) - f(0.0))


def test_degenerate_terms_give_no_approximant():
    # U_2 parallel to U_1: the orthogonalisation breaks down, the series must be kept
    U = np.zeros((6, 3))
    U[1] = [1.0, 0.0, 0.0]
    U[2] = [2.0, 0.0, 0.0]
    U[3:] = np.random.default_rng(1).standard_normal((3, 3))
    assert pade_pair(U, 1.0) is None


# --------------------------------------------------------------------------- settings


def test_pade_setting_is_validated(repo_root):
    assert ANMSettings().pade is True  # the default, as in config/config.yaml
    assert (
        ANMSettings.from_config(
            {"order": 20, "tolerance": 1e-8, "newton_threshold": 1e-7, "max_steps": 10, "pade": True}
        ).pade
        is True
    )
    with pytest.raises(ValueError, match="pade must be true or false"):
        ANMSettings(pade="yes")
    config = yaml.safe_load((repo_root / "tests" / "data" / "small_config.yaml").read_text())
    config = copy.deepcopy(config)
    config["anm"]["pade"] = False
    validate_config(config)
    config["anm"]["pade"] = 1
    with pytest.raises(ConfigError):
        validate_config(config)


# --------------------------------------------------------------------------- HBM branches

# the branches of tests/test_continuation.py (CASES), run three ways


@pytest.fixture(scope="module", params=list(CASES))
def three_runs(request):
    H, mode, stop = CASES[request.param]
    system = HarmonicBalanceSystem(two_dof_structure(PARAMS), H)
    U0, e = start_point(system, mode)
    runs = {
        pade: continue_anm(
            system,
            U0,
            e,
            stop(),
            ANMSettings(tolerance=TOLERANCE, points_per_step=4, pade=pade),
            progress_seconds=QUIET,
        )
        for pade in (True, False)
    }
    pal = continue_pseudo_arclength(
        system, U0, e, stop(), PseudoArclengthSettings(tolerance=TOLERANCE), progress_seconds=QUIET
    )
    return request.param, system, runs[True], runs[False], pal


@pytest.mark.numerics
def test_pade_and_series_anm_trace_the_same_branch(three_runs):
    name, system, pade, taylor, pal = three_runs
    assert pade.end_reason == taylor.end_reason == pal.end_reason
    assert pade.stats.pade_steps > 0 and taylor.stats.pade_steps == 0
    # longer steps: fewer factorizations than the plain series
    assert pade.stats.factorizations < taylor.stats.factorizations
    A = fep(system, pade)
    scale = np.array([1.0, A[0, 1]])
    for other in (taylor, pal):
        assert np.max(distance_to_polyline(fep(system, other)[:-1], A, scale)) < 2e-3
    # in the unknown space: Padé points (interior ones included) on the baseline branch
    reference = np.asarray(pal.points)
    for i in range(1, len(pade.points) - 1, 3):
        chord = pade.points[i + 1] - pade.points[i - 1]
        assert same_branch_gap(system, pade.points[i], reference, chord) < 1e-6


@pytest.mark.numerics
def test_pade_points_meet_the_newton_threshold(three_runs):
    name, system, pade, taylor, pal = three_runs
    residuals = [relative_residual(system, U) for U in pade.points]
    assert max(residuals) <= ANMSettings().newton_threshold
    ends = [U for U, k, k_next in zip(pade.points, pade.step, pade.step[1:] + [-1]) if k != k_next]
    assert np.median([relative_residual(system, U) for U in ends]) <= TOLERANCE
