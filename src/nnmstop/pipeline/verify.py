"""Check a build of the pipeline against the committed reference (``reference/``), variable by variable.

A build made on another CPU stores other points along the same curves (the continuation's
step sequence follows round-off), so byte identity is checked first and, for each file that
differs, everything it holds: that it can be read, that no number is NaN or infinite, that its
stored orbits satisfy their equations to the accuracy it states and that the states kept at some
points only (the exact forced responses' contact states) reproduce their points
(:mod:`nnmstop.stored_accuracy`), its variables (names, dimensions, types, attributes), its global
attributes, its curve and every variable along it at matched positions, its located points,
regimes and other values (:func:`nnmstop.pipeline.reference.unverified_variables` names the few
it does not compare, and why). The build's own manifests are checked against its files first. Each
check has its tolerance, printed with every row; a check that cannot run is a discrepancy
with its reason, and the table always comes out. What the reference keeps:
:mod:`nnmstop.pipeline.reference`; method and tolerances: docs/reproducibility.md.

Usage::

    python -m nnmstop.pipeline.verify RESULTS_DIR [--reference reference]
    python -m nnmstop.pipeline.verify --update-reference RESULTS_DIR [--reference reference]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop.atomic import atomic_folder
from nnmstop.netcdf import PROVENANCE_ATTRIBUTES, non_finite_variables, open_checked
from nnmstop.pipeline.curve import Curve
from nnmstop.pipeline.reference import (
    ACCURACY_FACTOR,
    ACCURACY_PATTERN,
    GRID_CLASS_DIMS,
    POINT,
    PROJECTIONS,
    REFERENCE_FORMAT,
    SAMPLING_VARIABLES,
    STABILITY_ERROR_VARIABLES,
    STABILITY_VALUE_PATTERN,
    STUDY_KINDS,
    attribute_kind,
    fingerprint_sums,
    grid_runs,
    json_value,
    point_table,
    profile,
    projected_columns,
    projections,
    read_csv,
    weight,
    write_csv,
)
from nnmstop.stored_accuracy import orbit_checks

__all__ = ["Row", "ReferenceRefused", "data_digest", "build_manifests", "update_reference", "verify", "file_verdicts",
           "format_table", "main"]

REGIMES_CSV = "compare/nnm1_regimes.csv"
REGIMES_NC = "compare/nnm1_regimes.nc"
# Exact (closed-form) orbits and the comparison's Newton-solved orbits (residual 1e-13) are accurate
# to round-off; their curves are checked to this relative accuracy.
EXACT_BASE_TOLERANCE = 1e-9
# A number derived at a located point (a tangent angle) or a regime statistic without a rule of its
# own: relative tolerance, at least this and ten times the file's base accuracy.
DERIVED_TOLERANCE = 1e-6
# Relative differences of two computed values (the backbone's prediction errors, off the curve): each value is
# accurate to the relative tolerance of derived numbers, so their relative difference is, in absolute value.
DIFFERENCE_VARIABLES = frozenset({"frequency_error", "amplitude_error"})
# Numbers of configured settings (global attributes): written from the configuration, so equal.
SETTING_TOLERANCE = 1e-12
LOCATED = {"branch point": ("branch_point_energy", "branch_point_frequency"), "fold": ("fold_energy", "fold_frequency")}
WITHIN, DISCREPANT = "within tolerance", "discrepant"
LOO_FACTOR = 3.0  # leave-one-out deviations per interpolation tolerance along a curve (see _check_projection)


@dataclass
class Row:
    """One line of the verification table."""

    file: str
    quantity: str
    reference: str
    build: str
    difference: float
    tolerance: float
    verdict: str  # "identical", "identical data" (all but provenance), "within tolerance" or "discrepant"


def _verdict(ok: bool) -> str:
    return WITHIN if ok else DISCREPANT


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def data_digest(path: Path) -> str:
    """SHA-256 of a file's content without its provenance.

    For a NetCDF file: every variable's name, type, dimensions, attributes and values,
    and the global attributes except ``netcdf.PROVENANCE_ATTRIBUTES`` (the git commit and
    its date, which change with every commit even when no number does). Other files:
    their bytes.
    """
    if path.suffix != ".nc":
        return _sha256(path)
    digest = hashlib.sha256()
    with xr.open_dataset(path, decode_cf=False) as ds:
        attrs = {k: v for k, v in ds.attrs.items() if k not in PROVENANCE_ATTRIBUTES}
        digest.update(repr(sorted((k, str(v)) for k, v in attrs.items())).encode())
        for name in sorted(ds.variables):
            variable = ds.variables[name]
            described = (name, str(variable.dtype), variable.dims, sorted((k, str(v)) for k, v in variable.attrs.items()))
            digest.update(repr(described).encode())
            digest.update(np.ascontiguousarray(variable.values).tobytes())
    return digest.hexdigest()


def _results_dir(path) -> Path:
    path = Path(path)
    if not path.is_dir():
        raise ValueError(
            f"results directory {str(path)!r} does not exist (expected e.g. 'results' after `snakemake --cores 2`)"
        )
    return path


def _curve_name(relative: str) -> str:
    return relative.removesuffix(".nc").replace("/", "__") + ".csv"


def _stage_of(relative: str) -> tuple[str, int] | None:
    """(branch file, stage number) of a stage file ``hbm/stages/<branch>_stage<k>.nc``."""
    match = re.fullmatch(r"(.*)/stages/(\w+)_stage(\d+)\.nc", relative)
    return (f"{match.group(1)}/{match.group(2)}.nc", int(match.group(3))) if match else None


def _base_tolerance(ds: xr.Dataset) -> float:
    """Relative accuracy of the stored orbits: the dataset's ``point_accuracy`` where it states one (a forced
    response: the Newton threshold amplified by the resonance), else the Newton threshold of the ANM (a stored
    point's relative residual stays below it), or round-off for closed-form and Newton-solved orbits."""
    return float(ds.attrs.get("point_accuracy", ds.attrs.get("newton_threshold", EXACT_BASE_TOLERANCE)))


def _fmt(e, f) -> str:
    return f"E={e:.9g} f={f:.9g}"


# --------------------------------------------------------------------------- the reference


def _regime_sampling(regimes: xr.Dataset) -> list[list[float]]:
    """Per regime, the largest change between neighbouring compared orbits of ln E, the
    frequency, the frequency error and the relative error, the orbits next to the regime on
    either side included: a statistic taken over the stored orbits (a maximum, a median, a
    range end) moves by at most that much when the orbits are sampled elsewhere on the same
    curve (a range end by up to the step that crosses into the regime)."""
    rows = []
    regime_of = regimes["point_regime"].values
    for k in range(regimes.sizes["regime"]):
        inside = np.flatnonzero(regime_of == k)
        if inside.size:
            inside = np.arange(max(inside[0] - 1, 0), min(inside[-1] + 2, len(regime_of)))
        part = regimes.isel(point=inside)
        values = [
            np.log(part["energy"].values),
            part["frequency"].values,
            part["frequency_error"].values,
            part["relative_frequency_error"].values,
        ]
        rows.append([float(np.abs(np.diff(v)).max()) if v.size > 1 else 0.0 for v in values])
    return rows


def _write_curve(path: Path, table: dict) -> dict:
    """Write one curve's CSV (see :mod:`nnmstop.pipeline.reference`); the projections' scales."""
    columns = {"energy": table["curve"]["energy"], "frequency": table["curve"]["frequency"]}
    columns.update({name: table[name] for name in ("step", "stage") if name in table})
    for kind in ("discrete", "stability", "marker"):
        columns.update(table[kind])
    scales = {}
    for projection, kind in PROJECTIONS.items():
        projected = projected_columns(table, kind)
        if projected:
            scales[projection] = {name: _column_scale(values) for name, values in projected.items()}
            columns[projection] = projections(projected, scales[projection])[0]
    write_csv(path, list(columns), zip(*columns.values()))
    return scales


def _column_scale(values) -> float:
    largest = float(np.max(np.abs(values))) if len(values) else 0.0
    return largest if largest > 0 else 1.0


def _compact_json(format_version: int, shared: dict, files: dict) -> str:
    """``files.json``: one line per shared value and per file (small, and a diff names what changed)."""

    def one_line(value) -> str:
        return json.dumps(value, sort_keys=True, separators=(",", ":"))

    def block(mapping: dict) -> str:
        return ",\n".join(f"  {json.dumps(key)}: {one_line(mapping[key])}" for key in sorted(mapping))

    return (f'{{"format": {format_version},\n"shared": {{\n{block(shared)}\n}},\n'
            f'"files": {{\n{block(files)}\n}}}}\n')


#: Manifests of a build, relative to its results directory: the paper's datasets (required) and those of the
#: other targets (recorded where they were built), with the target that writes each.
MANIFEST = "MANIFEST.sha256"
FORCED_MANIFEST = "forced/MANIFEST.sha256"
TUBE_MANIFEST = "tube/MANIFEST.sha256"
STUDY_MANIFEST = "study/MANIFEST.sha256"
ATLAS_MANIFEST = "atlas/MANIFEST.sha256"  # the bifurcation atlas (``snakemake atlas``; recorded when present)
TUBE_PLATES_MANIFEST = "tube_plates/MANIFEST.sha256"  # the tube on plates (``snakemake tube_plates``)
TARGET_OF_MANIFEST = {MANIFEST: "the default target", FORCED_MANIFEST: "forced", TUBE_MANIFEST: "tube",
                      STUDY_MANIFEST: "study", ATLAS_MANIFEST: "atlas", TUBE_PLATES_MANIFEST: "tube_plates"}


def build_manifests(results_dir) -> list[str]:
    """The manifests of the build in ``results_dir`` that a reference records: :data:`MANIFEST` and those of the
    forced, tube, study, atlas and tube-on-plates targets where they were built."""
    results = Path(results_dir)
    optional = (FORCED_MANIFEST, TUBE_MANIFEST, STUDY_MANIFEST, ATLAS_MANIFEST, TUBE_PLATES_MANIFEST)
    return [MANIFEST] + [name for name in optional if (results / name).is_file()]


class ReferenceRefused(ValueError):
    """The build cannot become the reference: ``rows`` say which files and why (``reference/`` is untouched)."""

    def __init__(self, message: str, rows: list):
        super().__init__(message)
        self.rows = rows


def _listed_files(results: Path, manifests: list) -> list[str]:
    """The manifest lines of the build (its manifests and the regime table), sorted by path."""
    lines = []
    for name in manifests:
        manifest = results / name
        if not manifest.is_file():
            target = TARGET_OF_MANIFEST.get(name, "the default target")
            raise ValueError(f"{manifest} is missing: build {target} first (`snakemake --cores 2 {target}`)"
                             if name != MANIFEST else f"{manifest} is missing: build {target} first (`snakemake --cores 2`)")
        lines += [line for line in manifest.read_text().splitlines() if line.strip()]
    for line in lines:
        if "  " not in line or not line.split("  ")[1].startswith("results/"):
            raise ValueError(f"a manifest of {results} has a line that is not '<sha256>  results/<path>': {line!r}")
    if (results / REGIMES_CSV).is_file():
        lines.append(f"{_sha256(results / REGIMES_CSV)}  results/{REGIMES_CSV}")
    return sorted(lines, key=lambda line: line.split("  ")[1])


def _refusals(results: Path, lines: list[str]) -> list[Row]:
    """A row per file of the build that cannot be recorded: missing, not the manifest's bytes, unreadable,
    holding NaN or infinity where numbers must be, or orbits that do not satisfy their equations
    (:func:`nnmstop.netcdf.read_dataset`)."""
    from nnmstop.netcdf import read_dataset

    rows = []
    for line in lines:
        digest, listed = line.split("  ")
        path = results / listed.removeprefix("results/")
        if not path.is_file():
            rows.append(Row(listed, "file", "listed in the manifest", "missing", float("nan"), 0.0, DISCREPANT))
            continue
        if _sha256(path) != digest:
            rows.append(Row(listed, "file (SHA-256)", f"manifest {digest[:12]}", f"file {_sha256(path)[:12]}",
                            float("nan"), 0.0, DISCREPANT))
            continue
        try:
            read_dataset(path) if path.suffix == ".nc" else read_csv(path)
        except (ValueError, OSError, IndexError) as error:
            reason = str(error).replace(str(path), "the file")
            rows.append(Row(listed, "readable, finite, orbits accurate", "-", reason[:120], float("nan"), 0.0,
                            DISCREPANT))
    return rows


def update_reference(results_dir, reference_dir="reference", manifests=None) -> Path:
    """Regenerate ``reference_dir`` from the build in ``results_dir``.

    ``manifests`` (paths relative to ``results_dir``; default :func:`build_manifests`) list the datasets
    recorded. Writes ``MANIFEST.sha256`` (the build's manifests plus the regime table), ``DATA.sha256``
    (the same files' :func:`data_digest`), ``files.json`` (each dataset's profile, see
    :func:`nnmstop.pipeline.reference.profile`, and its base tolerance), one curve CSV per
    branch and family (``curves/``) and the regime table with its sampling steps.

    Every listed file is read first, by the reader of the tasks: a file missing, other than its manifest
    says, unreadable, holding NaN or infinity where numbers must be, or whose orbits do not satisfy their
    equations is refused and nothing is written. The new reference is written beside the old one and
    replaces it only when complete (:func:`nnmstop.atomic.atomic_folder`): an interruption or a full disk
    leaves the old reference as it was.

    Raises
    ------
    ReferenceRefused
        If a file of the build cannot be recorded (its ``rows`` say which and why).
    ValueError
        If ``results_dir`` or one of its manifests is missing.
    """
    results = _results_dir(results_dir)
    manifests = build_manifests(results) if manifests is None else list(manifests)
    lines = _listed_files(results, manifests)
    refused = _refusals(results, lines)
    if refused:
        raise ReferenceRefused(
            f"{len(refused)} file(s) of {results} cannot be recorded; {reference_dir} is left as it was", refused
        )
    with atomic_folder(reference_dir) as reference:
        _write_reference(results, reference, lines)
    return Path(reference_dir)


def _write_reference(results: Path, reference: Path, lines: list[str]) -> None:
    """Write the reference of the files ``lines`` (manifest lines) of ``results`` into the empty ``reference``."""
    (reference / "curves").mkdir()
    (reference / "MANIFEST.sha256").write_text("\n".join(lines) + "\n")
    listed = [line.split("  ")[1].removeprefix("results/") for line in lines]
    data = [f"{data_digest(results / relative)}  results/{relative}" for relative in listed]
    (reference / "DATA.sha256").write_text("\n".join(data) + "\n")
    shared, files, scales = {}, {}, {}
    for relative in sorted(r for r in listed if r.endswith(".nc")):
        ds = open_checked(results / relative)
        entry = profile(ds, shared)
        entry["base"] = _base_tolerance(ds)
        table = point_table(ds)
        if table is not None and _stage_of(relative) is None:
            entry["curve"] = {"csv": _curve_name(relative)}
            scales[relative] = _write_curve(reference / "curves" / _curve_name(relative), table)
            entry["curve"]["scales"] = scales[relative]
        files[relative] = entry
    for relative, entry in files.items():
        stage = _stage_of(relative)
        if stage and stage[0] in files:
            entry["curve"] = {"csv": _curve_name(stage[0]), "stage": stage[1], "scales": scales[stage[0]]}
            entry["base"] = files[stage[0]]["base"]
    if REGIMES_NC in files and "hbm/nnm1.nc" in files:  # its points are NNM1's stored points
        files[REGIMES_NC]["base"] = files["hbm/nnm1.nc"]["base"]
    (reference / "files.json").write_text(_compact_json(REFERENCE_FORMAT, shared, files))
    if (results / REGIMES_CSV).is_file():
        shutil.copyfile(results / REGIMES_CSV, reference / "nnm1_regimes.csv")
        with xr.open_dataset(results / REGIMES_NC) as regimes:
            write_csv(
                reference / "nnm1_regimes_sampling.csv",
                ["d_log_energy", "d_frequency", "d_frequency_error", "d_relative_frequency_error"],
                _regime_sampling(regimes),
            )


# --------------------------------------------------------------------------- structure and attributes


def _check_finite(name: str, ds: xr.Dataset) -> list[Row]:
    """NaN or infinity in a variable that must hold numbers (netcdf.may_be_missing)."""
    found = non_finite_variables(ds)
    rows = [Row(name, f"variable {var}: NaN or infinite values", "finite", f"{count} non-finite", float(count), 0.0,
                DISCREPANT) for var, count in sorted(found.items())]
    if not rows:
        rows.append(Row(name, "every number finite", "finite", "finite", 0.0, 0.0, WITHIN))
    return rows


#: In the study's datasets (reference.STUDY_KINDS): numbers that estimate an accuracy (truncation indicators,
#: residuals, periodicity errors of closed-form orbits, the continuation path's own error), round-off or
#: truncation, compared as accuracy estimates; the study's results (the errors of the regularized model
#: against the exact orbits, the harmonics needed) are compared as numbers.
STUDY_ACCURACY_PATTERN = re.compile(r"(truncation|periodicity_error|integration_difference|residual|path_frequency_error)$")


def _study_accuracy(var: str, ds: xr.Dataset) -> bool:
    return ds.attrs.get("dataset_kind") in STUDY_KINDS and bool(STUDY_ACCURACY_PATTERN.search(var))


#: Values interpolated linearly between a branch's stored points (the structure comparison, kind
#: ``one_impact_comparison``): their build and reference differ by up to the sum of the stored estimates of the
#: interpolation error named here (relative ones divided by the variable named in INTERPOLATED_SCALE).
INTERPOLATED_BY = {
    "exact_frequency": ("exact_interpolation_error",),
    "regularized_frequency": ("regularized_interpolation_error",),
    "relative_difference": ("exact_interpolation_error", "regularized_interpolation_error"),
}
INTERPOLATED_SCALE = {"relative_difference": "exact_frequency"}
#: The study's results that are differences of two solved orbits (errors of the regularized model against the
#: exact one, and of H against H_ref): where they are round-off (the truncation part at large H), relative
#: comparison means nothing; their absolute round-off is below this share of the variable's largest value.
STUDY_DIFFERENCE_FLOOR = 1e-9
STUDY_RESULT_PATTERN = re.compile(r"(error|difference)")


def _study_result(var: str, ds: xr.Dataset) -> bool:
    return ds.attrs.get("dataset_kind") in STUDY_KINDS and bool(STUDY_RESULT_PATTERN.search(var))


def _resolved_cases(var: str, ds: xr.Dataset, entry: dict) -> np.ndarray | None:
    """In a study dataset, where the cases of variable ``var`` were resolved (their ``status``, of the same
    prefix and dimensions, is 0 in both the build and the reference); None elsewhere. An unresolved case's
    accuracy estimate (its largest truncation indicator) is that of the first point past the limit, whichever
    point that was."""
    if ds.attrs.get("dataset_kind") not in STUDY_KINDS:
        return None
    prefix = re.match(r"^(anm_|ratio_|reference_|energy_hbm_)?", var).group(0)
    status = f"{prefix}status"
    if status not in ds.variables or ds[status].dims != ds[var].dims or status not in entry["values"]:
        return None
    return (np.asarray(ds[status].values) == 0) & (np.asarray(entry["values"][status]) == 0)


def _type_name(dtype) -> str:
    """A variable's type as compared: text of any length is text (its longest string is data: a failure's
    message with more digits), every other type by its name."""
    text = str(dtype)
    return "text" if re.fullmatch(r"[<>|]?[US]\d*|object", text) else text


def _check_structure(name: str, ds: xr.Dataset, entry: dict, shared: dict) -> list[Row]:
    """Missing and extra variables; each variable's dimensions, type and attributes; dimension sizes."""
    rows = []
    expected, present = shared[entry["variables"]], {str(v) for v in ds.variables}
    missing, extra = sorted(set(expected) - present), sorted(present - set(expected))
    if missing:
        rows.append(Row(name, f"variable {missing[0]}" if len(missing) == 1 else f"{len(missing)} variables missing",
                        ", ".join(missing)[:90], "missing", float(len(missing)), 0.0, DISCREPANT))
    if extra:
        rows.append(Row(name, f"variable {extra[0]}" if len(extra) == 1 else f"{len(extra)} variables not in the "
                        "reference", "absent", ", ".join(extra)[:90], float(len(extra)), 0.0, DISCREPANT))
    for var in sorted(present & set(expected)):
        (dims, dtype, attributes), variable = expected[var], ds.variables[var]
        if list(variable.dims) != dims or _type_name(variable.dtype) != _type_name(dtype):
            rows.append(Row(name, f"variable {var}: dimensions and type", f"{dims} {dtype}",
                            f"{list(variable.dims)} {variable.dtype}", float("nan"), 0.0, DISCREPANT))
        wanted = shared.get(attributes, {})
        got = {key: json_value(value) for key, value in variable.attrs.items()}
        for key in sorted(set(wanted) | set(got)):
            if wanted.get(key) != got.get(key):
                rows.append(Row(name, f"variable {var}: attribute {key}", str(wanted.get(key, "absent"))[:60],
                                str(got.get(key, "absent"))[:60], float("nan"), 0.0, DISCREPANT))
    for dim, size in entry["dims"].items():
        if ds.sizes.get(dim) != size:
            rows.append(Row(name, f"dimension {dim}", str(size), str(ds.sizes.get(dim, "absent")), float("nan"), 0.0,
                            DISCREPANT))
    if not rows:
        rows.append(Row(name, f"{len(present)} variables: names, dimensions, types, attributes", "same", "same", 0.0,
                        0.0, WITHIN))
    return rows


def _mask_numbers(text: str) -> str:
    return re.sub(r"[-+]?\d+(\.\d*)?([eE][-+]?\d+)?", "#", text)


def _compare_attribute(key: str, wanted, got, base: float) -> tuple[float, float, bool] | None:
    """(difference, tolerance, ok) of one global attribute; None when it is not compared."""
    kind = attribute_kind(key)
    if kind in ("provenance", "sampling"):
        return None
    if isinstance(wanted, str) or isinstance(got, str):
        # text: same words; numbers in it restate what the data hold (range ends, counts of stored points)
        ok = isinstance(wanted, str) and isinstance(got, str) and _mask_numbers(wanted) == _mask_numbers(got)
        return (0.0 if ok else float("nan")), 0.0, ok
    try:  # a number, or an array of numbers compared entry by entry with the same tolerance
        w, g = np.asarray(wanted, dtype=float), np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        return float("nan"), 0.0, wanted == got
    if w.shape != g.shape or not (np.all(np.isfinite(w)) and np.all(np.isfinite(g))):
        return float("nan"), 0.0, False
    if w.size == 0:
        return 0.0, 0.0, True
    if kind == "accuracy":
        largest, allowed = float(np.max(np.abs(g))), ACCURACY_FACTOR * float(np.max(np.abs(w)))
        return largest, allowed, largest <= allowed
    tolerance = SETTING_TOLERANCE if kind == "exact" else max(DERIVED_TOLERANCE, 10 * base)
    difference = float(np.max(np.abs(g - w) / np.maximum(np.abs(w), 1e-300)))
    return difference, tolerance, difference <= tolerance


def _check_attributes(name: str, ds: xr.Dataset, entry: dict) -> list[Row]:
    """Every global attribute but the provenance (git commit and date) and those that count stored
    points; text compared word for word (numbers masked)."""
    wanted = entry["global"]
    got = {k: json_value(v) for k, v in ds.attrs.items() if k not in PROVENANCE_ATTRIBUTES}
    rows, compared, skipped = [], 0, []
    for key in sorted(set(wanted) | set(got)):
        if key not in wanted or key not in got:
            if attribute_kind(key) != "sampling":
                rows.append(Row(name, f"attribute {key}", str(wanted.get(key, "absent"))[:60],
                                str(got.get(key, "absent"))[:60], float("nan"), 0.0, DISCREPANT))
            continue
        result = _compare_attribute(key, wanted[key], got[key], entry["base"])
        if result is None:
            skipped.append(key)
            continue
        compared += 1
        difference, tolerance, ok = result
        if not ok or attribute_kind(key) in ("accuracy", "located"):
            rows.append(Row(name, f"attribute {key}", str(wanted[key])[:60], str(got[key])[:60], difference,
                            tolerance, _verdict(ok)))
    rows.append(Row(name, f"{compared} global attributes ({len(skipped)} counting stored points not compared)",
                    "-", "-", 0.0, 0.0, WITHIN if not any(r.verdict == DISCREPANT for r in rows) else DISCREPANT))
    return rows


# --------------------------------------------------------------------------- classes on a grid


def _check_grid_runs(name: str, ds: xr.Dataset, wanted: dict) -> list[Row]:
    """Classes read on a frequency grid per slice (:data:`~nnmstop.pipeline.reference.GRID_CLASS_DIMS`): each
    slice's runs of one class in the same order, each boundary within one grid cell of the reference's (a cell
    next to a boundary changes class with round-off)."""
    rows = []
    for var, reference in wanted.items():
        if var not in ds.variables or ds[var].dims != GRID_CLASS_DIMS:
            rows.append(Row(name, f"variable {var}: classes on the grid", "present", "absent", float("nan"), 0.0,
                            DISCREPANT))
            continue
        build = grid_runs(ds[var].values)
        moved, changed = 0, []
        for k, (want, got) in enumerate(zip(reference, build)):
            if len(want) != len(got) or [c for c, _ in want] != [c for c, _ in got]:
                changed.append(k)
                continue
            moved = max([moved] + [abs(a - b) for (_, a), (_, b) in zip(want, got)])
        if len(reference) != len(build):
            changed.append(min(len(reference), len(build)))
        ok = not changed and moved <= 1
        what = f"slices {changed[:5]} with other classes" if changed else f"boundaries moved by {moved} cell(s)"
        rows.append(Row(name, f"variable {var}: classes along each slice's grid (boundaries within one cell)",
                        f"{len(reference)} slices", what, float(moved if not changed else len(changed)), 1.0,
                        _verdict(ok)))
    return rows


# --------------------------------------------------------------------------- values off the curve


def _check_other_values(name: str, ds: xr.Dataset, entry: dict, skip=()) -> list[Row]:
    """Variables without the ``point`` dimension (located points' other numbers, coordinates, ...):
    integers and text equal, accuracy estimates within ACCURACY_FACTOR of the reference's, other
    numbers within DERIVED_TOLERANCE (relative)."""
    rows = []
    for var, wanted in entry["values"].items():
        if var in skip or var in SAMPLING_VARIABLES or var not in ds.variables or POINT in ds[var].dims:
            continue
        values = np.asarray(ds[var].values)
        if isinstance(wanted, dict):  # large: its digest and, for floating-point values, its fingerprint
            if hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest() == wanted["sha256"]:
                continue
            if "sums" not in wanted or list(values.shape) != wanted["shape"] or values.dtype.kind != "f":
                rows.append(Row(name, f"variable {var} (SHA-256 of its values)", wanted["sha256"][:12], "differs",
                                float("nan"), 0.0, DISCREPANT))
                continue
            sums, _ = fingerprint_sums(values)
            tolerance = max(DERIVED_TOLERANCE, 10 * entry["base"])
            worst = float(np.max(np.abs(sums - np.asarray(wanted["sums"])))) / max(2 * wanted["magnitude"], 1e-300)
            if not worst <= tolerance:
                rows.append(Row(name, f"variable {var} (weighted sums of its {values.size} values, relative)",
                                f"{wanted['sums'][0]:.10g}", f"{sums[0]:.10g}", worst, tolerance, DISCREPANT))
            continue
        reference = np.asarray(wanted)
        if reference.size == 0 and values.size == 0:  # none (no located change): JSON keeps no shape of it
            continue
        if reference.shape != values.shape:
            rows.append(Row(name, f"variable {var}: shape", str(reference.shape), str(values.shape), float("nan"), 0.0,
                            DISCREPANT))
            continue
        if values.dtype.kind not in "fc" or reference.dtype.kind not in "fc":
            # integers and flags equal; text the same words, its numbers (a failure's energy, a count of points)
            # restating what the data hold
            as_text = str if values.dtype.kind in "biu" else (lambda v: _mask_numbers(str(v)))
            ok = [as_text(v) for v in reference.ravel()] == [as_text(v) for v in values.ravel()]
            if not ok:
                rows.append(Row(name, f"variable {var}", str(reference.tolist())[:60], str(values.tolist())[:60],
                                float("nan"), 0.0, DISCREPANT))
            continue
        # a missing value (NaN: a case of the study not compared) must be missing in both builds
        missing_here, missing_there = np.isnan(values), np.isnan(reference)
        if np.any(missing_here != missing_there):
            first = np.argwhere(missing_here != missing_there)[0]
            rows.append(Row(name, f"variable {var}: missing values (NaN) at other positions", str(int(missing_there.sum())),
                            f"{int(missing_here.sum())} (first differing at {tuple(int(i) for i in first)})",
                            float("nan"), 0.0, DISCREPANT))
            continue
        values, reference = values[~missing_here], reference[~missing_there]
        if ACCURACY_PATTERN.search(var) or _study_accuracy(var, ds):
            resolved = _resolved_cases(var, ds, entry)
            if resolved is not None:  # a study's unresolved case stopped at the first point past its limit
                values, reference = values[resolved[~missing_here]], reference[resolved[~missing_there]]
            bound = max(ACCURACY_FACTOR * float(np.max(np.abs(reference), initial=0.0)), entry["base"])
            worst = float(np.max(np.abs(values), initial=0.0))
            rows.append(Row(name, f"variable {var} (accuracy estimate: largest)", f"{bound / ACCURACY_FACTOR:.3g}",
                            f"{worst:.3g}", worst, bound, _verdict(worst <= bound)))
            continue
        tolerance = max(DERIVED_TOLERANCE, 10 * entry["base"])
        scale = 1.0 if var in DIFFERENCE_VARIABLES else np.maximum(np.abs(reference), 1e-300)
        difference = np.abs(values - reference) / scale
        if var in INTERPOLATED_BY and all(e in ds.variables and isinstance(entry["values"].get(e), list)
                                          for e in INTERPOLATED_BY[var]):
            # linear interpolation between stored points: within both builds' estimates
            estimate = sum(np.asarray(ds[e].values) + np.asarray(entry["values"][e]) for e in INTERPOLATED_BY[var])
            scale_of = np.abs(np.asarray(ds[INTERPOLATED_SCALE[var]].values)) if var in INTERPOLATED_SCALE else 1.0
            difference = np.maximum(difference - (estimate / scale_of)[~missing_here] / scale, 0.0)
        elif _study_result(var, ds):  # a difference of two solved orbits: round-off of the larger ones below it
            floor = STUDY_DIFFERENCE_FLOOR * float(np.max(np.abs(reference), initial=0.0))
            difference = np.maximum(np.abs(values - reference) - floor, 0.0) / scale
        worst = float(np.max(difference)) if difference.size else 0.0
        if worst > tolerance:
            rows.append(Row(name, f"variable {var} ({'absolute' if var in DIFFERENCE_VARIABLES else 'relative'})", str(reference.tolist())[:60], str(values.tolist())[:60],
                            worst, tolerance, DISCREPANT))
    return rows


def _check_located(name: str, entry: dict, ds: xr.Dataset, curves: dict, base: float) -> list[Row]:
    """Branch points to the ANM's accuracy (bisection along the series, then Newton);
    folds within the spacing of the stored points around them (the parabola through the
    extremal point and its neighbours), from either build."""
    rows = []
    for kind, (energy, frequency) in LOCATED.items():
        if energy not in entry["values"]:
            continue
        ref = np.log(np.column_stack([entry["values"][energy], entry["values"][frequency]]).reshape(-1, 2))
        got = np.log(np.column_stack([ds[energy].values, ds[frequency].values]).reshape(-1, 2))
        if len(ref) != len(got):
            rows.append(Row(name, f"number of {kind}s", str(len(ref)), str(len(got)), float(abs(len(ref) - len(got))),
                            0.0, DISCREPANT))
            continue
        for j, (p, q) in enumerate(zip(ref, got)):
            tolerance = base
            if kind == "fold":  # length of the segment of each curve where its fold lies
                pairs = ((curves["reference"], p), (curves["build"], q))
                segments = [(c, int(c.distance(x[None])[1][0])) for c, x in pairs]
                tolerance += max(float(c.s[k + 1] - c.s[k]) for c, k in segments)
            gap = float(np.linalg.norm(p - q))
            rows.append(Row(name, f"{kind} {j + 1}", _fmt(*np.exp(p)), _fmt(*np.exp(q)), gap, tolerance,
                            _verdict(gap <= tolerance)))
    return rows


def _check_regimes(name: str, reference: dict, sampling: dict, build: dict, build_sampling: list) -> list[Row]:
    """The regime table: the regimes and their exact sequences exactly; statistics over
    stored orbits within the largest change between neighbouring orbits (either build)."""
    identities = ("impacts_per_period", "exact_sequence")
    if any(_labels(reference[k]) != _labels(build[k]) for k in identities):
        return [Row(name, "regimes (impacts per period, exact sequence)", str(list(reference["impacts_per_period"])),
                    str(list(build["impacts_per_period"])), float("nan"), 0.0, DISCREPANT)]
    step_of = {"energy": "d_log_energy", "frequency": "d_frequency", "frequency_error": "d_frequency_error",
               "rel_frequency_error": "d_relative_frequency_error"}
    rows = []
    for column in reference:
        if column in ("regime", *identities, "n_matched", "n_unmatched"):
            continue  # identities, or counts of stored orbits (they follow the sampling)
        kind = next((k for k in ("rel_frequency_error", "frequency_error", "energy", "frequency") if k in column), None)
        if kind is None:
            continue
        if column not in build:
            rows.append(Row(name, f"{column}", "present", "missing", float("nan"), 0.0, DISCREPANT))
            continue
        worst = None
        for k in range(len(reference[column])):
            r, b = float(reference[column][k]), float(build[column][k])
            tolerance = max(sampling[step_of[kind]][k], build_sampling[k][list(step_of).index(kind)])
            difference = abs(np.log(b / r)) if kind == "energy" else abs(b - r)
            if not np.isfinite(difference):
                difference = np.inf
            if worst is None or difference / max(tolerance, 1e-300) > worst[0]:
                worst = (difference / max(tolerance, 1e-300), k, r, b, difference, tolerance)
        _, k, r, b, difference, tolerance = worst
        rows.append(Row(name, f"{column} (worst of {len(reference[column])} regimes: regime {k})"
                        + (" (ln)" if kind == "energy" else ""), f"{r:.9g}", f"{b:.9g}", difference, tolerance,
                        _verdict(difference <= tolerance)))
    return rows


def _labels(values) -> list[str]:
    """Values as text, whole numbers without a decimal point (a CSV gives 2.0 where a dataset holds 2)."""
    return [str(v).removesuffix(".0") for v in np.asarray(values).tolist()]


def _regime_rows(name: str, ds: xr.Dataset, reference_dir: Path) -> list[Row]:
    """The regime dataset's variables along ``regime``, by the rules of the regime table."""
    table = read_csv(reference_dir / "nnm1_regimes.csv")
    sampling = read_csv(reference_dir / "nnm1_regimes_sampling.csv")
    build = {str(v): ds[v].values for v in ds.variables if ds[v].dims == ("regime",)}
    missing = [c for c in table if c not in build]
    if missing or "point_regime" not in ds.variables:
        return [Row(name, "regime table: columns missing", ", ".join(table)[:90], ", ".join(missing)[:90],
                    float(len(missing)), 0.0, DISCREPANT)]
    return _check_regimes(name, table, sampling, build, _regime_sampling(ds))


# --------------------------------------------------------------------------- along the curve


def _reference_rows(reference_dir: Path, spec: dict) -> dict[str, np.ndarray]:
    """The reference curve's CSV columns (a stage's rows, with the stored point it starts from)."""
    table = read_csv(reference_dir / "curves" / spec["csv"])
    if "stage" not in spec:
        return table
    rows = np.flatnonzero(table["stage"] == spec["stage"])
    if len(rows) and rows[0] > 0:
        rows = np.concatenate([[rows[0] - 1], rows])
    return {k: v[rows] for k, v in table.items()}


def _past_an_end(c_src: Curve, c_tgt: Curve, d: np.ndarray, tolerance: np.ndarray) -> np.ndarray:
    """Points of ``c_src`` off ``c_tgt`` within one end step of both curves' ends: they may lie past
    the other curve's end (where the other branch stopped one step earlier); the end rows check them."""
    out = np.zeros(len(d), dtype=bool)
    for end in (0, -1):
        step = max(c_src.end_length(end), c_tgt.end_length(end))
        along = np.abs(c_src.s - c_src.s[end])
        near = (along <= step) & (np.linalg.norm(c_src.points - c_tgt.points[end], axis=1) <= step)
        out |= near & (d > tolerance)
    return out


def _check_curve(name: str, curves: dict, base: float) -> tuple[list[Row], np.ndarray]:
    """Each curve's stored points on the other curve, and the two curves' ends; also which build
    points lie past an end of the reference curve (not compared along it)."""
    rows, build_past = [], None
    for label, source, target in (("build points on reference curve", "build", "reference"),
                                  ("reference points on build curve", "reference", "build")):
        c_src, c_tgt = curves[source], curves[target]
        d, segment, at_end = c_tgt.distance(c_src.points)
        tolerance = base + c_tgt.segment_error(segment)
        at_end |= _past_an_end(c_src, c_tgt, d, tolerance)
        build_past = at_end if source == "build" else build_past
        ratio = np.where(at_end, 0.0, d / tolerance)
        worst = int(np.argmax(ratio))
        e, f = np.exp(c_src.points[worst])
        rows.append(Row(name, f"{label} ({len(c_src.points)} points, {int(at_end.sum())} past an end; worst at "
                        f"{_fmt(e, f)})", f"{len(curves['reference'].points)} points",
                        f"{len(curves['build'].points)} points", float(d[worst]), float(tolerance[worst]),
                        _verdict(ratio[worst] <= 1)))
    for end, label in ((0, "start point"), (-1, "end point")):
        p_ref, p_build = curves["reference"].points[end], curves["build"].points[end]
        gap = float(np.linalg.norm(p_ref - p_build))
        tolerance = base + max(curves["reference"].end_length(end), curves["build"].end_length(end))
        rows.append(Row(name, label, _fmt(*np.exp(p_ref)), _fmt(*np.exp(p_build)), gap, tolerance,
                        _verdict(gap <= tolerance)))
    return rows, build_past


def _band(reference: dict, keep: np.ndarray) -> np.ndarray:
    """Reference segments within one segment of a change of stability verdict or resolution: there
    two builds may give either verdict (the tolerance band of a stability change)."""
    change = np.zeros(max(int(keep.sum()) - 1, 0), dtype=bool)  # a change within segment i (points i, i+1)
    for flag in ("stable", "stability_resolved"):
        if flag in reference:
            values = reference[flag][keep]
            change |= values[1:] != values[:-1]
    band = change.copy()
    band[1:] |= change[:-1]
    band[:-1] |= change[1:]
    return band


def _check_discrete(name: str, reference: dict, table: dict, curves: dict, match: tuple) -> list[Row]:
    """Flags, counts, labels and stability verdicts at each build point: one of the reference's
    values at the two stored points around its position (a change happens somewhere between
    them); stability verdicts outside the band of a change (:func:`_band`)."""
    segment, _, skip = match
    keep_ref, keep_build = curves["reference"].keep, curves["build"].keep
    band = _band(reference, keep_ref)
    rows = []
    for kind in ("discrete", "stability"):
        for column in sorted(table[kind]):
            if column not in reference:
                rows.append(Row(name, f"{column} along the curve", "absent", "present", float("nan"), 0.0, DISCREPANT))
                continue
            ref = np.array(_labels(reference[column][keep_ref]))
            got = np.array(_labels(np.asarray(table[kind][column])[keep_build]))
            valid = ~skip & (~band[segment] if kind == "stability" else True)
            wrong = valid & (got != ref[segment]) & (got != ref[segment + 1])
            if wrong.any():
                j = int(np.flatnonzero(wrong)[0])
                e, f = np.exp(curves["build"].points[j])
                allowed = sorted({ref[segment[j]], ref[segment[j] + 1]})
                rows.append(Row(name, f"{column} at {int(wrong.sum())} of {int(valid.sum())} build points (first at "
                                f"{_fmt(e, f)})", " or ".join(allowed), got[j], float(wrong.sum()), 0.0, DISCREPANT))
    compared = len(table["discrete"]) + len(table["stability"])
    rows.append(Row(name, f"{compared} flags, counts and verdicts at matched positions (stability verdicts outside "
                    "the band of a change)", "-", "-", 0.0, 0.0, WITHIN if not rows else DISCREPANT))
    return rows


def _check_markers(name: str, reference: dict, table: dict, curves: dict) -> list[Row]:
    """Flags of the stored points next to an event: the same events, each within the longer of the
    two stored segments around it (of either build) of the reference's."""
    rows = []
    c_ref, c_build = curves["reference"], curves["build"]
    for column in sorted(table["marker"]):
        if column not in reference:
            rows.append(Row(name, f"{column} along the curve", "absent", "present", float("nan"), 0.0, DISCREPANT))
            continue
        ref_values = reference[column][c_ref.keep].astype(int)
        build_values = np.asarray(table["marker"][column])[c_build.keep].astype(int)
        ref_events, build_events = np.flatnonzero(ref_values), np.flatnonzero(build_values)
        if len(ref_events) != len(build_events):
            rows.append(Row(name, f"{column}: number of flagged points", str(len(ref_events)), str(len(build_events)),
                            float(abs(len(ref_events) - len(build_events))), 0.0, DISCREPANT))
            continue
        if not len(build_events):
            continue
        _, segment, _, parameter = c_ref.match(c_build.points[build_events])
        worst = (0.0, 0.0, 0)
        for j, (p, seg) in enumerate(zip(parameter, segment)):
            same = ref_events[ref_values[ref_events] == build_values[build_events[j]]]
            gap = float(np.min(np.abs(c_ref.s[same] - p))) if len(same) else np.inf
            around = lambda c, k: max(float(np.diff(c.s)[max(k - 1, 0):k + 1].max()), 0.0)  # noqa: E731
            tolerance = max(around(c_ref, int(seg)), around(c_build, int(build_events[j])))
            if gap / max(tolerance, 1e-300) >= worst[0] / max(worst[1], 1e-300):
                worst = (gap, tolerance, j)
        gap, tolerance, j = worst
        e, f = np.exp(c_build.points[build_events[j]])
        rows.append(Row(name, f"{column}: {len(build_events)} flagged points (worst at {_fmt(e, f)})",
                        f"{len(ref_events)} flagged", f"{len(build_events)} flagged", gap, tolerance,
                        _verdict(gap <= tolerance)))
    return rows


def _check_projection(name: str, kind: str, reference: dict, columns: dict, scales: dict, curves: dict, match: tuple,
                      base: float, error=None) -> list[Row]:
    """Every orbit fingerprint or smooth quantity at each build point, through the projection: the
    build's value against the reference's interpolated at the point's position; tolerance = the
    base accuracy of the values + the reference's interpolation error there (leave-one-out) + twice the
    values' own error estimate where the file stores one (``error``, per build point: either build's
    values are within it)."""
    label = {"orbit": "orbits (harmonics, every signal)", "quantities": "smooth quantities",
             "stability": "stability numbers (multipliers, margins; outside the band of a change)"}[kind]
    missing = sorted(set(scales) - set(columns))
    if missing:
        return [Row(name, f"{label}: not compared, columns missing", "-", str(missing)[:60], float("nan"), 0.0,
                    DISCREPANT)]
    segment, parameter, skip = match
    c_ref, c_build = curves["reference"], curves["build"]
    if kind == "stability":
        skip = skip | _band(reference, c_ref.keep)[segment]
    value, size = projections(columns, scales)
    value, size = value[c_build.keep], size[c_build.keep]
    ref = np.asarray(reference[kind], dtype=float)[c_ref.keep]
    expected = c_ref.values_at(ref, parameter, segment)
    difference = np.abs(value - expected)
    # three times the largest leave-one-out deviation of the segments around: an over-estimate of the cubic's
    # error for smooth values, and it covers the noise of values sampled in time (x_max) or round-off
    loo = c_ref.leave_one_out(ref)
    around = np.max([c_ref.segment_error(np.clip(segment + k, 0, len(c_ref.s) - 2), loo) for k in (-1, 0, 1)], axis=0)
    tolerance = base * size + LOO_FACTOR * around + 1e-12 * np.abs(expected)
    if error is not None:  # each column is uncertain by twice the error estimate, at most its whole scale
        error = np.asarray(error, dtype=float)[c_build.keep]
        shares = [weight(column) * np.minimum(2.0 * error / scale, 1.0) for column, scale in scales.items()]
        tolerance = tolerance + np.sum(shares, axis=0) / sum(map(weight, scales))
    ratio = np.where(skip, 0.0, difference / np.maximum(tolerance, 1e-300))
    worst = int(np.argmax(ratio))
    e, f = np.exp(c_build.points[worst])
    return [Row(name, f"{label}: {len(scales)} columns at {int((~skip).sum())} build points (worst at {_fmt(e, f)})",
                f"{expected[worst]:.10g}", f"{value[worst]:.10g}", float(difference[worst]), float(tolerance[worst]),
                _verdict(ratio[worst] <= 1))]


def _column(table: dict, column: str):
    """A column of a point table, whatever its kind (None if absent)."""
    return next((t[column] for t in table.values() if isinstance(t, dict) and column in t), None)


def _check_ranges(name: str, entry: dict, table: dict, base: float, stability_error: float = 0.0) -> list[Row]:
    """Each smooth quantity's least and largest value on the curve: within its largest change between
    neighbouring stored points (either build) and its base accuracy; a stability number (a multiplier) also
    within ``stability_error``, the largest error estimate of the multipliers stored by either build (round-off
    of the monodromy where a multiplier is near zero). Names the variable of a change."""
    rows = []
    for column, (low, high, step) in sorted(entry.get("ranges", {}).items()):
        values = _column(table, column)
        if values is None:
            continue
        got_low, got_high, got_step = (float(np.min(values)), float(np.max(values)),
                                       float(np.max(np.abs(np.diff(values)))) if len(values) > 1 else 0.0)
        tolerance = max(step, got_step) + base * max(abs(low), abs(high))
        if STABILITY_VALUE_PATTERN.match(column.split("[")[0]):
            tolerance += stability_error
        difference = max(abs(got_low - low), abs(got_high - high))
        if not difference <= tolerance:
            rows.append(Row(name, f"{column}: range on the curve", f"[{low:.6g}, {high:.6g}]",
                            f"[{got_low:.6g}, {got_high:.6g}]", difference, tolerance, DISCREPANT))
    return rows


def _check_bounds(name: str, entry: dict, table: dict, base: float) -> list[Row]:
    """Accuracy estimates: at every stored point within ACCURACY_FACTOR of the reference's largest, or below the
    file's base accuracy ``base`` (what every stored orbit meets: an estimate below it is round-off, which
    another CPU may double or halve)."""
    rows, checked = [], 0
    for column, largest in sorted(entry.get("bounds", {}).items()):
        values = _column(table, column)
        if values is None:
            continue
        checked += 1
        worst = float(np.max(np.abs(values))) if len(values) else 0.0
        bound = max(ACCURACY_FACTOR * largest, base)
        if not worst <= bound:
            rows.append(Row(name, f"{column} (accuracy estimate: largest on the curve)", f"{largest:.3g}",
                            f"{worst:.3g}", worst, bound, DISCREPANT))
    if checked:
        rows.append(Row(name, f"{checked} accuracy estimates (residuals, errors) within {ACCURACY_FACTOR:g} times "
                        "the reference's largest", "-", "-", 0.0, 0.0, WITHIN if not rows else DISCREPANT))
    return rows


def _check_points(name: str, ds: xr.Dataset, entry: dict, reference_dir: Path) -> list[Row]:
    """The curve and every variable along it (see the module docstring)."""
    spec, base = entry["curve"], entry["base"]
    reference = _reference_rows(reference_dir, spec)
    table = point_table(ds)
    if table is None:
        return [Row(name, "frequency-energy curve", "present", "absent (no energy and frequency)", float("nan"), 0.0,
                    DISCREPANT)]
    curves = {
        "reference": Curve(reference["energy"], reference["frequency"], reference.get("step")),
        "build": Curve(table["curve"]["energy"], table["curve"]["frequency"], table.get("step")),
    }
    rows, past = _check_curve(name, curves, base)
    rows += _check_located(name, entry, ds, curves, base)
    _, segment, _, parameter = curves["reference"].match(curves["build"].points)
    match = (segment, parameter, past)
    rows += _check_discrete(name, reference, table, curves, match)
    rows += _check_markers(name, reference, table, curves)
    estimates = [table["accuracy"][c] for c in STABILITY_ERROR_VARIABLES if c in table["accuracy"]]
    for kind, source in PROJECTIONS.items():
        if kind in spec["scales"]:
            error = np.sum(estimates, axis=0) if kind == "stability" and estimates else None
            rows += _check_projection(name, kind, reference, table[source], spec["scales"][kind], curves, match, base,
                                      error)
    stability_error = sum(max(entry.get("bounds", {}).get(c, 0.0), float(np.max(table["accuracy"][c], initial=0.0)))
                          for c in STABILITY_ERROR_VARIABLES if c in table["accuracy"])
    rows += _check_ranges(name, entry, table, base, stability_error)
    rows += _check_bounds(name, entry, table, base)
    return rows


# --------------------------------------------------------------------------- verify


def _check_orbits(name: str, ds: xr.Dataset) -> list[Row]:
    """The stored orbits against their recomputed residual (:mod:`nnmstop.stored_accuracy`): each orbit
    satisfies its equations to the accuracy the file states, and the states kept at some points only (the
    exact forced response's contact states) reproduce their point's frequency and amplitudes. Independent
    of the reference: a file whose orbits are damaged but whose curve is right is discrepant too."""
    rows = []
    for check in orbit_checks(ds):
        if not len(check.points):
            continue
        worst = check.worst()
        where = f"{check.dim} {int(check.points[worst])}"
        rows.append(Row(name, f"{check.measure}: {len(check.points)} orbits ({', '.join(check.variables)}; worst at "
                        f"{where})", "-", f"{check.recomputed[worst]:.3g}", float(check.recomputed[worst]),
                        float(check.allowed[worst]), _verdict(not len(check.failed))))
    return rows


def _check_dataset(listed: str, path: Path, entry: dict, reference_dir: Path, shared: dict) -> list[Row]:
    """Every check of one NetCDF file; a check that fails to run is a discrepant row with its reason."""
    try:
        ds = open_checked(path)
    except ValueError as error:
        reason = str(error).replace(str(path), "the file")
        return [Row(listed, "readable NetCDF", "readable", reason[:90], float("nan"), 0.0, DISCREPANT)]
    relative = listed.removeprefix("results/")
    located = [v for pair in LOCATED.values() for v in pair]
    checks = [
        ("finite values", lambda: _check_finite(listed, ds)),
        ("stored orbits", lambda: _check_orbits(listed, ds)),
        ("structure", lambda: _check_structure(listed, ds, entry, shared)),
        ("global attributes", lambda: _check_attributes(listed, ds, entry)),
        ("values off the curve", lambda: _check_other_values(listed, ds, entry, skip=located + (
            [str(v) for v in ds.variables if ds[v].dims == ("regime",)] if relative == REGIMES_NC else []))),
    ]
    if relative == REGIMES_NC:
        checks.append(("regimes", lambda: _regime_rows(listed, ds, reference_dir)))
    if entry.get("grid_runs"):
        checks.append(("classes on a grid", lambda: _check_grid_runs(listed, ds, entry["grid_runs"])))
    if ds.attrs.get("dataset_kind") == "atlas":  # the atlas' curves: checked on the build (nnmstop.bifurcation_atlas.verification)
        from nnmstop.bifurcation_atlas.verification import atlas_rows

        checks.append(("atlas", lambda: atlas_rows(listed, ds, Row, WITHIN, DISCREPANT)))
    if entry.get("curve"):
        checks.append(("curve", lambda: _check_points(listed, ds, entry, reference_dir)))
    rows = []
    for label, check in checks:
        try:
            with np.errstate(all="ignore"):  # a damaged value overflows; the rows say where
                rows += check()
        except Exception as error:  # a damaged file must not stop the table: the check fails, with why
            rows.append(Row(listed, f"{label}: check could not run", "-", f"{type(error).__name__}: {error}"[:90],
                            float("nan"), 0.0, DISCREPANT))
    return rows


def _load_reference(reference: Path) -> dict:
    if not (reference / "MANIFEST.sha256").is_file():
        raise ValueError(f"no reference manifest {reference / 'MANIFEST.sha256'}: regenerate it with "
                         f"`python -m nnmstop.pipeline.verify --update-reference RESULTS_DIR --reference {reference}`")
    try:
        document = json.loads((reference / "files.json").read_text())
    except (OSError, ValueError) as error:
        raise ValueError(f"{reference / 'files.json'} cannot be read ({error}): regenerate the reference") from None
    if document.get("format") != REFERENCE_FORMAT or not {"shared", "files"} <= set(document):
        raise ValueError(f"{reference}/files.json is not of the format this verifier reads ({REFERENCE_FORMAT}): "
                         "regenerate the reference (--update-reference)")
    return document


def verify(results_dir, reference_dir="reference") -> list[Row]:
    """Compare the build in ``results_dir`` with ``reference_dir``; one :class:`Row` per check.

    Every file of the reference manifest is first compared byte for byte, then without
    its provenance attributes (:func:`data_digest`); a file that still differs is checked
    variable by variable; a file missing, unreadable or with no such check is discrepant.

    Raises
    ------
    ValueError
        If either directory or the reference manifest is missing.
    """
    results = _results_dir(results_dir)
    reference = Path(reference_dir)
    document = _load_reference(reference)
    data_digests = {line.split("  ")[1]: line.split("  ")[0] for line in (reference / "DATA.sha256").read_text().splitlines()}
    reference_lines = (reference / "MANIFEST.sha256").read_text().splitlines()
    rows = _check_build_manifests(results, [line.split("  ")[1] for line in reference_lines])
    for line in reference_lines:
        digest, listed = line.split("  ")
        relative = listed.removeprefix("results/")
        path = results / relative
        if not path.is_file():
            rows.append(Row(listed, "file", "present", "missing", float("nan"), 0.0, DISCREPANT))
            continue
        if _sha256(path) == digest:
            rows.append(Row(listed, "file (SHA-256)", digest[:12], digest[:12], 0.0, 0.0, "identical"))
            continue
        try:
            same_data = data_digest(path) == data_digests.get(listed)
        except Exception:  # unreadable: the checks below say why
            same_data = False
        if same_data:
            rows.append(Row(listed, "content without provenance (SHA-256)", data_digests[listed][:12],
                            data_digests[listed][:12], 0.0, 0.0, "identical data"))
        elif relative == REGIMES_CSV:
            rows += _regime_table_rows(listed, path, results, reference)
        elif relative in document["files"]:
            rows += _check_dataset(listed, path, document["files"][relative], reference, document["shared"])
        else:
            rows.append(Row(listed, "file (SHA-256)", digest[:12], _sha256(path)[:12], float("nan"), 0.0, DISCREPANT))
    return rows


def _check_build_manifests(results: Path, reference_files: list[str]) -> list[Row]:
    """The build's own manifests (:func:`build_manifests`): each line's file present with that SHA-256, and
    every dataset of the reference listed in one of them (the regime table is none of theirs)."""
    rows, listed = [], set()
    for name in build_manifests(results):
        manifest, label = results / name, f"results/{name}"
        if not manifest.is_file():
            rows.append(Row(label, "manifest of the build", "present", "missing", float("nan"), 0.0, DISCREPANT))
            continue
        wrong, count = [], 0
        for line in manifest.read_text().splitlines():
            if not line.strip():
                continue
            digest, sep, member = line.partition("  ")
            path = results / member.removeprefix("results/")
            count += 1
            listed.add(member)
            if not sep or not path.is_file():
                wrong.append(f"{member or line[:40]}: missing")
            elif _sha256(path) != digest:
                wrong.append(f"{member}: SHA-256 differs")
        rows.append(Row(label, f"{count} datasets, each present with its SHA-256 ({len(wrong)} not)", "-",
                        "; ".join(wrong)[:90] or "all", float(len(wrong)), 0.0, "identical" if not wrong else DISCREPANT))
    unlisted = sorted(f for f in reference_files if f.endswith(".nc") and f not in listed)
    if unlisted:
        rows.append(Row("results/MANIFEST.sha256", f"{len(unlisted)} datasets of the reference in no manifest of the "
                        "build", "listed", ", ".join(unlisted)[:90], float(len(unlisted)), 0.0, DISCREPANT))
    return rows


def _regime_table_rows(listed: str, path: Path, results: Path, reference: Path) -> list[Row]:
    try:
        table = read_csv(path)
        with xr.open_dataset(results / REGIMES_NC) as regimes:
            build_sampling = _regime_sampling(regimes.load())
        return _check_regimes(listed, read_csv(reference / "nnm1_regimes.csv"),
                              read_csv(reference / "nnm1_regimes_sampling.csv"), table, build_sampling)
    except Exception as error:
        return [Row(listed, "regime table: check could not run", "-", f"{type(error).__name__}: {error}"[:70],
                    float("nan"), 0.0, DISCREPANT)]


def file_verdicts(rows: list[Row]) -> dict[str, str]:
    """One verdict per file: the worst of its rows."""
    order = ("identical", "identical data", WITHIN, DISCREPANT)
    verdicts: dict[str, str] = {}
    for row in rows:
        verdicts[row.file] = max(verdicts.get(row.file, "identical"), row.verdict, key=order.index)
    return verdicts


def format_table(rows: list[Row]) -> str:
    """The rows as a text table, then the counts of files per verdict."""
    lines = ["Distances are in (ln E, ln f): relative differences. Curve tolerance = accuracy of the stored orbits "
             "(ANM Newton threshold, or 1e-9 for exact orbits) + interpolation error of the curve (leave-one-out "
             "cubic deviation of the stored points around). Ends: one continuation step. Variables along the curve "
             "are compared at matched positions (docs/reproducibility.md).",
             f"{'file':45s} {'quantity':70s} {'reference':32s} {'this build':32s} {'difference':>11s} {'tolerance':>10s}  verdict"]
    for r in rows:
        lines.append(f"{r.file:45s} {r.quantity:70s} {r.reference:32s} {r.build:32s} {r.difference:11.3e} {r.tolerance:10.3e}  {r.verdict}")
    verdicts = file_verdicts(rows)
    counts = list(verdicts.values())
    lines.append(f"files: {counts.count('identical')} identical, {counts.count('identical data')} identical data "
                 f"(other git commit), {counts.count(WITHIN)} within tolerance, {counts.count(DISCREPANT)} discrepant")
    discrepant = sorted(name for name, verdict in verdicts.items() if verdict == DISCREPANT)
    if discrepant:
        lines.append("discrepant: " + ", ".join(discrepant))
    return "\n".join(lines)


def main(argv=None) -> int:
    """Command line: verify a build, or regenerate the reference from one."""
    parser = argparse.ArgumentParser(prog="python -m nnmstop.pipeline.verify", description=__doc__.split("\n\n")[0])
    parser.add_argument("results", help="results directory of a build (e.g. results)")
    parser.add_argument("--reference", default="reference", help="reference directory (default: reference)")
    parser.add_argument("--update-reference", action="store_true", help="regenerate the reference from this build")
    args = parser.parse_args(argv)
    try:
        if args.update_reference:
            print(f"reference regenerated in {update_reference(args.results, args.reference)}")
            return 0
        rows = verify(args.results, args.reference)
    except ReferenceRefused as refused:
        print(format_table(refused.rows))
        print(f"error: {refused}", file=sys.stderr)
        return 1
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(format_table(rows))
    return 1 if any(r.verdict == DISCREPANT for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
