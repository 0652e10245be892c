"""Check a build of the pipeline against the committed reference (``reference/``).

A build made on another CPU stores other points along the same curves (the continuation's
step sequence follows round-off), so byte identity is checked first and, for each file
that differs, what the file means: its frequency-energy curve, its located points, its
table. Tolerances follow from the methods and are printed with every row; the method
notes are in docs/reproducibility.md.

Usage::

    python -m nnmstop.pipeline.verify RESULTS_DIR [--reference reference]
    python -m nnmstop.pipeline.verify --update-reference RESULTS_DIR [--reference reference]
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.spatial import cKDTree

from nnmstop.netcdf import PROVENANCE_ATTRIBUTES

__all__ = ["Row", "data_digest", "update_reference", "verify", "file_verdicts", "format_table", "main"]

REGIMES_CSV = "compare/nnm1_regimes.csv"
COMPARE_NC = "compare/nnm1_exact_vs_regularized.nc"
# Exact (closed-form) orbits solve their equations to round-off; their curve is checked to this.
EXACT_BASE_TOLERANCE = 1e-9
# Newton-solved orbits of the comparison dataset (residual 1e-13, nnmstop.compare.matching): relative
# tolerance on their frequencies at the same energy, allowing for the conditioning of the solve.
COMPARE_TOLERANCE = 1e-9
DENSE_SPACING = 2e-4  # largest distance between sub-points of the densified curve (first guess of the nearest point)
SAME_POINT = 1e-12  # points closer than this in (ln E, ln f) are one point of a curve


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


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def data_digest(path: Path) -> str:
    """SHA-256 of a file's content without its provenance.

    For a NetCDF file: every variable's name, type, dimensions, attributes and values,
    and the global attributes except ``datasets.PROVENANCE_ATTRIBUTES`` (the git commit and
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
            digest.update(repr((name, str(variable.dtype), variable.dims, sorted((k, str(v)) for k, v in variable.attrs.items()))).encode())
            digest.update(np.ascontiguousarray(variable.values).tobytes())
    return digest.hexdigest()


def _results_dir(path) -> Path:
    path = Path(path)
    if not path.is_dir():
        raise ValueError(f"results directory {str(path)!r} does not exist (expected e.g. 'results' after `snakemake --cores 2`)")
    return path


def _curve_name(relative: str) -> str:
    return relative.removesuffix(".nc").replace("/", "__") + ".csv"


def _is_curve(relative: str) -> bool:
    return relative.startswith(("hbm/", "exact/")) and "/stages/" not in relative


# --------------------------------------------------------------------------- reference


def _write_csv(path: Path, header: list[str], rows) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(header)
        for row in rows:
            writer.writerow([f"{float(v):.13g}" if isinstance(v, (float, np.floating)) else v for v in row])


def _read_csv(path: Path) -> dict[str, np.ndarray]:
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


def _curve_table(ds: xr.Dataset) -> dict[str, np.ndarray]:
    table = {"energy": ds["energy"].values, "frequency": ds["frequency"].values}
    for name in ("stage", "step"):
        if name in ds:
            table[name] = ds[name].values
    return table


def _base_tolerance(ds: xr.Dataset) -> float:
    """Relative accuracy of the stored orbits: the Newton threshold of the ANM (a stored
    point's relative residual stays below it, and the series' own tolerance is smaller),
    or round-off for the closed-form exact orbits."""
    return float(ds.attrs.get("newton_threshold", EXACT_BASE_TOLERANCE))


def _located(ds: xr.Dataset) -> list[tuple[str, float, float]]:
    located = []
    for kind, prefix in (("branch point", "branch_point"), ("fold", "fold")):
        if f"{prefix}_energy" in ds:
            located += [(kind, float(e), float(f)) for e, f in zip(ds[f"{prefix}_energy"].values, ds[f"{prefix}_frequency"].values)]
    return located


def _regime_sampling(regimes: xr.Dataset) -> list[list[float]]:
    """Per regime, the largest change between neighbouring compared orbits of ln E, the
    frequency, the frequency error and the relative error: a statistic taken over the
    stored orbits (a maximum, a median, a range end) moves by at most that much when the
    orbits are sampled elsewhere on the same curve."""
    rows = []
    for k in range(regimes.sizes["regime"]):
        part = regimes.isel(point=(regimes["point_regime"].values == k))
        values = [np.log(part["energy"].values), part["frequency"].values, part["frequency_error"].values,
                  part["relative_frequency_error"].values]
        rows.append([float(np.abs(np.diff(v)).max()) if v.size > 1 else 0.0 for v in values])
    return rows


def update_reference(results_dir, reference_dir="reference") -> Path:
    """Regenerate ``reference_dir`` from the build in ``results_dir``.

    Writes ``MANIFEST.sha256`` (the build's manifest plus the regime table), ``DATA.sha256``
    (the same files' :func:`data_digest`), one curve
    CSV per branch (energy, frequency, stage and step of every stored point),
    ``located.csv`` (branch points and folds), ``tolerances.json`` (base tolerance of
    each branch), ``compare_nnm1.csv`` and the regime table with its sampling steps.

    Raises
    ------
    ValueError
        If ``results_dir`` or its manifest is missing.
    """
    results = _results_dir(results_dir)
    manifest = results / "MANIFEST.sha256"
    if not manifest.is_file():
        raise ValueError(f"{manifest} is missing: build the default target first (`snakemake --cores 2`)")
    reference = Path(reference_dir)
    if reference.exists():
        shutil.rmtree(reference)
    (reference / "curves").mkdir(parents=True)
    lines = manifest.read_text().splitlines()
    if (results / REGIMES_CSV).is_file():
        lines.append(f"{_sha256(results / REGIMES_CSV)}  results/{REGIMES_CSV}")
    lines = sorted(lines, key=lambda line: line.split("  ")[1])
    (reference / "MANIFEST.sha256").write_text("\n".join(lines) + "\n")
    data = [f"{data_digest(results / line.split('  ')[1].removeprefix('results/'))}  {line.split('  ')[1]}" for line in lines]
    (reference / "DATA.sha256").write_text("\n".join(data) + "\n")
    located, tolerances = [], {}
    for path in sorted(results.rglob("*.nc")):
        relative = path.relative_to(results).as_posix()
        if not _is_curve(relative):
            continue
        with xr.open_dataset(path) as ds:
            table = _curve_table(ds)
            _write_csv(reference / "curves" / _curve_name(relative), list(table), zip(*table.values()))
            located += [(relative, *item) for item in _located(ds)]
            tolerances[relative] = _base_tolerance(ds)
    _write_csv(reference / "located.csv", ["file", "kind", "energy", "frequency"], located)
    (reference / "tolerances.json").write_text(json.dumps(tolerances, indent=1, sort_keys=True) + "\n")
    if (results / COMPARE_NC).is_file():
        with xr.open_dataset(results / COMPARE_NC) as ds:
            names = ["energy", "frequency_exact", "frequency_regularized"]
            _write_csv(reference / "compare_nnm1.csv", names, zip(*(ds[n].values for n in names)))
    if (results / REGIMES_CSV).is_file():
        shutil.copyfile(results / REGIMES_CSV, reference / "nnm1_regimes.csv")
        with xr.open_dataset(results / REGIMES_CSV.replace(".csv", ".nc")) as regimes:
            _write_csv(reference / "nnm1_regimes_sampling.csv",
                       ["d_log_energy", "d_frequency", "d_frequency_error", "d_relative_frequency_error"],
                       _regime_sampling(regimes))
    return reference


# --------------------------------------------------------------------------- curves


class Curve:
    """A stored frequency-energy curve in (ln E, ln f), interpolated by local cubics.

    Each segment between stored points i and i+1 is the cubic through points i-1..i+2
    in the chord-length parameter (fewer points at the ends); the curve is densified
    with those cubics and distances are taken to the densified polyline. The
    interpolation error near point j is bounded by the leave-one-out deviation: the
    distance of point j from the cubic through its four neighbours j-2, j-1, j+1, j+2,
    an interpolation over twice the spacing (about 16 times the error of the
    interpolation used, for a smooth curve; large at kinks, as it should be).
    """

    def __init__(self, energy, frequency, step=None):
        points = np.column_stack([np.log(energy), np.log(frequency)])
        # repeated points (a stage starts at its predecessor's last point; the exact branch
        # stores both sides of a grazing transition) are one point of the curve
        keep = np.ones(len(points), dtype=bool)
        last = points[0]
        for i in range(1, len(points)):
            keep[i] = np.linalg.norm(points[i] - last) > SAME_POINT
            last = points[i] if keep[i] else last
        self.points = points[keep]
        self.step = None if step is None else np.asarray(step)[keep]
        self.s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self.points, axis=0), axis=1))])
        n = len(self.points)
        if n < 5:
            raise ValueError(f"a curve needs at least 5 stored points to be compared, got {n}")
        # leave-one-out: cubic through the four nearest other points of each point
        window = np.clip(np.arange(n) - 2, 0, n - 5)[:, None] + np.arange(5)
        others = np.array([row[row != j] for j, row in enumerate(window)])
        self.interpolation_error = np.linalg.norm(self._lagrange(others, self.s) - self.points, axis=1)
        # densified curve: on segment i, the cubic through the four points around it
        nodes = np.clip(np.arange(n - 1) - 1, 0, n - 4)[:, None] + np.arange(4)
        # sub-points no farther apart than DENSE_SPACING, so that the nearest sub-point of
        # a query lies on the right arm where two arms of a branch pass close to each other
        count = np.maximum(4, np.ceil(np.diff(self.s) / DENSE_SPACING)).astype(int)
        owner = np.repeat(np.arange(n - 1), count)
        fractions = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        a = self.s[owner] + fractions / count[owner] * np.diff(self.s)[owner]
        self.nodes = nodes
        self.sub_length = np.diff(self.s) / count
        dense = self._lagrange(nodes[owner], a)
        self.dense = np.vstack([dense, self.points[-1:]])
        self.dense_s = np.concatenate([a, self.s[-1:]])
        self.owner = np.concatenate([owner, [n - 2]])
        self.tree = cKDTree(self.dense)

    def _lagrange(self, nodes: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Values at parameters ``a`` of the polynomials through the stored points ``nodes`` (one row each)."""
        s = self.s[nodes]
        weights = np.ones(nodes.shape)
        for k in range(nodes.shape[1]):
            for m in range(nodes.shape[1]):
                if m != k:
                    weights[:, k] *= (a - s[:, m]) / (s[:, k] - s[:, m])
        return np.einsum("ik,ikd->id", weights, self.points[nodes])

    def segment_error(self, segment: np.ndarray) -> np.ndarray:
        """Interpolation error bound on the given segments (largest of the points around them)."""
        n = len(self.points)
        around = [self.interpolation_error[np.clip(segment + d, 0, n - 1)] for d in (-1, 0, 1, 2)]
        return np.max(around, axis=0)

    def end_length(self, end: int) -> float:
        """Chord length of the continuation step at one end (0: start, -1: end): the last
        stored point of a stopped branch lies at most one step past its stop criterion.

        A step is a run of points with the same ``step`` number (numbers restart in each
        stage; a lone first point is the branch's start); without step numbers, two segments.
        """
        n = len(self.points)
        if self.step is None or not len(self.step):
            first, last = (0, 2) if end == 0 else (n - 3, n - 1)
        else:
            change = np.flatnonzero(np.diff(self.step) != 0)  # last point of each run but the final one
            if end == 0:
                last = n - 1 if not len(change) else (change[1] if change[0] == 0 and len(change) > 1 else change[0])
                first = 0
            else:
                first, last = (change[-1] if len(change) else 0), n - 1
        first, last = max(first, 0), min(last, n - 1)
        return float(self.s[last] - self.s[first])

    def distance(self, queries: np.ndarray):
        """Distance of points (ln E, ln f) to the curve; the segment and whether the nearest
        location is an end of the curve (then the point may lie beyond it).

        The nearest sub-segment of the densified curve gives a first parameter; the
        distance to the cubic of that segment is then minimised by a shrinking search on
        the parameter (the densified polyline alone would add its own chord error)."""
        _, nearest = self.tree.query(queries, k=min(8, len(self.dense)))
        nearest = np.atleast_2d(nearest)
        best = np.full(len(queries), np.inf)
        at_end = np.zeros(len(queries), dtype=bool)
        parameter = np.zeros(len(queries))
        last = len(self.dense) - 1
        for column in nearest.T:
            for lo in (column - 1, column):
                lo = np.clip(lo, 0, last - 1)
                a, b = self.dense[lo], self.dense[lo + 1]
                ab = b - a
                length2 = np.maximum((ab * ab).sum(axis=1), 1e-300)
                t = np.clip(((queries - a) * ab).sum(axis=1) / length2, 0.0, 1.0)
                d = np.linalg.norm(a + t[:, None] * ab - queries, axis=1)
                better = d < best
                best[better] = d[better]
                parameter[better] = (self.dense_s[lo] + t * (self.dense_s[lo + 1] - self.dense_s[lo]))[better]
                at_end[better] = ((lo[better] == 0) & (t[better] == 0)) | ((lo[better] == last - 1) & (t[better] == 1))
        segment = np.clip(np.searchsorted(self.s, parameter, side="right") - 1, 0, len(self.s) - 2)
        nodes = self.nodes[segment]
        width = self.sub_length[segment].copy()
        offsets = np.linspace(-1.0, 1.0, 5)
        for _ in range(40):
            trial = np.clip(parameter[:, None] + width[:, None] * offsets, self.s[0], self.s[-1])
            values = self._lagrange(np.repeat(nodes, 5, axis=0), trial.ravel()).reshape(len(queries), 5, 2)
            d = np.linalg.norm(values - queries[:, None, :], axis=2)
            parameter = trial[np.arange(len(queries)), np.argmin(d, axis=1)]
            best = np.minimum(best, d.min(axis=1))
            width /= 2
        return best, segment, at_end


def _fmt(e, f) -> str:
    return f"E={e:.9g} f={f:.9g}"


def _check_curve(name, reference: dict, build: dict, base: float) -> list[Row]:
    """Each curve's stored points on the other curve, and the two curves' ends."""
    curves = {side: Curve(t["energy"], t["frequency"], t.get("step")) for side, t in (("reference", reference), ("build", build))}
    rows = []
    for label, source, target in (("build points on reference curve", "build", "reference"),
                                  ("reference points on build curve", "reference", "build")):
        c_src, c_tgt = curves[source], curves[target]
        d, segment, at_end = c_tgt.distance(c_src.points)
        tolerance = base + c_tgt.segment_error(segment)
        # A point within one end step of both curves' ends may lie past the other curve's
        # end (where the other branch stopped one step earlier); the end rows check it.
        for end in (0, -1):
            step = max(c_src.end_length(end), c_tgt.end_length(end))
            along = np.abs(c_src.s - c_src.s[end])
            near = (along <= step) & (np.linalg.norm(c_src.points - c_tgt.points[end], axis=1) <= step)
            at_end |= near & (d > tolerance)
        ratio = np.where(at_end, 0.0, d / tolerance)
        worst = int(np.argmax(ratio))
        n_out = int(at_end.sum())
        verdict = "within tolerance" if ratio[worst] <= 1 else "discrepant"
        e, f = np.exp(c_src.points[worst])
        rows.append(Row(name, f"{label} ({len(c_src.points)} points, {n_out} past an end; worst at {_fmt(e, f)})",
                        f"{len(curves['reference'].points)} points", f"{len(curves['build'].points)} points",
                        float(d[worst]), float(tolerance[worst]), verdict))
    for end, label in ((0, "start point"), (-1, "end point")):
        p_ref, p_build = curves["reference"].points[end], curves["build"].points[end]
        gap = float(np.linalg.norm(p_ref - p_build))
        tolerance = base + max(curves["reference"].end_length(end), curves["build"].end_length(end))
        rows.append(Row(name, label, _fmt(*np.exp(p_ref)), _fmt(*np.exp(p_build)), gap, tolerance,
                        "within tolerance" if gap <= tolerance else "discrepant"))
    return rows


def _check_located(name, reference: list, build: list, ref_curve: dict, build_curve: dict, base: float) -> list[Row]:
    """Branch points to the ANM's accuracy (bisection along the series, then Newton);
    folds within the spacing of the stored points around them (the parabola through the
    extremal point and its neighbours), from either build."""
    rows = []
    curves = [Curve(t["energy"], t["frequency"], t.get("step")) for t in (ref_curve, build_curve)]
    for kind in ("branch point", "fold"):
        ref = np.array([[np.log(e), np.log(f)] for k, e, f in reference if k == kind]).reshape(-1, 2)
        got = np.array([[np.log(e), np.log(f)] for k, e, f in build if k == kind]).reshape(-1, 2)
        if len(ref) != len(got):
            rows.append(Row(name, f"number of {kind}s", str(len(ref)), str(len(got)), float(abs(len(ref) - len(got))), 0.0, "discrepant"))
            continue
        for j, (p, q) in enumerate(zip(ref, got)):
            tolerance = base
            if kind == "fold":  # length of the segment of each curve where its fold lies
                segments = [int(c.distance(x[None])[1][0]) for c, x in zip(curves, (p, q))]
                tolerance += max(float(c.s[k + 1] - c.s[k]) for c, k in zip(curves, segments))
            gap = float(np.linalg.norm(p - q))
            rows.append(Row(name, f"{kind} {j + 1}", _fmt(*np.exp(p)), _fmt(*np.exp(q)), gap, tolerance,
                            "within tolerance" if gap <= tolerance else "discrepant"))
    return rows


# --------------------------------------------------------------------------- tables


def _check_compare(reference: Path, build: xr.Dataset, tolerances: dict) -> list[Row]:
    """Figs 2-4's comparison. Orbits are Newton-solved at the matched energies (residual
    1e-13), so at the same energies both frequencies agree to COMPARE_TOLERANCE. The
    energies follow NNM1 stage 1's range, which ends one step apart between builds; then
    each (energy, frequency) must lie on the reference curve it was solved on."""
    name = f"results/{COMPARE_NC}"
    table = _read_csv(reference / "compare_nnm1.csv")
    energy = build["energy"].values
    rows = []
    if len(energy) == len(table["energy"]) and np.allclose(energy, table["energy"], rtol=1e-12, atol=0):
        for variable in ("frequency_exact", "frequency_regularized"):
            difference = np.abs(build[variable].values / table[variable] - 1)
            worst = int(np.argmax(difference))
            rows.append(Row(name, f"{variable} at the same energies (relative, worst at E={energy[worst]:.6g})",
                            f"{table[variable][worst]:.12g}", f"{build[variable].values[worst]:.12g}",
                            float(difference[worst]), COMPARE_TOLERANCE,
                            "within tolerance" if difference[worst] <= COMPARE_TOLERANCE else "discrepant"))
        return rows
    nnm1 = _read_csv(reference / "curves" / _curve_name("hbm/nnm1.nc"))
    stage1 = {k: v[nnm1["stage"] == 1] for k, v in nnm1.items()}
    for variable, curve, relative in (("frequency_exact", _read_csv(reference / "curves" / _curve_name("exact/nnm1_two_impacts.nc")),
                                       "exact/nnm1_two_impacts.nc"),
                                      ("frequency_regularized", stage1, "hbm/nnm1.nc")):
        target = Curve(curve["energy"], curve["frequency"], curve.get("step"))
        points = np.column_stack([np.log(energy), np.log(build[variable].values)])
        d, segment, _ = target.distance(points)
        tolerance = tolerances[relative] + target.segment_error(segment)
        worst = int(np.argmax(d / tolerance))
        rows.append(Row(name, f"{variable} on the reference curve of {relative} ({len(energy)} other energies; worst at E={energy[worst]:.6g})",
                        "curve", f"{build[variable].values[worst]:.12g}", float(d[worst]), float(tolerance[worst]),
                        "within tolerance" if d[worst] <= tolerance[worst] else "discrepant"))
    return rows


def _check_regimes(reference: dict, sampling: dict, build: dict, build_sampling: list) -> list[Row]:
    """The regime table: the regimes and their exact sequences exactly; statistics over
    stored orbits within the largest change between neighbouring orbits (either build)."""
    name = f"results/{REGIMES_CSV}"
    if list(reference["impacts_per_period"]) != list(build["impacts_per_period"]) or \
            list(reference["exact_sequence"]) != list(build["exact_sequence"]):
        return [Row(name, "regimes (impacts per period, exact sequence)", str(list(reference["impacts_per_period"])),
                    str(list(build["impacts_per_period"])), float("nan"), 0.0, "discrepant")]
    step_of = {"energy": "d_log_energy", "frequency": "d_frequency", "frequency_error": "d_frequency_error",
               "rel_frequency_error": "d_relative_frequency_error"}
    rows = []
    for column in reference:
        if column in ("regime", "impacts_per_period", "exact_sequence", "n_matched", "n_unmatched"):
            continue  # identities, or counts of stored orbits (they follow the sampling)
        kind = next((k for k in ("rel_frequency_error", "frequency_error", "energy", "frequency") if k in column), None)
        if kind is None:
            continue
        worst = None
        for k in range(len(reference[column])):
            r, b = float(reference[column][k]), float(build[column][k])
            tolerance = max(sampling[step_of[kind]][k], build_sampling[k][list(step_of).index(kind)])
            difference = abs(np.log(b / r)) if kind == "energy" else abs(b - r)
            if worst is None or difference / max(tolerance, 1e-300) > worst[0]:
                worst = (difference / max(tolerance, 1e-300), k, r, b, difference, tolerance)
        _, k, r, b, difference, tolerance = worst
        rows.append(Row(name, f"{column} (worst of {len(reference[column])} regimes: regime {k})"
                        + (" (ln)" if kind == "energy" else ""), f"{r:.9g}", f"{b:.9g}", difference, tolerance,
                        "within tolerance" if difference <= tolerance else "discrepant"))
    return rows


# --------------------------------------------------------------------------- verify


def verify(results_dir, reference_dir="reference") -> list[Row]:
    """Compare the build in ``results_dir`` with ``reference_dir``; one :class:`Row` per check.

    Every file of the reference manifest is first compared byte for byte, then without
    its provenance attributes (:func:`data_digest`); a file that still differs is
    checked by what it holds (curve, located points, table); a file with no
    such check, or missing, is discrepant.

    Raises
    ------
    ValueError
        If either directory or the reference manifest is missing.
    """
    results = _results_dir(results_dir)
    reference = Path(reference_dir)
    if not (reference / "MANIFEST.sha256").is_file():
        raise ValueError(f"no reference manifest {reference / 'MANIFEST.sha256'}: regenerate it with "
                         f"`python -m nnmstop.pipeline.verify --update-reference RESULTS_DIR --reference {reference}`")
    tolerances = json.loads((reference / "tolerances.json").read_text())
    data_digests = {line.split("  ")[1]: line.split("  ")[0] for line in (reference / "DATA.sha256").read_text().splitlines()}
    located_ref = _read_csv(reference / "located.csv") if (reference / "located.csv").stat().st_size else {}
    rows = []
    for line in (reference / "MANIFEST.sha256").read_text().splitlines():
        digest, listed = line.split("  ")
        relative = listed.removeprefix("results/")
        path = results / relative
        if not path.is_file():
            rows.append(Row(listed, "file", "present", "missing", float("nan"), 0.0, "discrepant"))
            continue
        if _sha256(path) == digest:
            rows.append(Row(listed, "file (SHA-256)", digest[:12], digest[:12], 0.0, 0.0, "identical"))
            continue
        if data_digest(path) == data_digests.get(listed):
            rows.append(Row(listed, "content without provenance (SHA-256)", data_digests[listed][:12],
                            data_digests[listed][:12], 0.0, 0.0, "identical data"))
            continue
        if relative == REGIMES_CSV:
            with xr.open_dataset(results / REGIMES_CSV.replace(".csv", ".nc")) as regimes:
                build_sampling = _regime_sampling(regimes)
            rows += _check_regimes(_read_csv(reference / "nnm1_regimes.csv"), _read_csv(reference / "nnm1_regimes_sampling.csv"),
                                   _read_csv(path), build_sampling)
        elif relative == COMPARE_NC:
            with xr.open_dataset(path) as ds:
                rows += _check_compare(reference, ds, tolerances)
        elif relative == REGIMES_CSV.replace(".csv", ".nc"):
            rows.append(Row(listed, "regime dataset: checked through its table", "-", "-", 0.0, 0.0, "within tolerance"))
        elif "/stages/" in relative:
            branch, stage = path.stem.split("_stage")
            ref_table = _read_csv(reference / "curves" / _curve_name(f"hbm/{branch}.nc"))
            keep = ref_table["stage"] == int(stage)
            with xr.open_dataset(path) as ds:
                rows += _check_curve(listed, {k: v[keep] for k, v in ref_table.items()}, _curve_table(ds),
                                     tolerances[f"hbm/{branch}.nc"])
        elif _is_curve(relative) and relative in tolerances:
            ref_table = _read_csv(reference / "curves" / _curve_name(relative))
            with xr.open_dataset(path) as ds:
                build_table, build_located = _curve_table(ds), _located(ds)
            base = tolerances[relative]
            ref_located = [] if not located_ref else [
                (k, e, f) for file, k, e, f in zip(located_ref["file"], located_ref["kind"], located_ref["energy"], located_ref["frequency"])
                if file == relative]
            rows += _check_curve(listed, ref_table, build_table, base)
            rows += _check_located(listed, ref_located, build_located, ref_table, build_table, base)
        else:
            rows.append(Row(listed, "file (SHA-256)", digest[:12], _sha256(path)[:12], float("nan"), 0.0, "discrepant"))
    return rows


def file_verdicts(rows: list[Row]) -> dict[str, str]:
    """One verdict per file: the worst of its rows."""
    order = ("identical", "identical data", "within tolerance", "discrepant")
    verdicts: dict[str, str] = {}
    for row in rows:
        verdicts[row.file] = max(verdicts.get(row.file, "identical"), row.verdict, key=order.index)
    return verdicts


def format_table(rows: list[Row]) -> str:
    """The rows as a text table, then the counts of files per verdict."""
    lines = ["Distances are in (ln E, ln f): relative differences. Curve tolerance = accuracy of the stored orbits "
             "(ANM Newton threshold, or 1e-9 for exact orbits) + interpolation error of the curve (leave-one-out "
             "cubic deviation of the stored points around). Ends: one continuation step.",
             f"{'file':45s} {'quantity':70s} {'reference':32s} {'this build':32s} {'difference':>11s} {'tolerance':>10s}  verdict"]
    for r in rows:
        lines.append(f"{r.file:45s} {r.quantity:70s} {r.reference:32s} {r.build:32s} {r.difference:11.3e} {r.tolerance:10.3e}  {r.verdict}")
    verdicts = list(file_verdicts(rows).values())
    lines.append(f"files: {verdicts.count('identical')} identical, {verdicts.count('identical data')} identical data "
                 f"(other git commit), {verdicts.count('within tolerance')} within tolerance, {verdicts.count('discrepant')} discrepant")
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
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(format_table(rows))
    return 1 if any(r.verdict == "discrepant" for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
