r"""Seeds and checks of the regularized curves, from the harmonic-balance responses of the forced path.

At each seed and check force, the regularized one-parameter response is computed as the forced target
computes it (:func:`nnmstop.forced.responses.regularized_response`) and its points of the curve's kind are
located on it: the folds where ``Omega`` is extremal on the ANM steps
(:func:`nnmstop.forced.responses.locate_folds`: exactly where the harmonic-balance Jacobian in the state is
singular, the fold curve's own condition), the Neimark-Sacker points where a complex pair of the monodromy's
multipliers crosses the unit circle (:func:`nnmstop.forced.regularized.regularized_stability`). The points at
the seed forces start the curves; those at the check forces must lie on them.
Method note: ``docs/methods/atlas.md``.
"""

from __future__ import annotations

import numpy as np

from nnmstop.bifurcation_atlas.augmented import FoldTest, NeimarkSackerTest
from nnmstop.bifurcation_atlas.equations import HarmonicBalanceEquations

__all__ = ["regularized_equations", "regularized_located", "regularized_seeds", "CHANGES_OF"]

#: The located point of a regularized response behind each regularized curve kind.
CHANGES_OF = {"regularized_fold": "fold", "regularized_neimark_sacker": "neimark_sacker"}


def regularized_equations(atlas) -> HarmonicBalanceEquations:
    """The harmonic-balance equations of the atlas' excitation (``atlas.regularized``: harmonics, Magnus steps,
    max_truncation)."""
    spec = atlas.regularized
    return HarmonicBalanceEquations(
        atlas.excitation,
        int(spec["harmonics"]),
        atlas.parameter,
        steps=int(spec["steps"]),
        max_truncation=float(spec["max_truncation"]),
    )


def regularized_located(atlas, kind: str, value: float, anm, stability) -> list:
    """Unknown vectors ``U`` of the points of ``kind`` located on the regularized response at ``value``."""
    from nnmstop.continuation.anm import ANMStepper
    from nnmstop.forced.regularized import regularized_stability
    from nnmstop.forced.responses import RegularizedSettings, locate_folds, regularized_response

    spec = atlas.regularized
    excitation = atlas.excitation_at(float(value))
    settings = RegularizedSettings(int(spec["harmonics"]), anm, float(spec["max_truncation"]))
    system, branch = regularized_response(excitation, atlas.frequency_range, settings, label=f"{kind} at {value:g}")
    if CHANGES_OF[kind] == "fold":
        return [U for _, U in locate_folds(system, ANMStepper(anm), branch.points, system.i_omega)]
    _, changes = regularized_stability(system, branch, anm, stability)
    return [change.U for change in changes if change.kind == "neimark_sacker"]


def regularized_seeds(atlas, kind: str, equations, located: dict) -> list:
    """``(test, x, extra, params)`` of the located points at each seed value (``located``: value -> points)."""
    seeds = []
    for value in atlas.regularized["seeds"]:
        for U in located[float(value)]:
            x, params = U[:-1], atlas.params_at(U[-1], float(value))
            test = FoldTest() if CHANGES_OF[kind] == "fold" else NeimarkSackerTest()
            extra = test.extra_guess(np.linalg.eigvals(equations.monodromy(x, params)), False)
            seeds.append((test, x, extra, params))
    return seeds
