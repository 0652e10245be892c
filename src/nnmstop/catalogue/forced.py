"""Dataset kinds of the forced responses (issue 23; see :mod:`nnmstop.catalogue` and docs/forced.md)."""

from nnmstop.catalogue import DatasetKind, Variable
from nnmstop.catalogue.branch import wear_variables
from nnmstop.forced.stability_changes import KINDS as CHANGE_KINDS
from nnmstop.forced.stability_changes import REGIMES

RESPONSE_VARIABLES = (
    Variable("frequency", ("point",), "frequency of the force and of the periodic response", units="Hz"),
    Variable("x_amplitude", ("point",), "largest |q| over the period of the DOF of the first stop (x)"),
    Variable("u_amplitude", ("point",), "largest |q| over the period of the first forced DOF (u)"),
    Variable("amplitude", ("point", "dof"), "largest |q| over the period of each degree of freedom"),
    Variable(
        "phase_lag",
        ("point", "dof"),
        "lag of the fundamental harmonic of each DOF behind the force cos(Omega t) (90 at phase resonance)",
        units="degree",
    ),
    Variable(
        "stable", ("point",), "Floquet stability: all multipliers inside the unit circle", flags=("unstable", "stable")
    ),
    Variable("multiplier_real", ("point", "multiplier"), "real part of the Floquet multipliers over one period"),
    Variable("multiplier_imag", ("point", "multiplier"), "imaginary part of the Floquet multipliers over one period"),
    Variable(
        "regime",
        ("point",),
        "what the response is where the periodic one is unstable (no periodic response claimed where it is not stable)",
        flags=REGIMES,
    ),
    Variable("segment", ("point",), "index of the continued piece of the response"),
    Variable(
        "stability_margin",
        ("point",),
        "distance of the multipliers to the unit circle (min | |mu| - 1 |): how far the verdict and the number of "
        "multipliers outside the circle are from changing",
    ),
    Variable(
        "stability_resolved",
        ("point",),
        "stability verdict resolved (1): stability_margin larger than the resolution factor (attribute "
        "stability_resolution_factor) times the multipliers' error estimates",
        flags=("unresolved", "resolved"),
    ),
    Variable("dof_label", ("dof",), "name of the degree of freedom"),
    Variable("change_frequency", ("change",), "frequency of the located stability change", units="Hz"),
    Variable("change_amplitude", ("change", "dof"), "largest |q| of each DOF at the located stability change"),
    Variable("change_kind", ("change",), "kind of the located stability change", flags=CHANGE_KINDS),
)


def _wear(law: str) -> tuple:
    """The wear of every response orbit at every stop (nnmstop.wear), optional: datasets written before it lack it."""
    return tuple(Variable(v.name, v.dims, v.long_name, optional=True) for v in wear_variables(("point", "stop"), law))


FORCED_EXACT = DatasetKind(
    "forced_exact",
    "Exact forced response of the non-smooth system",
    ("forced/exact_F<F>.nc",),
    "Periodic responses of the damped structure with piecewise-linear stops to F cos(Omega t) on the forced "
    "DOFs: the non-impacting (linear) response and the responses with one contact per grazing contact per period "
    "(symmetric under odd laws, over full periods otherwise), in closed form per phase (nnmstop.exact.forced); "
    "multipliers from the products of the phase exponentials.",
    RESPONSE_VARIABLES
    + (
        Variable(
            "contact_unknowns",
            ("contact_point", "unknown"),
            "unknowns of the one-contact responses: state (q, qdot) entering the right stop, its phase Omega t, "
            "the phase duration of the contact, Omega",
            optional=True,
        ),
        Variable(
            "contact_struck",
            ("contact_point",),
            "contact (index of the structure's half-space contacts, contact_stop) that a one-contact response "
            "with several stops strikes each half period",
            optional=True,
        ),
        Variable("contact_point_index", ("contact_point",), "index of the point of the response", optional=True),
        Variable(
            "switch_state",
            ("contact_point", "state"),
            "state (q, qdot) at the first switch of the period of a full-period response (no symmetry assumed)",
            optional=True,
        ),
        Variable("switch_point", ("switch",), "index of the contact point the switch belongs to", optional=True),
        Variable("switch_phase", ("switch",), "phase Omega t (mod 2 pi) of the switch", units="rad", optional=True),
        Variable(
            "switch_contact",
            ("switch",),
            "index of the half-space contact entered or left (dimension contact)",
            optional=True,
        ),
        Variable(
            "switch_entry",
            ("switch",),
            "whether the contact is entered or left",
            flags=("exit", "entry"),
            optional=True,
        ),
        Variable("contact_stop", ("contact",), "index of the stop of the half-space contact", optional=True),
        Variable(
            "contact_side",
            ("contact",),
            "side of the half-space contact: +1 where the stop's coordinate exceeds its gap, -1 where it is below "
            "minus its gap",
            optional=True,
        ),
        Variable(
            "multiplier_error",
            ("point",),
            "difference of the multipliers from the eigen-decomposed phase exponentials and from scipy's expm "
            "(error estimate)",
        ),
    )
    + _wear("piecewise-linear law of the stop, on the exact orbit"),
)

FORCED_REGULARIZED = DatasetKind(
    "forced_regularized",
    "Regularized forced response by harmonic balance",
    ("forced/regularized_F<F>.nc", "forced/regularized_tube_F<F>.nc"),
    "Periodic responses of the damped structure with the regularized stop law to F cos(Omega t), by harmonic "
    "balance and the ANM (nnmstop.hbm.forced); multipliers of the damped variational equation (nnmstop.floquet).",
    RESPONSE_VARIABLES
    + (
        Variable("harmonic", ("harmonic",), "harmonic number"),
        Variable("q_cos", ("point", "dof", "harmonic"), "cosine coefficients of the displacements in Omega t"),
        Variable("q_sin", ("point", "dof", "harmonic"), "sine coefficients of the displacements in Omega t"),
        Variable("f_cos", ("point", "stop", "harmonic"), "cosine coefficients of the regularized contact force / gap"),
        Variable("f_sin", ("point", "stop", "harmonic"), "sine coefficients of the regularized contact force / gap"),
        Variable("z_cos", ("point", "stop", "harmonic"), "cosine coefficients of the auxiliary z of the recast"),
        Variable("z_sin", ("point", "stop", "harmonic"), "sine coefficients of the auxiliary z of the recast"),
        Variable(
            "truncation", ("point",), "share of the mean square of x'' or f carried by the top tenth of the harmonics"
        ),
        Variable(
            "time_residual",
            ("point",),
            "largest residual in time of the equations of the stop DOFs relative to the largest restoring force",
        ),
        Variable("step", ("point",), "index of the ANM step that produced the point"),
        Variable(
            "multiplier_error",
            ("point",),
            "largest change of a Floquet multiplier between the last two Magnus step counts (error estimate)",
        ),
        Variable(
            "stability_orbit_error",
            ("point",),
            "estimate of the change of the largest multiplier modulus due to the HBM orbit's own error "
            "(time_residual x max(1, max |mu|))",
        ),
        Variable("stability_steps", ("point",), "Magnus steps per period of the kept multipliers"),
    )
    + _wear("regularized law of the stop"),
)

FORCED_BACKBONE = DatasetKind(
    "forced_backbone",
    "NNM backbones and the resonance peaks they predict",
    ("forced/backbone.nc", "atlas/<map>_backbone.nc"),
    "NNM1 and NNM2 of the regularized oscillator (HBM + ANM) over the forced range with the force whose resonance "
    "peak each orbit is (energy balance), and the peaks predicted at each force level (nnmstop.forced.backbone).",
    (
        Variable("backbone_frequency", ("point",), "frequency of the NNM orbit", units="Hz"),
        Variable("backbone_amplitude", ("point", "dof"), "largest |q| of each DOF over the NNM orbit"),
        Variable("backbone_mode", ("point",), "index of the NNM"),
        Variable(
            "required_force",
            ("point",),
            "force amplitude whose resonance peak is the NNM orbit (damping work = work of the force in quadrature)",
        ),
        Variable("forcing_amplitude", ("level",), "force amplitude F"),
        Variable("mode", ("mode",), "index of the NNM"),
        Variable(
            "predicted_frequency",
            ("level", "mode"),
            "frequency of the resonance peak predicted by the backbone",
            units="Hz",
            missing="where the computed backbone does not reach the force level",
        ),
        Variable(
            "predicted_amplitude",
            ("level", "mode", "dof"),
            "largest |q| of each DOF at the predicted resonance peak",
            missing="where the computed backbone does not reach the force level",
        ),
        Variable("dof_label", ("dof",), "name of the degree of freedom"),
    ),
)

FORCED_PREDICTION = DatasetKind(
    "forced_prediction",
    "The backbone's prediction of the resonance peak against the damping",
    ("forced/prediction_error.nc",),
    "At damping ratios going to zero with the force in proportion (one backbone orbit predicts every peak): the "
    "peak of NNM1 predicted by the energy balance on the regularized backbone and the peak of the regularized "
    "response located on its ANM steps (nnmstop.forced.backbone.prediction_errors), their relative errors and "
    "the phase lag at the peak.",
    (
        Variable("damping_ratio", ("level",), "damping ratio of both linear modes (Rayleigh damping)"),
        Variable("forcing_amplitude", ("level",), "force amplitude F (proportional to the damping ratio)"),
        Variable("predicted_frequency", ("level",), "frequency of the peak predicted by the backbone", units="Hz"),
        Variable("peak_frequency", ("level",), "frequency of the located peak of the response", units="Hz"),
        Variable("predicted_amplitude", ("level", "dof"), "largest |q| of each DOF at the predicted peak"),
        Variable("peak_amplitude", ("level", "dof"), "largest |q| of each DOF at the located peak"),
        Variable(
            "frequency_error", ("level",), "relative error of the predicted peak frequency: |f_pred - f_peak| / f_pred"
        ),
        Variable(
            "amplitude_error",
            ("level",),
            "relative error of the predicted peak amplitude of the stop DOF: |a_pred - a_peak| / a_pred",
        ),
        Variable(
            "peak_phase_lag",
            ("level", "dof"),
            "lag of each DOF's fundamental behind the force at the peak",
            units="degree",
        ),
        Variable("dof_label", ("dof",), "name of the degree of freedom"),
    ),
)

KINDS = (FORCED_EXACT, FORCED_REGULARIZED, FORCED_BACKBONE, FORCED_PREDICTION)
