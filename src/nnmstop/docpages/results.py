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

__all__ = ["RESULT_DATASETS", "OPTIONAL_DATASETS", "results_page", "page_inputs"]

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
    "exact_two_impacts": "exact NNM1, two impacts per period",
    "exact_nnm1": "exact NNM1, any number of impacts",
    "nnm1": "regularized NNM1",
    "nnm2": "regularized NNM2",
    "nnm1_3to1": "switched at the 3:1 resonance",
    "nnm1_5to1": "switched at the 5:1 resonance",
}
#: Datasets the page shows only when the build has them (the switched branches of ``bifurcations``).
OPTIONAL_DATASETS = ("nnm1_3to1", "nnm1_5to1")
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
    return str(int(resolved.sum())), str(int((stable & resolved).sum())), str(int((~stable & resolved).sum())), str(
        int((~resolved).sum())
    )


def _branches(data: dict) -> list:
    rows, ends = [], []
    for name, what in _BRANCHES.items():
        if name not in data:
            continue
        ds = data[name]
        energy, frequency = ds["energy"].values, ds["frequency"].values
        residual = ds["residual"] if "residual" in ds else ds["algebraic_residual"]
        resolved, stable, unstable, unresolved = _stability_counts(ds)
        rows.append(
            [
                f"{what} (`{RESULT_DATASETS[name]}`)",
                ds.sizes["point"],
                f"{g(energy.min())} - {g(energy.max())}",
                f"{g(frequency[0], 5)} -> {g(frequency[-1], 5)}",
                g(float(residual.max()), 2),
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
        rows.append(
            [
                f"{label})",
                g(ds["exact_energy"].values[k]),
                g(exact, 6),
                g(regularized, 6),
                g(ds["relative_frequency_difference"].values[k], 3),
                g(ds["max_x_difference"].values[k], 3),
                g(ds["max_force_difference"].values[k], 3),
            ]
        )
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
    results_dir = Path(results_dir)
    data = {
        name: xr.load_dataset(results_dir / path)
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
        "## Datasets read",
        "",
        "| dataset | data digest |",
        "|---|---|",
        *(f"| `results/{RESULT_DATASETS[name]}` | `{digests[RESULT_DATASETS[name]]}` |" for name in data),
    ]
    return "\n".join(lines) + "\n"


def page_inputs(page: str) -> dict:
    """The data digest of every dataset a generated results page lists, by path under ``results/``."""
    return {m["path"]: m["digest"] for m in map(_INPUT_LINE.match, page.splitlines()) if m}
