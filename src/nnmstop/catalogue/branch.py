"""Dataset kinds of the regularized branches of the paper's oscillator (see :mod:`nnmstop.catalogue`).

The variables marked optional beyond the first six stability variables exist with the monodromy method
(``stability.method: monodromy``, the default) only.
"""

from nnmstop.catalogue import DatasetKind, Variable

#: Floquet stability of the orbits of a branch, any structure (:func:`nnmstop.hbm.stability.orbit_stability`):
#: the 2-DOF branches', the tube's and a user's structure's. The first six with either method; the others
#: with the monodromy method only.
STABILITY_VARIABLES = (
    Variable(
        "stable",
        ("point",),
        "orbit linearly stable (1) or unstable (0), by the stability method of the configuration: every non-trivial "
        "Floquet multiplier pair on the unit circle",
        flags=("unstable", "stable"),
    ),
    Variable("multiplier_real", ("point", "multiplier"), "real part of the Floquet multipliers"),
    Variable("multiplier_imag", ("point", "multiplier"), "imaginary part of the Floquet multipliers"),
    Variable("max_multiplier", ("point",), "largest modulus of the non-trivial Floquet multipliers"),
    Variable(
        "stability_orbit_residual",
        ("point",),
        "estimate of the change of floquet_invariant due to the orbit's error: larger of time_residual and stability_trivial_deviation",
    ),
    Variable(
        "stability_resolved",
        ("point",),
        "stability verdict resolved (1): stability_margin larger than the error estimates (stability_reason), and "
        "time_residual within stability.max_orbit_residual",
        flags=("unresolved", "resolved"),
    ),
    Variable(
        "stability_trivial_deviation",
        ("point",),
        "distance of the trivial pair's invariant mu + 1/mu to 2 in the computed monodromy (exactly 0 on an exact orbit)",
        optional=True,
    ),
    Variable(
        "stability_reason",
        ("point",),
        "why the stability verdict is or is not resolved: 0 resolved; 1 stability_margin within resolution_factor (2) x "
        "stability_integration_error at the largest step count; 2 stability_margin within 2 x stability_orbit_residual, or "
        "time_residual above stability.max_orbit_residual (the HBM orbit's own error; more steps would not resolve it), "
        "and the orbit not refined; 3 resolved on the orbit refined by shooting into a periodic orbit of the regularized "
        "equations of motion (the HBM orbit's own error decided; stability variables from the refined orbit); 4 the "
        "shooting did not converge (verdict of the HBM orbit, unresolved); 5 the refined orbit's margin within 2 x its "
        "integration error at the largest step count or below trace_tol: a non-trivial pair sits at +1 (a stability "
        "change, e.g. an energy fold)",
        flags=(
            "resolved",
            "integration_error",
            "orbit_error",
            "resolved_refined",
            "shooting_not_converged",
            "refined_at_type_change",
        ),
        optional=True,
    ),
    Variable(
        "floquet_invariant",
        ("point",),
        "invariant mu + 1/mu of the non-trivial Floquet pair that sets stability_margin (in [-2, 2] when elliptic; "
        "its real part for a complex quartet)",
        optional=True,
    ),
    Variable(
        "stability_margin",
        ("point",),
        "distance of the non-trivial pairs' invariants mu + 1/mu to where the verdict can change: for a stable orbit to 2 "
        "(and -2 unless half-wave symmetric) and to another elliptic pair of opposite Krein sign, for an unstable one "
        "the largest distance of an unstable pair to [-2, 2]",
        optional=True,
    ),
    Variable(
        "stability_integration_error",
        ("point",),
        "largest change of a pair's invariant mu + 1/mu between the last two step counts of the integration",
        optional=True,
    ),
    Variable(
        "stability_steps",
        ("point",),
        "Magnus steps of the stored monodromy over the integrated interval (half a period if half-wave symmetric; "
        "commutator-free above 3 degrees of freedom); on refined orbits (stability_reason 3-5) Runge-Kutta steps over "
        "a quarter period",
        optional=True,
    ),
    Variable(
        "stability_refined",
        ("point",),
        "orbit refined by shooting into a periodic orbit of the regularized equations of motion for its verdict "
        "(stability_reason 3-5)",
        flags=("no", "yes"),
        optional=True,
    ),
    Variable(
        "stability_refined_frequency_change",
        ("point",),
        "relative change of the frequency from the HBM orbit to the shooting-refined orbit (0 where stability_refined = 0 or stability_reason = 4)",
        optional=True,
    ),
    Variable(
        "stability_refined_energy_change",
        ("point",),
        "relative change of the energy at t = 0 (start at rest) from the HBM orbit to the shooting-refined orbit (0 where stability_refined = 0 or stability_reason = 4)",
        optional=True,
    ),
    Variable(
        "stability_refined_residual",
        ("point",),
        "closure of the shooting conditions q = 0 at a quarter period relative to the amplitude (0 where "
        "stability_refined = 0; 1 where the shooting diverged at once)",
        optional=True,
    ),
    Variable(
        "multiplier",
        ("multiplier",),
        "index of the Floquet multiplier: 0, 1 the trivial pair; then each non-trivial pair mu, 1/mu (the larger "
        "first), pairs by decreasing largest modulus (2, 3 for the paper's oscillator)",
    ),
)

NNM_BRANCH_VARIABLES = (
    Variable("x_cos", ("point", "harmonic"), "cosine Fourier coefficients of x (first mass)"),
    Variable("x_sin", ("point", "harmonic"), "sine Fourier coefficients of x (first mass)"),
    Variable("u_cos", ("point", "harmonic"), "cosine Fourier coefficients of u (second mass)"),
    Variable("u_sin", ("point", "harmonic"), "sine Fourier coefficients of u (second mass)"),
    Variable("f_cos", ("point", "harmonic"), "cosine Fourier coefficients of regularized contact force f"),
    Variable("f_sin", ("point", "harmonic"), "sine Fourier coefficients of regularized contact force f"),
    Variable("z_cos", ("point", "harmonic"), "cosine Fourier coefficients of internal variable z = (f/alpha - x)^2"),
    Variable("z_sin", ("point", "harmonic"), "sine Fourier coefficients of internal variable z = (f/alpha - x)^2"),
    Variable("omega_squared", ("point",), "squared angular frequency (unknown lambda of the HBM system)"),
    Variable(
        "unfolding", ("point",), "unfolding parameter nu (fictitious damping times omega; zero on periodic orbits)"
    ),
    Variable(
        "energy", ("point",), "total energy of the regularized model (contact potential included), mean over the period"
    ),
    Variable("frequency", ("point",), "frequency omega/(2 pi) in Hz of the nondimensional time", units="Hz"),
    Variable("period", ("point",), "period of the orbit in nondimensional time"),
    Variable("x_max", ("point",), "largest displacement of the first mass over the period"),
    Variable("u_max", ("point",), "largest displacement of the second mass over the period"),
    Variable("impacts_per_period", ("point",), "number of excursions of x beyond the stops (|x| > 1) per period"),
    Variable(
        "algebraic_residual",
        ("point",),
        "norm of the residual of the HBM algebraic system relative to the norm of the unknowns",
    ),
    Variable(
        "time_residual",
        ("point",),
        "largest residual in time of the regularized equation of x (true cubic root for f) relative to the largest restoring force",
    ),
    Variable(
        "force_error",
        ("point",),
        "largest difference between the HBM contact force and the cubic root f(x(t)), relative to max |f|",
    ),
    Variable(
        "energy_spread", ("point",), "relative variation of the total energy over the period (zero for an exact orbit)"
    ),
    Variable(
        "truncation",
        ("point",),
        "share of the mean square of x'' or f carried by the top tenth of the harmonics (larger of the two)",
    ),
    Variable("step", ("point",), "index of the ANM step that produced the point"),
    Variable("stage", ("point",), "continuation stage of the point"),
    Variable(
        "branch_point",
        ("point",),
        "1 where a simple branch point of the HBM system (sign change of det [J; t^T]) lies within the ANM step that ends at this point",
        flags=("regular", "branch_point"),
    ),
    Variable(
        "energy_fold",
        ("point",),
        "1 where the energy has a local extremum along the branch (energy fold)",
        flags=("regular", "fold"),
    ),
    *STABILITY_VARIABLES,
    Variable("harmonic", ("harmonic",), "harmonic number k (0 is the mean)"),
    Variable("branch_point_energy", ("located_branch_point",), "energy of the located branch point"),
    Variable("branch_point_frequency", ("located_branch_point",), "frequency of the located branch point", units="Hz"),
    Variable(
        "branch_point_resonance",
        ("located_branch_point",),
        "n where the orbit at the branch point has period T/n (n:1 internal resonance), else 0",
    ),
    Variable(
        "branch_point_symmetry_breaking",
        ("located_branch_point",),
        "1 where the bifurcated tangent holds even harmonics only (the crossing curve breaks x(t + T/2) = -x(t))",
        flags=("no", "yes"),
    ),
    Variable(
        "branch_point_tangent_angle",
        ("located_branch_point",),
        "angle between the tangents of the two curves at the branch point",
        units="degree",
    ),
    Variable(
        "branch_point_singular_ratio",
        ("located_branch_point",),
        "smallest over second-smallest singular value of J at the located point (zero at an exact branch point)",
    ),
    Variable(
        "branch_point_flagged_point",
        ("located_branch_point",),
        "index of the point that ends the ANM step holding the branch point",
    ),
    Variable("point", ("point",), "index of the point along the branch"),
    Variable(
        "fold_energy",
        ("located_fold",),
        "energy at the fold (local extremum along the branch), parabola through the three nearest points",
    ),
    Variable("fold_frequency", ("located_fold",), "frequency at the fold, same parabola", units="Hz"),
    Variable("fold_point", ("located_fold",), "index of the point of extremal energy"),
)
NNM_BRANCH = DatasetKind(
    "nnm_branch",
    "Regularized NNM branch of the paper's oscillator (HBM + ANM)",
    ("hbm/nnm*.nc", "hbm/stages/nnm*_stage*.nc"),
    "A regularized NNM continued by harmonic balance and the asymptotic numerical method: one stage, or the whole branch (the stages concatenated). Fourier coefficients of Eq. (13) in the phase omega t, diagnostics, located branch points and folds, Floquet stability (`docs/methods/hbm.md`, `docs/methods/monodromy.md`).",
    NNM_BRANCH_VARIABLES,
)

SWITCHED_BRANCH = NNM_BRANCH.extended(
    "switched_branch",
    "Branch switched at a branch point of a regularized NNM",
    ("hbm/bifurcated/*.nc",),
    "The curve that crosses a regularized branch at its n:1 branch point (for n = 3 and 5 the NNM2 read over n "
    "periods), reached by branch switching and followed both ways; ordered along the curve through the branch point. "
    "Global attributes describe the branch point (`resonance`, `parent_branch`, `branch_point_energy`, ...).",
    Variable(
        "step",
        ("point",),
        "index of the ANM step that produced the point (negative on the side followed backwards)",
    ),
    Variable("stage", ("point",), "stage of the parent branch from whose branch point the branch was switched"),
    Variable(
        "subharmonic_share",
        ("point",),
        "share of the mean square of x and u in harmonics that are not multiples of n (global attribute resonance; "
        "zero for an orbit of period T/n)",
    ),
)

KINDS = (NNM_BRANCH, SWITCHED_BRANCH)
