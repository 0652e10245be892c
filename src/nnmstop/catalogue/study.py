"""Dataset kinds of the study datasets (see :mod:`nnmstop.catalogue`)."""

from nnmstop.catalogue import DatasetKind, Variable

MISSING = "where the case failed or was not compared (the variable `failure` says why)"

STUDY_CASE_VARIABLES = (
    Variable("converged", (), "the continuation reached the end of stage 1 with every orbit resolved"),
    Variable("compared", (), "converged and matched with the exact orbits at every study energy"),
    Variable("failure", (), "why the setting did not converge or was not compared ('' if it was)"),
    Variable(
        "runtime",
        (),
        "wall-clock time of the continuation of NNM1 stage 1 (start point included)",
        units="s",
        missing=MISSING,
    ),
    Variable("cpu_time", (), "CPU time of the continuation of NNM1 stage 1 (all threads)", units="s", missing=MISSING),
    Variable("load_average", (), "1-minute load average of the machine when the job started", missing=MISSING),
    Variable("steps", (), "ANM steps (-1: unknown, the run failed)"),
    Variable("factorizations", (), "LU factorizations of the bordered Jacobian (-1: unknown, the run failed)"),
    Variable("newton_iterations", (), "Newton corrections of step ends (-1: unknown)"),
    Variable(
        "truncation",
        (),
        "largest truncation indicator met along the run (top share of x'' or f, at least two harmonics)",
        missing=MISSING,
    ),
    Variable(
        "time_residual",
        (),
        "largest residual in time of Eq. (7) along the branch, relative to the largest restoring force",
        missing=MISSING,
    ),
    Variable(
        "path_residual",
        (),
        "largest relative algebraic residual of the HBM system over the branch points (interior points of ANM steps included)",
        missing=MISSING,
    ),
    Variable(
        "path_frequency_error",
        (),
        "relative frequency shift of the worst branch point (largest residual) from the HBM solution at the same amplitude",
        missing=MISSING,
    ),
    Variable(
        "exact_seconds_per_orbit",
        (),
        "mean time to solve one exact orbit at a prescribed energy (Newton on the closed form, validity checks)",
        units="s",
        missing=MISSING,
    ),
    Variable(
        "regularized_seconds_per_orbit",
        (),
        "mean time to solve one HBM orbit at a prescribed energy (Newton from the branch)",
        units="s",
        missing=MISSING,
    ),
    Variable(
        "orbit",
        ("energy", "unknown"),
        "HBM unknown vector of the matched regularized orbit (layout of nnmstop.hbm.system, cosine basis)",
        missing=MISSING,
    ),
    Variable(
        "relative_frequency_difference",
        ("energy",),
        "relative frequency difference (regularized minus exact) / exact",
        missing=MISSING,
    ),
    Variable("max_x_difference", ("energy",), "largest |x_regularized - x_exact| over the period", missing=MISSING),
    Variable("max_u_difference", ("energy",), "largest |u_regularized - u_exact| over the period", missing=MISSING),
    Variable(
        "max_force_difference",
        ("energy",),
        "largest |f_HBM - f_piecewise(x_exact)| over the period (regularized contact force series vs the piecewise-linear law on the exact orbit)",
        missing=MISSING,
    ),
    Variable("force_max_exact", ("energy",), "largest contact force over the exact orbit", missing=MISSING),
    Variable("energy", ("energy",), "matched total energy"),
    Variable("unknown", ("unknown",), "index into the HBM unknown vector"),
)
STUDY_CASE = DatasetKind(
    "study_case",
    "One case of the error-against-run-time study",
    ("study/cases/H*_eta*nc", "study/cases/anm_N*_tol*nc"),
    "NNM1 stage 1 continued with one setting (H and eta, or ANM order and tolerance): run time, cost counters, accuracy indicators, and the orbits matched with the exact family at the study energies (`docs/methods/study.md`).",
    STUDY_CASE_VARIABLES,
)


EXACT_COST_VARIABLES = (
    Variable(
        "family_seconds_per_orbit",
        (),
        "time per orbit of the pseudo-arclength continuation of the exact family (closed form, validity checks, end location)",
        units="s",
        missing=MISSING,
    ),
    Variable("family_orbits", (), "orbits of the exact family"),
    Variable(
        "family_seconds",
        (),
        "time to follow the whole exact family (fastest of the repeats)",
        units="s",
        missing=MISSING,
    ),
    Variable(
        "time_history_seconds",
        (),
        "time to evaluate one exact orbit on 2048 phases (closed form)",
        units="s",
        missing=MISSING,
    ),
    Variable("max_residual", (), "largest residual of the quarter-period equations along the family", missing=MISSING),
    Variable("load_average", (), "1-minute load average of the machine when the job started", missing=MISSING),
)
EXACT_COST = DatasetKind(
    "exact_cost",
    "Cost of the exact solver",
    ("study/cases/exact_cost.nc",),
    "Time per orbit of the exact family continuation and of exact and regularized orbits at prescribed energies.",
    EXACT_COST_VARIABLES,
)


STUDY_REFERENCE_VARIABLES = (
    Variable("converged", (), "every reference orbit was found and is resolved"),
    Variable("failure", (), "why the reference is incomplete ('' if it is complete)"),
    Variable(
        "runtime",
        (),
        "wall-clock time of the reference (seed continuation and Newton at H_ref)",
        units="s",
        missing=MISSING,
    ),
    Variable("load_average", (), "1-minute load average of the machine when the job started", missing=MISSING),
    Variable("truncation", ("energy",), "truncation indicator of each reference orbit", missing=MISSING),
    Variable(
        "orbit",
        ("energy", "unknown"),
        "HBM unknown vector of the reference orbit (H_ref harmonics, cosine basis)",
        missing=MISSING,
    ),
    Variable(
        "relative_frequency_difference",
        ("energy",),
        "reference orbit vs exact: relative frequency difference (regularized minus exact) / exact",
        missing=MISSING,
    ),
    Variable(
        "max_x_difference",
        ("energy",),
        "reference orbit vs exact: largest |x_regularized - x_exact| over the period",
        missing=MISSING,
    ),
    Variable(
        "max_u_difference",
        ("energy",),
        "reference orbit vs exact: largest |u_regularized - u_exact| over the period",
        missing=MISSING,
    ),
    Variable(
        "max_force_difference",
        ("energy",),
        "reference orbit vs exact: largest |f_HBM - f_piecewise(x_exact)| over the period (regularized contact force series vs the piecewise-linear law on the exact orbit)",
        missing=MISSING,
    ),
    Variable(
        "force_max_exact",
        ("energy",),
        "reference orbit vs exact: largest contact force over the exact orbit",
        missing=MISSING,
    ),
    Variable("energy", ("energy",), "matched total energy"),
    Variable("unknown", ("unknown",), "index into the HBM unknown vector"),
)
STUDY_REFERENCE = DatasetKind(
    "study_reference",
    "Reference orbits of the study (H_ref harmonics)",
    ("study/cases/reference_eta*nc",),
    "Regularized NNM1 orbits at the study energies with H_ref harmonics, the reference for the truncation part of the error (`docs/methods/study.md`).",
    STUDY_REFERENCE_VARIABLES,
)


ERROR_VS_RUNTIME_VARIABLES = (
    Variable(
        "converged", ("harmonics", "eta"), "the continuation reached the end of NNM1 stage 1 with every orbit resolved"
    ),
    Variable("compared", ("harmonics", "eta"), "converged and matched with the exact orbits at every study energy"),
    Variable("failure", ("harmonics", "eta"), "why the setting did not converge or was not compared ('' if it was)"),
    Variable(
        "runtime",
        ("harmonics", "eta"),
        "wall-clock time of the continuation of NNM1 stage 1",
        units="s",
        missing=MISSING,
    ),
    Variable(
        "cpu_time", ("harmonics", "eta"), "CPU time of the continuation of NNM1 stage 1", units="s", missing=MISSING
    ),
    Variable(
        "load_average",
        ("harmonics", "eta"),
        "1-minute load average when the job started (run times are measurements)",
        missing=MISSING,
    ),
    Variable("steps", ("harmonics", "eta"), "ANM steps (-1: unknown, the run failed)"),
    Variable(
        "factorizations",
        ("harmonics", "eta"),
        "LU factorizations of the bordered Jacobian (-1: unknown, the run failed)",
    ),
    Variable("newton_iterations", ("harmonics", "eta"), "Newton corrections of ANM step ends (-1: unknown)"),
    Variable(
        "truncation",
        ("harmonics", "eta"),
        "largest truncation indicator along the run (top share of x'' or f, at least two harmonics)",
        missing=MISSING,
    ),
    Variable(
        "time_residual",
        ("harmonics", "eta"),
        "largest residual in time of Eq. (7) along the branch, relative to the largest restoring force",
        missing=MISSING,
    ),
    Variable(
        "path_residual",
        ("harmonics", "eta"),
        "largest relative algebraic residual over the branch points (ANM interior points included)",
        missing=MISSING,
    ),
    Variable(
        "path_frequency_error",
        ("harmonics", "eta"),
        "relative frequency shift of the worst branch point from the HBM solution curve",
        missing=MISSING,
    ),
    Variable(
        "regularized_seconds_per_orbit",
        ("harmonics", "eta"),
        "mean time to solve one HBM orbit at a prescribed energy",
        units="s",
        missing=MISSING,
    ),
    Variable(
        "frequency_error",
        ("harmonics", "eta"),
        "largest |relative frequency error| against the exact orbits over the study energies",
        missing=MISSING,
    ),
    Variable(
        "x_error",
        ("harmonics", "eta"),
        "largest |x_regularized - x_exact| over the period and the study energies",
        missing=MISSING,
    ),
    Variable(
        "u_error",
        ("harmonics", "eta"),
        "largest |u_regularized - u_exact| over the period and the study energies",
        missing=MISSING,
    ),
    Variable(
        "force_error",
        ("harmonics", "eta"),
        "largest |f_HBM - f_piecewise(x_exact)| over the period and the study energies",
        missing=MISSING,
    ),
    Variable(
        "relative_force_error",
        ("harmonics", "eta"),
        "largest contact-force error relative to the largest exact contact force, over the study energies",
        missing=MISSING,
    ),
    Variable(
        "frequency_error_truncation",
        ("harmonics", "eta"),
        "truncation part of the frequency error: largest |f_H - f_Href| / f_Href over the study energies (same eta)",
        missing=MISSING,
    ),
    Variable(
        "x_error_truncation",
        ("harmonics", "eta"),
        "truncation part of the x error: largest |x_H - x_Href| over the period and the study energies",
        missing=MISSING,
    ),
    Variable(
        "u_error_truncation",
        ("harmonics", "eta"),
        "truncation part of the u error: largest |u_H - u_Href|",
        missing=MISSING,
    ),
    Variable(
        "force_error_truncation",
        ("harmonics", "eta"),
        "truncation part of the force error: largest |f_H - f_Href|",
        missing=MISSING,
    ),
    Variable(
        "reference_ratio",
        ("harmonics",),
        "H_ref / H: how much larger the reference is (the truncation part is underestimated when small)",
    ),
    Variable(
        "frequency_error_regularization",
        ("eta",),
        "regularization part of the frequency error: largest |relative frequency error| of the H_ref orbits against the exact ones",
        missing=MISSING,
    ),
    Variable(
        "x_error_regularization",
        ("eta",),
        "regularization part of the x error (H_ref orbits against the exact ones)",
        missing=MISSING,
    ),
    Variable(
        "u_error_regularization",
        ("eta",),
        "regularization part of the u error (H_ref orbits against the exact ones)",
        missing=MISSING,
    ),
    Variable(
        "force_error_regularization",
        ("eta",),
        "regularization part of the contact-force error (H_ref orbits against the exact ones)",
        missing=MISSING,
    ),
    Variable("reference_converged", ("eta",), "the H_ref reference of this eta is complete and resolved"),
    Variable("reference_failure", ("eta",), "why the reference is incomplete ('' if complete)"),
    Variable("reference_runtime", ("eta",), "wall-clock time of the reference of this eta", units="s", missing=MISSING),
    Variable("reference_truncation", ("eta",), "largest truncation indicator of the reference orbits", missing=MISSING),
    Variable(
        "anm_converged", ("order", "tolerance"), "ANM sweep: the continuation converged with every orbit resolved"
    ),
    Variable("anm_failure", ("order", "tolerance"), "ANM sweep: why the setting failed ('' if it did not)"),
    Variable(
        "anm_runtime", ("order", "tolerance"), "ANM sweep: wall-clock time of NNM1 stage 1", units="s", missing=MISSING
    ),
    Variable("anm_cpu_time", ("order", "tolerance"), "ANM sweep: CPU time of NNM1 stage 1", units="s", missing=MISSING),
    Variable(
        "anm_load_average",
        ("order", "tolerance"),
        "ANM sweep: 1-minute load average when the job started",
        missing=MISSING,
    ),
    Variable("anm_steps", ("order", "tolerance"), "ANM sweep: steps (-1: unknown)"),
    Variable("anm_factorizations", ("order", "tolerance"), "ANM sweep: LU factorizations (-1: unknown)"),
    Variable(
        "anm_newton_iterations", ("order", "tolerance"), "ANM sweep: Newton corrections of step ends (-1: unknown)"
    ),
    Variable(
        "anm_path_residual",
        ("order", "tolerance"),
        "ANM sweep: largest relative algebraic residual over the branch points, interior points of the steps included (accuracy of the path itself)",
        missing=MISSING,
    ),
    Variable(
        "anm_path_frequency_error",
        ("order", "tolerance"),
        "ANM sweep: relative frequency shift of the worst branch point (largest residual) from the HBM solution at the same amplitude (accuracy of the drawn curve)",
        missing=MISSING,
    ),
    Variable(
        "anm_time_residual",
        ("order", "tolerance"),
        "ANM sweep: largest residual in time of Eq. (7) along the branch",
        missing=MISSING,
    ),
    Variable(
        "anm_frequency_error",
        ("order", "tolerance"),
        "ANM sweep: largest |relative frequency error| against the exact orbits (Newton-corrected matched orbits)",
        missing=MISSING,
    ),
    Variable(
        "anm_x_error",
        ("order", "tolerance"),
        "ANM sweep: largest x error against the exact orbits (Newton-corrected matched orbits)",
        missing=MISSING,
    ),
    Variable(
        "exact_seconds_per_orbit",
        (),
        "exact solver: median time to solve one orbit at a prescribed energy (Newton on the closed form, validity checks)",
        units="s",
        missing=MISSING,
    ),
    Variable(
        "exact_family_seconds_per_orbit",
        (),
        "exact solver: time per orbit of the family continuation",
        units="s",
        missing=MISSING,
    ),
    Variable(
        "exact_time_history_seconds",
        (),
        "time to evaluate one exact orbit on 2048 phases (closed form)",
        units="s",
        missing=MISSING,
    ),
    Variable(
        "exact_max_residual",
        (),
        "exact solver: largest residual of the quarter-period equations along the family",
        missing=MISSING,
    ),
    Variable(
        "relative_frequency_difference_at_energy",
        ("harmonics", "eta", "energy"),
        "relative frequency difference (regularized minus exact) / exact",
        missing=MISSING,
    ),
    Variable(
        "relative_frequency_difference_regularization_at_energy",
        ("eta", "energy"),
        "regularization part (H_ref vs exact): relative frequency difference (regularized minus exact) / exact",
        missing=MISSING,
    ),
    Variable(
        "relative_frequency_difference_truncation_at_energy",
        ("harmonics", "eta", "energy"),
        "truncation part (H vs H_ref, same eta): relative frequency difference (H minus H_ref) / H_ref",
        missing=MISSING,
    ),
    Variable(
        "max_x_difference_at_energy",
        ("harmonics", "eta", "energy"),
        "largest |x_regularized - x_exact| over the period",
        missing=MISSING,
    ),
    Variable(
        "max_x_difference_regularization_at_energy",
        ("eta", "energy"),
        "regularization part (H_ref vs exact): largest |x_regularized - x_exact| over the period",
        missing=MISSING,
    ),
    Variable(
        "max_x_difference_truncation_at_energy",
        ("harmonics", "eta", "energy"),
        "truncation part (H vs H_ref, same eta): largest |x_H - x_H_ref| over the period",
        missing=MISSING,
    ),
    Variable(
        "max_u_difference_at_energy",
        ("harmonics", "eta", "energy"),
        "largest |u_regularized - u_exact| over the period",
        missing=MISSING,
    ),
    Variable(
        "max_u_difference_regularization_at_energy",
        ("eta", "energy"),
        "regularization part (H_ref vs exact): largest |u_regularized - u_exact| over the period",
        missing=MISSING,
    ),
    Variable(
        "max_u_difference_truncation_at_energy",
        ("harmonics", "eta", "energy"),
        "truncation part (H vs H_ref, same eta): largest |u_H - u_H_ref| over the period",
        missing=MISSING,
    ),
    Variable(
        "max_force_difference_at_energy",
        ("harmonics", "eta", "energy"),
        "largest |f_HBM - f_piecewise(x_exact)| over the period (regularized contact force series vs the piecewise-linear law on the exact orbit)",
        missing=MISSING,
    ),
    Variable(
        "max_force_difference_regularization_at_energy",
        ("eta", "energy"),
        "regularization part (H_ref vs exact): largest |f_HBM - f_piecewise(x_exact)| over the period (regularized contact force series vs the piecewise-linear law on the exact orbit)",
        missing=MISSING,
    ),
    Variable(
        "max_force_difference_truncation_at_energy",
        ("harmonics", "eta", "energy"),
        "truncation part (H vs H_ref, same eta): largest |f_HBM - f_piecewise(x_H_ref)| over the period (H contact force series vs the piecewise-linear law on the H_ref orbit)",
        missing=MISSING,
    ),
    Variable(
        "force_max_exact_at_energy",
        ("harmonics", "eta", "energy"),
        "largest contact force over the exact orbit",
        missing=MISSING,
    ),
    Variable("harmonics", ("harmonics",), "number of harmonics H"),
    Variable("eta", ("eta",), "regularization parameter eta"),
    Variable("energy", ("energy",), "matched total energy (two-impact range of NNM1)"),
    Variable("order", ("order",), "ANM series order N (ANM sweep)"),
    Variable("tolerance", ("tolerance",), "ANM step-length tolerance (ANM sweep)"),
)
ERROR_VS_RUNTIME = DatasetKind(
    "error_vs_runtime",
    "Error against run time, gathered",
    ("study/error_vs_runtime.nc",),
    "The study's cases gathered: frequency, orbit and contact-force errors split into their regularization and truncation parts, against run time (`docs/methods/study.md`).",
    ERROR_VS_RUNTIME_VARIABLES,
)


STIFF_ENERGY_VARIABLES = (
    Variable(
        "kind", ("energy",), "exact orbit used: one of linear, family, high_energy, none (none: no two-impact orbit)"
    ),
    Variable("exact_note", ("energy",), "how the exact orbit was found, or why there is none"),
    Variable("exact_energy", ("energy",), "energy of the exact orbit", missing=MISSING),
    Variable("exact_frequency", ("energy",), "frequency of the exact orbit", units="Hz", missing=MISSING),
    Variable("exact_residual", ("energy",), "norm of the quarter-period equations of the exact orbit", missing=MISSING),
    Variable(
        "periodicity_error",
        ("energy",),
        "event-located integration over one period: max |z(T) - z(0)| / max |z|",
        missing=MISSING,
    ),
    Variable(
        "integration_difference",
        ("energy",),
        "largest difference between integration and closed form / max |z|",
        missing=MISSING,
    ),
    Variable("hbm_converged", ("energy",), "an HBM orbit of the regularized model was found there and is resolved"),
    Variable("hbm_failure", ("energy",), "why there is no resolved HBM orbit ('' if there is)"),
    Variable(
        "hbm_frequency_difference", ("energy",), "(HBM frequency - exact frequency) / exact frequency", missing=MISSING
    ),
    Variable(
        "hbm_energy_mismatch",
        ("energy",),
        "(HBM energy - exact energy) / exact energy (the HBM orbit keeps the x amplitude)",
        missing=MISSING,
    ),
    Variable("hbm_truncation", ("energy",), "truncation indicator of the HBM orbit", missing=MISSING),
    Variable("energy", ("energy",), "requested total energy"),
)
STIFF_ENERGY = DatasetKind(
    "stiff_energy",
    "Stiff case: extreme energies",
    ("study/stiff/energy_a*nc",),
    "Exact and regularized orbits at extreme energies for one alpha of the stiff-case study.",
    STIFF_ENERGY_VARIABLES,
)


STIFF_EXACT_VARIABLES = (
    Variable(
        "energy",
        ("point",),
        "total energy of the non-smooth (piecewise-linear) model: kinetic + spring potential + stop potential alpha/2 (|x|-1)^2, conserved along the orbit",
    ),
    Variable(
        "frequency", ("point",), "frequency 1/T of the periodic orbit, in Hz of the nondimensional time", units="Hz"
    ),
    Variable("period", ("point",), "period T = 4 T1"),
    Variable("x_max", ("point",), "maximum of x over the period (x_max - 1 is the penetration into the stop)"),
    Variable("u_at_x_max", ("point",), "u at the time of the maximum of x"),
    Variable(
        "x_turning_point",
        ("point",),
        "x(T1) where both velocities vanish (equals x_max unless x peaks earlier during contact)",
    ),
    Variable("xdot0", ("point",), "velocity of x at x = u = 0 (t = 0)"),
    Variable("udot0", ("point",), "velocity of u at x = u = 0 (t = 0)"),
    Variable("free_flight_time", ("point",), "free-flight duration tau1 of the quarter period"),
    Variable("contact_time", ("point",), "contact duration T1 - tau1 of the quarter period"),
    Variable("residual", ("point",), "Euclidean norm of (x(tau1) - 1, xdot(T1), udot(T1))"),
    Variable(
        "validity_margin",
        ("point",),
        "smallest margin of the assumptions of the two-impact construction (> 0 inside the family, about 0 at its ends)",
    ),
    Variable(
        "multiplier_real",
        ("point",),
        "real part of the non-trivial Floquet multiplier of the exact orbit (monodromy = product of the phase exponentials); the other one is its reciprocal",
    ),
    Variable(
        "multiplier_imag",
        ("point",),
        "imaginary part of the non-trivial Floquet multiplier of the exact orbit (monodromy = product of the phase exponentials) (>= 0 on the unit circle)",
    ),
    Variable("multiplier_modulus", ("point",), "modulus of the largest non-trivial Floquet multiplier (1 if stable)"),
    Variable("trace_invariant", ("point",), "s = lambda + 1/lambda = trace of the monodromy matrix - 2"),
    Variable(
        "stability_margin",
        ("point",),
        "2 - |s|: > 0 elliptic multiplier pair (on the unit circle), < 0 real pair off it",
    ),
    Variable(
        "stability_tolerance",
        ("point",),
        "tolerance on s from its measured round-off; stable means stability_margin >= -stability_tolerance",
    ),
    Variable(
        "trivial_multiplier_distance",
        ("point",),
        "largest distance from +1 of the trivial multiplier pair (time shift and energy, a Jordan block; about sqrt(eps |M|) from round-off)",
    ),
    Variable(
        "stable",
        ("point",),
        "Floquet stability of the exact orbit: non-trivial multipliers on the unit circle",
        flags=("unstable", "stable"),
    ),
    Variable("point", ("point",), "index of the orbit along the family"),
    Variable("arclength", ("point",), "pseudo-arclength in (xdot0, udot0, tau1, T1) from the first orbit"),
    Variable(
        "check_relative_residual",
        (),
        "largest residual of the quarter-period equations, relative to max velocity * sqrt(1 + beta + alpha)",
        missing=MISSING,
    ),
    Variable(
        "check_periodicity_error",
        (),
        "middle orbit integrated over one period with event location: max |z(T) - z(0)| / max |z|",
        missing=MISSING,
    ),
    Variable(
        "check_integration_difference",
        (),
        "middle orbit: largest difference between integration and closed form / max |z|",
        missing=MISSING,
    ),
    Variable("check_integration_seconds", (), "time of that integration", units="s", missing=MISSING),
    Variable("check_seconds_per_orbit", (), "time per orbit of the family continuation", units="s", missing=MISSING),
    Variable("check_step", (), "continuation step used", missing=MISSING),
    Variable("check_end_confirmed", (), "the end of the family was met again with a step 100 times smaller"),
    Variable("check_end_note", (), "how the end of the family was confirmed"),
)
STIFF_EXACT = DatasetKind(
    "stiff_exact",
    "Stiff case: the exact family",
    ("study/stiff/exact_a*_b*_d*nc",),
    "The exact two-impact family for one (alpha, beta, delta) of the stiff-case study, with checks of its exactness (residual, periodicity by event-located integration) and of its end.",
    STIFF_EXACT_VARIABLES,
)


STIFF_NNM1_VARIABLES = (
    Variable("converged", (), "NNM1 stage 1 converged with every orbit resolved, for one of the harmonics tried"),
    Variable("compared", (), "converged and compared with the exact family at every chosen energy"),
    Variable("failure", (), "why the case did not converge or was not compared ('' if it was)"),
    Variable("attempts", (), "every number of harmonics tried, with its outcome"),
    Variable("harmonics", (), "smallest number of harmonics tried that resolves the branch (-1: none)"),
    Variable("steps", (), "ANM steps of the resolving run (-1: none)"),
    Variable("factorizations", (), "LU factorizations of the resolving run (-1: none)"),
    Variable("runtime", (), "wall-clock time of the resolving run", units="s", missing=MISSING),
    Variable("total_runtime", (), "wall-clock time of every attempt together", units="s", missing=MISSING),
    Variable(
        "truncation", (), "largest truncation indicator of the last attempt (up to its end or failure)", missing=MISSING
    ),
    Variable(
        "frequency_error",
        (),
        "largest |relative frequency error| against the exact orbits at the compared energies",
        missing=MISSING,
    ),
    Variable(
        "x_error", (), "largest |x_regularized - x_exact| over the period and the compared energies", missing=MISSING
    ),
    Variable(
        "u_error", (), "largest |u_regularized - u_exact| over the period and the compared energies", missing=MISSING
    ),
    Variable(
        "force_error", (), "largest contact-force difference over the period and the compared energies", missing=MISSING
    ),
    Variable(
        "relative_force_error",
        (),
        "largest contact-force difference relative to the largest exact force",
        missing=MISSING,
    ),
    Variable(
        "compared_energy_min",
        (),
        "lowest compared energy (log-fraction 1/(n+1) of the exact increasing arm)",
        missing=MISSING,
    ),
    Variable(
        "compared_energy_max",
        (),
        "highest compared energy (log-fraction n/(n+1) of the exact increasing arm)",
        missing=MISSING,
    ),
)
STIFF_NNM1 = DatasetKind(
    "stiff_nnm1",
    "Stiff case: regularized NNM1",
    ("study/stiff/nnm*_a*_b*_d*_e*nc",),
    "Regularized NNM1 stage 1 for one (alpha, beta, delta, eta) of the stiff-case study, with the number of harmonics that resolves it and its comparison with the exact family.",
    STIFF_NNM1_VARIABLES,
)


STIFF_CASES_VARIABLES = (
    Variable(
        "converged", ("alpha", "eta"), "NNM1 stage 1 converged with every orbit resolved for one of the harmonics tried"
    ),
    Variable("compared", ("alpha", "eta"), "converged and compared with the exact family at every chosen energy"),
    Variable("failure", ("alpha", "eta"), "why the case did not converge or was not compared ('' if it was)"),
    Variable("attempts", ("alpha", "eta"), "every number of harmonics tried, with its outcome"),
    Variable("harmonics", ("alpha", "eta"), "smallest number of harmonics tried that resolves the branch (-1: none)"),
    Variable("steps", ("alpha", "eta"), "ANM steps of the resolving run (-1: none)"),
    Variable("factorizations", ("alpha", "eta"), "LU factorizations of the resolving run (-1: none)"),
    Variable("runtime", ("alpha", "eta"), "wall-clock time of the resolving run", units="s", missing=MISSING),
    Variable(
        "total_runtime", ("alpha", "eta"), "wall-clock time of every attempt together", units="s", missing=MISSING
    ),
    Variable(
        "truncation",
        ("alpha", "eta"),
        "largest truncation indicator of the last attempt (up to its end or failure)",
        missing=MISSING,
    ),
    Variable(
        "frequency_error",
        ("alpha", "eta"),
        "largest |relative frequency error| against the exact orbits at the compared energies",
        missing=MISSING,
    ),
    Variable(
        "x_error",
        ("alpha", "eta"),
        "largest |x_regularized - x_exact| over the period and the compared energies",
        missing=MISSING,
    ),
    Variable(
        "u_error",
        ("alpha", "eta"),
        "largest |u_regularized - u_exact| over the period and the compared energies",
        missing=MISSING,
    ),
    Variable(
        "force_error",
        ("alpha", "eta"),
        "largest contact-force difference over the period and the compared energies",
        missing=MISSING,
    ),
    Variable(
        "relative_force_error",
        ("alpha", "eta"),
        "largest contact-force difference relative to the largest exact force",
        missing=MISSING,
    ),
    Variable(
        "compared_energy_min",
        ("alpha", "eta"),
        "lowest compared energy (log-fraction 1/(n+1) of the exact increasing arm)",
        missing=MISSING,
    ),
    Variable(
        "compared_energy_max",
        ("alpha", "eta"),
        "highest compared energy (log-fraction n/(n+1) of the exact increasing arm)",
        missing=MISSING,
    ),
    Variable(
        "ratio_converged",
        ("beta", "delta"),
        "NNM1 stage 1 converged with every orbit resolved for one of the harmonics tried",
    ),
    Variable(
        "ratio_compared", ("beta", "delta"), "converged and compared with the exact family at every chosen energy"
    ),
    Variable("ratio_failure", ("beta", "delta"), "why the case did not converge or was not compared ('' if it was)"),
    Variable("ratio_attempts", ("beta", "delta"), "every number of harmonics tried, with its outcome"),
    Variable(
        "ratio_harmonics", ("beta", "delta"), "smallest number of harmonics tried that resolves the branch (-1: none)"
    ),
    Variable("ratio_steps", ("beta", "delta"), "ANM steps of the resolving run (-1: none)"),
    Variable("ratio_factorizations", ("beta", "delta"), "LU factorizations of the resolving run (-1: none)"),
    Variable("ratio_runtime", ("beta", "delta"), "wall-clock time of the resolving run", units="s", missing=MISSING),
    Variable(
        "ratio_total_runtime",
        ("beta", "delta"),
        "wall-clock time of every attempt together",
        units="s",
        missing=MISSING,
    ),
    Variable(
        "ratio_truncation",
        ("beta", "delta"),
        "largest truncation indicator of the last attempt (up to its end or failure)",
        missing=MISSING,
    ),
    Variable(
        "ratio_frequency_error",
        ("beta", "delta"),
        "largest |relative frequency error| against the exact orbits at the compared energies",
        missing=MISSING,
    ),
    Variable(
        "ratio_x_error",
        ("beta", "delta"),
        "largest |x_regularized - x_exact| over the period and the compared energies",
        missing=MISSING,
    ),
    Variable(
        "ratio_u_error",
        ("beta", "delta"),
        "largest |u_regularized - u_exact| over the period and the compared energies",
        missing=MISSING,
    ),
    Variable(
        "ratio_force_error",
        ("beta", "delta"),
        "largest contact-force difference over the period and the compared energies",
        missing=MISSING,
    ),
    Variable(
        "ratio_relative_force_error",
        ("beta", "delta"),
        "largest contact-force difference relative to the largest exact force",
        missing=MISSING,
    ),
    Variable(
        "ratio_compared_energy_min",
        ("beta", "delta"),
        "lowest compared energy (log-fraction 1/(n+1) of the exact increasing arm)",
        missing=MISSING,
    ),
    Variable(
        "ratio_compared_energy_max",
        ("beta", "delta"),
        "highest compared energy (log-fraction n/(n+1) of the exact increasing arm)",
        missing=MISSING,
    ),
    Variable(
        "exact_relative_residual",
        ("alpha",),
        "exact solver: largest residual of the quarter-period equations, relative to max velocity * sqrt(1 + beta + alpha)",
        missing=MISSING,
    ),
    Variable(
        "exact_periodicity_error",
        ("alpha",),
        "exact solver: middle orbit integrated over one period with event location: max |z(T) - z(0)| / max |z|",
        missing=MISSING,
    ),
    Variable(
        "exact_integration_difference",
        ("alpha",),
        "exact solver: middle orbit: largest difference between integration and closed form / max |z|",
        missing=MISSING,
    ),
    Variable(
        "exact_seconds_per_orbit",
        ("alpha",),
        "exact solver: time per orbit of the family continuation",
        units="s",
        missing=MISSING,
    ),
    Variable("exact_step", ("alpha",), "exact solver: continuation step used", missing=MISSING),
    Variable(
        "exact_max_residual",
        ("alpha",),
        "exact solver: largest residual norm of the quarter-period equations",
        missing=MISSING,
    ),
    Variable("exact_orbits", ("alpha",), "exact solver: orbits of the two-impact family"),
    Variable("exact_energy_min", ("alpha",), "exact solver: lowest energy of the two-impact family", missing=MISSING),
    Variable("exact_energy_max", ("alpha",), "exact solver: highest energy of the two-impact family", missing=MISSING),
    Variable("exact_end_reason", ("alpha",), "exact solver: why the two-impact family ends"),
    Variable(
        "exact_end_confirmed",
        ("alpha",),
        "exact solver: the family end was met again with a step 100 times smaller (else recomputed with a 10 times smaller step)",
    ),
    Variable("exact_end_note", ("alpha",), "exact solver: how the family end was checked"),
    Variable(
        "ratio_exact_relative_residual",
        ("beta", "delta"),
        "exact solver: largest residual of the quarter-period equations, relative to max velocity * sqrt(1 + beta + alpha)",
        missing=MISSING,
    ),
    Variable(
        "ratio_exact_periodicity_error",
        ("beta", "delta"),
        "exact solver: middle orbit integrated over one period with event location: max |z(T) - z(0)| / max |z|",
        missing=MISSING,
    ),
    Variable(
        "ratio_exact_integration_difference",
        ("beta", "delta"),
        "exact solver: middle orbit: largest difference between integration and closed form / max |z|",
        missing=MISSING,
    ),
    Variable(
        "ratio_exact_seconds_per_orbit",
        ("beta", "delta"),
        "exact solver: time per orbit of the family continuation",
        units="s",
        missing=MISSING,
    ),
    Variable("ratio_exact_step", ("beta", "delta"), "exact solver: continuation step used", missing=MISSING),
    Variable(
        "ratio_exact_max_residual",
        ("beta", "delta"),
        "exact solver: largest residual norm of the quarter-period equations",
        missing=MISSING,
    ),
    Variable("ratio_exact_orbits", ("beta", "delta"), "exact solver: orbits of the two-impact family"),
    Variable(
        "ratio_exact_energy_min",
        ("beta", "delta"),
        "exact solver: lowest energy of the two-impact family",
        missing=MISSING,
    ),
    Variable(
        "ratio_exact_energy_max",
        ("beta", "delta"),
        "exact solver: highest energy of the two-impact family",
        missing=MISSING,
    ),
    Variable("ratio_exact_end_reason", ("beta", "delta"), "exact solver: why the two-impact family ends"),
    Variable(
        "ratio_exact_end_confirmed",
        ("beta", "delta"),
        "exact solver: the family end was met again with a step 100 times smaller (else recomputed with a 10 times smaller step)",
    ),
    Variable("ratio_exact_end_note", ("beta", "delta"), "exact solver: how the family end was checked"),
    Variable(
        "energy_kind",
        ("energy", "energy_alpha"),
        "exact orbit used: one of linear, family, high_energy, none (none: no two-impact orbit)",
    ),
    Variable("energy_exact_note", ("energy", "energy_alpha"), "how the exact orbit was found, or why there is none"),
    Variable("energy_exact_energy", ("energy", "energy_alpha"), "energy of the exact orbit", missing=MISSING),
    Variable(
        "energy_exact_frequency",
        ("energy", "energy_alpha"),
        "frequency of the exact orbit",
        units="Hz",
        missing=MISSING,
    ),
    Variable(
        "energy_exact_residual",
        ("energy", "energy_alpha"),
        "norm of the quarter-period equations of the exact orbit",
        missing=MISSING,
    ),
    Variable(
        "energy_periodicity_error",
        ("energy", "energy_alpha"),
        "event-located integration over one period: max |z(T) - z(0)| / max |z|",
        missing=MISSING,
    ),
    Variable(
        "energy_integration_difference",
        ("energy", "energy_alpha"),
        "largest difference between integration and closed form / max |z|",
        missing=MISSING,
    ),
    Variable(
        "energy_hbm_converged",
        ("energy", "energy_alpha"),
        "an HBM orbit of the regularized model was found there and is resolved",
    ),
    Variable("energy_hbm_failure", ("energy", "energy_alpha"), "why there is no resolved HBM orbit ('' if there is)"),
    Variable(
        "energy_hbm_frequency_difference",
        ("energy", "energy_alpha"),
        "(HBM frequency - exact frequency) / exact frequency",
        missing=MISSING,
    ),
    Variable(
        "energy_hbm_energy_mismatch",
        ("energy", "energy_alpha"),
        "(HBM energy - exact energy) / exact energy (the HBM orbit keeps the x amplitude)",
        missing=MISSING,
    ),
    Variable(
        "energy_hbm_truncation", ("energy", "energy_alpha"), "truncation indicator of the HBM orbit", missing=MISSING
    ),
    Variable("alpha", ("alpha",), "stop stiffness ratio alpha = K/k1"),
    Variable("eta", ("eta",), "regularization parameter eta"),
    Variable("beta", ("beta",), "coupling stiffness ratio beta = k2/k1 (ratio sweep)"),
    Variable("delta", ("delta",), "mass ratio delta = m2/m1 (ratio sweep)"),
    Variable("energy", ("energy",), "requested total energy (energy sweep)"),
    Variable("energy_alpha", ("energy_alpha",), "alpha of the energy sweep"),
)
STIFF_CASES = DatasetKind(
    "stiff_cases",
    "Stiff and extreme cases, gathered",
    ("study/stiff_cases.nc",),
    "The stiff-case study gathered (`docs/methods/study.md`).",
    STIFF_CASES_VARIABLES,
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
