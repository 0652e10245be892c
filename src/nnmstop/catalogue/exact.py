"""Dataset kinds of the exact datasets (see :mod:`nnmstop.catalogue`)."""

from nnmstop.catalogue import DatasetKind, Variable

#: Floquet stability of an exact orbit (product of the phase exponentials), in both exact NNM1 datasets.
EXACT_STABILITY_VARIABLES = (
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
)

EXACT_NNM1_VARIABLES = (
    Variable(
        "energy",
        ("point",),
        "total energy of the non-smooth (piecewise-linear) model: kinetic + spring potential + stop potential alpha/2 (|x|-1)^2, conserved along the orbit",
    ),
    Variable(
        "frequency", ("point",), "frequency 1/T of the periodic orbit, in Hz of the nondimensional time", units="Hz"
    ),
    Variable("period", ("point",), "period T = 4 T1 (T1: quarter period, from the origin to the turning point)"),
    Variable("x_max", ("point",), "maximum of x over the period (x_max - 1 is the penetration into the stop)"),
    Variable("u_at_x_max", ("point",), "u at the time of the maximum of x"),
    Variable("x_turning_point", ("point",), "x(T1) at the turning point, where both velocities vanish"),
    Variable("xdot0", ("point",), "velocity of x at x = u = 0 (t = 0)"),
    Variable("udot0", ("point",), "velocity of u at x = u = 0 (t = 0)"),
    Variable(
        "free_flight_time",
        ("point",),
        "total free-flight duration in the quarter period (tau1 for two impacts per period)",
    ),
    Variable(
        "contact_time",
        ("point",),
        "total contact duration in the quarter period (T1 - tau1 for two impacts per period)",
    ),
    Variable(
        "residual",
        ("point",),
        "Euclidean norm of the quarter-period equations (switching conditions, xdot(T1), udot(T1))",
    ),
    Variable(
        "validity_margin",
        ("point",),
        "smallest margin of the assumptions of the phase sequence (> 0 inside a segment, about 0 at its grazing transitions)",
    ),
    Variable("impacts_per_period", ("point",), "number of excursions of x beyond the stops (|x| > 1) per period"),
    Variable(
        "phase_sequence",
        ("point",),
        "linear phases of the quarter period from the origin to the turning point: F free flight, R contact with the stop x = 1, L contact with the stop x = -1 (the orbit -q, half a period later, has R and L swapped)",
    ),
    *EXACT_STABILITY_VARIABLES,
    Variable("n_phases", ("point",), "number of linear phases in the quarter period"),
    Variable("segment", ("point",), "index of the phase-sequence segment (0: the two-impact family)"),
    Variable(
        "grazing",
        ("point",),
        "1 for an exactly computed grazing orbit (a transition between phase sequences, or the start)",
    ),
    Variable(
        "branch_point",
        ("point",),
        "1 where the sign of det [J; t] changed since the previous orbit (a simple bifurcation was crossed)",
    ),
    Variable("point", ("point",), "index of the orbit along the branch"),
    Variable(
        "arclength",
        ("point",),
        "pseudo-arclength in the unknowns (xdot0, udot0, phase durations) of each segment, accumulated from the first orbit (a length in different unknowns on each segment)",
    ),
)
EXACT_NNM1 = DatasetKind(
    "exact_nnm1",
    "Exact NNM1 with any number of impacts per period",
    ("exact/nnm1.nc",),
    "The exact NNM1 of the non-smooth system continued past the two-impact family through every phase sequence, each segment ending at an exactly located grazing orbit (`docs/methods/exact.md`), with the Floquet multipliers of every orbit (product of the phase exponentials, `docs/methods/exact_stability.md`).",
    EXACT_NNM1_VARIABLES,
)


TWO_IMPACT_FAMILY_VARIABLES = (
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
    *EXACT_STABILITY_VARIABLES,
    Variable("point", ("point",), "index of the orbit along the family"),
    Variable("arclength", ("point",), "pseudo-arclength in (xdot0, udot0, tau1, T1) from the first orbit"),
)
TWO_IMPACT_FAMILY = DatasetKind(
    "two_impact_family",
    "Exact NNM1 with one impact per stop per period",
    ("exact/nnm1_two_impacts.nc",),
    "The non-smooth system's NNM1 family with two impacts per period (Section 3.1 of the paper), from the grazing orbit to the end of its validity (global attribute `end_reason`), by the closed-form quarter-period construction (free flight, then contact).",
    TWO_IMPACT_FAMILY_VARIABLES,
)

ONE_STOP_FAMILY_VARIABLES = (
    Variable("energy", ("orbit",), "total energy of the non-smooth model"),
    Variable("frequency", ("orbit",), "frequency 1/T in Hz of the nondimensional time", units="Hz"),
    Variable("contact_time", ("orbit",), "contact duration of the quarter period"),
    Variable("x_max", ("orbit",), "largest displacement at the stop over its gap"),
    Variable("initial_velocity", ("orbit", "dof"), "velocities at q = 0 (start of the orbit)"),
    Variable(
        "modal_energy",
        ("orbit", "mode"),
        "energy of each linear (free-flight) mode, b_k^2 / 2 with b the modal velocities at q = 0 (they add up to energy)",
    ),
    Variable(
        "resonant_mode",
        ("orbit",),
        "linear mode (1-based) in internal resonance with the orbit: it takes most of the energy growth along the family, at one harmonic; 0 on the backbone",
    ),
    Variable(
        "resonance_order",
        ("orbit",),
        "harmonic n of the orbit at which the resonant mode moves (an n:1 internal resonance); 0 on the backbone",
    ),
    Variable("orbit", ("orbit",), "index of the orbit along the family"),
    Variable("dof", ("dof",), "index of the degree of freedom"),
    Variable("dof_label", ("dof",), "name of the degree of freedom"),
    Variable("mode", ("mode",), "linear (free-flight) mode number"),
    Variable(
        "mode_frequency",
        ("mode",),
        "linear frequency of the mode without contact, in Hz of the nondimensional time",
        units="Hz",
    ),
)
ONE_STOP_FAMILY = DatasetKind(
    "one_stop_family",
    "Exact one-stop family of a structure (NNM1 with one impact per stop side)",
    ("tube/exact_nnm1.nc", "exact/nnm1_one_impact.nc"),
    "Exact periodic orbits of a non-smooth structure with one impact on each side of its stop per period (`docs/methods/exact_ndof.md`), from the grazing orbit of a linear mode, with the energy of every linear mode and, per orbit, the internal resonance it is in (global attribute `internal_resonance`: where the family leaves its backbone; `end_check`: how its end was confirmed).",
    ONE_STOP_FAMILY_VARIABLES,
)

SWITCHING_FAMILY_VARIABLES = (
    Variable("energy", ("orbit",), "total energy of the non-smooth model"),
    Variable("frequency", ("orbit",), "frequency 1/T in Hz of the nondimensional time", units="Hz"),
    Variable("period", ("orbit",), "period T in nondimensional time"),
    Variable("contact_time", ("orbit",), "time spent in contact (any stop) per period"),
    Variable("impacts_per_period", ("orbit",), "contacts entered per period, all stops"),
    Variable("stop_impacts", ("orbit", "stop"), "contacts entered per period at each stop"),
    Variable(
        "x_max", ("orbit", "stop"), "largest coordinate of each stop over the orbit, over its gap, in its own direction"
    ),
    Variable("initial_position", ("orbit", "dof"), "displacements at t = 0, where the orbit leaves its first contact"),
    Variable("initial_velocity", ("orbit", "dof"), "velocities at t = 0, where the orbit leaves its first contact"),
    Variable(
        "modal_energy",
        ("orbit", "mode"),
        "energy of each linear (free-flight) mode at t = 0, (a_k^2 + b_k^2) / 2 (no contact engaged there: they add up "
        "to energy)",
    ),
    Variable(
        "unfolding", ("orbit",), "unfolding parameter sigma of the periodicity equations (zero on periodic orbits)"
    ),
    Variable("residual", ("orbit",), "Euclidean norm of the full-period equations"),
    Variable("validity_margin", ("orbit",), "smallest validity margin of the phase sequence (> 0 where it holds)"),
    Variable("segment", ("orbit",), "segment of the family: 0 from its start, k > 0 after the k-th contact inserted"),
    Variable(
        "phase_sequence", ("orbit",), "the linear phases of the period, from t = 0 (free, or the stops in contact)"
    ),
    Variable("branch_point", ("orbit",), "sign change of det [J; t^T] since the previous orbit", flags=("no", "yes")),
    Variable("orbit", ("orbit",), "index of the orbit along the family"),
    Variable("dof", ("dof",), "index of the degree of freedom"),
    Variable("dof_label", ("dof",), "name of the degree of freedom"),
    Variable("stop", ("stop",), "index of the stop"),
    Variable("mode", ("mode",), "linear (free-flight) mode number"),
    Variable(
        "mode_frequency",
        ("mode",),
        "linear frequency of the mode without contact, in Hz of the nondimensional time",
        units="Hz",
    ),
)
SWITCHING_FAMILY = DatasetKind(
    "switching_family",
    "Exact NNM1 over full periods, one impact per active contact (one-sided stops, unequal gaps, relative stops)",
    ("exact/nnm1_one_impact.nc",),
    "Exact periodic orbits of a non-smooth structure whose stops are not all the paper's bilateral stop on one DOF, "
    "built over whole periods with no symmetry assumed (`docs/methods/one_sided_law.md`, `nnmstop.exact.switching`): "
    "from next to the grazing orbit of a linear mode at the first contact it reaches, one impact per contact struck, "
    "a contact inserted where an orbit grazes it (`segment`). A structure whose law is not piecewise linear (a "
    "circular clearance) has no exact orbits: the dataset then holds none and its `end_reason` says why.",
    SWITCHING_FAMILY_VARIABLES,
)

KINDS = (
    EXACT_NNM1,
    TWO_IMPACT_FAMILY,
    ONE_STOP_FAMILY,
    SWITCHING_FAMILY,
)
