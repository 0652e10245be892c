"""Dataset kinds of the regularized branches of any structure (see :mod:`nnmstop.catalogue`): the one branch schema.

The paper's oscillator, the finite-element tube and a structure of one's own share it
(:mod:`nnmstop.hbm.dataset`): ``q_cos``/``q_sin(point, dof, harmonic)`` with the coordinate ``dof_label``
(``x``, ``u`` for the paper's oscillator), the stop forces and internal variables per ``stop``, the
diagnostics, located branch points, folds and resonance tongues, the stops and linear limits of the
structure, and the Floquet verdicts of :func:`nnmstop.hbm.stability.orbit_stability` (any structure): the
variables marked optional beyond the first six stability variables exist with the monodromy method
(``stability.method: monodromy``, the default) only.
"""

from nnmstop.catalogue import DatasetKind, Variable


def _fourier_pair(name: str, dims: tuple, what: str) -> tuple:
    """The cosine and sine coefficients ``<name>_cos``, ``<name>_sin`` of ``what``."""
    return tuple(Variable(f"{name}_{part}", dims, f"{kind} Fourier coefficients of {what}")
                 for part, kind in (("cos", "cosine"), ("sin", "sine")))  # fmt: skip


ORBIT_VARIABLES = (
    *_fourier_pair("q", ("point", "dof", "harmonic"), "the degrees of freedom"),
    *_fourier_pair("f", ("point", "stop", "harmonic"), "the regularized stop forces (force over gap)"),
    *_fourier_pair("z", ("point", "stop", "harmonic"), "the internal variables z = (f/alpha - x)^2 of the stops"),
    *(
        Variable(v.name, v.dims, v.long_name, optional=True)
        for v in _fourier_pair(
            "f2",
            ("point", "stop", "harmonic"),
            "the second (Cartesian) component of the regularized stop forces over gap: a circular clearance's force "
            "along its second degree of freedom (zero for a stop with one coordinate)",
        )
    ),
    Variable("omega_squared", ("point",), "squared angular frequency (unknown lambda of the HBM system)"),
)

#: The structure: its stops, linear limits and coordinates (every branch dataset, skipped ones included).
STRUCTURE_VARIABLES = (
    Variable("stop_dof", ("stop",), "index of the degree of freedom that meets the stop"),
    Variable("stop_gap", ("stop",), "gap of the stop (nondimensional)"),
    Variable("stop_stiffness", ("stop",), "stiffness alpha of the stop (nondimensional)"),
    Variable("stop_eta", ("stop",), "regularization stiffness eta of the stop (nondimensional)"),
    Variable(
        "stop_kind",
        ("stop",),
        "kind of the stop's contact law: bilateral, one_sided, relative or circular (nnmstop.models.contact); a "
        "one-sided law's internal variable z is f/alpha - x (not squared), a circular clearance's the sum of both "
        "components' (f/alpha - x)^2",
        optional=True,
    ),
    Variable(
        "stop_side",
        ("stop",),
        "side of a one-sided law: +1 contact where the stop's coordinate exceeds its gap, -1 where it is below minus "
        "its gap, 0 both sides",
        optional=True,
    ),
    Variable(
        "stop_other_dof",
        ("stop",),
        "second degree of freedom the stop reads (relative stop: the gap closes on q[stop_dof] - q[stop_other_dof]; "
        "circular clearance: its second direction); stop_dof for a stop on one degree of freedom",
        optional=True,
    ),
    Variable(
        "no_contact_frequency", ("mode",), "frequency of the linear mode with no contact (every gap infinite)", "Hz"
    ),
    Variable(
        "regularized_frequency", ("mode",), "frequency of the linear mode of the regularized structure near rest", "Hz"
    ),
    Variable(
        "gap_zero_frequency", ("mode",), "frequency of the linear mode with every stop always engaged (gap 0)", "Hz"
    ),
    Variable("gap_zero_shape", ("dof", "mode"), "shape of the gap-0 linear mode (mass-normalized)"),
    Variable("point", ("point",), "index of the point along the branch"),
    Variable("dof", ("dof",), "index of the degree of freedom"),
    Variable("dof_label", ("dof",), "name of the degree of freedom"),
    Variable("stop", ("stop",), "index of the stop"),
    Variable("harmonic", ("harmonic",), "harmonic number k (0 is the mean)"),
    Variable("mode", ("mode",), "index of the linear mode (1 is the lowest)"),
    Variable("node", ("node",), "index of the finite-element node", optional=True),
    Variable(
        "node_coordinate",
        ("node",),
        "position of the finite-element node over the length of the structure",
        optional=True,
    ),
    # a structure reduced onto its contact DOFs (nnmstop.models.reduction): back to the full model's DOFs
    Variable(
        "recovery",
        ("recovered_dof", "dof"),
        "full-model degree of freedom per unit reduced degree of freedom (Craig-Bampton basis rows)",
        optional=True,
    ),
    Variable("recovered_dof", ("recovered_dof",), "index of a recovered full-model degree of freedom", optional=True),
    Variable(
        "recovered_dof_label", ("recovered_dof",), "name of the recovered full-model degree of freedom", optional=True
    ),
    Variable(
        "recovered_dof_node",
        ("recovered_dof",),
        "finite-element node of the recovered degree of freedom",
        optional=True,
    ),
)

#: Where the branch is: step, stage, segment and the flags of every point.
PATH_VARIABLES = (
    Variable(
        "unfolding", ("point",), "unfolding parameter nu (fictitious damping times omega; zero on periodic orbits)"
    ),
    Variable(
        "rotation_unfolding",
        ("point",),
        "unfolding parameter mu of the rotation phase condition (coefficient of the circulatory force mu M J q of a "
        "structure invariant under rotations; zero on periodic orbits but circles)",
        optional=True,
    ),
    Variable("period", ("point",), "period of the orbit in nondimensional time"),
    Variable(
        "energy",
        ("point",),
        "total energy of the regularized model (contact potentials included), mean over the period",
    ),
    Variable("frequency", ("point",), "frequency omega/(2 pi) in Hz of the nondimensional time", units="Hz"),
    Variable("impacts_per_period", ("point",), "number of excursions beyond the gaps per period, all stops"),
    Variable("step", ("point",), "index of the ANM step that produced the point"),
    Variable("stage", ("point",), "continuation stage of the point"),
    Variable(
        "segment",
        ("point",),
        "segment of the stage: 0 from its start, k > 0 the backbone beyond the k-th internal resonance tongue passed "
        "(see passed_resonance_*)",
    ),
    Variable(
        "branch_point",
        ("point",),
        "1 where a simple branch point of the HBM system (sign change of det [J; t^T]) lies within the ANM step that "
        "ends at this point",
        flags=("regular", "branch_point"),
    ),
    Variable(
        "energy_fold",
        ("point",),
        "1 where the energy has a local extremum along the branch (within its segment)",
        flags=("regular", "fold"),
    ),
)

DIAGNOSTIC_VARIABLES = (
    Variable("x_max", ("point",), "largest coordinate of the first stop (displacement over its gap) over the period"),
    Variable("q_max", ("point", "dof"), "largest value of each degree of freedom over the period"),
    Variable("stop_impacts", ("point", "stop"), "number of excursions beyond the gap per period at each stop"),
    Variable(
        "algebraic_residual",
        ("point",),
        "norm of the residual of the HBM algebraic system relative to the norm of the unknowns",
    ),
    Variable(
        "time_residual",
        ("point",),
        "largest residual in time of the equations of the stop degrees of freedom (true cubic root for f) relative "
        "to the largest restoring force",
    ),
    Variable(
        "force_error",
        ("point",),
        "largest difference between the HBM stop force and the cubic root f(x(t)), relative to max |f|",
    ),
    Variable(
        "energy_spread", ("point",), "relative variation of the total energy over the period (zero for an exact orbit)"
    ),
    Variable(
        "truncation",
        ("point",),
        "share of the mean square of x'' or f carried by the top tenth of the harmonics (largest over the stops)",
    ),
    Variable(
        "swept_area",
        ("point",),
        "area swept per period by the first circular clearance's coordinates, int (x dy - y dx), over 2 pi max(x^2 + "
        "y^2): 0 for planar motion, 1 for a whirl round a circle (structures with a circular clearance)",
        optional=True,
    ),
)

LOCATED_VARIABLES = (
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
        "branch_point_whirl",
        ("located_branch_point",),
        "1 where planar motion in a circular clearance gives way to whirl: the crossing curve's tangent sweeps area "
        "round the hole (nnmstop.hbm.bifurcation.is_whirl_branch_point); structures with a circular clearance",
        flags=("no", "yes"),
        optional=True,
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
    Variable(
        "fold_energy",
        ("located_fold",),
        "energy at the fold (local extremum along the branch), parabola through the three nearest points",
    ),
    Variable("fold_frequency", ("located_fold",), "frequency at the fold, same parabola", units="Hz"),
    Variable("fold_point", ("located_fold",), "index of the point of extremal energy"),
    Variable(
        "passed_resonance_frequency",
        ("passed_resonance",),
        "frequency maximum where the backbone bent into the internal resonance tongue",
        units="Hz",
    ),
    Variable("passed_resonance_energy", ("passed_resonance",), "energy at that frequency maximum"),
    Variable(
        "passed_resonance_harmonic",
        ("passed_resonance",),
        "harmonic that grew most into the tongue (n of the n:1 internal resonance)",
    ),
    Variable(
        "passed_resonance_landing_frequency",
        ("passed_resonance",),
        "frequency where the predictor over the tongue landed on the backbone beyond it",
        units="Hz",
    ),
)

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
        "shooting did not converge: Newton diverged, went farther than refine_max_change, or met a singular system (an "
        "orbit whose period is a multiple of its own, next to an n:1 branch point) (verdict of the HBM orbit, "
        "unresolved); 5 the refined orbit's margin within 2 x its "
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


def wear_variables(dims: tuple, where: str) -> tuple:
    """The wear quantities of every orbit at every stop (:mod:`nnmstop.wear`, ``docs/methods/wear.md``), with
    dimensions ``dims``; ``where`` says whose normal force (the law of the orbits)."""
    units = "nondimensional: forces in k0 L0, speeds in L0/T0, powers in k0 L0^2/T0 (docs/structures.md)"
    return (
        Variable(
            "contact_force_max",
            dims,
            f"largest normal contact force over the period ({where}; zero where the stop is not touched, its "
            f"coordinates within the gap); {units}",
        ),
        Variable("contact_force_mean", dims, f"normal contact force averaged over the period ({where}); {units}"),
        Variable(
            "sliding_speed_max",
            dims,
            "largest sliding speed while in contact: the circumferential speed in a circular clearance; zero for a "
            f"stop on one coordinate, whose model has no motion along the contact surface; {units}",
        ),
        Variable(
            "wear_power",
            dims,
            f"wear power <|F_N| |v_t|>: normal contact force times sliding speed averaged over the period (Archard; "
            f"code_aster POST_USURE's definition); zero for a stop on one coordinate; {units}",
        ),
        Variable(
            "impact_work_rate",
            dims,
            f"work done by the normal contact force on the stop while it is compressed, per unit time "
            f"<(F_N v_N)+> (given back on unloading); zero on a permanent contact such as a whirl; {units}",
        ),
    )


#: Wear of every orbit of a branch at every stop (every branch dataset written by nnmstop.hbm.dataset).
WEAR_VARIABLES = tuple(
    Variable(v.name, v.dims, v.long_name, optional=True)
    for v in wear_variables(("point", "stop"), "regularized law of the stop")
)

#: What each orbit is, from its harmonic content (:mod:`nnmstop.hbm.identity`, ``docs/methods/identity.md``).
IDENTITY_VARIABLES = (
    Variable(
        "dominant_harmonic",
        ("point",),
        "harmonic k >= 1 carrying the largest share of the mass-weighted mean square of the motion (1: the orbit "
        "moves at its own frequency; n > 1: it is an orbit of n times the stored frequency read over n periods)",
    ),
    Variable(
        "dominant_harmonic_share",
        ("point",),
        "share of the mass-weighted mean square of the motion in dominant_harmonic",
    ),
    Variable(
        "fundamental_share", ("point",), "share of the mass-weighted mean square of the motion in the first harmonic"
    ),
    Variable(
        "dominant_mode",
        ("point",),
        "linear mode (1 the lowest) carrying most of the dominant harmonic's motion: a mode of the structure with each "
        "stop replaced by its effective_stop_stiffness (eta near rest, alpha as the gap closes); for a structure "
        "invariant under rotations a mode and its copy turned by 90 degrees are one, the lower",
    ),
    Variable(
        "dominant_mode_share", ("point",), "share of the dominant harmonic's mass-weighted motion in dominant_mode"
    ),
    Variable(
        "tongue_harmonic",
        ("point",),
        "n of the n:1 internal resonance tongue the orbit lies on: a harmonic n >= 2 holding more than a tenth of the "
        "motion's mean square while the first harmonic dominates; 0 outside a tongue",
    ),
    Variable(
        "orbit_kind",
        ("point",),
        "what the orbit is: NNM dominant_mode at its own frequency; in the tongue_harmonic:1 tongue of NNM "
        "dominant_mode; NNM dominant_mode seen at 1/dominant_harmonic of its frequency",
        flags=("own_frequency", "tongue", "seen_at_fraction"),
    ),
    Variable(
        "dof_dominant_harmonic",
        ("point", "dof"),
        "harmonic k >= 1 of the largest amplitude of each degree of freedom's motion (0 where it does not move)",
    ),
    Variable(
        "effective_stop_stiffness",
        ("point", "stop"),
        "equivalent linear stiffness <f x> / <x^2> of each stop over the orbit (least squares of the stop force in "
        "time), between eta and alpha",
    ),
    Variable(
        "identity_change_point",
        ("identity_change",),
        "index of the first point of a new identity along the branch (dominant_harmonic, dominant_mode, "
        "tongue_harmonic, orbit_kind): where the branch crosses onto another family or a tongue; that point's "
        "identity says what it becomes",
    ),
    Variable("identity_change_energy", ("identity_change",), "energy at identity_change_point"),
    Variable("identity_change_frequency", ("identity_change",), "frequency at identity_change_point", units="Hz"),
)

NNM_BRANCH_VARIABLES = (
    ORBIT_VARIABLES + PATH_VARIABLES + DIAGNOSTIC_VARIABLES + WEAR_VARIABLES + LOCATED_VARIABLES
    + STABILITY_VARIABLES + STRUCTURE_VARIABLES + IDENTITY_VARIABLES
)  # fmt: skip
NNM_BRANCH = DatasetKind(
    "nnm_branch",
    "Regularized NNM branch of a structure (HBM + ANM)",
    (
        "hbm/nnm*.nc",
        "hbm/stages/nnm*_stage*.nc",
        "tube/nnm*.nc",
        "tube/stages/nnm*_stage*.nc",
        "tube/study/gap*_k*.nc",
        "tube/circular/*.nc",
        "tube/circular/stages/*_stage*.nc",
    ),
    "A regularized NNM of any structure (the paper's oscillator, the finite-element tube, the tube in a circular hole, "
    "a structure from matrices) "
    "continued by harmonic balance and the asymptotic numerical method: one stage, or the whole branch (the stages "
    "concatenated). Fourier coefficients in the phase omega t, diagnostics, located branch points, folds and "
    "resonance tongues passed, Floquet stability, the structure's stops and linear limits "
    "(`docs/methods/hbm.md`, `docs/methods/monodromy.md`). Global attributes: the structure's own (`structure`; "
    "the paper's `alpha`, `beta`, `delta`, `eta`; a beam's physical data), the settings, and how the stage ended "
    "(`stage_condition`, `stage_condition_met`, `stage_end`, `end_reason`; `end_check`: how its end was checked, "
    "a truncation end confirmed by a restart with ten times shorter steps, `docs/methods/continuation.md`).",
    NNM_BRANCH_VARIABLES,
)

SWITCHED_BRANCH = NNM_BRANCH.extended(
    "switched_branch",
    "Branch switched at a branch point of a regularized NNM",
    ("hbm/bifurcated/*.nc",),
    "The curve that crosses a regularized branch at its first n:1 branch point (for n = 3 and 5 the NNM2 read over n "
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
        "share of the mean square of the degrees of freedom in harmonics that are not multiples of n (global "
        "attribute resonance; zero for an orbit of period T/n); absent from a branch switched where planar motion "
        "gives way to whirl (resonance 0: swept_area says how far round the hole it goes)",
        optional=True,
    ),
)

SKIPPED_BRANCH = DatasetKind(
    "skipped_branch",
    "A stage or switched branch that was not continued",
    ("hbm/stages/nnm*_stage*.nc", "hbm/bifurcated/*.nc", "tube/stages/nnm*_stage*.nc"),
    "No orbit (`point` of length 0): the stage before ended without its condition (at its energy bound, or where "
    "the harmonics stopped resolving the stop), or the parent branch has no branch point of the resonance. Global "
    "attributes `skipped = 1` and `end_reason` say why; the structure's variables are kept.",
    ORBIT_VARIABLES + PATH_VARIABLES + STRUCTURE_VARIABLES,
)

KINDS = (NNM_BRANCH, SWITCHED_BRANCH, SKIPPED_BRANCH)
