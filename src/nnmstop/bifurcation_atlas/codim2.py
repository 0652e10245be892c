r"""Codimension-two points of the atlas: located on the curves and typed.

Along a followed curve (:class:`nnmstop.bifurcation_atlas.curves.Curve`) a codimension-two point is either a sign change
of a second test function between two stored points, located by Brent's method on the continuation path of
that step (the same path the driver locates events on), or the located event that ends the curve:

* on a fold curve: a **cusp** where the quadratic coefficient of the fold's normal form
  ``a = w^T G_xx[v, v]`` changes sign (two folds meet and disappear); an **isola** point where
  ``w^T G_Omega`` changes sign: the second parameter is extremal along the fold curve and the response at
  that value has an isolated singular point (a closed curve of responses is born there, or two response
  curves cross); a **fold-flip** point where ``det(M + I)`` changes sign (a multiplier -1 of the
  formulation's map on the fold curve: period doubling, or symmetry breaking for the half-period map);
* on a Neimark-Sacker curve of the half-period map (``mu = nu**2``): a **1:2 resonance** of the full period
  where ``cos(theta_nu)`` crosses 0 (``mu = -1`` double);
* where a curve ends: **grazing** (the contact duration vanishes: the curve meets the grazing curve),
  **second contact** (a second contact per period appears: the curve meets the boundary of the one-contact
  responses), **1:1** (or 1:2 for a full-period map at ``cos theta = -1``) resonance where a
  Neimark-Sacker pair becomes real.

Method note: ``docs/methods/atlas.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize

from nnmstop.bifurcation_atlas.augmented import FoldTest, NeimarkSackerTest
from nnmstop.bifurcation_atlas.flags import CODIM2_KINDS
from nnmstop.continuation.core import unit_tangent
from nnmstop.continuation.corrected_path import CorrectedPath

__all__ = ["CODIM2_KINDS", "Codim2Point", "locate_codim2", "curve_end_kind"]


_SECOND_CONTACT = ("early_impact", "leaves_stop", "other_stops", "free_duration")


@dataclass(frozen=True)
class Codim2Point:
    """A located codimension-two point: its kind, the curve's unknowns there, the parameters and the test."""

    kind: str
    U: np.ndarray
    params: np.ndarray
    test: str


def _second_difference(equations, x, params, v):
    """``G_xx[v, v]`` by a central second difference along the unit ``v``."""
    h = 1e-4 * max(1.0, float(np.linalg.norm(x)))
    G = [equations.residual(x + s * h * v, params) for s in (1.0, 0.0, -1.0)]
    return (G[0] - 2 * G[1] + G[2]) / h**2


def _fold_tests(system, test: FoldTest):
    """Second test functions on a fold curve, evaluated with the borders currently set in ``test``."""
    equations = system.equations
    free = system.free[0]

    def normal_form(U):
        x, _, params = system.split(U)
        v, _, w = test._solve(test.matrix(equations, x, params))
        unit = v / np.linalg.norm(v)
        return float(w @ _second_difference(equations, x, params, unit) / np.linalg.norm(w))

    def extremum(U):
        x, _, params = system.split(U)
        v, _, w = test._solve(test.matrix(equations, x, params))
        column = equations.jacobian(x, params)[:, equations.n + free]
        return float(w @ column / (np.linalg.norm(w) * np.linalg.norm(column)))

    def flip(U):
        x, _, params = system.split(U)
        M = equations.monodromy(x, params)
        return float(np.linalg.det(M + np.eye(len(M))))

    return {"cusp": normal_form, "isola": extremum, "fold_flip": flip}


def _interior_tests(system) -> dict:
    test = system.test
    if isinstance(test, FoldTest):
        return _fold_tests(system, test)
    if isinstance(test, NeimarkSackerTest) and system.equations.half_period:
        return {"resonance_1_2": lambda U: float(system.split(U)[1][0])}
    return {}


def curve_end_kind(system, key: str, U) -> str:
    """The codimension-two kind of a curve's end on the margin ``key`` ("" where the end is none: the window,
    the harmonics' resolution, the number of points)."""
    if key == "contact_duration":
        return "grazing"
    if key in _SECOND_CONTACT:
        return "second_contact"
    if key == "unit_pair":
        kappa = float(system.split(U)[1][0])
        return "resonance_1_2" if (kappa < 0 and not system.equations.half_period) else "resonance_1_1"
    return ""


def _locate(system, U_a, U_b, function, f_a, f_b, rel_tol: float = 1e-10):
    """The root of ``function`` on the continuation path from ``U_a`` to ``U_b`` (Brent)."""
    tangent, _ = unit_tangent(system, U_a, U_b - U_a)
    path = CorrectedPath(system, U_a, tangent, U_b, tol=1e-10)
    length = path.length
    a = scipy.optimize.brentq(
        lambda s: function(path(s)) if 0 < s < length else (f_a if s <= 0 else f_b),
        0.0,
        length,
        xtol=rel_tol * length,
    )
    return path(a)


def locate_codim2(curve) -> list:
    """Codimension-two points of ``curve`` (module docstring), in the order of the curve."""
    system = curve.system
    equations, test = system.equations, system.test
    points = np.asarray(curve.points)
    found = []
    tests = _interior_tests(system)
    if tests and len(points) > 1:
        values = {name: [] for name in tests}
        for U in points:
            x, extra, params = system.split(U)
            test.prepare(equations, x, extra, params)
            for name, function in tests.items():
                values[name].append(function(U))
        for name, function in tests.items():
            v = np.array(values[name])
            for i in np.flatnonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0):
                x, extra, params = system.split(points[i])
                test.prepare(equations, x, extra, params)
                # the borders at point i serve the whole step: recompute the end values with them
                f_a, f_b = function(points[i]), function(points[i + 1])
                if f_a * f_b > 0:
                    continue
                U = _locate(system, points[i], points[i + 1], function, f_a, f_b)
                found.append((i, Codim2Point(name, U, system.split(U)[2], name)))
    for end, (key, U) in enumerate(zip(curve.end_keys, (points[0], points[-1]))):
        kind = curve_end_kind(system, key, U)
        if kind:
            found.append((-1 if end == 0 else len(points), Codim2Point(kind, np.asarray(U), system.split(U)[2], key)))
    found.sort(key=lambda item: item[0])
    return [point for _, point in found]
