"""Dataset kinds of the compare datasets (see :mod:`nnmstop.catalogue`)."""

from dataclasses import replace

from nnmstop.catalogue import DatasetKind, Variable

EXACT_VS_REGULARIZED_VARIABLES = (
    Variable("frequency_exact", ("point",), "frequency 1/T of the exact (non-smooth) orbit", units="Hz"),
    Variable("frequency_regularized", ("point",), "frequency omega/(2 pi) of the regularized HBM orbit", units="Hz"),
    Variable(
        "frequency_difference",
        ("point",),
        "frequency of the regularized orbit minus frequency of the exact orbit",
        units="Hz",
    ),
    Variable(
        "relative_frequency_difference", ("point",), "frequency difference (regularized minus exact) over the exact one"
    ),
    Variable(
        "max_x_difference",
        ("point",),
        "largest |x_regularized - x_exact| over the period, on the phase t/T aligned at the turning point in contact",
    ),
    Variable(
        "max_u_difference",
        ("point",),
        "largest |u_regularized - u_exact| over the period, on the phase t/T aligned at the turning point in contact",
    ),
    Variable(
        "max_xdot_difference",
        ("point",),
        "largest |xdot_regularized - xdot_exact| over the period, on the phase t/T aligned at the turning point in contact",
    ),
    Variable(
        "max_udot_difference",
        ("point",),
        "largest |udot_regularized - udot_exact| over the period, on the phase t/T aligned at the turning point in contact",
    ),
    Variable(
        "max_force_difference",
        ("point",),
        "largest |f_HBM - f_piecewise(x_exact)|: regularized contact force from its Fourier coefficients vs the piecewise-linear law (Eq. 4) evaluated on the exact orbit, over the period, on the phase t/T aligned at the turning point in contact",
    ),
    Variable("x_max_exact", ("point",), "maximum of x over the exact orbit"),
    Variable("u_max_exact", ("point",), "maximum of |u| over the exact orbit"),
    Variable("force_max_exact", ("point",), "maximum of the piecewise-linear contact force over the exact orbit"),
    Variable(
        "regularized_origin_shift",
        ("point",),
        "shift of the time origin of the HBM cosine series, in periods, that puts its turning point in contact at t = 0 (0: it is at t = 0; 0.5: at t = T/2)",
    ),
    Variable(
        "exact_energy", ("point",), "total energy of the exact orbit (piecewise model), computed from its unknowns"
    ),
    Variable(
        "regularized_energy", ("point",), "total energy of the regularized HBM orbit (regularized model), period mean"
    ),
    Variable("exact_residual", ("point",), "norm of the quarter-period equations of the exact orbit"),
    Variable("regularized_residual", ("point",), "norm of the HBM residual relative to the norm of the unknowns"),
    Variable(
        "interpolation_coefficient_shift",
        ("point",),
        "largest difference between the matched HBM unknowns and their linear interpolation in energy between the neighbouring branch points (error that interpolation alone would add; not present in this comparison)",
    ),
    Variable(
        "interpolation_frequency_shift",
        ("point",),
        "frequency of the linear interpolation between neighbouring branch points minus frequency of the matched HBM orbit (error that interpolation alone would add; not present in this comparison)",
        units="Hz",
    ),
    Variable(
        "regularized_energy_spread",
        ("point",),
        "relative variation over the period of the energy of the regularized HBM orbit (HBM truncation)",
    ),
    Variable("exact_xdot0", ("point",), "exact orbit: velocity of x at x = u = 0"),
    Variable("exact_udot0", ("point",), "exact orbit: velocity of u at x = u = 0"),
    Variable("exact_tau1", ("point",), "exact orbit: free-flight duration tau1 of the quarter period"),
    Variable("exact_T1", ("point",), "exact orbit: quarter period T1 (the turning point, t = 0 of the aligned phase)"),
    Variable(
        "marked",
        ("point",),
        "labelled point of the paper's Figs 2-4 (0: not labelled)",
        flags=("none", "point_a", "point_b"),
    ),
    Variable(
        "q_cos",
        ("point", "dof", "harmonic"),
        "regularized orbit: cosine Fourier coefficients of the degrees of freedom",
    ),
    Variable(
        "q_sin", ("point", "dof", "harmonic"), "regularized orbit: sine Fourier coefficients of the degrees of freedom"
    ),
    Variable(
        "f_cos", ("point", "stop", "harmonic"), "regularized orbit: cosine Fourier coefficients of the stop force f"
    ),
    Variable(
        "f_sin", ("point", "stop", "harmonic"), "regularized orbit: sine Fourier coefficients of the stop force f"
    ),
    Variable(
        "z_cos", ("point", "stop", "harmonic"), "regularized orbit: cosine Fourier coefficients of internal variable z"
    ),
    Variable(
        "z_sin", ("point", "stop", "harmonic"), "regularized orbit: sine Fourier coefficients of internal variable z"
    ),
    Variable("omega_squared", ("point",), "regularized orbit: squared angular frequency"),
    Variable("point", ("point",), "index of the compared energy"),
    Variable("harmonic", ("harmonic",), "harmonic number k (0 is the mean)"),
    Variable("dof", ("dof",), "index of the degree of freedom"),
    Variable("dof_label", ("dof",), "name of the degree of freedom"),
    Variable("stop", ("stop",), "index of the stop"),
    Variable("energy", ("point",), "matched total energy of the exact and regularized orbits"),
)
#: The differences of a pair exist between like orbits only (``counterpart`` 0): missing otherwise.
_BETWEEN_LIKE_ORBITS = (
    "frequency_difference", "relative_frequency_difference", "max_x_difference", "max_u_difference",
    "max_xdot_difference", "max_udot_difference", "max_force_difference", "x_max_exact", "u_max_exact",
    "force_max_exact", "regularized_origin_shift",
)  # fmt: skip
EXACT_VS_REGULARIZED_VARIABLES = tuple(
    replace(v, missing="where the regularized orbit is no counterpart of the exact one", reason="counterpart")
    if v.name in _BETWEEN_LIKE_ORBITS
    else v
    for v in EXACT_VS_REGULARIZED_VARIABLES
) + (
    Variable(
        "counterpart",
        ("point",),
        "whether the regularized orbit is of the exact orbit's type: as many contacts per period with the stop "
        "(regularized_contacts_per_period, exact_impacts_per_period) and the same dominant and tongue harmonics "
        "(nnmstop.compare.matching.orbit_types); only then are they compared",
        flags=("counterpart", "other_contacts", "other_harmonic_content"),
    ),
    Variable("exact_impacts_per_period", ("point",), "excursions of x beyond the stops per period, exact orbit"),
    Variable(
        "regularized_contacts_per_period",
        ("point",),
        "excursions of x into the contact transition of the regularized law, |x| > 1 - sqrt(2 eta / alpha), per period, "
        "regularized orbit",
    ),
    Variable(
        "exact_dominant_harmonic", ("point",), "harmonic of largest share of the mass-weighted motion, exact orbit"
    ),
    Variable(
        "regularized_dominant_harmonic",
        ("point",),
        "harmonic of largest share of the mass-weighted motion, regularized orbit",
    ),
    Variable(
        "exact_tongue_harmonic",
        ("point",),
        "harmonic n >= 2 holding more than a tenth of the exact orbit's motion while the first dominates (0: none)",
    ),
    Variable(
        "regularized_tongue_harmonic",
        ("point",),
        "harmonic n >= 2 holding more than a tenth of the regularized orbit's motion while the first dominates (0: none)",
    ),
)

EXACT_VS_REGULARIZED = DatasetKind(
    "exact_vs_regularized",
    "Exact against regularized NNM1 at matched energies",
    ("compare/nnm1_exact_vs_regularized.nc",),
    "Exact (non-smooth) and regularized NNM1 orbits compared at log-spaced energies of their common two-impact range (Figs 2-4): frequencies, orbit and contact-force differences on a common phase grid (`docs/methods/compare.md`).",
    EXACT_VS_REGULARIZED_VARIABLES,
)


REGIME_ERRORS_VARIABLES = (
    Variable("impacts_per_period", ("regime",), "number of excursions of x beyond the stops (|x| > 1) per period"),
    Variable(
        "exact_sequence",
        ("regime",),
        "phase sequence(s) of the exact orbits of the regime (F free flight, R/L contact with the stop x = 1 / x = -1, over the quarter period; see nnmstop.exact.sequences)",
    ),
    Variable("exact_energy_min", ("regime",), "lowest energy of the exact regime (non-smooth model)"),
    Variable("exact_energy_max", ("regime",), "highest energy of the exact regime (non-smooth model)"),
    Variable("regularized_energy_min", ("regime",), "lowest energy of the regularized regime"),
    Variable("regularized_energy_max", ("regime",), "highest energy of the regularized regime"),
    Variable("exact_frequency_min", ("regime",), "lowest frequency of the exact regime", units="Hz"),
    Variable("exact_frequency_max", ("regime",), "highest frequency of the exact regime", units="Hz"),
    Variable("regularized_frequency_min", ("regime",), "lowest frequency of the regularized regime", units="Hz"),
    Variable("regularized_frequency_max", ("regime",), "highest frequency of the regularized regime", units="Hz"),
    Variable("n_matched", ("regime",), "number of regularized orbits of the regime compared with the exact branch"),
    Variable(
        "n_unmatched",
        ("regime",),
        "number of regularized orbits of the regime left out: energy outside every monotone piece of the exact regime",
    ),
    Variable(
        "max_abs_frequency_error",
        ("regime",),
        "largest |regularized - exact frequency| over the compared orbits of the regime",
        units="Hz",
    ),
    Variable("energy_at_max_error", ("regime",), "regularized energy where max_abs_frequency_error occurs"),
    Variable(
        "median_abs_frequency_error",
        ("regime",),
        "median of |regularized - exact frequency| over the compared orbits of the regime",
        units="Hz",
    ),
    Variable(
        "mean_frequency_error",
        ("regime",),
        "mean of (regularized - exact frequency) over the compared orbits of the regime",
        units="Hz",
    ),
    Variable(
        "max_rel_frequency_error",
        ("regime",),
        "largest |regularized - exact frequency| / exact frequency over the compared orbits of the regime",
    ),
    Variable(
        "regularized_index", ("point",), "index of the orbit in the regularized branch dataset (its dimension point)"
    ),
    Variable("energy", ("point",), "energy of the regularized orbit (the matched energy)"),
    Variable("frequency", ("point",), "frequency of the regularized orbit, Hz of the nondimensional time", units="Hz"),
    Variable(
        "exact_frequency",
        ("point",),
        "frequency of the exact orbit at the same energy (linear interpolation in ln E on the exact regime; of several exact orbits at that energy, the one of nearest frequency)",
        units="Hz",
    ),
    Variable("frequency_error", ("point",), "regularized minus exact frequency at the regularized energy", units="Hz"),
    Variable("relative_frequency_error", ("point",), "frequency_error / exact_frequency"),
    Variable("point_regime", ("point",), "index of the regime (dimension regime) of the compared orbit"),
    Variable("regime", ("regime",), "index of the pair of impact regimes, in branch order"),
    Variable("point", ("point",), "index of the compared regularized orbit"),
)
REGIME_ERRORS = DatasetKind(
    "regime_errors",
    "Regularization error of NNM1 per impact regime",
    ("compare/nnm1_regimes.nc",),
    "Both NNM1 branches cut into runs of equal impact count, paired in branch order; every regularized orbit compared with the exact frequency at its energy; per-regime statistics (dimension `regime`) and per-orbit errors (dimension `point`).",
    REGIME_ERRORS_VARIABLES,
)


STABILITY_COMPARISON_VARIABLES = (
    Variable("impacts_per_period", ("regime",), "number of excursions of x beyond the stops (|x| > 1) per period"),
    Variable(
        "exact_sequence",
        ("regime",),
        "phase sequence(s) of the exact orbits of the regime (see nnmstop.exact.sequences)",
    ),
    Variable(
        "n_compared", ("regime",), "regularized orbits of the regime with a verdict on both sides at the same energy"
    ),
    Variable("n_agree", ("regime",), "compared orbits where the exact and regularized verdicts agree"),
    Variable("n_both_stable", ("regime",), "compared orbits stable in both models"),
    Variable("n_both_unstable", ("regime",), "compared orbits unstable in both models"),
    Variable("n_exact_stable_only", ("regime",), "compared orbits stable in the exact model only"),
    Variable("n_regularized_stable_only", ("regime",), "compared orbits stable in the regularized model only"),
    Variable(
        "n_no_regularized_verdict", ("regime",), "matched regularized orbits without a verdict (stability_resolved = 0)"
    ),
    Variable(
        "n_at_exact_change", ("regime",), "matched regularized orbits whose energy falls at an exact stability change"
    ),
    Variable("agreement", ("regime",), "n_agree / n_compared (1 when nothing is compared)"),
    Variable(
        "disagreement_energies",
        ("regime",),
        "energy intervals (regularized energies, branch order) of consecutive compared orbits whose verdicts differ",
    ),
    Variable("n_exact_changes", ("regime",), "stability changes along the exact regime"),
    Variable(
        "n_regularized_changes",
        ("regime",),
        "stability changes along the regularized regime (orbits without a verdict skipped)",
    ),
    Variable(
        "exact_change_energies",
        ("regime",),
        "energies of the exact stability changes (geometric mean of the bracketing orbits)",
    ),
    Variable("regularized_change_energies", ("regime",), "energies of the regularized stability changes (same)"),
    Variable("change_regime", ("paired_change",), "index of the regime (dimension regime) of the paired change"),
    Variable("change_exact_energy", ("paired_change",), "energy of the exact stability change"),
    Variable("change_regularized_energy", ("paired_change",), "energy of the regularized stability change"),
    Variable("change_exact_frequency", ("paired_change",), "frequency of the exact stability change", units="Hz"),
    Variable(
        "change_regularized_frequency", ("paired_change",), "frequency of the regularized stability change", units="Hz"
    ),
    Variable("change_energy_ratio", ("paired_change",), "regularized over exact energy of the paired change"),
    Variable(
        "change_becomes_stable",
        ("paired_change",),
        "direction of the change in branch order",
        flags=("becomes_unstable", "becomes_stable"),
    ),
    Variable("regime", ("regime",), "index of the pair of impact regimes, in branch order"),
    Variable("paired_change", ("paired_change",), "index of the paired stability change"),
)
STABILITY_COMPARISON = DatasetKind(
    "stability_comparison",
    "Exact against regularized stability verdicts of NNM1",
    ("compare/nnm1_stability.nc",),
    "Stability verdicts of the regularized NNM1 against the exact orbits at the same energy, per impact regime, and the stability changes of each branch.",
    STABILITY_COMPARISON_VARIABLES,
)

NO_COMPARISON = DatasetKind(
    "no_comparison",
    "Exact against regularized NNM1: nothing to compare",
    ("compare/nnm1_exact_vs_regularized.nc",),
    "The exact two-impact family and the regularized NNM1 share no energy where both are compared (for example where "
    "few harmonics end the regularized branch before grazing): no point; `end_reason` says why, and Figs 2-4 say so.",
    tuple(
        v
        for v in EXACT_VS_REGULARIZED_VARIABLES
        if v.name in ("frequency_exact", "frequency_regularized", "marked", "point", "energy")
    ),
)

KINDS = (
    EXACT_VS_REGULARIZED,
    NO_COMPARISON,
    REGIME_ERRORS,
    STABILITY_COMPARISON,
)
