r"""Simple branch points of a continued curve: location, the crossing curve's tangent, switching onto it.

Method-generic: any system with ``residual``, ``jacobian`` and ``n_unknowns`` (and ``diagnostics``
for :func:`continue_bifurcated_branch`), any stepper of :mod:`nnmstop.continuation.driver`.
A *simple branch point* ``U*`` of ``S(U) = 0`` (``n`` equations, ``n + 1`` unknowns) is where two
solution curves cross: ``J(U*)`` has rank ``n - 1`` and its null space is a plane holding both
tangents. Along a branch the sign of ``det [J; t^T]`` changes there and not at folds; the driver
flags the steps across which it does (:attr:`nnmstop.continuation.core.Branch.branch_points`).

* :func:`locate_branch_point` bisects the sign change along the step's own path (the stepper's
  :meth:`~nnmstop.continuation.driver.Stepper.path_through`), :func:`project_onto_branch` puts the
  point back on the curve;
* :func:`bifurcation_tangents` solves Keller's algebraic bifurcation equation on the null plane of
  ``J(U*)``, with the system's second derivative (a ``quadratic`` form given by the caller, e.g. the
  exact one of the harmonic-balance recast, or central differences of the Jacobian);
* :func:`switch_branch` steps onto the other curve, :func:`continue_bifurcated_branch` follows it both
  ways; :func:`locate_flagged` locates every flagged step of a branch.

What the crossing curve *is* (an ``n:1`` resonance, a symmetry breaking) depends on the method's
unknowns: the harmonic balance classification is :mod:`nnmstop.hbm.bifurcation`.
Method notes: ``docs/methods/continuation.md``.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from nnmstop.continuation.anm import ANMSettings
from nnmstop.continuation.core import (
    Branch,
    ContinuationError,
    ContinuationStats,
    OrthogonalUpdate,
    newton_correct,
    relative_of_residual,
    unit_tangent,
)
from nnmstop.continuation.corrected_path import CorrectedPath
from nnmstop.continuation.driver import as_stepper, continue_branch, path_border
from nnmstop.continuation.linear import factorize_bordered
from nnmstop.continuation.newton import bisect_sign_change, newton_solve

__all__ = [
    "BranchPoint",
    "Quadratic",
    "difference_quadratic",
    "locate_branch_point",
    "project_onto_branch",
    "bifurcation_tangents",
    "switch_branch",
    "continue_bifurcated_branch",
    "locate_flagged",
]

logger = logging.getLogger("nnmstop.continuation.branch_points")

#: ``quadratic(a, b)``: the symmetric bilinear form ``1/2 d2S(U*)[a, b]`` at the branch point (any
#: nonzero multiple serves: only the roots of the bifurcation equation are used).
Quadratic = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass
class BranchPoint:
    """A located simple branch point.

    Attributes
    ----------
    U : ndarray
        The point (on the branch, residual at the Newton tolerance).
    incoming : ndarray
        Unit tangent of the branch that was followed, oriented along the travel.
    bifurcated : ndarray
        Unit tangent of the other curve through ``U`` (sign arbitrary).
    singular_ratio : float
        Smallest over second-smallest nonzero singular value of ``J(U)``: small at a
        simple branch point (the null space is two-dimensional).
    discriminant : float
        ``|A| / R`` of the bifurcation equation (see :func:`bifurcation_tangents`):
        below 1 for two real, distinct tangents; near 1 they nearly coincide.
    angle : float
        Angle between the two tangents, in degrees.
    """

    U: np.ndarray
    incoming: np.ndarray
    bifurcated: np.ndarray
    singular_ratio: float
    discriminant: float
    angle: float


def locate_branch_point(system, U_a, U_b, method=None, tol: float = 1e-12, newton_tol: float = 1e-9):
    """Branch point within the continuation step from ``U_a`` to ``U_b``.

    The path of the step is recomputed by the continuation method that took it
    (:meth:`nnmstop.continuation.driver.Stepper.path_through`: the ANM's series or Padé
    approximant, the pseudo-arclength corrected path); it is the followed branch all along
    the step. The sign of ``det [J(U(a)); U'(a)^T]`` is bisected in the path parameter
    ``a``: no Newton solve that could land on the other curve near the branch point,
    where any hyperplane meets both. The point found is put back on the branch by
    least-norm Newton (:func:`project_onto_branch`).

    Parameters
    ----------
    U_a, U_b : ndarray
        Start and end of the continuation step flagged with a sign change (the two
        stored points of the step, the end possibly Newton-corrected).
    method : Stepper or settings, optional
        The continuation method of the step (``ANMSettings``, ``PseudoArclengthSettings``
        or a stepper); the ANM with default settings when None.
    tol : float
        Bisection tolerance, relative to the step's path length.
    newton_tol : float
        Relative residual of the projection onto the branch.

    Returns
    -------
    U : ndarray
        The branch point.
    t : ndarray
        The path's unit border there (for the ANM its unit tangent, oriented from ``U_a`` to ``U_b``).

    Raises
    ------
    ValueError
        If the determinant has the same sign at both ends of the step (no branch
        point bracketed), or ``U_b`` is not on the step's path.
    """
    stepper = as_stepper(ANMSettings() if method is None else method)
    U_a, U_b = np.asarray(U_a, float), np.asarray(U_b, float)
    chord = U_b - U_a
    if not np.linalg.norm(chord) > 0:
        raise ValueError("locate_branch_point needs two distinct points")
    t_a, _ = unit_tangent(system, U_a, chord, singular_tol=None)
    # U_b may have been Newton-corrected off the recomputed step (the ANM's end residual near a branch
    # point): the step's own path up to its own end, then the corrected path from U_a to U_b
    path, a_end = stepper.path_through(system, U_a, t_a, U_b, ContinuationStats(), strict=False)
    bracket = _sign_change_on(system, path, a_end, tol)
    if bracket is None and not np.allclose(path(a_end), U_b, rtol=0.0, atol=1e-3 * np.linalg.norm(chord)):
        path = CorrectedPath(system, U_a, t_a, U_b)
        a_end = path.length
        bracket = _sign_change_on(system, path, a_end, tol)
    if bracket is None:
        raise ValueError("no branch point between the two points: det [J; t^T] has the same sign at both")
    a_star = bracket.midpoint
    border = path_border(path, a_star)
    return project_onto_branch(system, path(a_star), tol=newton_tol, reference=border), border


def _sign_change_on(system, path, a_end: float, tol: float):
    """Bisection bracket of the sign change of ``det [J(U(a)); b(a)^T]`` on ``[0, a_end]``, None when there is none."""

    def sign(a):
        return factorize_bordered(system, path(a), path_border(path, a), singular_tol=None).determinant_sign()

    try:
        return bisect_sign_change(sign, 0.0, a_end, tol=tol * a_end)
    except ValueError:
        return None


def project_onto_branch(system, U, tol: float = 1e-9, max_iter: int = 30, reference=None):
    """Nearest-point Newton (Moore-Penrose) iterations on ``S(U) = 0``.

    Each update is the least-norm solution of ``J dU = -S`` with the singular values
    below ``1e-12`` of the largest cut off, so the iteration stays well defined at and
    near a branch point, where the bordered matrices of the continuation are singular.
    A sparse system (``linear_algebra == "sparse"``) solves instead with the sparse LU of
    ``[J; t^T]``, ``t`` the unit null vector of ``J`` at the iterate: the least-norm update
    itself wherever no singular value is cut off, without a dense SVD.

    Parameters
    ----------
    reference : ndarray, optional
        A direction of the branch near ``U``, which orients the null vectors of sparse systems.

    Raises
    ------
    ContinuationError
        If the relative residual does not reach ``tol``.
    """
    if _is_sparse(system):
        direction = np.ones(system.n_unknowns) if reference is None else np.asarray(reference, float)

        def update(V):
            # the least-norm update is the one orthogonal to the null vector of J(V): the tangent there
            tangent, _ = unit_tangent(system, V, direction, singular_tol=None)
            return OrthogonalUpdate(factorize_bordered(system, V, tangent, singular_tol=None))
    else:

        def update(V):
            return _LeastNorm(system.jacobian(V))

    result = newton_solve(
        system.residual,
        update,
        U,
        tol=tol,
        max_iter=max_iter,
        criterion="residual",
        norm=relative_of_residual,
    )
    if result.converged:
        return result.y
    raise ContinuationError(
        f"projection onto the branch did not converge in {max_iter} iterations "
        f"(relative residual {result.residual_norm:.2e} > {tol:.1e})"
    )


class _LeastNorm:
    """Least-norm solutions of ``J x = rhs`` (singular values below ``1e-12`` of the largest cut off)."""

    def __init__(self, J):
        self.J = J

    def solve(self, rhs):
        return np.linalg.lstsq(self.J, rhs, rcond=1e-12)[0]


def _is_sparse(system) -> bool:
    return getattr(system, "linear_algebra", "dense") == "sparse"


def _null_plane(system, U, reference=None):
    """Right null plane (2 x n+1), left null vector and singular ratio of ``J(U)``.

    Dense systems: SVD of ``J``. Sparse systems (:func:`_sparse_null_plane`): inverse
    iterations with the sparse LU of ``[J; r^T]``, ``r`` the unit ``reference``.
    """
    if _is_sparse(system):
        return _sparse_null_plane(system, U, reference)
    u, sing, vt = np.linalg.svd(system.jacobian(U))
    # J is n x (n+1): vt[-1] spans its generic null space; vt[-2] belongs to the smallest
    # singular value sing[-1], which vanishes at a branch point.
    return vt[-2:], u[:, -1], float(sing[-1] / sing[-2])


def _sparse_null_plane(system, U, reference, iterations: int = 3):
    """Null plane, left null vector and singular ratio of a sparse ``J(U)`` near a simple branch point.

    With ``r`` a unit direction, ``B = [J; r^T]`` is singular exactly when ``J`` has a null
    vector orthogonal to ``r``, which a simple branch point always has. Inverse iterations
    on ``B^T B`` and ``B B^T`` with the LU of ``B`` give that vector ``v`` and ``B``'s left one
    (whose first ``n`` entries are the left null vector of ``J``): the singular vectors, not the
    eigenvectors of ``B``, which differ from them where ``B``'s left and right null vectors are far
    from parallel; the solution of ``B w = e_{n+1}`` with its ``v`` part removed is the null vector
    along ``r``. The ratio is the smallest singular value of
    ``B`` (``|B v|``) over the second smallest, estimated by inverse iterations on
    ``(B^T B)^{-1}`` deflated of ``v``.
    """
    J = system.jacobian(U, sparse=True)
    n = J.shape[0]
    r = np.zeros(n + 1) if reference is None else np.asarray(reference, float)
    if reference is None:
        r[0] = 1.0
    r = r / np.linalg.norm(r)
    B = sp.vstack([J, sp.csr_matrix(r[None, :])], format="csc")
    lu = splu(B)
    # deterministic starts (byte-reproducible datasets)
    start = np.cos(np.arange(n + 1) * 0.7071 + 0.3)
    v = w = start / np.linalg.norm(start)
    for _ in range(iterations):
        v = lu.solve(lu.solve(v, trans="T"))
        v /= np.linalg.norm(v)
        w = lu.solve(lu.solve(w), trans="T")
        w /= np.linalg.norm(w)
    e = np.zeros(n + 1)
    e[-1] = 1.0
    along = lu.solve(e)
    along -= (along @ v) * v
    along /= np.linalg.norm(along)
    psi = w[:n] / np.linalg.norm(w[:n])
    smallest = float(np.linalg.norm(B @ v))
    y = start - (start @ v) * v
    for _ in range(8):
        y = lu.solve(lu.solve(y, trans="T"))
        y -= (y @ v) * v
        y /= np.linalg.norm(y)
    second = float(np.linalg.norm(B @ y))
    return np.vstack([along, v]), psi, smallest / second


def difference_quadratic(system, U) -> Quadratic:
    """The bilinear form ``1/2 d2S(U)[a, b]`` by central differences of the Jacobian.

    ``(J(U + h b) - J(U - h b)) a / (4 h)``, exact to round-off for a quadratic system (whose
    Jacobian is affine in ``U``), second-order accurate otherwise; ``h`` is ``eps^(1/3)``
    relative to ``|U|``.
    """
    U = np.asarray(U, dtype=float)
    h = np.finfo(float).eps ** (1.0 / 3.0) * max(np.linalg.norm(U), 1.0)

    def quadratic(a, b):
        size = np.linalg.norm(b)
        if not size > 0:
            return np.zeros(len(U) - 1)
        unit = np.asarray(b, dtype=float) / size
        difference = system.jacobian(U + h * unit) @ a - system.jacobian(U - h * unit) @ a
        return difference * (size / (4.0 * h))

    return quadratic


def bifurcation_tangents(system, U_star, reference, quadratic: Quadratic | None = None):
    """Tangents of the two curves through the branch point ``U_star``.

    Solves the algebraic bifurcation equation ``psi^T Q(tau, tau) = 0`` on the null
    plane of ``J(U_star)`` (``psi`` its left null vector, ``Q`` the symmetric bilinear form
    ``quadratic``; by default :func:`difference_quadratic`). With
    ``tau = cos(theta) phi_1 + sin(theta) phi_2`` it reads
    ``A + B cos(2 theta) + C sin(2 theta) = 0``, two real roots at a branch point.

    Parameters
    ----------
    reference : ndarray
        A direction of the followed branch near ``U_star`` (for example the chord of the
        step across it): the root closer to it is the incoming tangent. The tangent
        computed *at* ``U_star`` cannot serve, because ``[J; t^T]`` is singular there.

    Returns
    -------
    BranchPoint

    Raises
    ------
    ContinuationError
        If the bifurcation equation has no two distinct real roots (not a simple
        branch point).
    """
    plane, psi, ratio = _null_plane(system, U_star, reference)
    if quadratic is None:
        quadratic = difference_quadratic(system, U_star)
    p1, p2 = plane
    c11 = psi @ quadratic(p1, p1)
    c12 = psi @ quadratic(p1, p2)
    c22 = psi @ quadratic(p2, p2)
    A, B, C = 0.5 * (c11 + c22), 0.5 * (c11 - c22), c12
    R = np.hypot(B, C)
    if not R > abs(A):
        raise ContinuationError(
            f"not a simple branch point: the bifurcation equation has no two real roots (|A|/R = {abs(A) / R:.3g})"
        )
    phase, spread = np.arctan2(C, B), np.arccos(-A / R)
    tangents = [np.cos(th) * p1 + np.sin(th) * p2 for th in (0.5 * (phase + spread), 0.5 * (phase - spread))]
    reference = np.asarray(reference, float) / np.linalg.norm(reference)
    tangents.sort(key=lambda v: -abs(v @ reference))
    incoming, bifurcated = tangents
    if incoming @ reference < 0:
        incoming = -incoming
    return BranchPoint(
        U=np.asarray(U_star, float),
        incoming=incoming,
        bifurcated=bifurcated,
        singular_ratio=ratio,
        discriminant=float(abs(A) / R),
        angle=float(np.degrees(np.arccos(min(1.0, abs(incoming @ bifurcated))))),
    )


def switch_branch(system, point: BranchPoint, step: float, tol: float = 1e-11):
    """First point of the bifurcated curve, ``step |U*|`` away from the branch point along it.

    The guess ``U* + step * tau`` is corrected by Newton in the hyperplane orthogonal
    to ``tau``. The sign of ``step`` selects the side.

    Raises
    ------
    ContinuationError
        If Newton fails or lands back on the incoming branch.
    """
    tau = point.bifurcated
    step = step * max(np.linalg.norm(point.U), 1.0)
    U1, _ = newton_correct(system, point.U + step * tau, tau, ContinuationStats(), tol=tol)
    offset = U1 - point.U
    # Newton keeps offset . tau = step: landing on the incoming curve instead makes the
    # offset point along the incoming tangent rather than along tau
    if abs(offset @ point.incoming) > abs(offset @ tau):
        raise ContinuationError(
            f"branch switching with step {step:g} fell back onto the incoming branch; try a smaller step"
        )
    return U1


def continue_bifurcated_branch(
    system, point: BranchPoint, stop, method, switch_step: float, label: str = "bifurcated", end_check=None
):
    """Follow the bifurcated curve through ``point`` both ways.

    ``method`` is the continuation method (a stepper or its settings, e.g. ``ANMSettings``).

    Each side starts from :func:`switch_branch` (``+switch_step`` and ``-switch_step``
    along ``point.bifurcated``) and runs until ``stop`` says so. ``end_check(side, side_label)``, when
    given, checks where each side ended (it may raise, e.g.
    :class:`~nnmstop.continuation.confirm.EndNotConfirmed`) and says how; the merged branch's ``end_check``
    holds both sides' texts.

    Returns
    -------
    Branch
        The points of one side in reverse order, the branch point, then the points of the
        other side, the side ending at the higher energy first: one curve, in order, through the branch point
        (whose index is ``branch.branch_points[0]``; the branch points passed on
        either side follow). ``stats`` add up both sides.
    """
    sides, checks = {}, {}
    for sign in (-1.0, 1.0):
        U1 = switch_branch(system, point, sign * switch_step)
        side_label = f"{label} ({'+' if sign > 0 else '-'} side)"
        sides[sign] = continue_branch(system, U1, sign * point.bifurcated, as_stepper(method), stop, label=side_label)
        if end_check is not None:
            checks[sign] = end_check(sides[sign], side_label)
    minus, plus = sides[-1.0], sides[1.0]
    # The sign of point.bifurcated comes from an SVD (round-off decides it): store the curve from its
    # high-energy end, so that it runs the same way on every machine.
    if _end_energy(system, minus) < _end_energy(system, plus):
        minus, plus = plus, minus
        checks = {-1.0: checks.get(1.0), 1.0: checks.get(-1.0)}
    merged = Branch()
    n_minus = len(minus.points)
    for U, step, diag in zip(minus.points[::-1], minus.step[::-1], minus.diagnostics[::-1]):
        merged.add(U, -step, diag)
    merged.add(point.U, 0, system.diagnostics(point.U))
    for U, step, diag in zip(plus.points, plus.step, plus.diagnostics):
        merged.add(U, step, diag)
    # the flags keep marking the same orbits (where each side's continuation saw the sign change)
    merged.branch_points = (
        [n_minus] + [n_minus - 1 - i for i in minus.branch_points] + [n_minus + 1 + i for i in plus.branch_points]
    )
    for field in dataclasses.fields(merged.stats):
        setattr(merged.stats, field.name, getattr(minus.stats, field.name) + getattr(plus.stats, field.name))
    merged.end_reason = f"- side: {minus.end_reason}; + side: {plus.end_reason}"
    if end_check is not None:
        merged.end_check = f"- side: {checks[-1.0]}; + side: {checks[1.0]}"
    return merged


def _end_energy(system, branch: Branch) -> float:
    diagnostics = branch.diagnostics[-1] or system.diagnostics(branch.points[-1])
    return float(diagnostics["energy"])


def locate_flagged(system, points, steps, flagged, method=None, quadratic=None) -> list:
    """Locate the branch points of the steps a continuation flagged, with both tangents there.

    Parameters
    ----------
    points, steps : sequences
        Points of the branch and the index of the continuation step that produced each.
    flagged : sequence of int
        Indices of the points ending a step across which ``det [J; t^T]`` changed sign.
    method : Stepper or settings, optional
        The continuation method that took the steps (see :func:`locate_branch_point`).
    quadratic : callable, optional
        ``quadratic(U_star)`` giving the bilinear form at a branch point (:data:`Quadratic`);
        :func:`difference_quadratic` by default.

    Returns
    -------
    list of (int, BranchPoint)
        The flagged index and the located point with its tangents (:func:`bifurcation_tangents`).
    """
    points, steps = np.asarray(points, float), np.asarray(steps)
    out = []
    for i in flagged:
        start = int(np.flatnonzero(steps == steps[i])[0]) - 1
        if start < 0:
            continue  # the first point of a branch ends no step
        U_star, _ = locate_branch_point(system, points[start], points[i], method)
        form = None if quadratic is None else quadratic(U_star)
        out.append((int(i), bifurcation_tangents(system, U_star, points[i] - points[start], form)))
    return out
