"""NNM branches of a structure with stops (a finite-element tube, or any :class:`Structure`).

Map: :func:`continue_structure_nnm` starts from a linear mode at small amplitude and follows the
regularized NNM by the ANM until an energy limit or the truncation limit, optionally passing the
first internal resonance tongues it meets (segments; ``docs/methods/tube_resonance.md``);
:func:`structure_branch_dataset` assembles the labelled dataset (Fourier coefficients of every
degree of freedom and stop force, energy, frequency, impacts per stop, residuals, located branch
points and folds, Floquet stability). The paper's 2-DOF branches keep their own stages and datasets
(:mod:`nnmstop.hbm.stages`); both run the same harmonic-balance system and continuation.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np
import xarray as xr

from nnmstop import fourier
from nnmstop.continuation.anm import ANMSettings, continue_anm
from nnmstop.continuation.core import Branch, ContinuationError, ContinuationStats, newton_correct, relative_residual
from nnmstop.hbm.bifurcation import locate_flagged_branch_points
from nnmstop.hbm.dataset import energy_folds, located_branch_point_variables, located_fold_variables
from nnmstop.hbm.system import HarmonicBalanceSystem, impacts_per_period
from nnmstop.netcdf import flag_variable

logger = logging.getLogger("nnmstop.hbm.structure_branch")

__all__ = ["PassedResonance", "structure_start_point", "continue_structure_nnm", "structure_branch_dataset"]


def structure_start_point(system: HarmonicBalanceSystem, mode: int, amplitude: float, tol: float = 1e-12):
    """A point of NNM ``mode`` at small amplitude and the direction of growing amplitude.

    The linear mode of the regularized structure, with the first stop's coordinate
    ``x_1 = amplitude cos(theta)``, corrected by Newton with that harmonic held fixed.
    """
    if not (np.isfinite(amplitude) and 0 < amplitude < 1):
        raise ValueError(f"start amplitude must lie in (0, 1) (inside the gap), got {amplitude!r}")
    U0 = system.linear_mode_guess(mode, amplitude)
    direction = np.zeros(system.n_unknowns)
    direction[system.phase_dof * system.nc + 1] = 1.0
    U0, _ = newton_correct(system, U0, direction, ContinuationStats(), tol=tol)
    return U0, direction


#: Start of the end reason of a segment that stopped where the backbone bends into a resonance tongue.
TONGUE = "resonance tongue"


@dataclass
class PassedResonance:
    """An internal resonance tongue that the backbone was continued over (:func:`continue_structure_nnm`).

    ``frequency`` and ``energy``: the frequency maximum of the segment that bent into the tongue;
    ``harmonic``: the harmonic whose amplitude grew most between the backbone below the tongue
    and that maximum (the harmonic of the other mode that the tongue locks, e.g. 17 for
    17 f1 = f3); ``landing_frequency``: frequency where the predictor over the tongue was
    corrected onto the backbone beyond it.
    """

    frequency: float
    energy: float
    harmonic: int
    landing_frequency: float


def continue_structure_nnm(
    system: HarmonicBalanceSystem,
    mode: int,
    start_amplitude: float,
    energy_max: float,
    max_truncation: float,
    settings: ANMSettings,
    label: str = "NNM",
    pass_resonances: int = 0,
    resonance_margin: float = 1e-3,
) -> Branch:
    """Follow NNM ``mode`` of ``system``'s structure from small amplitude up to ``energy_max``.

    The branch ends at the first point above ``energy_max``, or, keeping the points before it,
    at the first point whose truncation indicator exceeds ``max_truncation`` (the orbit needs more
    harmonics than ``system.H``): ``branch.end_reason`` says which.

    With ``pass_resonances = k > 0`` the first ``k`` internal resonance tongues are passed: a
    segment ends where its frequency, rising along the backbone, falls again by a relative
    ``1e-6`` (the backbone has bent into the tongue, whose frequency stays locked while the
    energy climbs); a predictor along the backbone below the tongue, corrected by Newton,
    lands on the backbone beyond it (frequency above the tongue's by ``resonance_margin``,
    relative), which is followed back to its energy fold at the tongue and from there up
    (:func:`_over_the_tongue`; ``docs/methods/tube_resonance.md``). The returned branch holds
    the segments in order, with ``branch.segment`` (segment index of every point) and
    ``branch.resonances`` (a :class:`PassedResonance` per tongue passed).
    """
    if not energy_max > 0:
        raise ValueError(f"energy_max must be > 0, got {energy_max!r}")
    if not 0 < max_truncation < 1:
        raise ValueError(f"max_truncation must lie in (0, 1), got {max_truncation!r}")
    if not (isinstance(pass_resonances, (int, np.integer)) and pass_resonances >= 0):
        raise ValueError(f"pass_resonances must be an integer >= 0, got {pass_resonances!r}")
    if not 0 < resonance_margin < 0.1:
        raise ValueError(f"resonance_margin must lie in (0, 0.1), got {resonance_margin!r}")
    # the start needs the accuracy the continuation asks of every point (its Newton threshold): on fine meshes
    # the round-off floor of the residual (stiffness spread ~ N**4) lies above a fixed 1e-12
    U, direction = structure_start_point(system, mode, start_amplitude, tol=settings.newton_threshold)
    segments, resonances = [], []
    for k in range(pass_resonances + 1):
        in_tongue = k < pass_resonances
        segment = _follow(system, U, direction, energy_max, max_truncation, settings, f"{label} segment {k}", in_tongue)
        segments.append(segment)
        if not segment.end_reason.startswith(TONGUE):
            break
        resonance, U, direction = _over_the_tongue(system, segment, settings, resonance_margin, f"{label} segment {k}")
        resonances.append(resonance)
    branch = _joined(segments)
    branch.resonances = resonances
    if len(branch.points) < 3:
        raise ContinuationError(f"{label}: only {len(branch.points)} resolved points ({branch.end_reason})")
    return branch


def _follow(system, U, direction, energy_max, max_truncation, settings, label, stop_in_tongue: bool) -> Branch:
    """One segment: the ANM from ``U`` until energy, truncation or (``stop_in_tongue``) a frequency maximum."""
    highest = [-np.inf]

    def stop(U, diagnostics):
        if diagnostics["truncation"] > max_truncation:
            return (
                f"truncation {diagnostics['truncation']:.3g} above {max_truncation:g} at E = "
                f"{diagnostics['energy']:.6g}"
            )
        if diagnostics["energy"] > energy_max:
            return f"energy above {energy_max:g}"
        frequency = diagnostics["frequency"]
        highest[0] = max(highest[0], frequency)
        # 1e-6: far above the continuation's accuracy, far below the backbone's frequency rise per step
        if stop_in_tongue and frequency < highest[0] * (1.0 - 1e-6):
            return (
                f"{TONGUE}: the frequency fell from its maximum {highest[0]:.7g} Hz at E = {diagnostics['energy']:.6g}"
            )
        return ""

    branch = continue_anm(system, U, direction, stop, settings, label=label)
    if branch.end_reason.startswith("truncation"):
        # the offending point is not resolved by H harmonics: drop it, keep the branch before it
        for key in ("points", "step", "diagnostics"):
            del getattr(branch, key)[-1:]
        branch.branch_points = [i for i in branch.branch_points if i < len(branch.points) - 1]
    return branch


def _amplitudes(system: HarmonicBalanceSystem, U) -> np.ndarray:
    """Root-sum-square over the degrees of freedom of the amplitude of each harmonic 0..H."""
    cos, sin = fourier.to_cos_sin(np.stack(system.split(U)[: system.n_dofs]), system.H)
    return np.sqrt(np.sum(cos**2 + sin**2, axis=0))


def _over_the_tongue(system, segment: Branch, settings: ANMSettings, margin: float, label: str):
    """The tongue at the end of ``segment`` passed: the resonance, and a start point and direction beyond it.

    The backbone meets the tongue of an internal resonance in an avoided crossing (not a branch
    point: no symmetry makes the two curves cross), too narrow for the continuation to stay on it.
    The predictor is the chord of the backbone at the last two stored points whose frequency is
    below the tongue's by ``margin`` (relative), from the last of them, of growing length (the
    chord's, doubled until it works); each guess is
    corrected by Newton in the hyperplane orthogonal to the chord and accepted once its frequency
    exceeds the tongue's by ``margin``. The curve through the landing point is followed back
    (decreasing frequency) to its energy fold within ``margin`` of the tongue's frequency: the next
    segment starts just past that fold, so that the fold is one of its points.

    Raises
    ------
    ContinuationError
        If no guess lands beyond the tongue.
    """
    points = np.array(segment.points)
    frequency = np.array([d["frequency"] for d in segment.diagnostics])
    peak = int(np.argmax(frequency))
    f_peak = float(frequency[peak])
    below = np.flatnonzero(frequency[:peak] < f_peak * (1.0 - margin))
    if below.size < 2:
        raise ContinuationError(f"{label}: too few points below the resonance tongue at {f_peak:.7g} Hz")
    a = int(below[-1])
    chord = points[a] - points[a - 1]
    chord /= np.linalg.norm(chord)
    harmonic = int(np.argmax((_amplitudes(system, points[peak]) - _amplitudes(system, points[a]))[2:])) + 2
    # the shortest jump that lands beyond the tongue: the backbone there may hold narrower tongues
    # (higher-order resonances) that a longer one would jump into
    length = float(np.linalg.norm(points[a] - points[a - 1]))
    landing = None
    for _ in range(12):
        try:
            # a guess too far off diverges: Newton reports it, the overflow on the way says nothing more
            with np.errstate(over="ignore", invalid="ignore"):
                guess, _ = newton_correct(
                    system, points[a] + length * chord, chord, ContinuationStats(), tol=0.01 * settings.newton_threshold
                )
        except (ContinuationError, np.linalg.LinAlgError):
            guess = None
        if guess is not None and system.frequency_hz(guess) > f_peak * (1.0 + margin):
            landing = guess
            break
        length *= 2.0
    if landing is None:
        raise ContinuationError(f"{label}: no predictor over the resonance tongue at {f_peak:.7g} Hz landed beyond it")
    resonance = PassedResonance(
        frequency=f_peak,
        energy=float(segment.diagnostics[peak]["energy"]),
        harmonic=harmonic,
        landing_frequency=float(system.frequency_hz(landing)),
    )
    logger.info(
        "%s: resonance tongue at %.7g Hz (harmonic %d) passed, landed at %.7g Hz",
        label,
        f_peak,
        harmonic,
        resonance.landing_frequency,
    )
    lowest, energy = [np.inf], system.diagnostics(landing)["energy"]

    def past_fold(U, diagnostics):
        near_tongue = diagnostics["frequency"] < f_peak * (1.0 + margin)
        # folds of narrower tongues higher up the backbone (higher-order resonances) are passed
        if diagnostics["energy"] > lowest[0] and near_tongue:
            return "energy fold passed"
        lowest[0] = diagnostics["energy"]
        if diagnostics["frequency"] < f_peak * (1.0 - margin):
            return "below the tongue"
        beyond = diagnostics["frequency"] > resonance.landing_frequency * (1.0 + margin)
        if beyond or diagnostics["energy"] > 2 * energy:
            return "away from the tongue"
        return ""

    back = continue_anm(system, landing, -chord, past_fold, settings, label=f"{label} back to the tongue")
    if back.end_reason != "energy fold passed":
        raise ContinuationError(f"{label}: the backbone beyond the tongue has no energy fold at it ({back.end_reason})")
    return resonance, back.points[-1], -back.end_tangent


def _joined(segments) -> Branch:
    """The segments as one branch: step indices made unique, flags moved, ``segment`` of every point."""
    joined = Branch()
    joined.segment = []
    offset = 0
    for k, segment in enumerate(segments):
        start = len(joined.points)
        for U, step, diagnostics in zip(segment.points, segment.step, segment.diagnostics):
            joined.add(U, offset + step, diagnostics)
            joined.segment.append(k)
        # a flag at a segment's start point would pair it with the previous segment's last point
        joined.branch_points += [start + i for i in segment.branch_points if i > 0]
        offset += max(segment.step) + 1
        for field in dataclasses.fields(joined.stats):
            setattr(joined.stats, field.name, getattr(joined.stats, field.name) + getattr(segment.stats, field.name))
    if len(segments) == 1:
        joined.end_reason = segments[0].end_reason
    else:
        joined.end_reason = "; ".join(f"segment {k}: {segment.end_reason}" for k, segment in enumerate(segments))
    joined.end_tangent = segments[-1].end_tangent
    return joined


def _per_stop_impacts(system: HarmonicBalanceSystem, U) -> np.ndarray:
    history = system.time_history(U, max(16 * system.H, 512))
    x = np.reshape(history["x"], (system.n_stops, -1))
    return np.array([impacts_per_period(x_i) for x_i in x], dtype=np.int32)


def _segment_folds(U, energy, frequency, segment) -> dict:
    """:func:`located_fold_variables` of each segment, point indices of the whole branch."""
    parts = []
    for k in np.unique(segment):
        index = np.flatnonzero(segment == k)
        parts.append(located_fold_variables(U[index], energy[index], frequency[index]))
        dims, values, attrs = parts[-1]["fold_point"]
        parts[-1]["fold_point"] = (dims, (values + index[0]).astype(np.int32), attrs)
    return {
        name: (dims, np.concatenate([part[name][1] for part in parts]), attrs)
        for name, (dims, _, attrs) in parts[0].items()
    }


def _passed_resonance_variables(resonances) -> dict:
    """Dataset variables (dimension ``passed_resonance``) of the tongues passed (:class:`PassedResonance`)."""
    dim = ("passed_resonance",)
    one = {"units": "1"}
    return {
        "passed_resonance_frequency": (
            dim,
            np.array([r.frequency for r in resonances], dtype=float),
            {
                "long_name": "frequency maximum where the backbone bent into the internal resonance tongue",
                "units": "Hz",
            },
        ),
        "passed_resonance_energy": (
            dim,
            np.array([r.energy for r in resonances], dtype=float),
            {"long_name": "energy at that frequency maximum", **one},
        ),
        "passed_resonance_harmonic": (
            dim,
            np.array([r.harmonic for r in resonances], dtype=np.int32),
            {"long_name": "harmonic that grew most into the tongue (n of the n:1 internal resonance)", **one},
        ),
        "passed_resonance_landing_frequency": (
            dim,
            np.array([r.landing_frequency for r in resonances], dtype=float),
            {
                "long_name": "frequency where the predictor over the tongue landed on the backbone beyond it",
                "units": "Hz",
            },
        ),
    }


def structure_branch_dataset(
    system: HarmonicBalanceSystem,
    branch: Branch,
    settings: ANMSettings,
    stability,
    attrs: dict | None = None,
    dof_labels=None,
    node_coordinates=None,
) -> xr.Dataset:
    """Labelled dataset of a branch of :func:`continue_structure_nnm`.

    Variables on ``point``: ``omega_squared``, ``energy``, ``frequency``, ``period``, ``x_max`` (largest
    coordinate of the first stop over gap), ``impacts_per_period`` (all stops) and ``stop_impacts``
    (per stop), residuals, truncation, branch-point and fold flags, Floquet stability (``stability``: the
    result of :func:`nnmstop.hbm.stability.orbit_stability`); Fourier
    coefficients ``q_cos``/``q_sin`` (point, dof, harmonic) and ``f_cos``/``f_sin`` (point, stop,
    harmonic). ``attrs``: global attributes to add (structure, mode, settings).
    """
    U = np.array(branch.points)
    H = system.H
    diags = [d if d is not None else system.diagnostics(u) for u, d in zip(U, branch.diagnostics)]
    if not all(np.isfinite(d["energy"]) for d in diags):
        raise ContinuationError("non-finite energy in the branch")
    blocks = system.split(U)
    N, s = system.n_dofs, system.n_stops
    Q, F = np.stack(blocks[:N], axis=1), np.stack(blocks[N : N + s], axis=1)
    lam, nu = blocks[-2], blocks[-1]

    def col(key):
        return np.array([d[key] for d in diags])

    def cos_sin(c):
        full = system.to_full(c)
        cos = np.concatenate([full[..., :1], full[..., 1 : H + 1]], axis=-1)
        sin = np.concatenate([np.zeros(full.shape[:-1] + (1,)), full[..., H + 1 :]], axis=-1)
        return cos, sin

    q_cos, q_sin = cos_sin(Q)
    f_cos, f_sin = cos_sin(F)
    one = {"units": "1"}
    energy = col("energy")
    segment = np.asarray(getattr(branch, "segment", np.zeros(len(U))), dtype=np.int32)
    segments = np.unique(segment)
    branch_point = np.zeros(len(U), dtype=bool)
    branch_point[branch.branch_points] = True
    data = {
        "q_cos": (
            ("point", "dof", "harmonic"),
            q_cos,
            {"long_name": "cosine Fourier coefficients of the degrees of freedom", **one},
        ),
        "q_sin": (
            ("point", "dof", "harmonic"),
            q_sin,
            {"long_name": "sine Fourier coefficients of the degrees of freedom", **one},
        ),
        "f_cos": (
            ("point", "stop", "harmonic"),
            f_cos,
            {"long_name": "cosine Fourier coefficients of the regularized stop forces", **one},
        ),
        "f_sin": (
            ("point", "stop", "harmonic"),
            f_sin,
            {"long_name": "sine Fourier coefficients of the regularized stop forces", **one},
        ),
        "omega_squared": (
            "point",
            lam,
            {"long_name": "squared angular frequency (unknown lambda of the HBM system)", **one},
        ),
        "unfolding": ("point", nu, {"long_name": "unfolding parameter nu (zero on periodic orbits)", **one}),
        "energy": (
            "point",
            energy,
            {"long_name": "total energy of the regularized model, mean over the period", **one},
        ),
        "frequency": (
            "point",
            col("frequency"),
            {"long_name": "frequency omega/(2 pi) in Hz of the nondimensional time", "units": "Hz"},
        ),
        "period": (
            "point",
            2 * np.pi / np.sqrt(lam),
            {"long_name": "period of the orbit in nondimensional time", **one},
        ),
        "x_max": ("point", col("x_max"), {"long_name": "largest displacement at the first stop over its gap", **one}),
        "impacts_per_period": (
            "point",
            col("impacts_per_period").astype(np.int32),
            {"long_name": "excursions beyond the gaps per period, all stops", **one},
        ),
        "stop_impacts": (
            ("point", "stop"),
            np.array([_per_stop_impacts(system, u) for u in U]),
            {"long_name": "excursions beyond the gap per period at each stop", **one},
        ),
        "algebraic_residual": (
            "point",
            np.array([relative_residual(system, p) for p in U]),
            {"long_name": "norm of the HBM residual relative to the norm of the unknowns", **one},
        ),
        "time_residual": (
            "point",
            col("time_residual"),
            {
                "long_name": "largest residual in time of the equations of the stop degrees of freedom relative "
                "to the largest restoring force",
                **one,
            },
        ),
        "truncation": (
            "point",
            col("truncation"),
            {"long_name": "share of the mean square of x'' or f carried by the top tenth of the harmonics", **one},
        ),
        "step": (
            "point",
            np.asarray(branch.step, dtype=np.int32),
            {"long_name": "index of the ANM step that produced the point", **one},
        ),
        "branch_point": flag_variable(
            "point",
            branch_point,
            "1 where a simple branch point (sign change of det [J; t^T]) lies within the ANM step that ends at "
            "this point",
            "regular branch_point",
        ),
        "energy_fold": flag_variable(
            "point",
            np.concatenate([energy_folds(energy[segment == k]) for k in segments]),
            "1 where the energy has a local extremum along the branch (within its segment)",
            "regular fold",
        ),
        "segment": (
            "point",
            segment,
            {
                "long_name": "segment of the branch: 0 from the linear mode, k > 0 the backbone beyond the k-th "
                "internal resonance tongue passed (see passed_resonance_*)",
                **one,
            },
        ),
    }
    located, unlocated = [], []
    for i in branch.branch_points:
        try:
            located += locate_flagged_branch_points(system, U, branch.step, [i], settings)
        except (ValueError, ContinuationError) as err:
            # kept as a flagged step without a located point; the count goes into the attributes
            logger.warning("branch point flagged at point %d not located: %s", i, err)
            unlocated.append(i)
    data.update(located_branch_point_variables(system, located))
    data.update(_segment_folds(U, energy, col("frequency"), segment))
    data.update(_passed_resonance_variables(getattr(branch, "resonances", [])))
    data.update(stability.data_vars())
    coords = {
        "point": np.arange(len(U)),
        "dof": np.arange(system.n_dofs),
        "stop": np.arange(system.n_stops),
        "harmonic": np.arange(H + 1),
        "multiplier": np.arange(stability.multipliers.shape[1]),
    }
    ds = xr.Dataset(data, coords=coords)
    ds["point"].attrs = {"long_name": "index of the point along the branch", **one}
    ds["dof"].attrs = {"long_name": "index of the degree of freedom", **one}
    ds["stop"].attrs = {"long_name": "index of the stop", **one}
    ds["harmonic"].attrs = {"long_name": "harmonic number k (0 is the mean)", **one}
    ds["multiplier"].attrs = {"long_name": "index of the Floquet multiplier, by decreasing modulus", **one}
    if dof_labels is not None:
        ds["dof_label"] = (
            "dof",
            np.array(dof_labels, dtype=str),
            {
                "long_name": "degree of freedom: w<node> displacement over gap, theta<node> rotation over gap/length",
                **one,
            },
        )
    if node_coordinates is not None:
        ds = ds.assign_coords(node=np.arange(len(node_coordinates)))
        ds["node"].attrs = {"long_name": "index of the finite-element node", **one}
        ds["node_coordinate"] = (
            "node",
            np.asarray(node_coordinates, float),
            {"long_name": "position of the node along the tube over its length", **one},
        )
    stats = branch.stats
    ds.attrs = {
        **(attrs or {}),
        "harmonics": H,
        "time_samples": system.M,
        "basis": system.basis,
        "order": settings.order,
        "tolerance": settings.tolerance,
        "pade": int(settings.pade),
        "end_reason": branch.end_reason,
        "anm_steps": stats.steps,
        "factorizations": stats.factorizations,
        "unlocated_branch_points": len(unlocated),
        "passed_resonances": len(getattr(branch, "resonances", [])),
    }
    return ds
