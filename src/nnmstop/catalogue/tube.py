"""Dataset kinds of any structure beyond its branches, the tube's included (see :mod:`nnmstop.catalogue`).

The tube's regularized branches have the one branch schema (:mod:`.branch`, kind ``nnm_branch``); here are
the exact NNM1 of a non-smooth structure with one impact per stop side and its comparison with the
regularized NNM1 (:mod:`nnmstop.tasks.structure`).
"""

from nnmstop.catalogue import DatasetKind, Variable

ONE_IMPACT_FAMILY_VARIABLES = (
    Variable("energy", ("orbit",), "total energy of the non-smooth model"),
    Variable("frequency", ("orbit",), "frequency 1/T in Hz of the nondimensional time", units="Hz"),
    Variable("contact_time", ("orbit",), "contact duration of the quarter period"),
    Variable("x_max", ("orbit",), "largest displacement at the stop over its gap"),
    Variable("initial_velocity", ("orbit", "dof"), "velocities at q = 0 (start of the orbit)"),
    Variable("orbit", ("orbit",), "index of the orbit along the family"),
    Variable("dof", ("dof",), "index of the degree of freedom"),
    Variable("dof_label", ("dof",), "name of the degree of freedom"),
)
ONE_IMPACT_FAMILY = DatasetKind(
    "one_impact_family",
    "Exact NNM1 of a structure, one impact per stop side",
    ("tube/exact_nnm1.nc", "exact/nnm1_one_impact.nc"),
    "Exact periodic orbits of a non-smooth (piecewise-linear) structure with one impact on each side of its stop "
    "per period, from the grazing orbit of its first linear mode (closed-form phases, `nnmstop.exact.ndof`); "
    "`end_reason` says which assumption of the family fails at its end.",
    ONE_IMPACT_FAMILY_VARIABLES,
)


ONE_IMPACT_COMPARISON_VARIABLES = (
    Variable("exact_frequency", ("energy",), "frequency of the exact non-smooth orbit", units="Hz"),
    Variable("regularized_frequency", ("energy",), "frequency of the regularized HBM orbit", units="Hz"),
    Variable("relative_difference", ("energy",), "(regularized - exact) / exact frequency"),
    Variable("energy", ("energy",), "matched total energy"),
)
ONE_IMPACT_COMPARISON = DatasetKind(
    "one_impact_comparison",
    "Exact against regularized NNM1 of a structure",
    ("tube/nnm*_exact_vs_regularized.nc", "compare/nnm1_one_impact.nc"),
    "Frequencies of the exact non-smooth and the regularized NNM1 where each branch first reaches log-spaced energies "
    "of their common range.",
    ONE_IMPACT_COMPARISON_VARIABLES,
)

KINDS = (ONE_IMPACT_FAMILY, ONE_IMPACT_COMPARISON)
