"""Dataset kinds of the tube datasets (see :mod:`nnmstop.catalogue`)."""

from nnmstop.catalogue import DatasetKind, Variable
from nnmstop.catalogue.branch import STABILITY_VARIABLES

TUBE_EXACT_FAMILY_VARIABLES = (
    Variable("energy", ("orbit",), "total energy of the non-smooth model"),
    Variable("frequency", ("orbit",), "frequency 1/T in Hz of the nondimensional time", units="Hz"),
    Variable("contact_time", ("orbit",), "contact duration of the quarter period"),
    Variable("x_max", ("orbit",), "largest displacement at the stop over its gap"),
    Variable("initial_velocity", ("orbit", "dof"), "velocities at q = 0 (start of the orbit)"),
    Variable("orbit", ("orbit",), "index of the orbit along the family"),
    Variable("dof", ("dof",), "index of the degree of freedom"),
)
TUBE_EXACT_FAMILY = DatasetKind(
    "tube_exact_family",
    "Exact NNM1 of the finite-element tube, one impact per stop side",
    ("tube/exact_nnm1.nc",),
    "Exact periodic orbits of the non-smooth finite-element tube with one impact on each side of its stop per period, from the grazing orbit of its first linear mode (closed-form phases).",
    TUBE_EXACT_FAMILY_VARIABLES,
)


STRUCTURE_BRANCH_VARIABLES = (
    Variable("q_cos", ("point", "dof", "harmonic"), "cosine Fourier coefficients of the degrees of freedom"),
    Variable("q_sin", ("point", "dof", "harmonic"), "sine Fourier coefficients of the degrees of freedom"),
    Variable("f_cos", ("point", "stop", "harmonic"), "cosine Fourier coefficients of the regularized stop forces"),
    Variable("f_sin", ("point", "stop", "harmonic"), "sine Fourier coefficients of the regularized stop forces"),
    Variable("omega_squared", ("point",), "squared angular frequency (unknown lambda of the HBM system)"),
    Variable("unfolding", ("point",), "unfolding parameter nu (zero on periodic orbits)"),
    Variable("energy", ("point",), "total energy of the regularized model, mean over the period"),
    Variable("frequency", ("point",), "frequency omega/(2 pi) in Hz of the nondimensional time", units="Hz"),
    Variable("period", ("point",), "period of the orbit in nondimensional time"),
    Variable("x_max", ("point",), "largest displacement at the first stop over its gap"),
    Variable("impacts_per_period", ("point",), "excursions beyond the gaps per period, all stops"),
    Variable("stop_impacts", ("point", "stop"), "excursions beyond the gap per period at each stop"),
    Variable("algebraic_residual", ("point",), "norm of the HBM residual relative to the norm of the unknowns"),
    Variable(
        "time_residual",
        ("point",),
        "largest residual in time of the equations of the stop degrees of freedom relative to the largest restoring force",
    ),
    Variable(
        "truncation", ("point",), "share of the mean square of x'' or f carried by the top tenth of the harmonics"
    ),
    Variable("step", ("point",), "index of the ANM step that produced the point"),
    Variable(
        "branch_point",
        ("point",),
        "1 where a simple branch point (sign change of det [J; t^T]) lies within the ANM step that ends at this point",
        flags=("regular", "branch_point"),
    ),
    Variable(
        "energy_fold",
        ("point",),
        "1 where the energy has a local extremum along the branch (within its segment)",
        flags=("regular", "fold"),
    ),
    Variable(
        "segment",
        ("point",),
        "segment of the branch: 0 from the linear mode, k > 0 the backbone beyond the k-th internal resonance tongue passed (see passed_resonance_*)",
    ),
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
    *STABILITY_VARIABLES,
    Variable("point", ("point",), "index of the point along the branch"),
    Variable("dof", ("dof",), "index of the degree of freedom"),
    Variable("stop", ("stop",), "index of the stop"),
    Variable("harmonic", ("harmonic",), "harmonic number k (0 is the mean)"),
    Variable(
        "dof_label", ("dof",), "degree of freedom: w<node> displacement over gap, theta<node> rotation over gap/length"
    ),
    Variable("node", ("node",), "index of the finite-element node"),
    Variable("node_coordinate", ("node",), "position of the node along the tube over its length"),
)
STRUCTURE_BRANCH = DatasetKind(
    "structure_branch",
    "Regularized NNM branch of a structure (HBM + ANM)",
    ("tube/nnm*.nc", "tube/study/gap*_k*nc"),
    "A regularized NNM of a structure with stops (the finite-element tube, its parameter study): Fourier coefficients of every degree of freedom and stop force, diagnostics, located branch points and folds, resonance tongues passed, Floquet stability.",
    STRUCTURE_BRANCH_VARIABLES,
)


TUBE_COMPARISON_VARIABLES = (
    Variable("exact_frequency", ("energy",), "frequency of the exact non-smooth orbit", units="Hz"),
    Variable("regularized_frequency", ("energy",), "frequency of the regularized HBM orbit", units="Hz"),
    Variable("relative_difference", ("energy",), "(regularized - exact) / exact frequency"),
    Variable("energy", ("energy",), "matched total energy"),
)
TUBE_COMPARISON = DatasetKind(
    "tube_comparison",
    "Exact against regularized NNM1 of the tube",
    ("tube/nnm*_exact_vs_regularized.nc",),
    "Frequencies of the exact non-smooth and the regularized NNM1 of the tube where each branch first reaches log-spaced energies of their common range.",
    TUBE_COMPARISON_VARIABLES,
)

KINDS = (
    TUBE_EXACT_FAMILY,
    STRUCTURE_BRANCH,
    TUBE_COMPARISON,
)
