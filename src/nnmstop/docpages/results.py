"""The results page of the documentation (``docs/results.md``), generated from the datasets of a build.

:func:`results_page` reads the datasets behind the paper's figures (the default target) and writes
every number of the page from them: the linear limits, each branch's range, points, end and
stability counts, the located branch points and folds, the comparison at the paper's points a) and
b), and the error per impact regime. The page lists the data digest
(:func:`nnmstop.pipeline.verify.data_digest`) of every dataset it read, so a test can tell whether it
was generated from the committed reference build (``reference/DATA.sha256``).
Run it with ``snakemake --cores 2 docs`` (task :func:`nnmstop.tasks.docs.docs_pages`).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop.models.two_dof import ModelParameters, linear_modes

__all__ = [
    "RESULT_DATASETS",
    "OPTIONAL_DATASETS",
    "STRUCTURE_DATASETS",
    "results_page",
    "datasets_read",
    "structure_results_page",
    "identity_table",
    "page_inputs",
]

#: The datasets the page reads, under ``results/``, by the name the page uses.
RESULT_DATASETS = {
    "exact_two_impacts": "exact/nnm1_two_impacts.nc",
    "exact_nnm1": "exact/nnm1.nc",
    "nnm1": "hbm/nnm1.nc",
    "nnm2": "hbm/nnm2.nc",
    "nnm1_3to1": "hbm/bifurcated/nnm1_3to1.nc",
    "nnm1_5to1": "hbm/bifurcated/nnm1_5to1.nc",
    "compare": "compare/nnm1_exact_vs_regularized.nc",
    "regimes": "compare/nnm1_regimes.nc",
}
_BRANCHES = {
    "exact_one_stop": "exact NNM1, one impact per side of its struck stop",
    "exact_two_impacts": "exact NNM1, two impacts per period",
    "exact_nnm1": "exact NNM1, any number of impacts",
    "nnm1": "regularized NNM1",
    "nnm2": "regularized NNM2",
    "nnm1_3to1": "switched at the 3:1 resonance",
    "nnm1_5to1": "switched at the 5:1 resonance",
}
#: Datasets the page shows only when the build has them (the switched branches of ``bifurcations``).
OPTIONAL_DATASETS = ("nnm1_3to1", "nnm1_5to1")
#: The datasets of the page of a structure of one's own (``structure.kind`` beam or matrices), under ``results/``.
STRUCTURE_DATASETS = {
    "nnm1": "hbm/nnm1.nc",
    "nnm2": "hbm/nnm2.nc",
    "exact_one_stop": "exact/nnm1_one_impact.nc",
    "compare_one_stop": "compare/nnm1_one_impact.nc",
}
_PATHS = {**RESULT_DATASETS, **STRUCTURE_DATASETS}
_INPUT_LINE = re.compile(r"^\| `results/(?P<path>[^`]+)` \| `(?P<digest>[0-9a-f]{64})` \|$")


def g(value, digits: int = 4) -> str:
    """``value`` with ``digits`` significant digits (``%g`` style), for the tables."""
    return f"{float(value):.{digits}g}"


def _is_number(cell) -> bool:
    try:
        float(str(cell).split(" ")[0])
    except ValueError:
        return False
    return True


def _table(header: list, rows: list) -> list:
    """A Markdown table; columns whose cells all start with a number are right-aligned."""
    align = ["---:" if rows and all(_is_number(row[k]) for row in rows) else "---" for k in range(len(header))]
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join(align) + " |"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines


def _linear_limits(params: ModelParameters) -> list:
    rows = []
    for limit, what in (
        ("no_contact", "no contact (the underlying linear system)"),
        ("regularized", "regularized, near rest (added stiffness eta)"),
        ("gap_zero", "gap 0 (stop always engaged, added stiffness alpha)"),
    ):
        omega, _ = linear_modes(params, limit)
        rows.append([what, g(omega[0] / (2 * np.pi)), g(omega[1] / (2 * np.pi))])
    return _table(["limit", "f NNM1 [Hz]", "f NNM2 [Hz]"], rows)


def _stability_counts(ds: xr.Dataset) -> tuple:
    """Resolved verdicts, stable and unstable among them, and the unresolved orbits (whose ``stable`` is only the
    HBM orbit's unconfirmed verdict, so it is counted in neither): the four add up to the points."""
    if "stable" not in ds:
        return "", "", "", ""
    resolved = ds["stability_resolved"].values == 1 if "stability_resolved" in ds else np.ones(ds.sizes["point"], bool)
    stable = ds["stable"].values == 1
    return (
        str(int(resolved.sum())),
        str(int((stable & resolved).sum())),
        str(int((~stable & resolved).sum())),
        str(int((~resolved).sum())),
    )


def _branches(data: dict) -> list:
    rows, ends = [], []
    for name, what in _BRANCHES.items():
        if name not in data:
            continue
        ds = data[name]
        energy, frequency = ds["energy"].values, ds["frequency"].values
        residual = next((ds[v] for v in ("residual", "algebraic_residual") if v in ds), None)
        resolved, stable, unstable, unresolved = _stability_counts(ds)
        rows.append(
            [
                f"{what} (`{_PATHS[name]}`)",
                ds.sizes["point"],
                f"{g(energy.min())} - {g(energy.max())}",
                f"{g(frequency[0], 5)} -> {g(frequency[-1], 5)}",
                g(float(residual.max()), 2) if residual is not None else "",
                resolved,
                stable,
                unstable,
                unresolved,
            ]
        )
        ends.append(f"- {what}: {ds.attrs.get('end_reason', '')}")
    header = [
        "branch (dataset)",
        "points",
        "E range",
        "f first -> last [Hz]",
        "max residual",
        "verdicts",
        "stable",
        "unstable",
        "unresolved",
    ]
    return [*_table(header, rows), "", "Where each branch ends (`end_reason`):", "", *ends]


def _exact_regimes(ds: xr.Dataset) -> list:
    rows = []
    for segment in np.unique(ds["segment"].values):
        part = ds.isel(point=np.flatnonzero(ds["segment"].values == segment))
        energy = part["energy"].values
        rows.append(
            [
                int(segment),
                str(part["phase_sequence"].values[0]),
                int(part["impacts_per_period"].values.max()),  # the first orbit may be the grazing one
                part.sizes["point"],
                f"{g(energy.min())} - {g(energy.max())}",
                f"{g(energy[0])} -> {g(energy[-1])}",
                _stability_counts(part)[1],
            ]
        )
    header = ["segment", "sequence", "impacts per period", "points", "E range", "E first -> last", "stable"]
    return _table(header, rows)


def _located(data: dict) -> list:
    rows = []
    for name in ("nnm1", "nnm2", "nnm1_3to1", "nnm1_5to1"):
        if name not in data:
            continue
        ds = data[name]
        for k in range(ds.sizes.get("located_branch_point", 0)):
            resonance = int(ds["branch_point_resonance"].values[k])
            kind = f"{resonance}:1 resonance" if resonance > 0 else "branch point"
            if int(ds["branch_point_symmetry_breaking"].values[k]):
                kind = "symmetry-breaking branch point"
            rows.append(
                [
                    _BRANCHES[name],
                    kind,
                    g(ds["branch_point_energy"].values[k], 6),
                    g(ds["branch_point_frequency"].values[k], 6),
                    g(ds["branch_point_singular_ratio"].values[k], 2),
                ]
            )
        for k in range(ds.sizes.get("located_fold", 0)):
            rows.append(
                [
                    _BRANCHES[name],
                    "energy fold",
                    g(ds["fold_energy"].values[k], 6),
                    g(ds["fold_frequency"].values[k], 6),
                    "",
                ]
            )
    return _table(["branch", "point", "E", "f [Hz]", "singular ratio"], rows)


def _points_a_b(ds: xr.Dataset) -> list:
    rows = []
    for code, label in enumerate(("a", "b"), start=1):  # flag_values of `marked`: 1 point a), 2 point b)
        (k,) = np.flatnonzero(ds["marked"].values == code)
        exact, regularized = ds["frequency_exact"].values[k], ds["frequency_regularized"].values[k]
        alike = "counterpart" not in ds or int(ds["counterpart"].values[k]) == 0
        differences = (
            [g(ds[name].values[k], 3) for name in ("relative_frequency_difference", "max_x_difference",
                                                   "max_force_difference")]
            if alike
            else ["no counterpart", "", ""]
        )  # fmt: skip
        rows.append([f"{label})", g(ds["exact_energy"].values[k]), g(exact, 6), g(regularized, 6), *differences])
    header = [
        "point",
        "E",
        "f exact [Hz]",
        "f regularized [Hz]",
        "relative difference",
        "max x difference",
        "max f difference",
    ]
    return _table(header, rows)


def _regimes(ds: xr.Dataset) -> list:
    rows = []
    for k in range(ds.sizes["regime"]):
        r = ds.isel(regime=k)
        rows.append(
            [
                int(r["impacts_per_period"]),
                str(r["exact_sequence"].values),
                f"{g(r['exact_energy_min'])} - {g(r['exact_energy_max'])}",
                f"{g(r['regularized_energy_min'])} - {g(r['regularized_energy_max'])}",
                f"{int(r['n_matched'])} ({int(r['n_unmatched'])})",
                g(r["max_abs_frequency_error"], 3),
                g(r["energy_at_max_error"]),
                g(r["median_abs_frequency_error"], 3),
                g(r["mean_frequency_error"], 2),
                g(r["max_rel_frequency_error"], 3),
            ]
        )
    header = [
        "impacts/period",
        "exact sequence",
        "exact E",
        "regularized E",
        "compared (left out)",
        "max abs df [Hz]",
        "at E",
        "median abs df [Hz]",
        "mean df [Hz]",
        "max abs df / f",
    ]
    return _table(header, rows)


def identity_table(data: dict) -> list:
    """What the orbits of each regularized branch are along it (:func:`nnmstop.hbm.identity.identity_runs`): one row
    per run of one identity, with its points and energies (where the branch crosses onto another family)."""
    from nnmstop.hbm.identity import identity_runs

    rows = []
    for name in ("nnm1", "nnm2", "nnm1_3to1", "nnm1_5to1"):
        if name not in data:
            continue
        ds = data[name]
        energy, frequency = ds["energy"].values, ds["frequency"].values
        for run in identity_runs(ds):
            a, b = run.start, run.stop - 1
            rows.append(
                [_BRANCHES[name], run.label, f"{a} - {b}", f"{g(energy[a])} -> {g(energy[b])}",
                 f"{g(frequency[a], 5)} -> {g(frequency[b], 5)}"]
            )  # fmt: skip
    return _table(["branch", "orbits are", "points", "E first -> last", "f first -> last [Hz]"], rows)


def _stability_reasons(data: dict) -> list:
    rows = []
    for name in ("nnm1", "nnm2", "nnm1_3to1", "nnm1_5to1"):
        if name not in data:
            continue
        reason = data[name]["stability_reason"]
        meanings = reason.attrs["flag_meanings"].split()
        counts = {int(v): int((reason == v).sum()) for v in reason.attrs["flag_values"]}
        rows.append([_BRANCHES[name], reason.sizes["point"], *(counts[int(v)] for v in reason.attrs["flag_values"])])
    header = ["branch", "points", *(m.replace("_", " ") for m in meanings)]
    return _table(header, rows)


def _introduction(params: ModelParameters, nnm1: xr.Dataset) -> list[str]:
    """The page's title and what it is generated from."""
    return [
        "# Results",
        "",
        "<!-- Generated by `snakemake --cores 2 docs` (nnmstop.docpages.results): do not edit by hand. -->",
        "",
        "Every number on this page is written by `snakemake --cores 2 docs` from the datasets of the",
        "default build (`snakemake --cores 2`), with the parameters of `config/config.yaml`",
        f"(alpha = {g(params.alpha)}, beta = {g(params.beta)}, delta = {g(params.delta)}, eta = {g(params.eta)},",
        f"H = {nnm1.attrs['harmonics']} harmonics, ANM order {nnm1.attrs['order']}). The datasets it read, with their",
        "data digests (`nnmstop.pipeline.verify.data_digest`), are listed at the end; a test checks them against",
        "the committed reference build (`reference/DATA.sha256`), so this page cannot silently fall behind it.",
        "Frequencies are in Hz of the nondimensional time (1/T); energies are nondimensional.",
    ]


def results_page(results_dir, params: ModelParameters, digests: dict) -> str:
    """The results page (MyST Markdown) of the build in ``results_dir``.

    Parameters
    ----------
    results_dir : path
        The build's ``results/`` folder, holding every file of :data:`RESULT_DATASETS` (those of
        :data:`OPTIONAL_DATASETS` where the build has them).
    params : ModelParameters
        The model of the build (``model`` section of its configuration), for the linear limits.
    digests : dict
        Data digest of each dataset read, by its path under ``results/`` (listed on the page).

    Returns
    -------
    str
        The page; every number on it is read or computed from the datasets and ``params``.
    """
    from nnmstop.netcdf import read_dataset

    results_dir = Path(results_dir)
    data = {
        name: read_dataset(results_dir / path)
        for name, path in RESULT_DATASETS.items()
        if name not in OPTIONAL_DATASETS or (results_dir / path).exists()
    }
    nnm1 = data["nnm1"]
    lines = [
        *_introduction(params, nnm1),
        "",
        "## Linear limits",
        "",
        *_linear_limits(params),
        "",
        "## Branches",
        "",
        "Each dataset's points, energy range, frequency at its first and last point, largest residual",
        "(relative algebraic residual of the HBM equations; norm of the quarter-period equations for the exact",
        "orbits), Floquet verdicts resolved (stable and unstable among them) and orbits whose verdict is",
        "unresolved (their `stable` is the HBM orbit's unconfirmed verdict, counted in neither column).",
        "",
        *_branches(data),
        "",
        "## The exact NNM1, regime by regime",
        "",
        "The exact NNM1 continued through its grazing transitions (`results/exact/nnm1.nc`): each segment is",
        "one phase sequence (F free flight, L and R contact with the left and right stop), in branch order.",
        "",
        *_exact_regimes(data["exact_nnm1"]),
        "",
        "## What the orbits are along each branch",
        "",
        "From each orbit's harmonic content (`dominant_harmonic`, `dominant_mode`, `tongue_harmonic`, `orbit_kind`;",
        "[the method](methods/identity.md)): runs of one identity in branch order; a change is where the branch",
        "enters an internal resonance tongue or crosses onto another family (an NNM seen at 1/n of its frequency).",
        "",
        *identity_table(data),
        "",
        "## Branch points and energy folds",
        "",
        "Located on the regularized branches (`branch_point_*`, `fold_*`); the singular ratio is the smallest",
        "over the second-smallest singular value of the Jacobian at the located point.",
        "",
        *_located(data),
        "",
        "## Exact against regularized at the paper's points a) and b)",
        "",
        "From `results/compare/nnm1_exact_vs_regularized.nc` (Figs 2-4): orbits matched at equal energy.",
        "",
        *_points_a_b(data["compare"]),
        "",
        "## Frequency error per impact regime",
        "",
        "From `results/compare/nnm1_regimes.nc` (also `results/compare/nnm1_regimes.csv`): both branches cut",
        "into runs of equal impact count, paired in branch order; each regularized orbit compared with the",
        "exact frequency at its energy; df = regularized - exact frequency.",
        "",
        *_regimes(data["regimes"]),
        "",
        "## Stability verdicts",
        "",
        "Counts of `stability_reason` (its `flag_meanings`) on each regularized branch",
        "([monodromy](methods/monodromy.md)).",
        "",
        *_stability_reasons(data),
        "",
        *datasets_read({RESULT_DATASETS[name]: digests[RESULT_DATASETS[name]] for name in data}),
    ]
    return "\n".join(lines) + "\n"


def _structure_limits(nnm1: xr.Dataset) -> list:
    rows = []
    for limit, what in (
        ("no_contact_frequency", "no contact (every gap infinite)"),
        ("regularized_frequency", "regularized, near rest (added stiffness eta at each stop)"),
        ("gap_zero_frequency", "gap 0 (every stop always engaged, added stiffness alpha)"),
    ):
        values = nnm1[limit].values[:2]
        rows.append([what, *(g(v, 4) for v in values)])
    return _table(["limit", "f mode 1 [Hz]", "f mode 2 [Hz]"][: 1 + len(nnm1["mode"].values[:2])], rows)


def _structure_comparison(ds: xr.Dataset) -> list:
    if ds.sizes["energy"] == 0:
        return [f"Nothing compared: {ds.attrs.get('end_reason', 'no common energy')}."]
    compared = ds["no_counterpart"].values == 0 if "no_counterpart" in ds else np.ones(ds.sizes["energy"], bool)
    difference = np.abs(ds["relative_difference"].values[compared])
    rows = [
        [
            ds.sizes["energy"],
            int(compared.sum()),
            f"{g(float(ds['energy'].values.min()))} - {g(float(ds['energy'].values.max()))}",
            g(float(difference.max()), 3) if difference.size else "",
            g(float(np.median(difference)), 3) if difference.size else "",
        ]
    ]
    return _table(["energies", "compared (counterparts)", "E range", "max abs df / f", "median abs df / f"], rows)


def structure_results_page(results_dir, digests: dict) -> str:
    """The results page of the build of a structure of one's own (``structure.kind`` beam or matrices).

    The sections that apply to any structure (linear limits, branches, what the orbits are, branch points,
    stability verdicts, the exact one-stop family against the regularized NNM1) from the datasets of
    :data:`STRUCTURE_DATASETS`; what exists for the paper's oscillator only is named as such.
    """
    from nnmstop.figures.frequency_energy import structure_line

    results_dir = Path(results_dir)
    data = {name: xr.load_dataset(results_dir / path) for name, path in STRUCTURE_DATASETS.items()}
    nnm1 = data["nnm1"]
    branches = {name: data[name] for name in ("exact_one_stop", "nnm1", "nnm2")}
    branches["exact_one_stop"] = branches["exact_one_stop"].rename({"orbit": "point"})  # the family's orbits
    lines = [
        "# Results",
        "",
        "<!-- Generated by `snakemake --cores 2 docs` (nnmstop.docpages.results): do not edit by hand. -->",
        "",
        f"Every number on this page is written by `snakemake --cores 2 docs` from the datasets of this build: "
        f"{structure_line(nnm1)}, ANM order {nnm1.attrs['order']}. Frequencies in Hz of the nondimensional time, "
        "energies nondimensional.",
        "",
        "## Linear limits",
        "",
        *_structure_limits(nnm1),
        "",
        "## Branches",
        "",
        *_branches(branches),
        "",
        "## What the orbits are along each branch",
        "",
        *identity_table(data),
        "",
        "## Branch points and energy folds",
        "",
        *_located(data),
        "",
        "## Exact against regularized NNM1",
        "",
        "From `results/compare/nnm1_one_impact.nc`: frequencies where each branch first reaches log-spaced energies",
        "of the exact family's backbone; energies where the regularized NNM1 is of another type are not compared.",
        "",
        *_structure_comparison(data["compare_one_stop"]),
        "",
        "## Stability verdicts",
        "",
        *_stability_reasons(data),
        "",
        "## For the paper's oscillator only",
        "",
        "The exact NNM1 through any number of impacts, the branches switched at its 3:1 and 5:1 resonances, the",
        "orbits at the paper's points a) and b) and the error per impact regime are built for the paper's 2-DOF",
        "oscillator (`structure.kind: two_dof`); this build has none of them.",
        "",
        *datasets_read(dict(sorted(digests.items()))),
    ]
    return "\n".join(lines) + "\n"


def datasets_read(digests: dict) -> list[str]:
    """The section "Datasets read" of a generated page: the data digest of each dataset ``{path under results/:
    digest}``, in the given order (what :func:`page_inputs` reads back)."""
    return [
        "## Datasets read",
        "",
        "| dataset | data digest |",
        "|---|---|",
        *(f"| `results/{path}` | `{digest}` |" for path, digest in digests.items()),
    ]


def page_inputs(page: str) -> dict:
    """The data digest of every dataset a generated results page lists, by path under ``results/``."""
    return {m["path"]: m["digest"] for m in map(_INPUT_LINE.match, page.splitlines()) if m}
