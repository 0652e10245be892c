"""Dataset kinds of the study (see :mod:`nnmstop.catalogue`; method notes ``docs/methods/study.md``).

Every value the study did not compute is missing (NaN, written as the fill value) exactly where a
status flag (:class:`nnmstop.study.status.Status`) or a failure text says why; the variables that
hold a missing value name them (``reason``). The gathered datasets repeat the variables of their
cases over the grid of settings (:func:`over`).
"""

from nnmstop.catalogue import DatasetKind, Variable
from nnmstop.catalogue.exact import TWO_IMPACT_FAMILY
from nnmstop.study.status import Status

#: The meanings of the study's status flags, in the order of their values.
STATUS_FLAGS = tuple(s.name.lower() for s in Status)


def status(name: str, long_name: str, dims=()) -> Variable:
    """A status flag variable of the study."""
    return Variable(name, dims, long_name, flags=STATUS_FLAGS)


def missing(name: str, long_name: str, reason: str, units: str = "1", dims=()) -> Variable:
    """A float the study may not have computed, with the variables that say why (``reason``)."""
    text = f"where `{reason.split()[0]}` is not 0 (`computed`)"
    return Variable(name, dims, long_name, units=units, missing=text, reason=reason)


def over(variables, dims: tuple, prefix: str = "", label: str = "") -> tuple:
    """``variables`` repeated over the grid ``dims`` (leading), named ``prefix + name`` (their reasons too)."""
    out = []
    for v in variables:
        reason = " ".join(prefix + r for r in v.reason.split())
        text = v.missing.replace("`", "`" + prefix, 1) if v.missing and prefix else v.missing
        out.append(
            Variable(
                prefix + v.name, tuple(dims) + v.dims, label + v.long_name, v.units, v.flags, v.optional, text, reason
            )
        )
    return tuple(out)


# --------------------------------------------------------------------------- one run of NNM1 stage 1

#: What every setting of the error sweep stores about its run (a case: scalars; the gather: over its grid).
RUN_VARIABLES = (
    status("status", "why the setting was not compared at every study energy (0: it was)"),
    Variable("converged", (), "the continuation reached the end of NNM1 stage 1 with every orbit resolved"),
    Variable("compared", (), "converged and matched with the exact orbits at every study energy"),
    Variable("failure", (), "why the setting did not converge or was not compared ('' if it was)"),
    Variable("runtime", (), "wall-clock time of the continuation of NNM1 stage 1 (start point included)", units="s"),
    Variable("cpu_time", (), "CPU time of the continuation of NNM1 stage 1 (all threads)", units="s"),
    Variable(
        "load_average", (), "1-minute load average of the machine when the job started (run times are measurements)"
    ),
    Variable(
        "truncation", (), "largest truncation indicator along the run (top share of x'' or f, at least two harmonics)"
    ),
    missing(
        "time_residual",
        "largest residual in time of Eq. (7) along the branch, relative to the largest restoring force",
        "status failure",
    ),
    missing(
        "path_residual",
        "largest relative algebraic residual over the branch points, interior points of the ANM steps included (accuracy of the path itself)",
        "status failure",
    ),
    missing(
        "path_frequency_error",
        "relative frequency shift of the worst branch point (largest residual) from the HBM solution at the same amplitude (accuracy of the drawn curve)",
        "status failure",
    ),
    Variable("steps", (), "ANM steps (-1: unknown, the run ended early)", reason="status failure"),
    Variable(
        "factorizations",
        (),
        "LU factorizations of the bordered Jacobian (-1: unknown, the run ended early)",
        reason="status failure",
    ),
    Variable(
        "newton_iterations",
        (),
        "Newton corrections of ANM step ends (-1: unknown, the run ended early)",
        reason="status failure",
    ),
)

#: Orbit differences at one energy (:func:`nnmstop.study.runs.match_energies`), with their units.
PER_ENERGY = (
    ("relative_frequency_difference", "relative frequency difference (regularized minus exact) / exact"),
    ("max_x_difference", "largest |x_regularized - x_exact| over the period"),
    ("max_u_difference", "largest |u_regularized - u_exact| over the period"),
    (
        "max_force_difference",
        "largest |f_HBM - f_piecewise(x_exact)| over the period (regularized contact force series vs the piecewise-linear law on the exact orbit)",
    ),
    ("force_max_exact", "largest contact force over the exact orbit"),
)

ENERGY = Variable("energy", ("energy",), "matched total energy (two-impact range of NNM1)")
UNKNOWN = Variable("unknown", ("unknown",), "index into the HBM unknown vector")

STUDY_CASE = DatasetKind(
    "study_case",
    "One case of the error-against-run-time study",
    ("study/cases/H*_eta*.nc", "study/cases/anm_N*_tol*.nc"),
    "NNM1 stage 1 continued with one setting (H and eta, or ANM order and tolerance): run time, cost counters, accuracy indicators, and the orbits matched with the exact family at the study energies (`docs/methods/study.md`).",
    RUN_VARIABLES
    + (
        status("energy_status", "why the setting was not compared at this energy (0: it was)", ("energy",)),
        missing(
            "exact_seconds_per_orbit",
            "mean time to solve one exact orbit at a prescribed energy (Newton on the closed form, validity checks)",
            "status failure",
            "s",
        ),
        missing(
            "regularized_seconds_per_orbit",
            "mean time to solve one HBM orbit at a prescribed energy (Newton from the branch)",
            "status failure",
            "s",
        ),
        missing(
            "orbit",
            "HBM unknown vector of the matched regularized orbit (layout of nnmstop.hbm.system, cosine basis)",
            "energy_status failure",
            dims=("energy", "unknown"),
        ),
    )
    + tuple(missing(name, text, "energy_status failure", dims=("energy",)) for name, text in PER_ENERGY)
    + (ENERGY, UNKNOWN),
)

STUDY_REFERENCE = DatasetKind(
    "study_reference",
    "Reference orbits of the study (H_ref harmonics)",
    ("study/cases/reference_eta*.nc",),
    "Regularized NNM1 orbits at the study energies with H_ref harmonics, the reference for the truncation part of the error (`docs/methods/study.md`).",
    (
        status("status", "why the reference is incomplete (0: every orbit found and resolved)"),
        status("energy_status", "why there is no reference orbit at this energy (0: there is)", ("energy",)),
        Variable("converged", (), "every reference orbit was found and is resolved"),
        Variable("failure", (), "why the reference is incomplete ('' if it is complete)"),
        Variable("runtime", (), "wall-clock time of the reference (seed continuation and Newton at H_ref)", units="s"),
        Variable("load_average", (), "1-minute load average of the machine when the job started"),
        missing(
            "truncation", "truncation indicator of each reference orbit", "energy_status failure", dims=("energy",)
        ),
        missing(
            "orbit",
            "HBM unknown vector of the reference orbit (H_ref harmonics, cosine basis)",
            "energy_status failure",
            dims=("energy", "unknown"),
        ),
    )
    + tuple(
        missing(name, "reference orbit vs exact: " + text, "energy_status failure", dims=("energy",))
        for name, text in PER_ENERGY
    )
    + (ENERGY, UNKNOWN),
)

EXACT_COST = DatasetKind(
    "exact_cost",
    "Cost of the exact solver",
    ("study/cases/exact_cost.nc",),
    "Time per orbit of the exact family continuation and of one exact time history (measurements).",
    (
        Variable(
            "family_seconds_per_orbit",
            (),
            "time per orbit of the pseudo-arclength continuation of the exact family (closed form, validity checks, end location)",
            units="s",
        ),
        Variable("family_orbits", (), "orbits of the exact family"),
        Variable("family_seconds", (), "time to follow the whole exact family (fastest of the repeats)", units="s"),
        Variable(
            "time_history_seconds",
            (),
            "time to evaluate one exact orbit on study.phase_samples phases (closed form)",
            units="s",
        ),
        Variable("max_residual", (), "largest residual of the quarter-period equations along the family"),
        Variable("load_average", (), "1-minute load average of the machine when the job started"),
    ),
)

# --------------------------------------------------------------------------- the gathered error sweep

_HZ, _HE = ("harmonics", "eta"), ("harmonics", "eta", "energy")
_SPLIT_NAMES = {
    "relative_frequency_difference": "frequency",
    "max_x_difference": "x",
    "max_u_difference": "u",
    "max_force_difference": "force",
}
_PARTS = dict(PER_ENERGY)

ERROR_VS_RUNTIME = DatasetKind(
    "error_vs_runtime",
    "Error against run time of the regularized NNM1",
    ("study/error_vs_runtime.nc",),
    "The error sweep gathered: per setting (harmonics, eta) its run and its errors against the exact orbits, split into a regularization part (H_ref against exact, per eta) and a truncation part (H against H_ref); the ANM order and tolerance sweep (order, tolerance); the exact solver's cost. Run times are measurements (`docs/methods/study.md`).",
    over(RUN_VARIABLES, _HZ)
    + over(RUN_VARIABLES, ("order", "tolerance"), "anm_", "ANM sweep: ")
    + (
        status("energy_status", "why the setting was not compared at this energy (0: it was)", _HE),
        missing(
            "regularized_seconds_per_orbit",
            "mean time to solve one HBM orbit at a prescribed energy",
            "status failure",
            "s",
            _HZ,
        ),
        missing(
            "frequency_error",
            "largest |relative frequency error| against the exact orbits over the study energies",
            "status failure",
            dims=_HZ,
        ),
        missing(
            "x_error",
            "largest |x_regularized - x_exact| over the period and the study energies",
            "status failure",
            dims=_HZ,
        ),
        missing(
            "u_error",
            "largest |u_regularized - u_exact| over the period and the study energies",
            "status failure",
            dims=_HZ,
        ),
        missing(
            "force_error",
            "largest |f_HBM - f_piecewise(x_exact)| over the period and the study energies",
            "status failure",
            dims=_HZ,
        ),
        missing(
            "relative_force_error",
            "largest contact-force error relative to the largest exact contact force, over the study energies",
            "status failure",
            dims=_HZ,
        ),
        status(
            "reference_status", "why the H_ref reference of this eta is incomplete (0: complete and resolved)", ("eta",)
        ),
        status(
            "reference_energy_status",
            "why there is no H_ref reference orbit at this energy (0: there is)",
            ("eta", "energy"),
        ),
        Variable("reference_converged", ("eta",), "the H_ref reference of this eta is complete and resolved"),
        Variable("reference_failure", ("eta",), "why the reference is incomplete ('' if complete)"),
        Variable("reference_runtime", ("eta",), "wall-clock time of the reference of this eta", units="s"),
        missing(
            "reference_truncation",
            "largest truncation indicator of the reference orbits",
            "reference_status reference_failure",
            dims=("eta",),
        ),
        Variable(
            "reference_ratio",
            ("harmonics",),
            "H_ref / H: how much larger the reference is (the truncation part is underestimated when small)",
        ),
        status(
            "split_status",
            "why the truncation part of this setting is not summarized: the setting's status, else its reference's (0: both complete)",
            _HZ,
        ),
        missing(
            "anm_frequency_error",
            "ANM sweep: largest |relative frequency error| against the exact orbits (Newton-corrected matched orbits)",
            "anm_status anm_failure",
            dims=("order", "tolerance"),
        ),
        missing(
            "anm_x_error",
            "ANM sweep: largest x error against the exact orbits (Newton-corrected matched orbits)",
            "anm_status anm_failure",
            dims=("order", "tolerance"),
        ),
        Variable(
            "exact_seconds_per_orbit",
            (),
            "exact solver: median time to solve one orbit at a prescribed energy (Newton on the closed form, validity checks)",
            units="s",
        ),
        Variable(
            "exact_family_seconds_per_orbit", (), "exact solver: time per orbit of the family continuation", units="s"
        ),
        Variable(
            "exact_time_history_seconds",
            (),
            "exact solver: time to evaluate one exact orbit on study.phase_samples phases (closed form)",
            units="s",
        ),
        Variable(
            "exact_max_residual", (), "exact solver: largest residual of the quarter-period equations along the family"
        ),
    )
    + tuple(missing(f"{key}_at_energy", text, "energy_status", dims=_HE) for key, text in PER_ENERGY)
    + tuple(
        missing(
            f"{short}_error_regularization",
            f"regularization part of the {short} error: largest |H_ref orbit - exact orbit| over the study energies",
            "reference_status reference_failure",
            dims=("eta",),
        )
        for short in _SPLIT_NAMES.values()
    )
    + tuple(
        missing(
            f"{short}_error_truncation",
            f"truncation part of the {short} error: largest |H orbit - H_ref orbit| (same eta) over the study energies",
            "split_status",
            dims=_HZ,
        )
        for short in _SPLIT_NAMES.values()
    )
    + tuple(
        missing(
            f"{key}_regularization_at_energy",
            "regularization part (H_ref vs exact): " + _PARTS[key],
            "reference_energy_status",
            dims=("eta", "energy"),
        )
        for key in _SPLIT_NAMES
    )
    + tuple(
        missing(
            f"{key}_truncation_at_energy",
            "truncation part (H vs H_ref, same eta): "
            + _PARTS[key].replace("regularized", "H").replace("exact", "H_ref"),
            "energy_status reference_energy_status",
            dims=_HE,
        )
        for key in _SPLIT_NAMES
    )
    + (
        Variable("harmonics", ("harmonics",), "number of harmonics H"),
        Variable("eta", ("eta",), "regularization parameter eta"),
        ENERGY,
        Variable("order", ("order",), "ANM series order N (ANM sweep)"),
        Variable("tolerance", ("tolerance",), "ANM step-length tolerance (ANM sweep)"),
    ),
)

# --------------------------------------------------------------------------- stiff cases

STIFF_EXACT = TWO_IMPACT_FAMILY.extended(
    "stiff_exact",
    "Stiff case: the exact family",
    ("study/stiff/exact_a*_b*_d*.nc",),
    "The exact two-impact family for one (alpha, beta, delta) of the stiff-case study, with checks of its exactness (residual, periodicity by event-located integration) and of its end.",
    Variable(
        "check_relative_residual",
        (),
        "largest residual of the quarter-period equations, relative to max velocity * sqrt(1 + beta + alpha)",
    ),
    Variable(
        "check_periodicity_error",
        (),
        "middle orbit integrated over one period with event location: max |z(T) - z(0)| / max |z|",
    ),
    Variable(
        "check_integration_difference",
        (),
        "middle orbit: largest difference between integration and closed form / max |z|",
    ),
    Variable("check_integration_seconds", (), "time of that integration", units="s"),
    Variable("check_seconds_per_orbit", (), "time per orbit of the family continuation", units="s"),
    Variable("check_step", (), "continuation step used"),
    Variable("check_end_confirmed", (), "the end of the family was met again with a step 100 times smaller"),
    Variable("check_end_note", (), "how the end of the family was confirmed"),
)

STIFF_NNM1_VARIABLES = (
    status("status", "why the case was not compared with the exact family at every chosen energy (0: it was)"),
    Variable("converged", (), "NNM1 stage 1 converged with every orbit resolved, for one of the harmonics tried"),
    Variable("compared", (), "converged and compared with the exact family at every chosen energy"),
    Variable("failure", (), "why the case did not converge or was not compared ('' if it was)"),
    Variable("attempts", (), "every number of harmonics tried, with its outcome"),
    Variable(
        "harmonics",
        (),
        "smallest number of harmonics tried that resolves the branch (-1: none)",
        reason="status failure",
    ),
    Variable("steps", (), "ANM steps of the resolving run (-1: none)", reason="status failure"),
    Variable("factorizations", (), "LU factorizations of the resolving run (-1: none)", reason="status failure"),
    missing("runtime", "wall-clock time of the resolving run", "status failure", "s"),
    Variable("total_runtime", (), "wall-clock time of every attempt together", units="s"),
    Variable("truncation", (), "largest truncation indicator of the last attempt (up to its end)"),
    missing(
        "frequency_error",
        "largest |relative frequency error| against the exact orbits at the compared energies",
        "status failure",
    ),
    missing("x_error", "largest |x_regularized - x_exact| over the period and the compared energies", "status failure"),
    missing("u_error", "largest |u_regularized - u_exact| over the period and the compared energies", "status failure"),
    missing(
        "force_error", "largest contact-force difference over the period and the compared energies", "status failure"
    ),
    missing(
        "relative_force_error", "largest contact-force difference relative to the largest exact force", "status failure"
    ),
    missing(
        "compared_energy_min",
        "lowest compared energy (log-fraction 1/(n+1) of the exact increasing arm)",
        "status failure",
    ),
    missing(
        "compared_energy_max",
        "highest compared energy (log-fraction n/(n+1) of the exact increasing arm)",
        "status failure",
    ),
)
STIFF_NNM1 = DatasetKind(
    "stiff_nnm1",
    "Stiff case: harmonics needed and error of NNM1 stage 1",
    ("study/stiff/nnm1_a*_b*_d*_e*.nc",),
    "The harmonics ladder of one (alpha, beta, delta, eta): the smallest H that resolves NNM1 stage 1 (or why none does) and its errors against the exact family.",
    STIFF_NNM1_VARIABLES,
)

STIFF_ENERGY_VARIABLES = (
    Variable("kind", ("energy",), "exact orbit used: linear, family, high_energy or none (no two-impact orbit)"),
    status("exact_status", "why there is no exact orbit at this energy (0: there is)", ("energy",)),
    Variable("exact_note", ("energy",), "how the exact orbit was found, or why there is none"),
    missing("exact_energy", "energy of the exact orbit", "exact_status", dims=("energy",)),
    missing("exact_frequency", "frequency of the exact orbit", "exact_status", "Hz", ("energy",)),
    missing(
        "exact_residual", "norm of the quarter-period equations of the exact orbit", "exact_status", dims=("energy",)
    ),
    missing(
        "periodicity_error",
        "event-located integration over one period: max |z(T) - z(0)| / max |z|",
        "exact_status",
        dims=("energy",),
    ),
    missing(
        "integration_difference",
        "largest difference between integration and closed form / max |z|",
        "exact_status",
        dims=("energy",),
    ),
    status("hbm_status", "why there is no resolved HBM orbit at this energy (0: there is)", ("energy",)),
    Variable("hbm_converged", ("energy",), "an HBM orbit of the regularized model was found there and is resolved"),
    Variable("hbm_failure", ("energy",), "why there is no resolved HBM orbit ('' if there is)"),
    missing(
        "hbm_frequency_difference",
        "(HBM frequency - exact frequency) / exact frequency",
        "hbm_status hbm_failure",
        dims=("energy",),
    ),
    missing(
        "hbm_energy_mismatch",
        "(HBM energy - exact energy) / exact energy (the HBM orbit keeps the x amplitude)",
        "hbm_status hbm_failure",
        dims=("energy",),
    ),
    missing("hbm_truncation", "truncation indicator of the HBM orbit", "exact_status", dims=("energy",)),
)
STIFF_ENERGY = DatasetKind(
    "stiff_energy",
    "Stiff case: exact solver and HBM at extreme energies",
    ("study/stiff/energy_a*.nc",),
    "The exact solver (with its periodicity by event-located integration) and an HBM orbit at energies from 1e-6 to 1e6 for one alpha, or why there is none.",
    STIFF_ENERGY_VARIABLES + (Variable("energy", ("energy",), "requested total energy"),),
)

EXACT_SUMMARY_VARIABLES = (
    Variable(
        "exact_relative_residual",
        (),
        "exact solver: largest residual of the quarter-period equations, relative to max velocity * sqrt(1 + beta + alpha)",
    ),
    Variable(
        "exact_periodicity_error",
        (),
        "exact solver: middle orbit integrated over one period with event location: max |z(T) - z(0)| / max |z|",
    ),
    Variable(
        "exact_integration_difference",
        (),
        "exact solver: middle orbit: largest difference between integration and closed form / max |z|",
    ),
    Variable("exact_seconds_per_orbit", (), "exact solver: time per orbit of the family continuation", units="s"),
    Variable("exact_step", (), "exact solver: continuation step used"),
    Variable("exact_max_residual", (), "exact solver: largest residual norm of the quarter-period equations"),
    Variable("exact_orbits", (), "exact solver: orbits of the two-impact family"),
    Variable("exact_energy_min", (), "exact solver: lowest energy of the two-impact family"),
    Variable("exact_energy_max", (), "exact solver: highest energy of the two-impact family"),
    Variable("exact_end_reason", (), "exact solver: why the two-impact family ends"),
    Variable(
        "exact_end_confirmed",
        (),
        "exact solver: the family end was met again with a step 100 times smaller (else recomputed with a 10 times smaller step)",
    ),
    Variable("exact_end_note", (), "exact solver: how the family end was checked"),
)
STIFF_CASES = DatasetKind(
    "stiff_cases",
    "Stiff and extreme cases",
    ("study/stiff_cases.nc",),
    "The stiff-case study gathered: the cases of the alpha x eta grid, those of the beta x delta grid (`ratio_`), the exact family of each (`exact_*`, `ratio_exact_*`) and the extreme-energy sweep (`energy_*`, energy_alpha x energy) (`docs/methods/study.md`).",
    over(STIFF_NNM1_VARIABLES, ("alpha", "eta"))
    + over(STIFF_NNM1_VARIABLES, ("beta", "delta"), "ratio_", "beta x delta grid: ")
    + over(EXACT_SUMMARY_VARIABLES, ("alpha",))
    + over(EXACT_SUMMARY_VARIABLES, ("beta", "delta"), "ratio_", "beta x delta grid: ")
    + over(STIFF_ENERGY_VARIABLES, ("energy_alpha",), "energy_", "energy sweep: ")
    + (
        Variable("alpha", ("alpha",), "stop stiffness ratio alpha = K/k1"),
        Variable("eta", ("eta",), "regularization parameter eta"),
        Variable("beta", ("beta",), "coupling stiffness ratio beta = k2/k1 (beta x delta grid)"),
        Variable("delta", ("delta",), "mass ratio delta = m2/m1 (beta x delta grid)"),
        Variable("energy", ("energy",), "requested total energy (energy sweep)"),
        Variable("energy_alpha", ("energy_alpha",), "alpha of the energy sweep"),
    ),
)

KINDS = (
    STUDY_CASE,
    EXACT_COST,
    STUDY_REFERENCE,
    ERROR_VS_RUNTIME,
    STIFF_ENERGY,
    STIFF_EXACT,
    STIFF_NNM1,
    STIFF_CASES,
)
