r"""Minimally augmented systems: a codimension-one point of periodic responses as a curve in two parameters.

A periodic response solves ``G(x; Omega, F, p) = 0`` (:mod:`nnmstop.bifurcation_atlas.equations`). A codimension-one
point (fold, flip, Neimark-Sacker, grazing) adds test functions ``psi(x, e; Omega, F, p) = 0`` with ``e``
extra unknowns (one more equation than extra unknowns): with two of the three parameters free,
``[G; psi] = 0`` is a curve, followed by the project's continuation driver like any branch
(:class:`CurveSystem` has the driver's ``residual``, ``jacobian``, ``diagnostics``).

Test functions (Govaerts' minimally augmented systems; the borders ``b, c`` are fixed over a segment of
the curve and refreshed between segments, :meth:`TestFunction.prepare`):

* :class:`FoldTest`: ``[[G_x, b], [c^T, 0]] [v; s] = [0; 1]``, ``psi = s`` (zero exactly where ``G_x`` is
  singular: the response turns back in ``Omega``, a multiplier through +1 of the formulation's map). With
  ``[[G_x, b], [c^T, 0]]^T [w; .] = [0; 1]``, ``ds = -w^T d(G_x) v``, obtained as the central difference of
  the Jacobian row ``w^T [G_x | G_params]`` along the null vector ``v`` (two Jacobians, no second
  derivative tensor);
* :class:`FlipTest`: the same bordering on ``M + I`` with ``M`` the formulation's map: a multiplier -1
  (period doubling of the full period, or ``nu = -1`` of the half-period map: symmetry breaking), with
  ``ds = -w^T dM v`` from the map's derivatives;
* :class:`NeimarkSackerTest`: ``M_k = M^2 - 2 k M + I`` with the extra unknown ``k = cos(theta)`` has a
  two-dimensional kernel when ``M`` has the pair ``exp(+-i theta)``; bordered by two columns and rows,
  ``[[M_k, B], [C^T, 0]] [V; G] = [0; I_2]``, the 2 x 2 block ``G`` vanishes there: two of its entries are
  the test functions (the pair whose Jacobian is best conditioned at the start), with
  ``dG = -W^T dM_k V``, ``dM_k = dM M + M dM - 2 k dM``, ``dM_k/dk = -2 M``. Where ``|k| > 1`` the same
  equations describe a real pair with product 1 (a neutral saddle), not a Neimark-Sacker point: ``|k| = 1``
  is a validity margin (a 1:1 resonance where it is reached);
* :class:`StateTest`: one state component at a value (``delta = 0``: the grazing orbit of the exact
  formulation, where the contact phase has zero duration; regular there by construction);
* :class:`InteriorGrazingTest`: the stop coordinate touches a level with zero velocity inside a phase,
  ``q_c(theta*) = level`` and ``qdot_c(theta*) = 0`` with the phase ``theta*`` the extra unknown: the grazing
  of a second contact per period (the boundary of the one-contact responses), derivatives by central
  differences of the closed-form orbit.

Method note: ``docs/methods/atlas.md``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = [
    "PARAMETER_NAMES",
    "TestFunction",
    "FoldTest",
    "FlipTest",
    "NeimarkSackerTest",
    "StateTest",
    "InteriorGrazingTest",
    "CurveSystem",
]

#: Names of the three parameters, in the order of ``params``.
PARAMETER_NAMES = ("frequency", "force", "parameter")
#: Relative length of the central difference along the null vector (FoldTest).
NULL_STEP = 1e-6


def _bordered(matrix, B, C):
    """``[[matrix, B], [C^T, 0]]`` for column blocks ``B``, ``C`` (m x k)."""
    k = B.shape[1]
    return np.block([[matrix, B], [C.T, np.zeros((k, k))]])


def _smallest_singular(matrix, k: int):
    """Left and right singular vectors (m x k) of the ``k`` smallest singular values."""
    U, _, Vt = scipy.linalg.svd(matrix)
    return U[:, -k:], Vt[-k:].T


def _orient(new, old):
    """``new`` with each column's sign chosen to point along ``old`` (borders refreshed without sign flips)."""
    if old is None:
        return new
    signs = np.sign(np.sum(new * old, axis=0))
    return new * np.where(signs == 0, 1.0, signs)


class TestFunction:
    """Test functions ``psi`` of a codimension-one point (``n_tests = n_extra + 1`` of them).

    ``prepare`` sets the borders at a point (of or near the curve); ``values`` and ``gradients`` evaluate
    ``psi`` and its derivatives in ``[x, e, Omega, F, p]``.
    """

    kind = ""
    n_extra = 0
    n_tests = 1

    def prepare(self, equations, x, extra, params) -> None:
        """Set the borders at this point."""

    def values(self, equations, x, extra, params) -> np.ndarray:
        raise NotImplementedError

    def gradients(self, equations, x, extra, params) -> np.ndarray:
        raise NotImplementedError

    def conditioning(self, equations, x, extra, params) -> float:
        """How far the borders are from the null vectors (1: on them; the borders are refreshed when it grows)."""
        return 1.0

    def extra_guess(self, multipliers, half_period: bool) -> np.ndarray:
        """Extra unknowns at a located point from its multipliers."""
        return np.zeros(self.n_extra)

    def margins(self, equations, x, extra, params) -> dict:
        """Validity margins of the test's own unknowns (> 0 while they mean what they should)."""
        return {}


class _SingleBordered(TestFunction):
    """A matrix made singular by one border: ``[[A, b], [c^T, 0]]``."""

    def __init__(self):
        self.b = self.c = None
        self._last = None  # (key, solution): residual and Jacobian are asked at the same point one after the other

    def matrix(self, equations, x, params):
        raise NotImplementedError

    def prepare(self, equations, x, extra, params) -> None:
        left, right = _smallest_singular(self.matrix(equations, x, params), 1)
        self.b, self.c = _orient(left, self.b), _orient(right, self.c)
        self._last = None

    def _solve(self, A):
        """``v``, ``s`` and ``w`` of the bordered matrix (one LU factorization for both systems)."""
        bordered = _bordered(A, self.b, self.c)
        rhs = np.zeros(len(bordered))
        rhs[-1] = 1.0
        lu = scipy.linalg.lu_factor(bordered, check_finite=False)
        vs = scipy.linalg.lu_solve(lu, rhs, check_finite=False)
        wt = scipy.linalg.lu_solve(lu, rhs, trans=1, check_finite=False)
        return vs[:-1], vs[-1], wt[:-1]

    def solve_at(self, equations, x, params):
        """:meth:`_solve` at ``(x, params)``, kept for the next call at the same point."""
        key = (np.asarray(x, dtype=float).tobytes(), np.asarray(params, dtype=float).tobytes())
        if self._last is None or self._last[0] != key:
            self._last = (key, self._solve(self.matrix(equations, x, params)))
        return self._last[1]

    def values(self, equations, x, extra, params) -> np.ndarray:
        return np.array([self.solve_at(equations, x, params)[1]])

    def conditioning(self, equations, x, extra, params) -> float:
        """``max(|v|, |w|)``: with ``c^T v = b^T w = 1`` it is 1 where the borders are the null vectors and grows
        as they lose them (a cheap stand-in for the bordered matrix's condition number)."""
        v, _, w = self.solve_at(equations, x, params)
        return float(max(np.linalg.norm(v), np.linalg.norm(w)))


class FoldTest(_SingleBordered):
    """``G_x`` singular: a fold of the responses (module docstring)."""

    kind = "fold"

    def matrix(self, equations, x, params):
        return equations.jacobian(x, params)[:, : equations.n]

    def gradients(self, equations, x, extra, params) -> np.ndarray:
        v, _, w = self.solve_at(equations, x, params)
        h = NULL_STEP * max(1.0, float(np.linalg.norm(x))) / float(np.linalg.norm(v))
        rows = [w @ equations.jacobian(x + s * h * v, params) for s in (1.0, -1.0)]
        return -((rows[0] - rows[1]) / (2 * h))[None, :]


class FlipTest(_SingleBordered):
    """``M + I`` singular, ``M`` the formulation's map: a multiplier -1 of that map."""

    kind = "flip"

    def matrix(self, equations, x, params):
        M = equations.monodromy(x, params)
        return M + np.eye(len(M))

    def gradients(self, equations, x, extra, params) -> np.ndarray:
        v, _, w = self.solve_at(equations, x, params)
        indices, d_state, d_params = equations.monodromy_derivatives(x, params)
        out = np.zeros(equations.n + 3)
        out[indices] = -np.einsum("i,kij,j->k", w, d_state, v)
        out[equations.n :] = -np.einsum("i,kij,j->k", w, d_params, v)
        return out[None, :]


class NeimarkSackerTest(TestFunction):
    """The map has a pair ``exp(+-i theta)``, ``k = cos(theta)`` the extra unknown (module docstring)."""

    kind = "neimark_sacker"
    n_extra = 1
    n_tests = 2

    def __init__(self):
        self.B = self.C = None
        self.entries = ((0, 0), (1, 1))

    @staticmethod
    def _matrix(M, kappa):
        return M @ M - 2.0 * kappa * M + np.eye(len(M))

    def prepare(self, equations, x, extra, params) -> None:
        M = equations.monodromy(x, params)
        left, right = _smallest_singular(self._matrix(M, float(extra[0])), 2)
        self.B, self.C = _orient(left, self.B), _orient(right, self.C)

    def _solve(self, M, kappa):
        bordered = _bordered(self._matrix(M, kappa), self.B, self.C)
        m = len(M)
        rhs = np.zeros((m + 2, 2))
        rhs[m:, :] = np.eye(2)
        VG, WH = np.linalg.solve(bordered, rhs), np.linalg.solve(bordered.T, rhs)
        return VG[:m], VG[m:], WH[:m]

    def all_entries(self, equations, x, extra, params):
        """The whole 2 x 2 block ``G`` and its derivatives ``(2, 2, n + 4)`` in ``[x, k, Omega, F, p]``."""
        M = equations.monodromy(x, params)
        kappa = float(extra[0])
        V, G, W = self._solve(M, kappa)
        indices, d_state, d_params = equations.monodromy_derivatives(x, params)
        n = equations.n
        out = np.zeros((2, 2, n + 4))

        def contract(dM):  # -W^T (dM M + M dM - 2 k dM) V for a stack of dM
            dMk = dM @ M + M @ dM - 2.0 * kappa * dM
            return -np.einsum("ia,kij,jb->abk", W, dMk, V)

        out[:, :, indices] = contract(d_state)
        out[:, :, n] = -W.T @ (-2.0 * M) @ V
        out[:, :, n + 1 :] = contract(d_params)
        return G, out

    def values(self, equations, x, extra, params) -> np.ndarray:
        M = equations.monodromy(x, params)
        G = self._solve(M, float(extra[0]))[1]
        return np.array([G[i, j] for i, j in self.entries])

    def gradients(self, equations, x, extra, params) -> np.ndarray:
        _, grads = self.all_entries(equations, x, extra, params)
        return np.array([grads[i, j] for i, j in self.entries])

    def choose_entries(self, equations, x, extra, params, free) -> None:
        """The two entries of ``G`` whose gradients, with ``G_x``, make the best-conditioned square Jacobian in
        the state, ``k`` and the first free parameter (the curve's Jacobian at the start)."""
        _, grads = self.all_entries(equations, x, extra, params)
        J = equations.jacobian(x, params)
        n = equations.n
        pairs = [
            ((0, 0), (1, 1)),
            ((0, 0), (0, 1)),
            ((0, 0), (1, 0)),
            ((0, 1), (1, 0)),
            ((0, 1), (1, 1)),
            ((1, 0), (1, 1)),
        ]
        best = None
        for pair in pairs:
            rows = np.array([grads[i, j] for i, j in pair])
            top = np.column_stack([J[:, :n], np.zeros(n), J[:, n + free[0]]])
            bottom = np.column_stack([rows[:, : n + 1], rows[:, n + 1 + free[0]]])
            condition = np.linalg.cond(np.vstack([top, bottom]))
            if best is None or condition < best[0]:
                best = (condition, pair)
        self.entries = best[1]

    def conditioning(self, equations, x, extra, params) -> float:
        """The largest column norm of ``V`` and ``W`` (1 where the borders span the kernels, module docstring)."""
        V, _, W = self._solve(equations.monodromy(x, params), float(extra[0]))
        return float(max(np.linalg.norm(V, axis=0).max(), np.linalg.norm(W, axis=0).max()))

    def extra_guess(self, multipliers, half_period: bool) -> np.ndarray:
        """``k = cos(theta)`` of the complex multiplier nearest the unit circle (of the formulation's map)."""
        m = np.asarray(multipliers)
        complex_ = m[np.abs(m.imag) > 1e-9 * np.abs(m)]
        pick = complex_ if complex_.size else m
        mu = pick[np.argmin(np.abs(np.abs(pick) - 1.0))]
        return np.array([float(np.cos(np.angle(mu)))])


class StateTest(TestFunction):
    """One state component at a given value: ``x[index] - value = 0`` (``delta = 0``: grazing)."""

    kind = "grazing"

    def __init__(self, index: int, value: float = 0.0):
        self.index, self.value = int(index), float(value)

    def values(self, equations, x, extra, params) -> np.ndarray:
        return np.array([x[self.index] - self.value])

    def gradients(self, equations, x, extra, params) -> np.ndarray:
        out = np.zeros((1, equations.n + 3))
        out[0, self.index] = 1.0
        return out


class InteriorGrazingTest(TestFunction):
    """The struck coordinate (or that of ``contact``) touches ``level`` with zero velocity at the phase ``theta*``
    (extra unknown) inside ``phase`` ("F": the free flight, "R": the contact) of the exact formulation
    (:meth:`ExactContactEquations.stop_state`); ``margin``: the formulation's validity margin that vanishes there
    (by default ``early_impact`` in the free flight, ``leaves_stop`` in the contact)."""

    kind = "second_contact"
    n_extra = 1
    n_tests = 2

    def __init__(self, phase: str, level: float, contact: int | None = None, margin: str | None = None):
        self.phase, self.level, self.contact = phase, float(level), contact
        self.margin = margin or ("early_impact" if phase == "F" else "leaves_stop")

    def margins(self, equations, x, extra, params) -> dict:
        """The touching phase stays inside its phase interval."""
        start, end = equations.phase_interval(x, self.phase)
        theta = float(extra[0])
        return {"touch_inside": min(theta - start, end - theta) / np.pi}

    def values(self, equations, x, extra, params) -> np.ndarray:
        q, qdot = equations.stop_state(x, params, float(extra[0]), self.phase, self.contact)
        return np.array([q - self.level, qdot])

    def gradients(self, equations, x, extra, params) -> np.ndarray:
        point = np.concatenate([x, extra, params])
        n = equations.n
        out = np.zeros((2, n + 4))
        for k in range(n + 4):
            h = 1e-7 * max(1.0, abs(point[k]))
            values = []
            for sign in (1.0, -1.0):
                shifted = point.copy()
                shifted[k] += sign * h
                values.append(self.values(equations, shifted[:n], shifted[n : n + 1], shifted[n + 1 :]))
            out[:, k] = (values[0] - values[1]) / (2 * h)
        return out


class CurveSystem:
    """``[G; psi] = 0`` in the unknowns ``U = [x, e, a, b]``, ``(a, b)`` the two free parameters.

    Parameters
    ----------
    equations : OrbitEquations
    test : TestFunction
    free : tuple of two ints
        Indices into ``(Omega, F, p)`` of the free parameters (the first is ``Omega`` in every atlas plane).
    params : array_like
        ``(Omega, F, p)``: the value of the fixed one is taken from here.
    """

    def __init__(self, equations, test: TestFunction, free, params):
        self.equations, self.test = equations, test
        self.free = tuple(int(i) for i in free)
        if len(self.free) != 2 or len(set(self.free)) != 2 or not all(0 <= i < 3 for i in self.free):
            raise ValueError(f"free must name two distinct parameters of {PARAMETER_NAMES}, got {free!r}")
        self.base = np.asarray(params, dtype=float).copy()
        self.n = equations.n
        self.n_extra = test.n_extra
        self.n_unknowns = self.n + self.n_extra + 2
        self.n_equations = self.n + test.n_tests

    def split(self, U):
        U = np.asarray(U, dtype=float)
        n, e = self.n, self.n_extra
        params = self.base.copy()
        params[list(self.free)] = U[n + e :]
        return U[:n], U[n : n + e], params

    def pack(self, x, extra, params) -> np.ndarray:
        return np.concatenate([x, np.atleast_1d(extra), np.asarray(params)[list(self.free)]])

    def residual(self, U) -> np.ndarray:
        x, extra, params = self.split(U)
        return np.concatenate([self.equations.residual(x, params), self.test.values(self.equations, x, extra, params)])

    def jacobian(self, U) -> np.ndarray:
        x, extra, params = self.split(U)
        n, e = self.n, self.n_extra
        J = self.equations.jacobian(x, params)
        top = np.column_stack([J[:, :n], np.zeros((n, e)), J[:, n + np.array(self.free)]])
        grads = self.test.gradients(self.equations, x, extra, params)
        if e:
            bottom = np.column_stack([grads[:, : n + e], grads[:, n + e + np.array(self.free)]])
        else:
            bottom = np.column_stack([grads[:, :n], grads[:, n + np.array(self.free)]])
        return np.vstack([top, bottom])

    def diagnostics(self, U) -> dict:
        """For the driver's messages: the frequency (Hz) and, as "energy", the second free parameter."""
        _, _, params = self.split(U)
        return {
            "energy": float(params[self.free[1]]),
            "frequency": float(params[0]) / (2 * np.pi),
            "impacts_per_period": 2,
        }
