"""Typed settings from the configuration: the one layer between ``config/config.yaml`` and the engine.

The tasks (:mod:`nnmstop.tasks`) and the study (:mod:`nnmstop.study`) turn the validated
configuration dict into the frozen dataclasses below and hand those to the numerics; nothing
under this layer reads the dict. Another value (a study's ``H``, ``eta`` or ``alpha``) is
:func:`dataclasses.replace` on a setting, never an edited copy of the configuration.

Each function reads only the sections it names, so a task reads only what its rule passes
(``params: config=task_config(...)`` in ``workflow/rules``).

* the structure and its harmonic balance: :func:`model_parameters` (``model``),
  :func:`structure_from_config` (``structure``, or ``model`` for the paper's oscillator),
  :func:`system_from_config` (those and ``hbm``);
* continuation of the regularized branches: :func:`anm_settings` (``anm``),
  :func:`stability_settings` (``stability``), :func:`branch_settings` (``anm``, ``hbm``,
  ``stability``), :func:`branch_spec` (``branches``), :func:`bifurcation_spec` (``bifurcations``);
* exact family: :func:`exact_settings` (``exact``);
* comparison of Figs 2-4: :class:`CompareSettings`, :func:`compare_settings` (``compare``);
* the study: :class:`StageOneRun` (one continuation of NNM1 stage 1), :class:`ErrorRuntimeSweep`,
  :class:`StiffSweep`, :class:`StudySettings`, :func:`study_settings`.

Values are checked where they are built (the dataclasses of the engine check their own; the
study's cross-checks are in :class:`StudySettings`), with errors naming the configuration key.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np

from nnmstop.continuation.anm import ANMSettings
from nnmstop.exact.family import FamilySettings
from nnmstop.hbm.monodromy import MonodromySettings
from nnmstop.hbm.stability import StabilitySettings
from nnmstop.hbm.stages import BifurcationSpec, BranchSettings, BranchSpec, StageSpec
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import Structure, two_dof_structure
from nnmstop.models.two_dof import ModelParameters

__all__ = [
    "model_parameters",
    "STRUCTURE_KINDS",
    "structure_from_config",
    "system_from_config",
    "anm_settings",
    "stability_settings",
    "branch_settings",
    "branch_spec",
    "bifurcation_spec",
    "exact_settings",
    "CompareSettings",
    "compare_settings",
    "StageOneRun",
    "ErrorRuntimeSweep",
    "StiffSweep",
    "StudySettings",
    "study_settings",
]


def _section(config: dict, name: str) -> dict:
    if name not in config:
        raise ValueError(f"config lacks the section {name!r} (see config/config.yaml)")
    return config[name]


# --------------------------------------------------------------------------- model, HBM, continuation


def model_parameters(config: dict) -> ModelParameters:
    """The paper's oscillator of the ``model`` section."""
    return ModelParameters.from_config(_section(config, "model"))


#: Kinds of the ``structure`` section.
STRUCTURE_KINDS = ("two_dof", "beam", "matrices")


def structure_from_config(config: dict, eta: float | None = None) -> Structure:
    """The structure of the ``structure`` section (the paper's oscillator of ``model`` without one).

    ``kind: two_dof`` (default) is the oscillator of ``model`` (``eta`` replaces ``model.eta`` when
    given); ``kind: beam`` the finite-element beam of ``structure.beam``
    (:func:`nnmstop.models.beam.beam_structure`); ``kind: matrices`` the matrices of
    ``structure.matrices`` (:func:`nnmstop.models.matrices.matrix_structure`). With a ``reduction`` key
    (``{modes, boundary_dofs}``) the beam or matrices are reduced onto their contact DOFs
    (:func:`nnmstop.models.reduction.reduce_structure`).
    """
    section = config.get("structure", {"kind": "two_dof"})
    if "reduction" in section:
        from nnmstop.models.reduction import reduce_structure

        unreduced = {key: value for key, value in section.items() if key != "reduction"}
        full = structure_from_config({**config, "structure": unreduced}, eta)
        return reduce_structure(full, section["reduction"], "structure.reduction")
    kind = section.get("kind", "two_dof")
    if kind not in STRUCTURE_KINDS:
        raise ValueError(f"structure.kind must be one of {STRUCTURE_KINDS}, got {kind!r}")
    if eta is not None and kind != "two_dof":
        raise ValueError(f"eta can be replaced only on the paper's oscillator (structure.kind two_dof), not {kind}")
    if kind == "two_dof":
        params = model_parameters(config)
        return two_dof_structure(params if eta is None else dataclasses.replace(params, eta=float(eta)))
    if kind == "beam":
        from nnmstop.models.beam import Beam, beam_structure

        return beam_structure(Beam.from_parameters(copy.deepcopy(section["beam"])))
    from nnmstop.models.matrices import matrix_structure

    spec = section["matrices"]
    return matrix_structure(spec["mass"], spec["stiffness"], spec["stops"], spec.get("dof_labels"))


def system_from_config(config: dict, harmonics: int | None = None, eta: float | None = None) -> HarmonicBalanceSystem:
    """The HBM system of the ``structure`` (or ``model``) and ``hbm`` sections (optionally another ``H`` or,
    on the paper's oscillator, ``eta``)."""
    hbm = _section(config, "hbm")
    H = hbm["harmonics"] if harmonics is None else harmonics
    return HarmonicBalanceSystem(
        structure_from_config(config, eta), int(H), time_samples=int(hbm.get("time_samples", 0))
    )


def anm_settings(config: dict, points_per_step: int = 1) -> ANMSettings:
    """ANM continuation settings of the ``anm`` section, storing ``points_per_step`` points per step."""
    return ANMSettings.from_config(_section(config, "anm"), points_per_step=int(points_per_step))


def stability_settings(config: dict) -> StabilitySettings:
    """Stability settings from the ``stability`` section (the monodromy method when it is absent), any structure."""
    spec = config.get("stability", {"method": "monodromy"})
    hill = {"hill_tol": spec["hill_tol"]} if "hill_tol" in spec else {}
    return StabilitySettings(
        method=spec.get("method", "monodromy"), monodromy=MonodromySettings.from_config(spec), **hill
    )


def branch_settings(config: dict, setting: str = "hbm.max_truncation") -> BranchSettings:
    """Continuation, truncation and stability settings of the regularized branches (``anm``, ``hbm``,
    ``stability``); ``setting`` names the truncation limit's key in messages."""
    hbm = _section(config, "hbm")
    start = {"start_tolerance": float(hbm["start_tolerance"])} if "start_tolerance" in hbm else {}
    return BranchSettings(
        anm_settings(config, hbm.get("points_per_step", 1)),
        hbm["max_truncation"],
        stability_settings(config),
        truncation_setting=setting,
        **start,
    )


def branch_spec(config: dict, name: str) -> BranchSpec:
    """The branch ``branches.<name>`` of the configuration: its stages, their conditions and bounds."""
    spec = _section(config, "branches")[name]
    stages = tuple(
        StageSpec(
            stage["name"],
            dict(stage["until"]),
            energy_max=stage.get("energy_max"),
            pass_resonances=int(stage.get("pass_resonances", 0)),
        )
        for stage in spec["stages"]
    )
    bound = {"energy_max": float(spec["energy_max"])} if "energy_max" in spec else {}
    motion = {"motion": spec["motion"]} if "motion" in spec else {}
    return BranchSpec(name, int(spec["mode"]), spec["start_amplitude"], stages, **bound, **motion)


def bifurcation_spec(config: dict, name: str) -> BifurcationSpec:
    """The switched branch ``bifurcations.<name>`` of the configuration."""
    spec = _section(config, "bifurcations")[name]
    return BifurcationSpec(name, spec["parent"], spec["resonance"], tuple(spec["energy_range"]), spec["switch_step"])


def exact_settings(config: dict) -> FamilySettings:
    """Continuation settings of the exact two-impact family (``exact``: ``step``, ``max_points``)."""
    exact = _section(config, "exact")
    return FamilySettings(step=float(exact["step"]), max_points=int(exact["max_points"]))


# --------------------------------------------------------------------------- comparison (Figs 2-4)


@dataclass(frozen=True)
class CompareSettings:
    """Exact against regularized NNM1 at matched energies (section ``compare``).

    Attributes
    ----------
    energy_count : int
        Log-spaced energies over the common range.
    end_margin : float
        Relative margin kept from both ends of that range, in ``[0, 0.5)``.
    phase_samples : int
        Phases ``t/T`` per period for the largest orbit differences (>= 64).
    points : dict
        Labelled points (``a``, ``b``): an energy, or ``{"energy_fraction": r}`` (the energy at the fraction
        ``r`` of the compared range, in log energy).
    """

    energy_count: int
    end_margin: float
    phase_samples: int
    points: dict

    def __post_init__(self):
        if not 0.0 <= self.end_margin < 0.5:
            raise ValueError(f"compare.end_margin must lie in [0, 0.5), got {self.end_margin!r}")
        if self.phase_samples < 64:
            raise ValueError(f"compare.phase_samples must be >= 64, got {self.phase_samples!r}")


def compare_settings(config: dict) -> CompareSettings:
    """The ``compare`` section."""
    spec = _section(config, "compare")
    return CompareSettings(
        int(spec["energy_count"]),
        float(spec["end_margin"]),
        int(spec["phase_samples"]),
        {label: point if isinstance(point, dict) else float(point) for label, point in spec["points"].items()},
    )


# --------------------------------------------------------------------------- the study


@dataclass(frozen=True)
class StageOneRun:
    """One continuation of stage 1 of a regularized branch (NNM1 in the study), all it needs.

    A study case is :func:`dataclasses.replace` of this (another ``harmonics``, ``params``,
    ``continuation``), for example
    ``replace(run, harmonics=200, params=replace(run.params, eta=1e-3))``.

    Attributes
    ----------
    params : ModelParameters
        The oscillator (``alpha``, ``beta``, ``delta``, ``eta``).
    harmonics : int
        ``H``.
    time_samples : int
        FFT samples per period (0: automatic, ``hbm.time_samples``).
    continuation : ANMSettings
        ANM settings (``points_per_step`` included).
    stability : StabilitySettings
        Floquet analysis of the stored points (every branch dataset holds it).
    max_truncation : float
        Truncation indicator beyond which the guard refuses an orbit (:class:`~nnmstop.hbm.stages.TruncationGuard`).
    branch : BranchSpec
        Mode, start amplitude and stages; the run ends at the criterion of the first stage.
    """

    params: ModelParameters
    harmonics: int
    time_samples: int
    continuation: ANMSettings
    stability: StabilitySettings
    max_truncation: float
    branch: BranchSpec

    def __post_init__(self):
        if not isinstance(self.harmonics, (int, np.integer)) or isinstance(self.harmonics, bool) or self.harmonics < 1:
            raise ValueError(f"harmonics must be an integer >= 1, got {self.harmonics!r}")
        if not 0.0 < self.max_truncation < 1.0:
            raise ValueError(f"max_truncation must lie in (0, 1), got {self.max_truncation!r}")
        if not self.branch.stages:
            raise ValueError(f"branch {self.branch.name!r} has no stage")

    def system(self) -> HarmonicBalanceSystem:
        """The HBM system of this run."""
        structure = two_dof_structure(self.params)
        return HarmonicBalanceSystem(structure, int(self.harmonics), time_samples=int(self.time_samples))

    def branch_settings(self) -> BranchSettings:
        """The settings of :mod:`nnmstop.hbm.stages` (dataset assembly, stability)."""
        return BranchSettings(self.continuation, self.max_truncation, self.stability)

    def attrs(self) -> dict:
        """The settings as NetCDF global attributes (a study dataset records what it was computed with)."""
        c = self.continuation
        return {
            **{k: float(v) for k, v in self.params.as_attrs().items()},
            "harmonics": int(self.harmonics),
            "time_samples": int(self.time_samples),
            "order": int(c.order),
            "tolerance": float(c.tolerance),
            "newton_threshold": float(c.newton_threshold),
            "points_per_step": int(c.points_per_step),
            "max_truncation": float(self.max_truncation),
        }


def _positive(values, key: str, kind=float) -> tuple:
    values = tuple(kind(v) for v in values)
    if not values or any(v <= 0 for v in values):
        raise ValueError(f"{key} must be a non-empty list of positive numbers, got {list(values)!r}")
    return values


@dataclass(frozen=True)
class ErrorRuntimeSweep:
    """Error against run time (section ``study.error_runtime``); see ``docs/methods/study.md``.

    ``harmonics`` x ``eta`` are the sweep cases (at the configuration's ANM order and
    tolerance), ``anm_orders`` x ``anm_tolerances`` the ANM cases (at ``anm_harmonics`` and
    ``model.eta``); each ``eta`` has a reference with ``reference_harmonics`` seeded by a
    continuation at ``reference_seed_harmonics``.
    """

    harmonics: tuple[int, ...]
    eta: tuple[float, ...]
    reference_harmonics: int
    reference_seed_harmonics: int
    anm_harmonics: int
    anm_orders: tuple[int, ...]
    anm_tolerances: tuple[float, ...]

    def __post_init__(self):
        largest = max((*self.harmonics, self.anm_harmonics, self.reference_seed_harmonics))
        if self.reference_harmonics <= largest:
            raise ValueError(
                f"study.error_runtime.reference_harmonics = {self.reference_harmonics!r} must exceed every swept "
                f"number of harmonics (largest {largest})"
            )

    @classmethod
    def from_config(cls, section: dict) -> ErrorRuntimeSweep:
        key = "study.error_runtime."
        return cls(
            _positive(section["harmonics"], key + "harmonics", int),
            _positive(section["eta"], key + "eta"),
            int(section["reference_harmonics"]),
            int(section["reference_seed_harmonics"]),
            int(section["anm_harmonics"]),
            _positive(section["anm_orders"], key + "anm_orders", int),
            _positive(section["anm_tolerances"], key + "anm_tolerances"),
        )


@dataclass(frozen=True)
class StiffSweep:
    """Stiff and extreme cases (section ``study.stiff``); see ``docs/methods/study.md``.

    ``alpha`` x ``eta`` (at ``model.beta``, ``model.delta``) and ``ratios`` x ``ratios``
    (``beta`` x ``delta`` at ``model.alpha``, ``model.eta``): a ladder of ``harmonics`` with
    ``max_steps`` ANM steps per attempt, compared at ``compare_count`` energies; the energy
    sweep: ``energies`` x ``energy_alpha`` at ``energy_eta`` with ``energy_harmonics``.
    """

    harmonics: tuple[int, ...]
    max_steps: int
    energy_limit_factor: float
    compare_count: int
    alpha: tuple[float, ...]
    eta: tuple[float, ...]
    ratios: tuple[float, ...]
    energies: tuple[float, ...]
    energy_alpha: tuple[float, ...]
    energy_eta: float
    energy_harmonics: int

    def __post_init__(self):
        if self.compare_count < 1:
            raise ValueError(f"study.stiff.compare_count must be >= 1, got {self.compare_count!r}")
        if not self.energy_limit_factor > 1.0:
            raise ValueError(f"study.stiff.energy_limit_factor must exceed 1, got {self.energy_limit_factor!r}")
        if list(self.harmonics) != sorted(self.harmonics):
            raise ValueError(f"study.stiff.harmonics must be increasing (a ladder), got {list(self.harmonics)!r}")

    @classmethod
    def from_config(cls, section: dict) -> StiffSweep:
        key = "study.stiff."
        return cls(
            _positive(section["harmonics"], key + "harmonics", int),
            int(section["max_steps"]),
            float(section["energy_limit_factor"]),
            int(section["compare_count"]),
            _positive(section["alpha"], key + "alpha"),
            _positive(section["eta"], key + "eta"),
            _positive(section["ratios"], key + "ratios"),
            _positive(section["energies"], key + "energies"),
            _positive(section["energy_alpha"], key + "energy_alpha"),
            float(section["energy_eta"]),
            int(section["energy_harmonics"]),
        )


@dataclass(frozen=True)
class StudySettings:
    """Everything the study computes with (``docs/methods/study.md``).

    Attributes
    ----------
    run : StageOneRun
        NNM1 stage 1 of the configuration (``model``, ``anm``, ``stability``, ``branches.nnm1``)
        at the study's truncation limit and point density, with ``H = error_runtime.anm_harmonics``
        (or ``stiff.energy_harmonics`` without an ``error_runtime`` section): every job replaces
        ``H`` by its own, so the FFT samples are always the automatic, alias-free number (the
        smallest power of two above ``3H``), whatever ``hbm.time_samples`` says.
    exact : FamilySettings
        The exact two-impact family (section ``exact``).
    energies : tuple of float
        Matched energies of the error sweep (increasing).
    end_margin : float
        Relative margin from the ends of the common energy range.
    phase_samples : int
        Phases per period for the orbit differences.
    error_runtime : ErrorRuntimeSweep or None
        None when the task was not given ``study.error_runtime`` (the stiff jobs).
    stiff : StiffSweep or None
        None when the task was not given ``study.stiff`` (the error-sweep jobs).
    """

    run: StageOneRun
    exact: FamilySettings
    energies: tuple[float, ...]
    end_margin: float
    phase_samples: int
    error_runtime: ErrorRuntimeSweep | None = None
    stiff: StiffSweep | None = None

    def __post_init__(self):
        energies = np.asarray(self.energies, dtype=float)
        if energies.size < 1 or np.any(energies <= 0) or np.any(np.diff(energies) <= 0):
            raise ValueError(f"study.energies must be positive and strictly increasing, got {list(self.energies)!r}")
        if not 0.0 <= self.end_margin < 0.5:
            raise ValueError(f"study.end_margin must lie in [0, 0.5), got {self.end_margin!r}")
        if self.phase_samples < 64:
            raise ValueError(f"study.phase_samples must be >= 64, got {self.phase_samples!r}")

    def sweep(self) -> ErrorRuntimeSweep:
        """The error sweep; ``ValueError`` if the task was not given ``study.error_runtime``."""
        if self.error_runtime is None:
            raise ValueError("this task was not given the section study.error_runtime")
        return self.error_runtime

    def stiff_sweep(self) -> StiffSweep:
        """The stiff cases; ``ValueError`` if the task was not given ``study.stiff``."""
        if self.stiff is None:
            raise ValueError("this task was not given the section study.stiff")
        return self.stiff


#: Keys of the ``study`` section that the study's numerics read (``png_dpi`` is the figures').
STUDY_KEYS = ("energies", "end_margin", "phase_samples", "max_truncation", "points_per_step", "error_runtime", "stiff")


def study_settings(config: dict) -> StudySettings:
    """The study's settings from the sections ``model``, ``anm``, ``stability``, ``branches``
    (``nnm1``), ``exact`` and ``study``.

    Raises
    ------
    ValueError
        For a missing section or an inconsistent value, naming its configuration key.
    """
    study = _section(config, "study")
    error_runtime = ErrorRuntimeSweep.from_config(study["error_runtime"]) if "error_runtime" in study else None
    stiff = StiffSweep.from_config(study["stiff"]) if "stiff" in study else None
    if error_runtime is None and stiff is None:
        raise ValueError("config lacks both study.error_runtime and study.stiff")
    harmonics = error_runtime.anm_harmonics if error_runtime is not None else stiff.energy_harmonics
    run = StageOneRun(
        params=model_parameters(config),
        harmonics=harmonics,
        time_samples=0,
        continuation=anm_settings(config, study["points_per_step"]),
        stability=stability_settings(config),
        max_truncation=float(study["max_truncation"]),
        branch=branch_spec(config, "nnm1"),
    )
    return StudySettings(
        run=run,
        exact=exact_settings(config),
        energies=tuple(float(e) for e in study["energies"]),
        end_margin=float(study["end_margin"]),
        phase_samples=int(study["phase_samples"]),
        error_runtime=error_runtime,
        stiff=stiff,
    )
