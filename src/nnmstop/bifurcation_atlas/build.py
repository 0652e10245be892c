r"""An atlas, step by step: its map, its slices, its curves (seeded on slices, checked on others), the whole.

:class:`AtlasMap` is one map: a forced structure (the excitation of a forced scene), the plane (``force``:
frequency against force amplitude; or a structural parameter,
:data:`~nnmstop.bifurcation_atlas.parameters.STRUCTURAL`, at a fixed force), the window, the values of the
slices (one exact one-parameter response each, :mod:`nnmstop.bifurcation_atlas.slices`), the slices that seed
the curves and those that check them. The work splits into independent pieces, so that each is its own job
(:mod:`nnmstop.tasks.atlas`):

* :func:`slice_dataset`: one slice;
* :func:`curves_dataset`: the curves of one kind (grazing, fold, Neimark-Sacker, flip, second contact; the
  regularized folds and Neimark-Sacker points) through the points the seed slices locate, each followed both
  ways (:mod:`nnmstop.bifurcation_atlas.curves`), a seed on a curve already followed skipped; their
  codimension-two points (:mod:`nnmstop.bifurcation_atlas.codim2`); and the checks: at every check slice, every
  point of that kind the one-parameter response locates must lie on a curve (the curve's point at that value,
  solved on the augmented system, within ``check_tolerance`` of it in frequency), or the job fails;
* :func:`atlas_dataset`: the slices' regions and the curves in one dataset.

Method note: ``docs/methods/atlas.md``.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from nnmstop.bifurcation_atlas.augmented import (
    CurveSystem,
    FlipTest,
    FoldTest,
    InteriorGrazingTest,
    NeimarkSackerTest,
)
from nnmstop.bifurcation_atlas.codim2 import locate_codim2
from nnmstop.bifurcation_atlas.curves import CurveSettings, correct_on_curve, follow_curve, grazing_test
from nnmstop.bifurcation_atlas.equations import ORBIT_HARMONICS, contact_entered, exact_equations
from nnmstop.bifurcation_atlas.flags import CODIM2_KINDS, CURVE_KINDS, END_KINDS, LAWS
from nnmstop.bifurcation_atlas.parameters import PLANES, parameter_value, with_parameters
from nnmstop.bifurcation_atlas.slices import classify, compute_slice, orbit_dofs
from nnmstop.continuation.core import ContinuationError
from nnmstop.exact.forced import mirror_contacts, structure_contacts
from nnmstop.forced.responses import ExactSettings
from nnmstop.forced.stability_changes import KINDS as CHANGE_KINDS

__all__ = [
    "CURVE_KINDS",
    "EXACT_KINDS",
    "REGULARIZED_KINDS",
    "LAWS",
    "AtlasMap",
    "CheckFailed",
    "slice_dataset",
    "curves_dataset",
    "atlas_dataset",
]

logger = logging.getLogger("nnmstop.bifurcation_atlas.build")

#: The curve kinds of the exact responses and of the regularized ones (one job each).
EXACT_KINDS = CURVE_KINDS
REGULARIZED_KINDS = ("regularized_fold", "regularized_neimark_sacker")
#: The located changes of a one-parameter response that seed (and check) each kind of curve.
SEEDING_CHANGES = {
    "fold": ("fold",),
    "neimark_sacker": ("neimark_sacker",),
    "flip": ("symmetry_breaking", "period_doubling"),
}
#: Relative distance in frequency under which a seed lies on a curve already followed (it is not followed again).
SAME_CURVE = 1e-5


class CheckFailed(RuntimeError):
    """A point a one-parameter response locates lies on no curve of its kind (the atlas would miss it)."""


def without_exact_responses(structure) -> str | None:
    """Why the atlas of ``structure`` cannot be exact (a phrase naming the stops), or None where it can.

    The exact atlas follows families of forced responses with one contact phase per period, or per half period
    under the half-wave symmetry, in closed form. It has none where a stop is not piecewise linear (a circular
    clearance), nor where two contacts of one stop graze together (a bilateral stop, a relative stop on both
    sides) without that symmetry, as beside a one-sided stop: the family leaving such a grazing has two contact
    phases at once. Both kinds of structure get the regularized atlas.
    """
    curved = [s.label for s in structure.stops if not s.piecewise_linear]
    if curved:
        return f"the {', '.join(curved)} is not piecewise linear, so it has no exact responses"
    contacts = structure_contacts(structure)
    if mirror_contacts(contacts) is None:
        stops = [
            structure.stops[i].label
            for i in sorted({c.stop for c in contacts})
            if sum(d.stop == i for d in contacts) > 1
        ]
        if stops:
            return (
                f"the two sides of the {', '.join(stops)} graze together without the half-wave symmetry (another "
                "stop is not odd), so its exact responses leave grazing with two contact phases at once, which the "
                "exact atlas does not follow"
            )
    return None


@dataclass(frozen=True)
class AtlasMap:
    """One map of an atlas (module docstring).

    ``excitation`` holds the structure, damping and force (its amplitude is the map's fixed force when the
    plane is structural); ``frequency_range`` (Hz) and ``second_range`` bound the curves; ``slices`` are the
    second parameter's values of the slices, ``seeds`` and ``checks`` subsets of them; ``grid``: frequencies of
    the regions per slice.
    """

    name: str
    excitation: object
    plane: str
    frequency_range: tuple
    second_range: tuple
    slices: tuple
    seeds: tuple
    checks: tuple
    kinds: tuple
    exact: ExactSettings = field(default_factory=ExactSettings)
    curve: CurveSettings = field(default_factory=CurveSettings)
    grid: int = 240
    check_tolerance: float = 1e-7
    regularized: dict | None = None

    def __post_init__(self):
        if self.plane not in PLANES:
            raise ValueError(f"atlas map {self.name!r}: plane must be one of {list(PLANES)}, got {self.plane!r}")
        low, high = self.frequency_range
        if not 0 < low < high:
            raise ValueError(
                f"atlas map {self.name!r}: frequency_range must be 0 < low < high, got {self.frequency_range}"
            )
        low, high = self.second_range
        if not 0 < low < high:
            raise ValueError(f"atlas map {self.name!r}: range must be 0 < low < high, got {self.second_range}")
        if not self.slices or any(not low <= v <= high for v in self.slices):
            raise ValueError(
                f"atlas map {self.name!r}: every slice must lie in range [{low:g}, {high:g}], got {self.slices}"
            )
        for key in ("seeds", "checks"):
            missing = [v for v in getattr(self, key) if not any(np.isclose(v, s, rtol=1e-12) for s in self.slices)]
            if missing:
                raise ValueError(f"atlas map {self.name!r}: {key} {missing} are not values of its slices")
        if self.regularized is None and any(k in REGULARIZED_KINDS for k in self.kinds):
            raise ValueError(f"atlas map {self.name!r}: the regularized curve kinds need a `regularized` section")
        unknown = [k for k in self.kinds if k not in EXACT_KINDS + REGULARIZED_KINDS]
        if unknown:
            raise ValueError(
                f"atlas map {self.name!r}: unknown curve kinds {unknown} (allowed: "
                f"{list(EXACT_KINDS + REGULARIZED_KINDS)})"
            )

    @property
    def exact_responses(self) -> bool:
        """Whether the slices and curves are exact (:func:`without_exact_responses`); else they are regularized."""
        return without_exact_responses(self.excitation.structure) is None

    def check_exact(self, kind: str | None = None) -> None:
        """Refuse (ValueError naming it) an exact curve ``kind`` (any, by default) of a structure without exact
        responses in the atlas (:func:`without_exact_responses`). Its grazing curve is in closed form and its
        slices are the regularized responses (:func:`slice_dataset`). Checked where the curves are computed, not
        when the map is read (a configuration of such a structure whose other targets do not build the atlas stays
        valid)."""
        why = without_exact_responses(self.excitation.structure)
        if why and kind != "grazing":
            exact = [k for k in self.kinds if k in EXACT_KINDS and k != "grazing"]
            raise ValueError(
                f"atlas map {self.name!r}: {why}: the exact curve kinds "
                f"({exact or [k for k in EXACT_KINDS if k != 'grazing']}) cannot be computed. Its atlas is the "
                "regularized one (harmonic balance): regularized slices, the closed-form grazing curve and the "
                f"regularized curve kinds {list(REGULARIZED_KINDS)}"
            )

    def check_regularized_slices(self) -> None:
        """A structure without exact responses in the atlas has regularized slices: ValueError saying why when the
        map has no ``regularized`` section (harmonics, steps, max_truncation)."""
        why = without_exact_responses(self.excitation.structure)
        if why and self.regularized is None:
            raise ValueError(
                f"atlas map {self.name!r}: {why}, so its slices are the regularized responses (harmonic balance), "
                "which need the map's `regularized` section (harmonics, steps, max_truncation; with the regularized "
                f"curve kinds {list(REGULARIZED_KINDS)})"
            )

    @property
    def free(self) -> tuple:
        """Indices of the free parameters in ``(Omega, F, p)``."""
        return (0, 1) if self.plane == "force" else (0, 2)

    @property
    def parameter(self):
        return None if self.plane == "force" else self.plane

    def base_params(self) -> np.ndarray:
        """``(Omega, F, p)`` with the fixed one at its value (``Omega`` and the free one set per point)."""
        p = parameter_value(self.excitation, self.plane) if self.parameter else 0.0
        return np.array([0.0, self.excitation.force.amplitude, p])

    def params_at(self, omega: float, value: float) -> np.ndarray:
        params = self.base_params()
        params[0] = omega
        params[self.free[1]] = value
        return params

    def slice_index(self, value: float) -> int:
        return int(np.argmin(np.abs(np.asarray(self.slices) - value)))

    def window(self) -> tuple:
        return tuple(2 * np.pi * np.asarray(self.frequency_range)), tuple(self.second_range)

    def exact_equations(self, contact: int | None = None):
        """The exact formulation of the responses striking ``contact`` (the first stop's by default): half-wave
        or full period, as the structure's stops allow
        (:func:`~nnmstop.bifurcation_atlas.equations.exact_equations`)."""
        return exact_equations(self.excitation, self.parameter, contact)

    def excitation_at(self, value: float):
        if self.plane == "force":
            return self.excitation.with_amplitude(float(value))
        return with_parameters(self.excitation, self.excitation.force.amplitude, self.plane, value)


# --------------------------------------------------------------------------- slices


def slice_dataset(atlas: AtlasMap, index: int, anm=None) -> xr.Dataset:
    """The slice ``index`` of ``atlas`` with its regions: the exact response
    (:func:`nnmstop.bifurcation_atlas.slices.compute_slice`) where every stop is piecewise linear, else the
    regularized one (:func:`nnmstop.bifurcation_atlas.regularized.regularized_slice`, ``anm`` its ANM settings,
    by default ``ANMSettings(points_per_step=2)``; attributes ``slice_law = "regularized"`` and ``harmonics``)."""
    value = float(atlas.slices[index])
    if atlas.exact_responses:
        result = compute_slice(atlas.excitation, atlas.plane, value, atlas.frequency_range, atlas.exact)
        law = "piecewise_linear"
    else:
        from nnmstop.bifurcation_atlas.regularized import regularized_slice
        from nnmstop.continuation.anm import ANMSettings

        atlas.check_regularized_slices()
        result = regularized_slice(atlas, value, anm or ANMSettings(points_per_step=2))
        law = "regularized"
    low, high = atlas.frequency_range
    grid = low + (np.arange(atlas.grid) + 0.5) * (high - low) / atlas.grid  # cell centres: the range's ends excluded
    regions = classify(result.all_frequency, result.all_stable, result.all_impacting, result.end_frequency, grid)
    mu = result.multipliers
    ds = xr.Dataset(
        {
            "grid_frequency": ("grid", grid),
            "region": ("grid", regions["region"]),
            "responses": ("grid", regions["responses"]),
            "stable_responses": ("grid", regions["stable_responses"]),
            "response_frequency": ("response", result.frequency),
            "response_piece": ("response", result.piece.astype(np.int32)),
            "response_impacting": ("response", result.impacting.astype(np.int8)),
            "response_stable": ("response", result.stable.astype(np.int8)),
            "response_amplitude": (("response", "orbit_dof"), result.amplitude),
            "response_multiplier_real": (("response", "multiplier"), mu.real),
            "response_multiplier_imag": (("response", "multiplier"), mu.imag),
            "response_orbit": (("response", "orbit_dof", "coefficient"), result.orbit),
            "change_kind": ("change", result.change_kind),
            "change_state": (("change", "unknown"), result.change_state),
            "end_kind": ("end", result.end_kind),
            "end_state": (("end", "unknown"), result.end_state),
            "end_frequency": ("end", result.end_frequency),
        }
    )
    ds.attrs.update(_map_attributes(atlas))
    ds.attrs.update(slice_index=int(index), slice_value=value, complete=int(result.end_frequency.size == 0))
    if law == "regularized":  # (an exact slice has no such attribute: its bytes stay those of the exact maps)
        ds.attrs.update(slice_law=law, harmonics=int(atlas.regularized["harmonics"]))
    return ds


def _map_attributes(atlas: AtlasMap) -> dict:
    excitation = atlas.excitation
    stop = excitation.structure.stops[0]
    return {
        "atlas_map": atlas.name,
        "plane": atlas.plane,
        "frequency_range": np.array(atlas.frequency_range, dtype=float),
        "second_range": np.array(atlas.second_range, dtype=float),
        **excitation.as_attrs(),
        "stop_dof": int(stop.dofs[0]),
        "stop_gap": float(stop.gap),
        "stop_stiffness": float(stop.stiffness),
        "stop_eta": float(stop.eta),
        "orbit_dofs": np.array(orbit_dofs(excitation), dtype=np.int32),
        "orbit_harmonics": int(ORBIT_HARMONICS),
    }


# --------------------------------------------------------------------------- curves


def _half_period_extremum(equations, x, params, phase: str, level: float, contact=None) -> float:
    """The interior phase of ``phase`` where the struck coordinate (or that of ``contact``) comes closest to
    ``level`` with zero velocity (a sampled sign change of the velocity refined by Brent's method)."""
    import scipy.optimize

    start, end = equations.phase_interval(x, phase)
    theta = np.linspace(start, end, 2049)[1:-1]
    states = np.array([equations.stop_state(x, params, t, phase, contact) for t in theta])
    best, found = np.inf, None
    for i in np.flatnonzero(np.sign(states[:-1, 1]) != np.sign(states[1:, 1])):
        r = scipy.optimize.brentq(
            lambda t: equations.stop_state(x, params, t, phase, contact)[1], theta[i], theta[i + 1], xtol=1e-15
        )
        distance = abs(equations.stop_state(x, params, r, phase, contact)[0] - level)
        if distance < best:
            best, found = distance, r
    if found is None:
        raise ContinuationError(f"no interior extremum of the stop coordinate in phase {phase!r} near {level:g}")
    return float(found)


def _exact_seeds(atlas: AtlasMap, kind: str, slice_ds: xr.Dataset) -> list:
    """``(test, x, extra, params, equations)`` of every point of kind ``kind`` the slice locates, each with the
    exact formulation of the contact its response strikes."""
    value = float(slice_ds.attrs["slice_value"])
    at = atlas.excitation_at(value)
    seeds = []
    if kind in SEEDING_CHANGES:
        wanted = [CHANGE_KINDS.index(k) for k in SEEDING_CHANGES[kind]]
        for change, state in zip(slice_ds["change_kind"].values, slice_ds["change_state"].values):
            if change not in wanted:
                continue
            equations = atlas.exact_equations(contact_entered(at, state))
            x, params = state[:-1], atlas.params_at(state[-1], value)
            test = {"fold": FoldTest, "neimark_sacker": NeimarkSackerTest, "flip": FlipTest}[kind]()
            extra = test.extra_guess(np.linalg.eigvals(equations.monodromy(x, params)), True)
            seeds.append((test, x, extra, params, equations))
    elif kind == "grazing":
        for state in _grazing_states(atlas, slice_ds):
            equations = atlas.exact_equations(contact_entered(at, state))
            x, params = state[:-1], atlas.params_at(state[-1], value)
            seeds.append((grazing_test(equations), x, np.zeros(0), params, equations))
    elif kind == "second_contact":
        for end, state in zip(slice_ds["end_kind"].values, slice_ds["end_state"].values):
            margin = END_KINDS[int(end)]
            equations = atlas.exact_equations(contact_entered(at, state))
            x, params = state[:-1], atlas.params_at(state[-1], value)
            best = None
            for phase, level, contact in _touching_candidates(equations, margin, params):
                try:
                    theta = _half_period_extremum(equations, x, params, phase, level, contact)
                except ContinuationError:
                    continue
                distance = abs(equations.stop_state(x, params, theta, phase, contact)[0] - level)
                if best is None or distance < best[0]:
                    best = (distance, phase, level, contact, theta)
            if best is not None:
                _, phase, level, contact, theta = best
                test = InteriorGrazingTest(phase, level, contact, margin)
                seeds.append((test, x, np.array([theta]), params, equations))
    return seeds


def _touching_candidates(equations, margin: str, params) -> list:
    """``(phase, level, contact)`` where a one-contact response that ends on ``margin`` may touch a second time:
    the struck stop's coordinate at ``+-gap`` in the free flight (``early_impact``: the stop itself, or its other
    side for a symmetric response) or at its gap in the contact (``leaves_stop``); over the full period, the
    coordinate of any contact not struck at its gap, in either phase (``other_stops``; contact None: the struck
    coordinate)."""
    if margin == "early_impact":
        gap = equations.contact_gap(params)
        return [("F", gap, None), ("F", -gap, None)] if equations.half_period else [("F", gap, None)]
    if margin == "leaves_stop":
        return [("R", equations.contact_gap(params), None)]
    if margin == "other_stops" and not equations.half_period:
        problem = equations.problem(params)
        return [(phase, float(problem.gaps[c]), int(c)) for c in problem.passive for phase in ("F", "R")]
    return []


def _grazing_states(atlas: AtlasMap, slice_ds: xr.Dataset) -> list:
    """The grazing orbits of a slice: the non-impacting response's grazing frequencies, as states of the exact
    formulation (zero contact duration, :meth:`~nnmstop.exact.forced.ForcedResponseProblem.grazing_start` of the
    family from there, :func:`~nnmstop.exact.forced.grazing_problem`)."""
    from nnmstop.exact.forced import SymmetricContactProblem, grazing_frequencies, grazing_problem

    excitation = atlas.excitation_at(float(slice_ds.attrs["slice_value"]))
    low, high = (2 * np.pi * f for f in atlas.frequency_range)
    if all(s.kind == "bilateral" for s in excitation.structure.stops):
        problem = SymmetricContactProblem(excitation)
        return [problem.grazing_start(omega) for omega in grazing_frequencies(excitation, low, high)]
    states = []
    for omega in grazing_frequencies(excitation, low, high):
        problem, y0, _ = grazing_problem(excitation, omega)
        if problem.m != 2:  # several contacts graze at once without the half-wave symmetry: not followed
            raise ValueError(
                f"atlas map {atlas.name!r}: at {omega / (2 * np.pi):.6g} Hz several contacts graze at once "
                f"({problem.describe()}) without the half-wave symmetry; the atlas follows one contact phase per "
                "period (or half period): not yet"
            )
        states.append(problem.grazing_start(omega))
    return states


def _on_curves(curves: list, atlas: AtlasMap, omega: float, value: float) -> bool:
    """Whether one of ``curves`` passes within :data:`SAME_CURVE` (relative frequency) of ``(omega, value)``."""
    return any(
        abs(crossing - omega) <= SAME_CURVE * omega
        for curve in curves
        for crossing in _crossings(curve, atlas, value, atlas.curve.tolerance)
    )


def _follow(atlas: AtlasMap, equations, seed, label: str):
    test, x, extra, params = seed[:4]
    system = CurveSystem(equations, test, atlas.free, params)
    settings = atlas.curve
    if equations.law == "regularized":  # its own step: the unknowns are Fourier coefficients of q, f and z
        settings = dataclasses.replace(settings, step=float(atlas.regularized["step"]))
    test.prepare(equations, x, extra, params)
    if isinstance(test, NeimarkSackerTest):
        test.choose_entries(equations, x, extra, params, atlas.free)
    U = correct_on_curve(system, system.pack(x, extra, params), tolerance=settings.tolerance)
    # On the grazing curve the linear response touches the gap at its maximum by construction: the margins of a
    # second contact are zero there up to round-off (a mesh's fast modes put a sampled extremum at -1e-12), not
    # assumptions to check.
    skip = ("contact_duration", "early_impact", "leaves_stop") if test.kind == "grazing" else ()
    if test.kind == "second_contact":
        skip = (test.margin,)
    window = atlas.window()
    if equations.law == "regularized" and "range" in atlas.regularized:
        window = (window[0], tuple(float(v) for v in atlas.regularized["range"]))
    return follow_curve(system, U, window, settings, skip=skip, label=label)


def follow_kind(atlas: AtlasMap, kind: str, seed_slices: list, equations=None, seeds=None) -> list:
    """Every curve of ``kind`` through the points the ``seed_slices`` locate (exact kinds, each seed with the
    formulation of the contact it strikes), or through ``seeds`` (``(test, x, extra, params)`` on ``equations``,
    or with their own equations as a fifth entry), with their codimension-two points."""
    equations = atlas.exact_equations() if equations is None else equations
    if seeds is None:
        seeds = [seed for ds in seed_slices for seed in _exact_seeds(atlas, kind, ds)]
    curves = []
    for seed in seeds:
        params = seed[3]
        if _on_curves(curves, atlas, params[0], params[atlas.free[1]]):
            continue
        label = f"{atlas.name} {kind} curve from {params[0] / (2 * np.pi):.6g} Hz, {params[atlas.free[1]]:.6g}"
        curve = _follow(atlas, seed[4] if len(seed) > 4 else equations, seed, label)
        curve.codim2 = locate_codim2(curve)
        curve.seed_value = float(params[atlas.free[1]])
        curves.append(curve)
        logger.info("%s: %d points, ends %s", label, len(curve.points), curve.end_keys)
    return curves


def _crossings(curve, atlas: AtlasMap, value: float, tolerance: float) -> list:
    """The curve's points at the second parameter ``value``, solved on the augmented system (``Omega`` each)."""
    P = curve.params()
    second = P[:, atlas.free[1]]
    out = []
    for i in np.flatnonzero((second[:-1] - value) * (second[1:] - value) <= 0):
        span = second[i + 1] - second[i]
        w = 0.5 if span == 0 else (value - second[i]) / span
        U = curve.points[i] + w * (curve.points[i + 1] - curve.points[i])
        U[-1] = value
        x, extra, params = curve.system.split(U)
        curve.system.test.prepare(curve.system.equations, x, extra, params)
        try:
            U = correct_on_curve(curve.system, U, tolerance=tolerance)
        except ContinuationError:
            continue
        out.append(float(curve.system.split(U)[2][0]))
    return out


def check_curves(atlas: AtlasMap, kind: str, curves: list, located: list, tolerance: float) -> list:
    """Rows ``(curve index, value, curve frequency Hz, located frequency Hz, relative distance)``: every located
    point (``(value, omega)`` pairs from the one-parameter responses) matched with the nearest crossing of a
    curve. Raises :class:`CheckFailed` when one lies on no curve within ``tolerance`` (relative)."""
    rows, missed = [], []
    for value, omega in located:
        best = None
        for j, curve in enumerate(curves):
            for crossing in _crossings(curve, atlas, value, atlas.curve.tolerance):
                distance = abs(crossing - omega) / omega
                if best is None or distance < best[-1]:
                    best = (j, value, crossing / (2 * np.pi), omega / (2 * np.pi), distance)
        if best is None or best[-1] > tolerance:
            missed.append((value, omega / (2 * np.pi), None if best is None else best[-1]))
        if best is not None:
            rows.append(best)
    if missed:
        raise CheckFailed(
            f"atlas map {atlas.name!r}: {kind} points located by the one-parameter responses lie on no {kind} curve "
            f"(value, frequency Hz, nearest relative distance): {missed}; tolerance {tolerance:g}"
        )
    return rows


def _located_exact(atlas: AtlasMap, kind: str, check_slices: list) -> list:
    """``(value, omega)`` of every point of ``kind`` the check slices locate (exact)."""
    out = []
    for ds in check_slices:
        value = float(ds.attrs["slice_value"])
        if kind in SEEDING_CHANGES:
            wanted = [CHANGE_KINDS.index(k) for k in SEEDING_CHANGES[kind]]
            out += [(value, s[-1]) for k, s in zip(ds["change_kind"].values, ds["change_state"].values) if k in wanted]
        elif kind == "grazing":
            out += [(value, s[-1]) for s in _grazing_states(atlas, ds)]
        elif kind == "second_contact":
            out += [
                (value, s[-1])
                for k, s in zip(ds["end_kind"].values, ds["end_state"].values)
                if END_KINDS[int(k)] in ("early_impact", "leaves_stop")
            ]
    return out


def curve_points_variables(atlas: AtlasMap, curves: list, kind: str, law: str) -> dict:
    """Per point, per curve and per codimension-two point variables of ``curves`` (dataset layout)."""
    dofs = list(orbit_dofs(atlas.excitation))
    freq, second, index, amplitude, mu_re, mu_im, orbit, extra = [], [], [], [], [], [], [], []
    kinds, ends, seeds, c2_kind, c2_freq, c2_second, c2_curve = [], [], [], [], [], [], []
    for j, curve in enumerate(curves):
        equations = curve.system.equations
        for U in curve.points:
            x, e, params = curve.system.split(U)
            freq.append(params[0] / (2 * np.pi))
            second.append(params[atlas.free[1]])
            index.append(j)
            coefficients = equations.orbit(x, params)
            orbit.append(coefficients[dofs])
            amplitude.append(_sampled_amplitudes(coefficients[dofs]))
            mu = np.linalg.eigvals(equations.monodromy(x, params))
            mu = mu * mu if equations.half_period else mu
            mu = mu[np.argsort(-np.abs(mu), kind="stable")]
            mu_re.append(mu.real)
            mu_im.append(mu.imag)
            extra.append(float(e[0]) if len(e) else 0.0)
        kinds.append(CURVE_KINDS.index(kind.removeprefix("regularized_")))
        ends.append("; ".join(curve.end_reasons))
        seeds.append(curve.seed_value)
        for point in curve.codim2:
            c2_kind.append(CODIM2_KINDS.index(point.kind))
            c2_freq.append(point.params[0] / (2 * np.pi))
            c2_second.append(point.params[atlas.free[1]])
            c2_curve.append(j)
    m = len(mu_re[0]) if mu_re else 2 * atlas.excitation.structure.n_dofs
    return {
        "frequency": ("point", np.array(freq, dtype=float)),
        "second": ("point", np.array(second, dtype=float)),
        "point_curve": ("point", np.array(index, dtype=np.int32)),
        "amplitude": (("point", "orbit_dof"), np.array(amplitude, dtype=float).reshape(-1, len(dofs))),
        "multiplier_real": (("point", "multiplier"), np.array(mu_re, dtype=float).reshape(-1, m)),
        "multiplier_imag": (("point", "multiplier"), np.array(mu_im, dtype=float).reshape(-1, m)),
        "orbit": (
            ("point", "orbit_dof", "coefficient"),
            np.array(orbit, dtype=float).reshape(-1, len(dofs), 2 * ORBIT_HARMONICS + 1),
        ),
        "test_unknown": ("point", np.array(extra, dtype=float)),
        "curve_kind": ("curve", np.array(kinds, dtype=np.int8)),
        "curve_law": ("curve", np.full(len(curves), LAWS.index(law), dtype=np.int8)),
        "curve_ends": ("curve", np.array(ends, dtype=object)),
        "curve_seed": ("curve", np.array(seeds, dtype=float)),
        "codim2_kind": ("codim2", np.array(c2_kind, dtype=np.int8)),
        "codim2_frequency": ("codim2", np.array(c2_freq, dtype=float)),
        "codim2_second": ("codim2", np.array(c2_second, dtype=float)),
        "codim2_curve": ("codim2", np.array(c2_curve, dtype=np.int32)),
    }


def closed_form_grazing_variables(atlas: AtlasMap, curves: list) -> dict:
    """The layout of :func:`curve_points_variables` for closed-form grazing curves (``[(omega, second), ...]``,
    :func:`nnmstop.bifurcation_atlas.grazing.closed_form_grazing_curves`): each point the linear response at its
    grazing force (or gap), its multipliers those of the linear flow; ``test_unknown`` 0 (no test function), the
    seed the curve's first value, no codimension-two point, law ``piecewise_linear`` (the grazing of the
    non-smooth law, whose non-impacting response is linear)."""
    from nnmstop.bifurcation_atlas.grazing import linear_multipliers
    from nnmstop.exact.forced import non_impacting_response

    dofs = list(orbit_dofs(atlas.excitation))
    freq, second, index, orbit, mu = [], [], [], [], []
    for j, (omega, values) in enumerate(curves):
        for w, value in zip(omega, values):
            at = atlas.excitation_at(float(value))
            Q = non_impacting_response(at, [w])[0][dofs]
            coefficients = np.zeros((len(dofs), 2 * ORBIT_HARMONICS + 1))
            coefficients[:, 1], coefficients[:, ORBIT_HARMONICS + 1] = Q.real, -Q.imag
            freq.append(w / (2 * np.pi))
            second.append(value)
            index.append(j)
            orbit.append(coefficients)
            mu.append(linear_multipliers(at, w))
    m = 2 * atlas.excitation.structure.n_dofs
    orbit = np.array(orbit, dtype=float).reshape(-1, len(dofs), 2 * ORBIT_HARMONICS + 1)
    mu = np.array(mu, dtype=complex).reshape(-1, m)
    ends = "closed form: the frequency range or the window of the second parameter"
    return {
        "frequency": ("point", np.array(freq, dtype=float)),
        "second": ("point", np.array(second, dtype=float)),
        "point_curve": ("point", np.array(index, dtype=np.int32)),
        "amplitude": (("point", "orbit_dof"), np.abs(orbit[:, :, 1] - 1j * orbit[:, :, ORBIT_HARMONICS + 1])),
        "multiplier_real": (("point", "multiplier"), mu.real),
        "multiplier_imag": (("point", "multiplier"), mu.imag),
        "orbit": (("point", "orbit_dof", "coefficient"), orbit),
        "test_unknown": ("point", np.zeros(len(freq))),
        "curve_kind": ("curve", np.full(len(curves), CURVE_KINDS.index("grazing"), dtype=np.int8)),
        "curve_law": ("curve", np.full(len(curves), LAWS.index("piecewise_linear"), dtype=np.int8)),
        "curve_ends": ("curve", np.array([ends] * len(curves), dtype=object)),
        "curve_seed": ("curve", np.array([float(values[0]) for _, values in curves], dtype=float)),
        "codim2_kind": ("codim2", np.zeros(0, dtype=np.int8)),
        "codim2_frequency": ("codim2", np.zeros(0)),
        "codim2_second": ("codim2", np.zeros(0)),
        "codim2_curve": ("codim2", np.zeros(0, dtype=np.int32)),
    }


def _sampled_amplitudes(coefficients, samples: int = 2048) -> np.ndarray:
    """``max |q|`` of each row of Fourier coefficients ``[mean, cos 1..K, sin 1..K]`` on ``samples`` phases."""
    K = (coefficients.shape[-1] - 1) // 2
    theta = 2 * np.pi * np.arange(samples) / samples
    k = np.arange(1, K + 1)
    q = (
        coefficients[:, :1]
        + coefficients[:, 1 : K + 1] @ np.cos(np.outer(k, theta))
        + coefficients[:, K + 1 :] @ np.sin(np.outer(k, theta))
    )
    return np.abs(q).max(axis=1)


def _check_variables(rows: list, curve_offset: int = 0) -> dict:
    rows = np.array(rows, dtype=float).reshape(-1, 5)
    return {
        "check_curve": ("check", rows[:, 0].astype(np.int32) + curve_offset),
        "check_second": ("check", rows[:, 1]),
        "check_curve_frequency": ("check", rows[:, 2]),
        "check_response_frequency": ("check", rows[:, 3]),
        "check_deviation": ("check", rows[:, 4]),
    }


def curves_dataset(atlas: AtlasMap, kind: str, seed_slices: list, check_slices: list, regularized=None) -> xr.Dataset:
    """The curves of one kind with their codimension-two points and checks (module docstring).

    ``regularized`` (regularized kinds): ``(equations, seeds, located)``, the harmonic-balance equations, the
    seeds and the ``(value, omega)`` located at the check values (:mod:`nnmstop.bifurcation_atlas.regularized`).
    """
    law = "regularized" if kind in REGULARIZED_KINDS else "piecewise_linear"
    if law == "piecewise_linear" and kind == "grazing" and not atlas.exact_responses:
        # no exact formulation to continue it on: the closed form of the non-impacting response
        from nnmstop.bifurcation_atlas.grazing import closed_form_grazing_curves, grazing_checks

        curves = closed_form_grazing_curves(atlas)
        tolerance = float(atlas.check_tolerance)
        values = [float(ds.attrs["slice_value"]) for ds in check_slices]
        rows, missed = grazing_checks(atlas, curves, values)
        missed += [(r[1], r[3], r[4]) for r in rows if r[4] > tolerance]
        if missed:
            raise CheckFailed(
                f"atlas map {atlas.name!r}: grazing points located on the orbits lie on no closed-form grazing "
                f"curve (value, frequency Hz, nearest relative distance): {missed}; tolerance {tolerance:g}"
            )
        variables = closed_form_grazing_variables(atlas, curves)
    else:
        if law == "regularized":
            equations, seeds, located = regularized
            curves = follow_kind(atlas, kind, [], equations=equations, seeds=seeds)
            tolerance = float(atlas.regularized["check_tolerance"])
        else:
            atlas.check_exact(kind)
            curves = follow_kind(atlas, kind, seed_slices)
            located = _located_exact(atlas, kind, check_slices)
            tolerance = float(atlas.check_tolerance)
        rows = check_curves(atlas, kind, curves, located, tolerance)
        variables = curve_points_variables(atlas, curves, kind, law)
    ds = xr.Dataset({**variables, **_check_variables(rows)})
    ds.attrs.update(_map_attributes(atlas))
    ds.attrs.update(curve_kind=kind, contact_law=law, check_tolerance=tolerance)
    return ds


# --------------------------------------------------------------------------- the atlas


def atlas_dataset(atlas: AtlasMap, slices: list, curve_sets: list) -> xr.Dataset:
    """Slices (regions) and curve sets (points, curves, codimension-two points, checks) of ``atlas`` in one
    dataset. The slices' response points and orbits stay in the slice datasets (the explorer reads them)."""
    slices = sorted(slices, key=lambda ds: ds.attrs["slice_index"])
    values = np.array([ds.attrs["slice_value"] for ds in slices], dtype=float)
    data = {
        "slice_value": ("slice", values),
        "slice_complete": ("slice", np.array([ds.attrs["complete"] for ds in slices], dtype=np.int8)),
        "grid_frequency": ("grid", slices[0]["grid_frequency"].values),
        "region": (("slice", "grid"), np.stack([ds["region"].values for ds in slices])),
        "responses": (("slice", "grid"), np.stack([ds["responses"].values for ds in slices])),
        "stable_responses": (("slice", "grid"), np.stack([ds["stable_responses"].values for ds in slices])),
    }
    point_vars = ("frequency", "second", "amplitude", "multiplier_real", "multiplier_imag", "orbit", "test_unknown")
    curve_vars = ("curve_kind", "curve_law", "curve_ends", "curve_seed")
    codim2_vars = ("codim2_kind", "codim2_frequency", "codim2_second")
    check_vars = ("check_second", "check_curve_frequency", "check_response_frequency", "check_deviation")
    indexed = ("point_curve", "codim2_curve", "check_curve")
    parts = {name: [] for name in point_vars + curve_vars + codim2_vars + check_vars + indexed}
    dims, offset = {}, 0
    for ds in curve_sets:
        for name in parts:
            parts[name].append(ds[name].values + offset if name in indexed else ds[name].values)
            dims[name] = ds[name].dims
        offset += ds.sizes.get("curve", 0)
    for name, values in parts.items():
        data[name] = (dims[name], np.concatenate(values))
    ds = xr.Dataset(data)
    ds.attrs.update(_map_attributes(atlas))
    ds.attrs["check_tolerance"] = float(atlas.check_tolerance)
    if atlas.regularized is not None:
        ds.attrs["regularized_check_tolerance"] = float(atlas.regularized["check_tolerance"])
        ds.attrs["harmonics"] = int(atlas.regularized["harmonics"])
    return ds
