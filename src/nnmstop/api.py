"""The few functions a user composes: continue an NNM, its stability, the exact one-impact family.

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

__all__ = ["continue_nnm", "stability", "exact_family", "exact_family_dataset", "switching_family_dataset"]


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
    spec = BranchSpec(f"nnm{mode}", mode, start_amplitude, (stage,), energy_max=float(energy_max))
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
    from nnmstop.hbm.dataset import dataset_unknowns
    from nnmstop.hbm.stability import orbit_stability

    system = HarmonicBalanceSystem(structure, int(branch.attrs["harmonics"]), basis=str(branch.attrs["basis"]))
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
