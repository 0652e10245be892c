"""Dataset kinds of any structure beyond its branches, the tube's included (see :mod:`nnmstop.catalogue`).

The tube's regularized branches have the one branch schema (:mod:`.branch`, kind ``nnm_branch``), the exact
NNM1 of a non-smooth structure with one impact per stop side the kind ``one_stop_family`` of :mod:`.exact`;
here is their comparison (:mod:`nnmstop.tasks.structure`).
"""

from nnmstop.catalogue import DatasetKind, Variable

ONE_IMPACT_COMPARISON_VARIABLES = (
    Variable("exact_frequency", ("energy",), "frequency of the exact non-smooth orbit", units="Hz"),
    Variable("regularized_frequency", ("energy",), "frequency of the regularized HBM orbit", units="Hz"),
    Variable(
        "relative_difference",
        ("energy",),
        "(regularized - exact) / exact frequency",
        missing="where the regularized orbit is no counterpart of the exact one",
        reason="no_counterpart",
    ),
    Variable(
        "no_counterpart",
        ("energy",),
        "1 where the regularized NNM1 first reaches the energy on orbits not of the exact family's type (not NNM1 at "
        "its own frequency: an internal resonance tongue, another NNM seen at 1/n; or striking another stop): not "
        "compared",
        flags=("counterpart", "no_counterpart"),
    ),
    Variable(
        "exact_interpolation_error",
        ("energy",),
        "estimated error of the exact frequency, interpolated linearly between the family's stored orbits",
        units="Hz",
    ),
    Variable(
        "regularized_interpolation_error",
        ("energy",),
        "estimated error of the regularized frequency, interpolated linearly between the branch's stored orbits",
        units="Hz",
    ),
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

KINDS = (ONE_IMPACT_COMPARISON,)
