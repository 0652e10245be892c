r"""Seeds and checks of the regularized curves, from the harmonic-balance responses of the forced path.

At each seed and check force, the regularized one-parameter response is computed as the forced target
computes it (:func:`nnmstop.forced.responses.regularized_response`) and its points of the curve's kind are
located on it: the folds where ``Omega`` is extremal on the ANM steps
(:func:`nnmstop.forced.responses.locate_folds`: exactly where the harmonic-balance Jacobian in the state is
singular, the fold curve's own condition), the Neimark-Sacker points where a complex pair of the monodromy's
multipliers crosses the unit circle (:func:`nnmstop.forced.regularized.regularized_stability`). The points at
the seed forces start the curves; those at the check forces must lie on them.

:func:`regularized_slice` is a slice of a structure without exact responses (a circular clearance): the same
regularized response at one value of the second parameter with its Floquet stability, in the layout of the
exact slices (:class:`~nnmstop.bifurcation_atlas.slices.Slice`), classified into the same regions.
Method note: ``docs/methods/atlas.md``.
"""

from __future__ import annotations

import numpy as np

from nnmstop.bifurcation_atlas.augmented import FoldTest, NeimarkSackerTest
from nnmstop.bifurcation_atlas.equations import ORBIT_HARMONICS, HarmonicBalanceEquations, harmonic_orbit
from nnmstop.bifurcation_atlas.slices import Slice, keep_points, orbit_dofs, with_changes

__all__ = [
    "regularized_equations",
    "regularized_located",
    "regularized_seeds",
    "regularized_inputs",
    "regularized_slice",
    "stability_settings",
    "CHANGES_OF",
]

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


def stability_settings(atlas):
    """Floquet settings of the regularized responses: Magnus steps ``regularized.steps`` at least (the
    multipliers as precise as the curves'), up to ``max(4 steps, 2048)``."""
    from nnmstop.forced.regularized import ForcedStabilitySettings

    steps = int(atlas.regularized["steps"])
    return ForcedStabilitySettings(steps, max(4 * steps, 2048), 2.0)


def regularized_inputs(atlas, kind: str, anm) -> tuple:
    """``(equations, seeds, located)`` of a regularized curve kind for
    :func:`~nnmstop.bifurcation_atlas.build.curves_dataset`: the harmonic-balance equations, the seeds at
    ``regularized.seeds`` and the ``(value, omega)`` located at ``regularized.checks`` (``anm``: the ANM settings
    of the responses)."""
    if atlas.regularized is None:
        raise ValueError(f"atlas map {atlas.name!r}: the kind {kind!r} needs a `regularized` section")
    spec = atlas.regularized
    stability = stability_settings(atlas)
    located = {float(v): regularized_located(atlas, kind, float(v), anm, stability) for v in spec["seeds"]}
    checks = []
    for value in spec["checks"]:
        checks += [(float(value), U[-1]) for U in regularized_located(atlas, kind, float(value), anm, stability)]
    equations = regularized_equations(atlas)
    return equations, regularized_seeds(atlas, kind, equations, located), checks


def _impacting(excitation, system, U_array) -> np.ndarray:
    """Whether each orbit reaches a stop of the piecewise-linear law somewhere: the largest penetration over the
    sampled period (a circular clearance's radius beyond its gap; a one-component stop's coordinate beyond its
    gap, on its side) is positive."""
    from nnmstop import fourier

    n, nc, H = system.n_dofs, system.nc, system.H
    Q = np.asarray(U_array, dtype=float)[:, : n * nc].reshape(-1, n, nc)
    q = fourier.to_time(fourier.to_full(Q, H), H, max(256, 16 * H))  # (points, N, samples)
    q = np.moveaxis(q, 1, 0)  # (N, points, samples)
    reach = [s.penetration(s.coordinates(q)).max(axis=-1) for s in excitation.structure.stops]
    return np.max(reach, axis=0) > 0


def regularized_slice(atlas, value: float, anm) -> Slice:
    """The regularized response at ``value`` of the second parameter (the forced target's
    :func:`~nnmstop.forced.responses.regularized_response` with the map's ``regularized`` harmonics and
    max_truncation), its Floquet stability and located changes
    (:func:`~nnmstop.forced.regularized.regularized_stability`), as a :class:`Slice`: one piece; impacting where
    the orbit reaches a stop (:func:`_impacting`); no family ends (``end_*`` empty: the harmonic balance has no
    second-contact boundary, its responses cover every contact sequence)."""
    from nnmstop.forced.regularized import regularized_stability
    from nnmstop.forced.responses import RegularizedSettings, regularized_response
    from nnmstop.forced.stability_changes import KINDS, unstable_count

    spec = atlas.regularized
    excitation = atlas.excitation_at(float(value))
    settings = RegularizedSettings(int(spec["harmonics"]), anm, float(spec["max_truncation"]))
    label = f"{atlas.name} regularized slice at {value:g}"
    system, branch = regularized_response(excitation, atlas.frequency_range, settings, label=label)
    stability, changes = regularized_stability(system, branch, anm, stability_settings(atlas))
    U = np.asarray(branch.points)
    frequency_hz = U[:, -1] / (2 * np.pi)
    stable = np.array([unstable_count(m) == 0 for m in stability.multipliers])
    impacting = _impacting(excitation, system, U)
    all_frequency, all_stable = with_changes(frequency_hz, stable, changes)
    # an inserted change point (its orbit between two stored ones) takes the impact verdict of the point before it
    all_impacting = with_changes(frequency_hz, impacting, changes)[1]
    index = keep_points(len(U), changes)
    dofs = list(orbit_dofs(excitation))
    from nnmstop.hbm.forced import response_amplitudes

    n_state = U.shape[1]
    return Slice(
        float(value),
        frequency_hz[index],
        np.zeros(len(index), dtype=int),
        impacting[index],
        stable[index],
        response_amplitudes(system, U[index])[:, dofs],
        stability.multipliers[index],
        np.array([harmonic_orbit(system, u, ORBIT_HARMONICS)[dofs] for u in U[index]]),
        np.array([KINDS.index(c.kind) for c in changes], dtype=np.int8),
        np.array([c.U for c in changes], dtype=float).reshape(-1, n_state),
        np.zeros(0, dtype=np.int8),
        np.zeros((0, n_state)),
        [all_frequency],
        [all_stable],
        [all_impacting],
        np.zeros(0),
    )
