"""What the verifier keeps of a build (``reference/``) and how it reads a dataset, variable by variable.

A dataset of the pipeline is read by the verifier through :func:`profile`, for any schema:

* its global attributes (without provenance), its dimensions, and each variable's dimensions,
  type and attributes;
* the variables along the stored points (dimension ``point``) of a file that holds a
  frequency-energy curve (:data:`CURVE_COORDINATES`), each by its kind (:func:`variable_kind`):
  ``discrete`` values (flags, counts, labels), ``stability`` verdicts, ``marker`` flags of the
  stored points next to an event, ``accuracy`` estimates (residuals, errors), ``sampling`` values
  that follow the continuation's steps (indices, step counts), and ``smooth`` quantities, among
  them the orbits (variables with a ``harmonic`` dimension, one *fingerprint* per signal: the
  norm of its harmonics weighted by ``1 + k**4``, so that a change of any harmonic counts);
* the other variables (located points, regimes, coordinates) whole.

The reference (:func:`write_reference`) stores per curve file one CSV row per stored point:
energy, frequency, step and stage numbers, the discrete, stability and marker values, and two
*projections*: ``orbit`` and ``quantities``, weighted sums of every orbit fingerprint and every
smooth quantity, each divided by its largest magnitude on the reference curve (weights from a
hash of the name). Any change of any of them moves a projection; storing every smooth variable at
every point would make ``reference/`` ten times larger. Per smooth variable ``files.json`` keeps
its range (least and largest value and largest change between neighbouring points), which names
the variable of a change along the whole curve; per accuracy estimate its largest value.
Method: docs/reproducibility.md.
"""

from __future__ import annotations

import csv
import hashlib
import json
import re
from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop.netcdf import PROVENANCE_ATTRIBUTES, may_be_missing

__all__ = [
    "CURVE_COORDINATES",
    "SAMPLED_DIMENSIONS",
    "STUDY_KINDS",
    "not_compared",
    "unverified_variables",
    "STABILITY_ERROR_VARIABLES",
    "weight",
    "array_fingerprint",
    "fingerprint_sums",
    "REFERENCE_FORMAT",
    "variable_kind",
    "attribute_kind",
    "curve_coordinates",
    "profile",
    "point_table",
    "json_value",
    "share",
    "projections",
    "projected_columns",
    "PROJECTIONS",
    "write_csv",
    "read_csv",
]

REFERENCE_FORMAT = 3
POINT = "point"

#: Pairs (energy, frequency) that make a file's stored points a frequency-energy curve, first found first. A
#: forced response is a curve of the stop DOF's amplitude against the frequency of the force, a backbone one of
#: the force whose peak each NNM orbit is against the orbit's frequency: there the first of the pair plays the
#: role of the energy (positive, compared in logarithm).
CURVE_COORDINATES = (
    ("energy", "frequency"),
    ("energy", "frequency_regularized"),
    ("x_amplitude", "frequency"),
    ("required_force", "backbone_frequency"),
)
#: Dimensions of variables kept at some of the stored points only (the exact forced response's contact points,
#: ``contact_point``, and the switches of the full-period ones, ``switch``): their sizes follow the steps like the
#: points'. Their values are checked by the verifier against the points they belong to, whose variables
#: (frequency, amplitudes, phase lags, multipliers) are compared along the curve: each contact state must solve its
#: equations and reproduce its point's frequency and amplitudes by the closed-form flow
#: (:mod:`nnmstop.stored_accuracy`).
SAMPLED_DIMENSIONS = frozenset({"contact_point", "switch"})

#: Variables that follow the continuation's steps, not the curve: not compared (indices of stored
#: points, step numbers and counts of integration steps, arclength summed over the steps).
SAMPLING_VARIABLES = frozenset(
    {
        "point",
        "step",
        "stability_steps",
        "regularized_index",
        "branch_point_flagged_point",
        "fold_point",
        "arclength",
        # a passed tongue (nnmstop.hbm.tongues): the energy of the stored point that ended the segment where the
        # frequency had fallen from its maximum (flat there: the energy moves with the steps), and where the predictor
        # over the tongue, of a length doubled from the chord of the last stored points, was corrected
        "passed_resonance_energy",
        "passed_resonance_landing_frequency",
        # where an orbit's identity changes (nnmstop.hbm.identity): the first stored point past a harmonic share's
        # threshold, so its index, energy and frequency follow the steps; the identity of every point is compared
        # along the curve
        "identity_change_point",
        "identity_change_energy",
        "identity_change_frequency",
    }
)
#: Measurements of the machine that ran the build (the study's run times, CPU times and load averages): they
#: change from run to run and are not compared; the study's figures draw them as what they are.
MEASUREMENT_PATTERN = re.compile(r"(runtime|cpu_time|load_average|seconds)")
#: Counts of the continuation's work in the study's datasets (steps, factorizations, Newton iterations, orbits of
#: a family): they follow the step sequence, which moves with round-off; the curves they come from are compared.
STEP_COUNT_PATTERN = re.compile(r"^(anm_|ratio_)?(steps|factorizations|newton_iterations|exact_orbits)$")
#: Dataset kinds of the study (``snakemake study``): every case on a grid, no curve.
STUDY_KINDS = frozenset({"error_vs_runtime", "stiff_cases"})


def not_compared(name: str, ds: xr.Dataset) -> str:
    """Why the verifier does not compare the values of variable ``name`` of a study dataset ("" when it does):
    a measurement of the machine (:data:`MEASUREMENT_PATTERN`) or a count of the continuation's work
    (:data:`STEP_COUNT_PATTERN`)."""
    if ds.attrs.get("dataset_kind") not in STUDY_KINDS:
        return ""
    if MEASUREMENT_PATTERN.search(name):
        return "a measurement of the machine that ran the build (run time, load)"
    if STEP_COUNT_PATTERN.match(name):
        return "counts the continuation's work, which follows its steps, not the curve"
    return ""


#: Flags of the stored points next to an event (a branch point, a fold, a grazing, a marked orbit): which
#: stored point carries the flag follows the steps; compared as events along the curve.
MARKER_VARIABLES = frozenset({"branch_point", "energy_fold", "grazing", "marked"})
#: Stability verdicts: compared outside the band of a change of verdict or resolution.
STABILITY_VARIABLES = frozenset(
    {"stable", "stability_resolved", "stability_reason", "stability_refined", "regime"}  # regime: forced responses
)
#: Stability numbers (Floquet multipliers and what is made of them): where two multipliers collide (a change
#: of stability) they vary as a square root along the curve and cannot be interpolated; compared outside
#: the band of a change, like the verdicts.
STABILITY_VALUE_PATTERN = re.compile(
    r"^(multiplier_\w+|max_multiplier|floquet_invariant|trace_invariant|stability_margin)$"
)
#: Values interpolated between the stored orbits of another file (the regime dataset's exact frequencies and
#: frequency errors): accurate to that interpolation, not to the orbits; compared by their ranges.
INTERPOLATED_VARIABLES = frozenset({"exact_frequency", "frequency_error", "relative_frequency_error"})
#: A smooth quantity whose largest magnitude on the reference curve is below this is zero up to round-off
#: (a share of subharmonics on a symmetric branch): compared as an accuracy estimate.
ZERO_LEVEL = 1e-12
#: Accuracy estimates (residuals, errors, deviations of the computed orbits): round-off or truncation,
#: not reproducible point by point; each must stay within ACCURACY_FACTOR of the reference's largest.
ACCURACY_PATTERN = re.compile(
    r"(residual|_deviation|integration_error|_change|_shift|energy_spread|force_error|^unfolding|"
    r"trivial_multiplier_distance|singular_ratio|stability_tolerance|multiplier_error|orbit_error|interpolation_error)$"
)
ACCURACY_FACTOR = 10.0
#: Error estimates of the stability numbers (absolute, per stored point) where a file stores them (the forced
#: responses: integration error and the orbit's own error): the multipliers of two builds differ within them.
STABILITY_ERROR_VARIABLES = ("multiplier_error", "stability_orbit_error")
#: Variables compared as accuracy estimates in the datasets of one kind (attribute ``dataset_kind``): a forced
#: response's truncation indicator (the share of its top harmonics, 1e-10 away from the stop) moves by several
#: per cent between CPUs where it is smallest, as the residuals do; it bounds the truncation error.
ACCURACY_BY_DATASET_KIND = {"forced_regularized": frozenset({"truncation"})}

#: Global attributes that count stored points or steps, or restate where a range ended: they follow the
#: continuation's steps (the data they describe are compared as curves).
SAMPLING_ATTRIBUTES = frozenset(
    {
        "anm_steps",
        "factorizations",
        "pade_steps",
        "exact_points",
        "regularized_points",
        "matched_points",
        "unmatched_points",
        "unpaired_points",
        "unpaired_regimes",
        "regularized_last_point",
        "exact_arm_first_point",
        "compared_orbits",
        "agreeing_orbits",
        "two_impact_points",
        "energy_range_min",
        "energy_range_max",
    }
)
#: The energies of a comparison's marked points (``point_a_energy``, ...): placed at fractions of the compared
#: range, whose ends are stored points of the branches (SAMPLING_ATTRIBUTES), so they move with them; the
#: compared orbits there are checked as a curve.
SAMPLING_PATTERN = re.compile(r"point_\w+_energy")
#: Global attributes that estimate an accuracy (see ACCURACY_PATTERN).
ACCURACY_ATTRIBUTES = frozenset({"max_residual", "singular_ratio"})
#: Global attributes that give a located point or a number derived at it.
LOCATED_ATTRIBUTES = frozenset({"branch_point_energy", "branch_point_frequency", "tangent_angle"})


def curve_coordinates(ds: xr.Dataset) -> tuple[str, str] | None:
    """The (energy, frequency) variables of a file whose stored points make a curve, or None."""
    for energy, frequency in CURVE_COORDINATES:
        if energy in ds.variables and frequency in ds.variables and ds[energy].dims == (POINT,):
            return energy, frequency
    return None


def variable_kind(name: str, variable: xr.Variable | xr.DataArray, coordinates=(), accuracy=frozenset()) -> str:
    """How a variable along ``point`` is compared: ``curve`` (the coordinates), ``sampling``,
    ``marker``, ``stability`` (verdicts), ``stability_value``, ``accuracy`` (also the names in
    ``accuracy``), ``interpolated``, ``orbit`` (harmonics), ``discrete`` or ``smooth``; ``other`` for a
    variable without the ``point`` dimension."""
    if POINT not in variable.dims:
        return "other"
    if name in coordinates:
        return "curve"
    if name in SAMPLING_VARIABLES:
        return "sampling"
    if name in MARKER_VARIABLES:
        return "marker"
    if name in STABILITY_VARIABLES:
        return "stability"
    if "harmonic" in variable.dims:
        return "orbit"
    kind = variable.dtype.kind
    if kind not in "fc":
        return "discrete"  # integers, flags, labels
    if ACCURACY_PATTERN.search(name) or name in accuracy:
        return "accuracy"
    if name in INTERPOLATED_VARIABLES:
        return "interpolated"
    if STABILITY_VALUE_PATTERN.match(name):
        return "stability_value"
    return "smooth"


def attribute_kind(name: str) -> str:
    """How a global attribute is compared: ``provenance`` (not), ``sampling`` (not), ``accuracy``,
    ``located`` or ``exact``."""
    if name in PROVENANCE_ATTRIBUTES:
        return "provenance"
    if name in SAMPLING_ATTRIBUTES or SAMPLING_PATTERN.fullmatch(name):
        return "sampling"
    if name in ACCURACY_ATTRIBUTES:
        return "accuracy"
    if name in LOCATED_ATTRIBUTES:
        return "located"
    return "exact"


def json_value(value):
    """A NetCDF attribute value as JSON (numbers, strings, lists)."""
    if isinstance(value, np.ndarray):
        return json_value(value.item()) if value.ndim == 0 else [json_value(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [json_value(v) for v in value]
    return value


def _signals(ds: xr.Dataset) -> dict[str, np.ndarray]:
    """Orbit fingerprints per stored point: for each signal (``x`` of ``x_cos`` and ``x_sin``, or one
    degree of freedom of ``q_cos``, named by its ``dof_label``: ``x``, ``u`` of the paper's oscillator in
    either layout), sqrt(sum over harmonics k of (1 + k**4) (cos**2 + sin**2))."""
    labels = [str(v) for v in ds["dof_label"].values] if "dof_label" in ds.variables else None
    sums: dict[str, np.ndarray] = {}
    for name, variable in ds.variables.items():
        if POINT not in variable.dims or "harmonic" not in variable.dims or variable.dtype.kind != "f":
            continue
        signal = re.sub(r"_(cos|sin)$", "", str(name))
        values = variable.transpose(POINT, ..., "harmonic").values
        k = ds["harmonic"].values if "harmonic" in ds.variables else np.arange(values.shape[-1])
        with np.errstate(over="ignore", invalid="ignore"):  # a damaged coefficient gives inf, which the check reports
            energy = (values**2 * (1.0 + np.asarray(k, dtype=float) ** 4)).sum(axis=-1)
        energy = energy.reshape(values.shape[0], -1)
        by_label = labels is not None and signal == "q" and variable.dims[1:] == ("dof", "harmonic")
        for j in range(energy.shape[1]):
            key = labels[j] if by_label else signal if energy.shape[1] == 1 else f"{signal}[{j}]"
            sums[key] = sums.get(key, 0.0) + energy[:, j]
    return {key: np.sqrt(total) for key, total in sums.items()}


def _columns(ds: xr.Dataset, name: str) -> dict[str, np.ndarray]:
    """A variable along ``point`` as columns, one per index of its other dimensions."""
    values = ds[name].transpose(POINT, ...).values
    if values.ndim == 1:
        return {name: values}
    flat = values.reshape(values.shape[0], -1)
    return {f"{name}[{j}]": flat[:, j] for j in range(flat.shape[1])}


POINT_KINDS = ("discrete", "stability", "marker", "accuracy", "interpolated", "stability_value", "smooth")
#: The projections of the reference's curve tables: name -> the kind of the columns it sums.
PROJECTIONS = {"orbit": "orbit", "quantities": "smooth", "stability": "stability_value"}


def point_table(ds: xr.Dataset) -> dict:
    """The variables along ``point`` of a curve file by kind: ``curve`` (energy, frequency),
    ``step``/``stage`` (if any), one table of columns per kind of :data:`POINT_KINDS`, and ``orbit``
    fingerprints (see :func:`_signals`); None if the file holds no curve."""
    coordinates = curve_coordinates(ds)
    if coordinates is None:
        return None
    table = {kind: {} for kind in POINT_KINDS}
    table["curve"] = {"energy": ds[coordinates[0]].values, "frequency": ds[coordinates[1]].values}
    for name in ("step", "stage"):
        if name in ds.variables and ds[name].dims == (POINT,):
            table[name] = ds[name].values
    accuracy = ACCURACY_BY_DATASET_KIND.get(ds.attrs.get("dataset_kind"), frozenset())
    for name, variable in ds.variables.items():
        kind = variable_kind(str(name), variable, coordinates, accuracy)
        if kind != "discrete" and may_be_missing(variable):
            # missing where not computed (a comparison between orbits that are no counterparts): no curve to
            # interpolate or bound through its gaps; the flag saying where and why is compared as discrete
            continue
        if kind in table and kind != "curve":
            table[kind].update(_columns(ds, str(name)))
    table["orbit"] = _signals(ds)
    return table


#: Weighted sums that stand for a large floating-point array in the reference (see :func:`array_fingerprint`).
FINGERPRINT_SUMS = 4


def array_fingerprint(values: np.ndarray) -> dict:
    """What the reference keeps of an array of more than 256 values: its SHA-256 and, for floating-point
    values, ``FINGERPRINT_SUMS`` sums of the values with fixed weights in [1, 2) (:func:`fingerprint_sums`) and
    the sum of their magnitudes: the same numbers up to round-off (a mode shape, the start states of an exact
    family on another CPU) give sums within a relative tolerance of that magnitude, any change of one value
    moves them."""
    out = {"sha256": hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest()}
    if values.dtype.kind == "f":
        sums, magnitude = fingerprint_sums(values)
        out.update(shape=list(values.shape), sums=[float(v) for v in sums], magnitude=magnitude)
    return out


def fingerprint_sums(values: np.ndarray) -> tuple[np.ndarray, float]:
    """The weighted sums of :func:`array_fingerprint` (weights from a fixed hash of each value's position)."""
    flat = np.ravel(np.asarray(values, dtype=float))
    index = np.arange(flat.size, dtype=np.uint64)
    weights = np.stack(
        [
            1.0 + ((index * np.uint64(2654435761) + np.uint64(k * 40503)) % np.uint64(2**16)) / 2.0**16
            for k in range(1, FINGERPRINT_SUMS + 1)
        ]
    )
    return weights @ flat, float(np.sum(np.abs(flat)))


def weight(name: str) -> float:
    """A fixed weight in [1, 2) of a column of a projection, from a hash of its name."""
    return 1.0 + int(hashlib.sha256(name.encode()).hexdigest()[:8], 16) / 2**32


def projections(columns: dict[str, np.ndarray], scales: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The projection of ``columns`` (one value per stored point each) with the reference's ``scales``:
    sum over columns of weight * value / scale, divided by the sum of the weights; and the same sum of
    weight * |value| / scale (the magnitude a relative accuracy applies to)."""
    total = sum(weight(name) for name in scales)
    value = sum(weight(name) * np.asarray(columns[name], dtype=float) / scale for name, scale in scales.items())
    size = sum(weight(name) * np.abs(np.asarray(columns[name], dtype=float)) / scale for name, scale in scales.items())
    return value / total, size / total


def _scale(values: np.ndarray) -> float:
    largest = float(np.max(np.abs(values))) if len(values) else 0.0
    return largest if largest > 0 and np.isfinite(largest) else 1.0


def _range(values: np.ndarray) -> list[float]:
    values = np.asarray(values, dtype=float)
    step = float(np.max(np.abs(np.diff(values)))) if len(values) > 1 else 0.0
    return [float(np.min(values)), float(np.max(values)), step]


def share(shared: dict, value) -> str:
    """Key of ``value`` in the table ``shared`` of values kept once for all files (added if new)."""
    key = hashlib.sha256(json.dumps(value, sort_keys=True).encode()).hexdigest()[:12]
    shared[key] = value
    return key


#: Classes read on a frequency grid, one row per slice (the atlas' regions and response counts): a grid cell next
#: to a boundary changes class with round-off, so the reference keeps each row's runs of one class (:func:`grid_runs`)
#: and the verifier allows each boundary one cell.
GRID_CLASS_DIMS = ("slice", "grid")


def grid_runs(values) -> list:
    """The runs of one class along each row of an integer array ``(slice, grid)``: per row, ``[[class, first
    index], ...]``."""
    runs = []
    for row in np.asarray(values):
        starts = np.r_[0, np.flatnonzero(np.diff(row)) + 1]
        runs.append([[int(row[k]), int(k)] for k in starts])
    return runs


def profile(ds: xr.Dataset, shared: dict) -> dict:
    """What the reference keeps of one dataset (read with CF decoding), in JSON types.

    ``shared`` collects what files have in common (stage and branch files carry the same variables):
    each variable's attributes, and the table of the variables (name -> [dimensions, type, key of its
    attributes]); the profile names the table by its key there.
    """
    variables = {}
    for name, variable in ds.variables.items():
        attrs = share(shared, {key: json_value(value) for key, value in variable.attrs.items()})
        variables[str(name)] = [list(variable.dims), str(variable.dtype), attrs]
    entry = {
        "global": {k: json_value(v) for k, v in ds.attrs.items() if k not in PROVENANCE_ATTRIBUTES},
        "dims": {str(k): int(v) for k, v in ds.sizes.items() if k != POINT and k not in SAMPLED_DIMENSIONS},
        "variables": share(shared, variables),
        "values": {},
    }
    for name, variable in ds.variables.items():
        if POINT in variable.dims or SAMPLED_DIMENSIONS & set(variable.dims) or not_compared(str(name), ds):
            continue
        values = np.asarray(variable.values)
        if variable.dims == GRID_CLASS_DIMS and values.dtype.kind in "iu":
            entry.setdefault("grid_runs", {})[str(name)] = grid_runs(values)
        elif values.size <= 256:
            entry["values"][str(name)] = json_value(values)
        else:
            entry["values"][str(name)] = array_fingerprint(values)
    table = point_table(ds)
    if table is not None:
        entry["ranges"], entry["bounds"] = {}, {}
        for kind in ("accuracy", "interpolated", *PROJECTIONS.values()):
            for name, values in table[kind].items():
                largest = float(np.max(np.abs(values))) if len(values) else 0.0
                if kind == "accuracy" or largest <= ZERO_LEVEL:
                    entry["bounds"][name] = largest
                else:
                    entry["ranges"][name] = _range(values)
    return entry


def unverified_variables(ds: xr.Dataset) -> dict[str, str]:
    """The variables of ``ds`` whose values the verifier does not compare, each with the reason.

    Along the stored points of a curve, the variables that follow the continuation's steps and not the curve
    (:data:`SAMPLING_VARIABLES`: indices of stored points, step counts, arclength summed over the steps); the
    variables of a file without a curve that lie along ``point``; and the variables of a
    :data:`SAMPLED_DIMENSIONS` dimension that no recomputation of the stored orbits checks against their
    points (:func:`nnmstop.stored_accuracy.orbit_checks`). Every other variable is compared with the
    reference, or checked against the variables that are. A figure, page or explorer view must read none of
    these (tests/pipeline/test_verified_reads.py).
    """
    from nnmstop.stored_accuracy import orbit_checks

    coordinates = curve_coordinates(ds)
    accuracy = ACCURACY_BY_DATASET_KIND.get(ds.attrs.get("dataset_kind"), frozenset())
    checked = {name for check in orbit_checks(ds) for name in check.variables}
    out = {}
    for name, variable in ds.variables.items():
        name = str(name)
        if POINT in variable.dims and coordinates is None:
            out[name] = "along the stored points of a file without a frequency-energy curve"
        elif POINT in variable.dims and variable_kind(name, variable, coordinates or (), accuracy) == "sampling":
            out[name] = "follows the continuation's steps, not the curve"
        elif POINT not in variable.dims and name in SAMPLING_VARIABLES:
            out[name] = "follows the continuation's steps (an index of stored points, where a segment ended)"
        elif SAMPLED_DIMENSIONS & set(variable.dims) and name not in checked:
            out[name] = "kept at some stored points only, and not checked against them"
        elif not_compared(name, ds):
            out[name] = not_compared(name, ds)
    return out


def projected_columns(table: dict, kind: str) -> dict[str, np.ndarray]:
    """The columns of ``kind`` that a projection sums: those not zero up to round-off (ZERO_LEVEL)."""
    return {name: values for name, values in table[kind].items() if np.max(np.abs(values), initial=0.0) > ZERO_LEVEL}


def write_csv(path: Path, header: list[str], rows) -> None:
    """A CSV table; floats with 13 significant digits (the exact orbits' energies need 1e-9)."""
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(header)
        for row in rows:
            writer.writerow([f"{float(v):.13g}" if isinstance(v, (float, np.floating)) else v for v in row])


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Columns of a CSV table: numbers where every value is one, text otherwise."""
    with path.open() as handle:
        rows = list(csv.reader(handle))
    columns = {}
    for j, name in enumerate(rows[0]):
        values = [r[j] for r in rows[1:]]
        try:
            columns[name] = np.array([float(v) for v in values])
        except ValueError:
            columns[name] = np.array(values)
    return columns
