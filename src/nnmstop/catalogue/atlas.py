"""Dataset kinds of the bifurcation atlas (issue 31; see :mod:`nnmstop.catalogue` and docs/atlas.md)."""

from nnmstop.bifurcation_atlas.flags import CODIM2_KINDS, CURVE_KINDS, END_KINDS, LAWS, REGIONS
from nnmstop.catalogue import DatasetKind, Variable
from nnmstop.forced.stability_changes import KINDS as CHANGE_KINDS

SECOND = "the second parameter of the map: the force amplitude, or the structural parameter of the plane attribute"

REGION_VARIABLES = (
    Variable("grid_frequency", ("grid",), "frequency of the grid on which the regions are read", units="Hz"),
    Variable(
        "region",
        ("slice", "grid"),
        "region of the map: one stable response without contact; one stable impacting response; two or more "
        "stable responses; no stable periodic response; not covered (responses with more contacts per period)",
        flags=REGIONS,
    ),
    Variable("responses", ("slice", "grid"), "number of periodic responses (one-contact or non-impacting) there"),
    Variable("stable_responses", ("slice", "grid"), "number of stable periodic responses there"),
)

RESPONSE_VARIABLES = (
    Variable("response_frequency", ("response",), "frequency of a point of a slice's response", units="Hz"),
    Variable(
        "response_impacting",
        ("response",),
        "the response touches the stop",
        flags=("no_contact", "impacting"),
    ),
    Variable("response_stable", ("response",), "Floquet stability of the response", flags=("unstable", "stable")),
    Variable("response_amplitude", ("response", "orbit_dof"), "largest |q| over the period of the kept DOFs (x, u)"),
    Variable(
        "response_orbit",
        ("response", "orbit_dof", "coefficient"),
        "Fourier coefficients of the kept DOFs' orbit in the phase of the force Omega t: mean, cos 1..K, sin 1..K",
    ),
    Variable("response_multiplier_real", ("response", "multiplier"), "real part of the Floquet multipliers"),
    Variable("response_multiplier_imag", ("response", "multiplier"), "imaginary part of the Floquet multipliers"),
)

CURVE_VARIABLES = (
    Variable("frequency", ("point",), "frequency of the force at a point of a curve", units="Hz"),
    Variable("second", ("point",), SECOND),
    Variable("point_curve", ("point",), "index of the curve of the point"),
    Variable("amplitude", ("point", "orbit_dof"), "largest |q| over the period of the kept DOFs (x, u), sampled"),
    Variable("multiplier_real", ("point", "multiplier"), "real part of the Floquet multipliers over one period"),
    Variable("multiplier_imag", ("point", "multiplier"), "imaginary part of the Floquet multipliers over one period"),
    Variable(
        "orbit",
        ("point", "orbit_dof", "coefficient"),
        "Fourier coefficients of the kept DOFs' orbit in the phase of the force Omega t: mean, cos 1..K, sin 1..K",
    ),
    Variable(
        "test_unknown",
        ("point",),
        "extra unknown of the curve's test function: cos(theta) of a Neimark-Sacker pair (of the half-period map "
        "for the exact responses), the touching phase of a second contact; 0 where there is none",
    ),
    Variable("curve_kind", ("curve",), "kind of the curve", flags=CURVE_KINDS),
    Variable("curve_law", ("curve",), "contact law of the responses on the curve", flags=LAWS),
    Variable("curve_ends", ("curve",), "why the curve ends, at its first and at its last point"),
    Variable("curve_seed", ("curve",), "value of the second parameter at the located point the curve starts from"),
    Variable("codim2_kind", ("codim2",), "kind of the codimension-two point", flags=CODIM2_KINDS),
    Variable("codim2_frequency", ("codim2",), "frequency of the codimension-two point", units="Hz"),
    Variable("codim2_second", ("codim2",), "second parameter at the codimension-two point"),
    Variable("codim2_curve", ("codim2",), "index of the curve on which it was located"),
    Variable("check_curve", ("check",), "index of the curve through the checked point"),
    Variable("check_second", ("check",), "second parameter of the one-parameter response that located the point"),
    Variable("check_curve_frequency", ("check",), "frequency of the curve at that value (solved)", units="Hz"),
    Variable("check_response_frequency", ("check",), "frequency located by the one-parameter response", units="Hz"),
    Variable(
        "check_deviation",
        ("check",),
        "relative distance between the two frequencies (within the attribute check_tolerance, or the regularized one)",
    ),
)

ATLAS_SLICE = DatasetKind(
    "atlas_slice",
    "One slice of an atlas: the exact (or regularized) one-parameter response, classified",
    ("atlas/<map>/slice_<k>.nc",),
    "The exact response (non-impacting and symmetric one-contact, nnmstop.forced.responses.exact_response) at one "
    "value of the second parameter (attribute slice_value), its regions on a frequency grid, a thinned set of its "
    "points with their orbits, its located stability changes (the states that seed and check the curves) and "
    "the ends of its one-contact families on a second contact (attribute complete: none). A structure whose stop is "
    "not piecewise linear (a circular clearance) has the regularized response instead (attribute slice_law "
    "regularized, harmonics): one piece, change_state the harmonic-balance unknowns, no family ends.",
    REGION_VARIABLES[:1]
    + (
        Variable("region", ("grid",), "region of the map at the grid frequency", flags=REGIONS),
        Variable("responses", ("grid",), "number of periodic responses there"),
        Variable("stable_responses", ("grid",), "number of stable periodic responses there"),
        Variable("response_piece", ("response",), "index of the piece of the response"),
        Variable("change_kind", ("change",), "kind of the located stability change", flags=CHANGE_KINDS),
        Variable(
            "change_state",
            ("change", "unknown"),
            "unknowns of the response at the change: exact, state entering the stop, its phase, contact duration, Omega; "
            "regularized, the harmonic-balance unknowns",
        ),
        Variable("end_kind", ("end",), "why a one-contact family ends there", flags=END_KINDS),
        Variable("end_state", ("end", "unknown"), "unknowns of the exact response at the family's end"),
        Variable("end_frequency", ("end",), "frequency of the family's end", units="Hz"),
    )
    + RESPONSE_VARIABLES,
)

ATLAS_CURVES = DatasetKind(
    "atlas_curves",
    "The curves of one kind of an atlas",
    ("atlas/<map>/curves_<kind>.nc",),
    "Codimension-one points followed in two parameters (attribute curve_kind, contact_law): every point with its "
    "orbit and multipliers, each curve's kind and ends, the codimension-two points located on them, and the "
    "checks against the one-parameter responses (attribute check_tolerance).",
    CURVE_VARIABLES,
)

ATLAS = DatasetKind(
    "atlas",
    "A bifurcation atlas: regions and curves over frequency and a second parameter",
    ("atlas/<map>.nc",),
    "The map of a forced structure over the frequency and the force (or a structural parameter, attribute plane): "
    "the regions read from the slices (slice_value; their response points and orbits are in the slice datasets), "
    "every curve (grazing, fold, Neimark-Sacker, flip, second contact; exact and regularized) with its points' "
    "orbits and multipliers, the codimension-two points and the checks. The backbone's prediction of the peak: "
    "atlas/<map>_backbone.nc (the layout of forced/backbone.nc).",
    REGION_VARIABLES
    + (
        Variable("slice_value", ("slice",), "value of the second parameter of each slice"),
        Variable(
            "slice_complete",
            ("slice",),
            "no one-contact family of the slice ends on a second contact",
            flags=("incomplete", "complete"),
        ),
    )
    + CURVE_VARIABLES,
)

KINDS = (ATLAS_SLICE, ATLAS_CURVES, ATLAS)
