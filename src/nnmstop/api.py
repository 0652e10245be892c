"""The few functions a user composes: continue an NNM, its stability, the exact one-impact family, a forced response,
the bifurcation atlas.

They take a :class:`~nnmstop.models.structure.Structure` (the paper's oscillator is
:func:`~nnmstop.models.structure.two_dof_structure`, a structure of one's own is built from matrices,
:class:`~nnmstop.models.structure.Structure` or :func:`~nnmstop.models.matrices.matrix_structure`) and
return labelled :class:`xarray.Dataset` objects in the schema of the pipeline's datasets
(``docs/datasets.md``): the same engine as ``snakemake`` (:mod:`nnmstop.hbm.stages`), no configuration
file. ``docs/structures.md`` says how to make a structure nondimensional.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from nnmstop.catalogue import describe, kind
from nnmstop.continuation.anm import ANMSettings
from nnmstop.hbm.stability import StabilitySettings
from nnmstop.hbm.stages import BranchSettings, BranchSpec, StageSpec, continue_stage
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import Structure

__all__ = [
    "continue_nnm",
    "stability",
    "exact_family",
    "exact_family_dataset",
    "switching_family_dataset",
    "forced_response",
    "atlas",
]


def continue_nnm(
    structure: Structure,
    mode: int = 1,
    harmonics: int = 40,
    energy_max: float = 100.0,
    start_amplitude: float = 0.05,
    until: dict | None = None,
    max_truncation: float = 1e-3,
    pass_resonances: int = 0,
    continuation: ANMSettings | None = None,
    stability: StabilitySettings | None = None,
    motion: str = "planar",
) -> xr.Dataset:
    """Continue the regularized NNM ``mode`` of ``structure`` from its linear mode and return its dataset.

    Harmonic balance with ``harmonics`` harmonics and the asymptotic numerical method, one stage from the
    linear mode of the regularized structure near rest (the first stop's coordinate at
    ``start_amplitude`` of its gap) until ``until`` (default: the first orbit above ``energy_max``),
    ending anyway above ``energy_max`` or where the harmonics stop resolving the stop (truncation
    indicator above ``max_truncation``); branch points located, folds, Floquet multipliers.

    Parameters
    ----------
    structure : Structure
    mode : int
        Index of the linear mode the branch starts from (1 the lowest).
    harmonics : int
        ``H``.
    energy_max : float
        The branch ends at the first orbit above this energy.
    start_amplitude : float
        In ``(0, 1)``: amplitude of the first stop's coordinate (over its gap) at the start.
    until : dict, optional
        A stage condition (:data:`nnmstop.hbm.criteria.CRITERIA`), e.g. ``{"impacts_above": 2}``.
    max_truncation : float
        Largest truncation indicator of a stored orbit.
    pass_resonances : int
        Internal resonance tongues passed onto the backbone beyond (``docs/methods/tube_resonance.md``).
    continuation : ANMSettings, optional
        Series order, tolerance, Newton threshold, steps, points per step.
    stability : StabilitySettings, optional
        How the Floquet multipliers are computed (:func:`nnmstop.hbm.stability.orbit_stability`; default: the
        monodromy with Magnus steps, error estimates and shooting refinement, ``docs/methods/monodromy.md``).
    motion : {"planar", "whirl"}
        For a structure invariant under rotations (``Structure.rotation_pairs``: an isotropic structure in a
        circular hole): ``planar`` orbits (the rotation fixed by a phase condition) or ``whirl``, the mode
        whirling round the hole (full basis; ``docs/methods/circular_clearance.md``).

    Returns
    -------
    xarray.Dataset
        ``energy``, ``frequency``, ``q_cos``/``q_sin(point, dof, harmonic)`` (coordinate ``dof_label``),
        stop forces, impacts, residuals, located branch points and folds, multipliers; its attribute
        ``end_reason`` says why it ended.

    Examples
    --------
    NNM1 of the paper's oscillator up to its first orbit with impacts, few harmonics:

    >>> from nnmstop import two_dof_structure, continue_nnm
    >>> nnm1 = continue_nnm(two_dof_structure(), harmonics=20, until={"impacts_above": 0})
    >>> round(float(nnm1.frequency[0]), 4), int(nnm1.impacts_per_period[-1]), nnm1.attrs["end_reason"]
    (0.1018, 2, 'more than 0 impacts per period')
    """
    system = HarmonicBalanceSystem(structure, harmonics)
    settings = BranchSettings(
        continuation or ANMSettings(points_per_step=2),
        max_truncation,
        stability or StabilitySettings(),
        truncation_setting="max_truncation",
    )
    stage = StageSpec("api", until or {"energy_above": float(energy_max)}, pass_resonances=pass_resonances)
    name = f"{'whirl' if motion == 'whirl' else 'nnm'}{mode}"
    spec = BranchSpec(name, mode, start_amplitude, (stage,), energy_max=float(energy_max), motion=motion)
    return continue_stage(system, settings, spec, 1)


def stability(structure: Structure, branch: xr.Dataset, settings: StabilitySettings | None = None) -> xr.Dataset:
    """Floquet stability of the orbits of a branch dataset of ``structure``, recomputed.

    The one interface of every branch (:func:`nnmstop.hbm.stability.orbit_stability`): by default the
    monodromy matrix of the variational equation by Magnus steps, with its integration and orbit error
    estimates, the orbits whose own error decides the verdict refined by shooting
    (``docs/methods/monodromy.md``); ``settings`` chooses the method (``hill``) and its tolerances. An
    orbit whose ``time_residual`` exceeds ``settings.monodromy.max_orbit_residual`` gets no resolved verdict.

    Returns
    -------
    xarray.Dataset
        ``stable``, ``multiplier_real``, ``multiplier_imag(point, multiplier)``, ``max_multiplier``,
        ``stability_resolved`` and the method's error estimates (names and meanings: ``docs/datasets.md``).

    Examples
    --------
    >>> from nnmstop import two_dof_structure, continue_nnm, stability
    >>> s = two_dof_structure()
    >>> verdicts = stability(s, continue_nnm(s, harmonics=10, energy_max=0.05))
    >>> bool(verdicts.stable.all()), bool(verdicts.stability_resolved.all())  # NNM1 below grazing: linear, stable
    (True, True)
    """
    from nnmstop.hbm.dataset import dataset_unknowns, system_arguments
    from nnmstop.hbm.stability import orbit_stability

    system = HarmonicBalanceSystem(structure, int(branch.attrs["harmonics"]), **system_arguments(branch.attrs))
    residual = branch["time_residual"].values if "time_residual" in branch else None
    verdicts = orbit_stability(
        system, dataset_unknowns(branch, system), settings or StabilitySettings(), time_residual=residual
    )
    ds = xr.Dataset(verdicts.data_vars(), coords={"point": branch["point"].values})
    spec = kind("nnm_branch")  # labelled as in a branch dataset (not one: no orbits)
    for name in ds.variables:
        ds[name].attrs = spec[name].attrs()
    return ds


def exact_family_dataset(structure: Structure, family) -> xr.Dataset:
    """Labelled dataset of a one-stop exact family (:func:`nnmstop.exact.ndof.follow_one_stop_family`).

    The family's orbits, modal energies and internal resonances (:func:`nnmstop.exact.dataset.one_stop_dataset`)
    with the structure's DOF labels and attributes. Long names and units from the variable catalogue (kind
    ``one_stop_family``).
    """
    from nnmstop.exact.dataset import one_stop_dataset

    ds = one_stop_dataset(family)
    ds = ds.assign_coords(dof_label=("dof", np.array(structure.dof_labels, dtype=str)))
    ds.attrs = {
        **structure.attributes,
        "dofs": structure.n_dofs,
        "stops": len(structure.stops),
        "mode": 1,
        **ds.attrs,
    }
    return describe(ds, "one_stop_family")


def switching_family_dataset(structure: Structure, family=None, reason: str = "") -> xr.Dataset:
    """Labelled dataset of a full-period exact family (:func:`nnmstop.exact.switching.follow_switching_family`),
    or, with no ``family``, of a structure without exact orbits (``reason``): kind ``switching_family``."""
    from nnmstop.exact.dataset import switching_dataset

    ds = switching_dataset(structure, family, reason)
    ds = ds.assign_coords(dof_label=("dof", np.array(structure.dof_labels, dtype=str)))
    ds.attrs = {**structure.attributes, "dofs": structure.n_dofs, "stops": len(structure.stops), "mode": 1, **ds.attrs}
    return describe(ds, "switching_family")


def uses_quarter_period(structure: Structure) -> bool:
    """Whether the exact family of ``structure`` is the quarter-period one (:mod:`nnmstop.exact.ndof`): every stop
    the paper's bilateral stop on one DOF. Otherwise it is built over full periods (:mod:`nnmstop.exact.switching`)."""
    return all(stop.kind == "bilateral" for stop in structure.stops)


def exact_family(structure: Structure, step: float = 0.02, max_points: int = 2000) -> xr.Dataset:
    """The exact NNM1 of the non-smooth structure with one impact per stop side per period.

    Closed-form phases (matrix exponentials of the 2N first-order system) from the grazing orbit of the
    first linear mode, continued by pseudo-arclength until an assumption of the family fails (its
    ``end_reason``). Bilateral stops: the quarter-period construction (:mod:`nnmstop.exact.ndof`,
    ``docs/methods/exact_ndof.md``); one-sided stops, unequal gaps and relative stops: full periods with the
    switching times as unknowns, one impact per contact struck (:mod:`nnmstop.exact.switching`, kind
    ``switching_family``).

    Raises
    ------
    ValueError
        For a circular clearance, whose law is not piecewise linear in the degrees of freedom (no exact orbits:
        use :func:`continue_nnm`).

    Examples
    --------
    >>> from nnmstop import two_dof_structure, exact_family
    >>> family = exact_family(two_dof_structure(), step=0.1, max_points=20)
    >>> round(float(family.frequency[0]), 4)  # the grazing orbit: the no-contact linear mode, 0.618 rad
    0.0984
    """
    if uses_quarter_period(structure):
        from nnmstop.exact.ndof import follow_one_stop_family

        return exact_family_dataset(structure, follow_one_stop_family(structure, step=step, max_points=max_points))
    from nnmstop.exact.switching import follow_switching_family

    family = follow_switching_family(structure, step=step, max_points=max_points)
    return switching_family_dataset(structure, family)


#: Methods of :func:`forced_response`.
FORCED_METHODS = ("exact", "regularized")


def _damping(structure: Structure, damping):
    from nnmstop.forced.scenes import _damping as from_spec
    from nnmstop.models.excitation import Damping

    if isinstance(damping, Damping):
        return damping
    if isinstance(damping, dict):
        return from_spec(structure, damping)
    ratios = np.atleast_1d(np.asarray(damping, dtype=float))
    if not 1 <= ratios.size <= 2:
        raise ValueError(
            f"damping: give a Damping, a dict as the config's forced.damping, or the damping ratios of the lowest one "
            f"or two linear modes; got {damping!r}"
        )
    return Damping.from_modal_ratios(structure, ratios.tolist(), list(range(1, ratios.size + 1)))


def _force(structure: Structure, force):
    from nnmstop.forced.scenes import _dof_indices
    from nnmstop.models.excitation import HarmonicForce

    if isinstance(force, HarmonicForce):
        return force
    try:
        amplitude, dofs = force
    except (TypeError, ValueError):
        raise ValueError(
            f"force: give a HarmonicForce or (amplitude, dofs) with dofs labels or indices, got {force!r}"
        ) from None
    dofs = [dofs] if isinstance(dofs, (str, int, np.integer)) else list(dofs)
    return HarmonicForce(float(amplitude), tuple(_dof_indices(structure, dofs, "force")))


def forced_response(
    structure: Structure,
    damping,
    force,
    frequency_range,
    method: str = "exact",
    harmonics: int = 40,
    continuation=None,
    stability=None,
    max_truncation: float = 1e-3,
) -> xr.Dataset:
    """The periodic responses of ``structure`` with ``damping`` to ``force`` over ``frequency_range``, with stability.

    ``M q'' + C q' + K q + (stop forces) = F cos(Omega t) b``, the same computation as the pipeline's
    ``snakemake forced`` (:mod:`nnmstop.forced.assemble`, ``docs/forced.md``):

    * ``method="exact"``: the piecewise-linear law of every stop in closed form per phase: the non-impacting
      response and, from each of its grazing orbits, the responses with one contact per grazing contact per
      period (no symmetry assumed; the half-wave reduction where every law is odd), each family followed until
      an assumption fails, its end located and confirmed; multipliers from the product of the phase exponentials.
      Every stop must be piecewise linear: a circular clearance is refused (use ``method="regularized"``).
    * ``method="regularized"``: the regularized law of every stop by harmonic balance (``harmonics``) and the
      asymptotic numerical method through the folds; multipliers of the damped variational equation at the
      precision their verdicts need.

    Both locate and type the stability changes (folds, symmetry breaking, period doubling, Neimark-Sacker) and
    say per point what the response is where the periodic one is unstable (``regime``).

    Parameters
    ----------
    structure : Structure
    damping : Damping, sequence of float or dict
        A :class:`~nnmstop.models.excitation.Damping`; or the damping ratios of the lowest one or two linear modes
        (Rayleigh damping); or a dict as the configuration's ``forced.damping`` (``{ratios, modes}`` or
        ``{mass_coefficient, stiffness_coefficient}``).
    force : HarmonicForce or (float, dofs)
        A :class:`~nnmstop.models.excitation.HarmonicForce`, or its amplitude ``F`` and the forced degrees of
        freedom (labels or indices; the unit pattern ``b``).
    frequency_range : (float, float)
        Lowest and highest frequency of the force, Hz of the nondimensional time.
    method : {"exact", "regularized"}
    harmonics : int
        ``H`` of the regularized response.
    continuation : ExactSettings or ANMSettings, optional
        :class:`~nnmstop.forced.responses.ExactSettings` (exact) or
        :class:`~nnmstop.continuation.anm.ANMSettings` (regularized).
    stability : ForcedStabilitySettings, optional
        Magnus steps and resolution factor of the verdicts
        (:class:`~nnmstop.forced.regularized.ForcedStabilitySettings`; its ``resolution_factor`` also applies to
        the exact verdicts).
    max_truncation : float
        Largest truncation indicator of a regularized orbit.

    Returns
    -------
    xarray.Dataset
        Per point ``frequency``, ``amplitude`` (``max |q|`` of every DOF; ``x_amplitude`` of the first stop's DOF,
        ``u_amplitude`` of the first forced DOF), ``phase_lag``, ``stable``, the multipliers, ``regime``,
        ``stability_resolved``; the located changes (``change_frequency``, ``change_kind``); the orbits
        (exact: their unknowns or switches; regularized: Fourier coefficients). Kinds ``forced_exact`` and
        ``forced_regularized`` of the catalogue (``docs/datasets.md``).

    Raises
    ------
    ValueError
        An unknown ``method``; a circular clearance with ``method="exact"``; bad damping, force or range.

    Examples
    --------
    A 2-DOF chain with a one-sided stop on its first mass, forced there:

    >>> import numpy as np
    >>> import nnmstop
    >>> stop = nnmstop.Stop(kind="one_sided", dof=0, side="positive", gap=1.0, stiffness=20.0, eta=0.05)
    >>> chain = nnmstop.Structure(np.eye(2), [[2.0, -1.0], [-1.0, 2.0]], [stop])
    >>> exact = nnmstop.forced_response(chain, [0.02, 0.02], (0.2, [0]), (0.1, 0.35))
    >>> exact.attrs["segment_kinds"], bool((exact.stable == 0).any())  # an unstable stretch past the fold
    ('non_impacting one_contact non_impacting', True)
    >>> [str(k) for k in exact.change_kind.attrs["flag_meanings"].split()][:2]
    ['fold', 'symmetry_breaking']
    """
    from nnmstop.catalogue import describe
    from nnmstop.forced import assemble
    from nnmstop.forced.regularized import ForcedStabilitySettings
    from nnmstop.forced.responses import ExactSettings, RegularizedSettings
    from nnmstop.forced.scenes import _frequency_range
    from nnmstop.models.excitation import Excitation

    if method not in FORCED_METHODS:
        raise ValueError(f"method must be one of {FORCED_METHODS}, got {method!r}")
    if method == "exact":
        curved = [s.label for s in structure.stops if not s.piecewise_linear]
        if curved:
            raise ValueError(
                f"method='exact' needs piecewise-linear stops; the {', '.join(curved)} is not (use "
                "method='regularized')"
            )
    excitation = Excitation(structure, _damping(structure, damping), _force(structure, force))
    frequency_range = _frequency_range(frequency_range, "frequency_range")
    stability = stability or ForcedStabilitySettings()
    if method == "exact":
        ds = assemble.exact_response_dataset(
            excitation, frequency_range, continuation or ExactSettings(), stability.resolution_factor
        )
    else:
        anm = continuation or ANMSettings(points_per_step=2)
        settings = RegularizedSettings(int(harmonics), anm, float(max_truncation))
        ds = assemble.regularized_response_dataset(excitation, frequency_range, settings, stability)
    ds.attrs = {**structure.attributes, **ds.attrs}
    return describe(ds, f"forced_{'exact' if method == 'exact' else 'regularized'}")


#: Harmonic-balance settings of :func:`atlas` where its ``regularized`` argument does not give them.
REGULARIZED_DEFAULTS = {"harmonics": 20, "max_truncation": 1e-3, "steps": 128, "step": 0.5, "check_tolerance": 1e-5}


def atlas(
    structure: Structure,
    frequency_range,
    force_dofs,
    second_range,
    slices: int = 12,
    damping=0.01,
    plane: str = "force",
    force: float = 1.0,
    seeds=None,
    checks=None,
    kinds=("grazing", "fold", "neimark_sacker", "flip", "second_contact"),
    frequency_samples: int = 200,
    check_tolerance: float = 1e-7,
    curve=None,
    exact=None,
    regularized=None,
    anm=None,
) -> xr.Dataset:
    """The bifurcation atlas of ``structure`` forced on ``force_dofs``, as a labelled dataset (kind ``atlas``).

    The same computation as ``snakemake atlas`` (:mod:`nnmstop.bifurcation_atlas.build`), in this process: ``slices``
    exact one-parameter responses evenly spaced over ``second_range`` (force amplitudes on the ``force`` plane,
    else values of the structural parameter ``plane`` at the force ``force``), classified into regions, and every
    curve of ``kinds`` (exact, piecewise-linear stops) through the points the ``seeds`` slices locate, checked
    against the ``checks`` slices (a located point on no curve raises
    :class:`~nnmstop.bifurcation_atlas.build.CheckFailed`), with their codimension-two points. The exact
    formulation follows the stops (:func:`nnmstop.bifurcation_atlas.equations.exact_equations`): the symmetric
    responses over half a period for bilateral stops and relative stops on both sides, the responses with one
    contact per period over the full period for one-sided stops, unequal gaps and one-sided relative stops. A
    structure without exact responses in the atlas
    (:func:`~nnmstop.bifurcation_atlas.build.without_exact_responses`: a stop not piecewise linear, such as a
    circular clearance, or a two-sided stop beside a one-sided one) has regularized slices (the harmonic-balance
    responses with their Floquet stability), its grazing curve in closed form and the regularized curve kinds; its
    exact kinds other than ``grazing`` are refused (ValueError saying why).

    Parameters
    ----------
    structure : Structure
        Any structure with at least one stop (the structural parameter is the first stop's) and no rigid-body
        mode.
    frequency_range : (float, float)
        Hz of the nondimensional time.
    force_dofs : sequence of int or str
        Forced degrees of freedom (indices or labels); unit weights.
    second_range : (float, float)
        Range of the slices; the curves run on ten per cent of it beyond either end.
    slices : int
        Number of slices (one response each: exact, or regularized for a structure without exact responses).
    damping : float or Damping
        Damping ratio of the first two linear modes (one mode for a 1-DOF structure), or a Damping.
    plane : {"force", "gap", "stiffness", "damping_ratio"}
    force : float
        The force amplitude of a structural plane.
    seeds, checks : sequence of float, optional
        Slice values (they snap to the nearest slice) that seed and check the curves; by default the middle
        slice seeds and the slices at a quarter and three quarters check.
    kinds : sequence of str
        Curve kinds (:data:`nnmstop.bifurcation_atlas.build.EXACT_KINDS`,
        :data:`~nnmstop.bifurcation_atlas.build.REGULARIZED_KINDS`).
    frequency_samples : int
        Grid frequencies of the regions.
    check_tolerance : float
        Relative frequency distance allowed between a curve and a located point.
    curve : CurveSettings, optional
    exact : ExactSettings, optional
    regularized : dict, optional
        The harmonic-balance settings (the keys of a map's ``regularized`` section: ``harmonics``,
        ``max_truncation``, ``steps``, ``step``, ``check_tolerance``, ``seeds``, ``checks``, ``range``) over
        :data:`REGULARIZED_DEFAULTS`; ``seeds`` and ``checks`` default to those of the slices. Used by the
        regularized kinds and the slices of a stop that is not piecewise linear.
    anm : ANMSettings, optional
        Continuation of the regularized responses (default ``ANMSettings(points_per_step=2)``).

    Examples
    --------
    >>> import nnmstop
    >>> ds = nnmstop.atlas(nnmstop.two_dof_structure(), (0.08, 0.12), ["u"], (0.05, 0.1), slices=3,
    ...                    kinds=("grazing",), frequency_samples=20)  # doctest: +SKIP
    >>> sorted(set(ds["curve_kind"].values.tolist()))  # doctest: +SKIP
    [0]
    """
    from nnmstop.bifurcation_atlas.build import (
        EXACT_KINDS,
        REGULARIZED_KINDS,
        AtlasMap,
        atlas_dataset,
        curves_dataset,
        slice_dataset,
        without_exact_responses,
    )
    from nnmstop.bifurcation_atlas.curves import CurveSettings
    from nnmstop.bifurcation_atlas.regularized import regularized_inputs
    from nnmstop.forced.responses import ExactSettings
    from nnmstop.forced.scenes import _dof_indices
    from nnmstop.models.excitation import Damping, Excitation, HarmonicForce

    if not isinstance(damping, Damping):  # one ratio for the first two linear modes (one for a 1-DOF structure)
        damping = [float(damping)] * min(2, structure.n_dofs)
    dofs = tuple(_dof_indices(structure, list(force_dofs), "force_dofs"))
    excitation = Excitation(structure, _damping(structure, damping), HarmonicForce(float(force), dofs))
    values = (
        tuple(float(v) for v in np.linspace(*second_range, int(slices))) if slices > 1 else (float(second_range[0]),)
    )

    def snap(chosen):
        return tuple(values[int(np.argmin(np.abs(np.asarray(values) - v)))] for v in chosen)

    n = len(values)
    chosen_seeds = snap(seeds) if seeds is not None else (values[n // 2],)
    chosen_checks = snap(checks) if checks is not None else tuple(sorted({values[n // 4], values[(3 * n) // 4]}))
    inexact = without_exact_responses(structure) is not None  # regularized slices (a circular clearance, ...)
    spec = None
    if regularized is not None or inexact or any(k in REGULARIZED_KINDS for k in kinds):
        spec = {**REGULARIZED_DEFAULTS, **(regularized or {})}
    low, high = (float(v) for v in second_range)
    margin = 0.1 * (high - low)  # the curves run past the end slices, so that they cross them
    atlas_map = AtlasMap(
        name="atlas",
        excitation=excitation,
        plane=plane,
        frequency_range=tuple(float(v) for v in frequency_range),
        second_range=(max(low - margin, 0.5 * low), high + margin),
        slices=values,
        seeds=chosen_seeds,
        checks=chosen_checks,
        kinds=tuple(kinds),
        exact=exact or ExactSettings(),
        curve=curve or CurveSettings(),
        grid=int(frequency_samples),
        check_tolerance=float(check_tolerance),
        regularized=None if spec is None else {"seeds": chosen_seeds, "checks": chosen_checks, **spec},
    )
    for name in kinds:  # refused before anything is computed
        if name in EXACT_KINDS:
            atlas_map.check_exact(name)
    anm = anm or ANMSettings(points_per_step=2)
    slice_sets = [slice_dataset(atlas_map, k, anm) for k in range(n)]

    def at(chosen):
        return [slice_sets[values.index(v)] for v in chosen]

    curve_sets = [
        curves_dataset(
            atlas_map,
            kind,
            at(atlas_map.seeds),
            at(atlas_map.checks),
            regularized_inputs(atlas_map, kind, anm) if kind in REGULARIZED_KINDS else None,
        )
        for kind in kinds
    ]
    return describe(atlas_dataset(atlas_map, slice_sets, curve_sets), "atlas")
