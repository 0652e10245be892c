"""The "paper against this build" page of the documentation (``docs/paper_vs_build.md``), generated from the datasets.

A referee's first question: what does the paper state, and what does this build give for it? The paper states
three frequencies in words (Section 4: the first linear mode, 0.618/(2 pi) = 0.098 Hz; the regularized NNM2 near
rest, 1.639/(2 pi) = 0.2611 Hz; its high-energy asymptote, 5.666/(2 pi) = 0.9022 Hz) and shows everything else
(the grazing orbit, the 3:1 and 5:1 branch points, the labelled points a)-s)) in its figures only, without
numbers. :func:`paper_table_page` lists each of them with what the paper says of it (its words or the figure
that shows it: nothing is copied into a number it does not give) and what this build computes: the
frequencies of the linear limits of the datasets, the grazing orbit of the exact family, the located branch
points of NNM1, and every labelled point placed by the figures' own rule (:mod:`nnmstop.figures.modal_lines`)
with its energy, frequency, impacts and identity (:mod:`nnmstop.hbm.identity`). The page lists the data digest of
every dataset it read, so a test notices when it falls behind the reference build.
Run it with ``snakemake --cores 2 docs`` (task :func:`nnmstop.tasks.docs.docs`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop.docpages.results import _table, datasets_read, g
from nnmstop.figures.modal_lines import identity_text, impact_text, label_specs, locate_label

__all__ = ["PAPER_TABLE_DATASETS", "QUOTED", "paper_table_page"]

#: The datasets the page reads, under ``results/``, by the name the page uses.
PAPER_TABLE_DATASETS = {
    "exact_two_impacts": "exact/nnm1_two_impacts.nc",
    "nnm1": "hbm/nnm1.nc",
    "nnm2": "hbm/nnm2.nc",
    "compare": "compare/nnm1_exact_vs_regularized.nc",
}

#: The frequencies the paper quotes in words (Section 4), as printed: angular frequency (rad per unit of
#: nondimensional time) and Hz, where, and which linear limit of the datasets it is (and its mode).
QUOTED = (
    ("first linear mode of the underlying linear system", "0.618", "0.098", "Section 4.1", "no_contact_frequency", 1),
    ("NNM2 near rest (regularized: stiffness eta added)", "1.639", "0.2611", "Section 4.2", "regularized_frequency", 2),
    ("NNM2 at high energy: second linear mode, gap 0", "5.666", "0.9022", "Section 4.2", "gap_zero_frequency", 2),
)  # fmt: skip


def _agrees(printed: str, value: float) -> bool:
    """Whether ``value`` rounds to the ``printed`` number (within half a unit of its last printed digit)."""
    decimals = len(printed.partition(".")[2])
    return abs(float(printed) - value) <= 0.5 * 10.0**-decimals * (1 + 1e-9)


#: The figures whose labelled points the page lists, and the branch each labels.
LABELLED = {"fig06": "nnm2", "fig07": "nnm1", "fig08": "nnm1", "fig09": "nnm1", "fig10": "nnm1", "fig11": "nnm1"}


def _quoted(nnm1: xr.Dataset) -> list:
    rows = []
    for what, omega, hz, where, limit, mode in QUOTED:
        build = float(nnm1[limit].sel(mode=mode))
        build_rad = 2 * np.pi * build
        rad_ok, hz_ok = _agrees(omega, build_rad), _agrees(hz, build)
        if rad_ok and hz_ok:
            note = "agrees to the printed digits"
        elif hz_ok:
            note = f"the Hz agree; {omega}/(2 pi) = {float(omega) / (2 * np.pi):.4f} Hz: the rad value is rounded"
        else:
            note = (
                f"differs: this limit of the paper's Eqs. (3)-(4) is {build_rad:.4f} rad = {build:.4f} Hz; the paper's "
                f"{omega} rad is a misprint (its {hz} Hz follows from it)"
            )
        rows.append([what, f"{omega} rad = {hz} Hz ({where})", f"{g(build_rad, 5)} rad = {g(build, 5)} Hz", note])
    return _table(["quantity", "the paper", "this build", "note"], rows)


def _features(exact: xr.Dataset, nnm1: xr.Dataset) -> list:
    rows = [
        [
            "grazing orbit (first linear mode with x amplitude 1)",
            "Fig 2 (start of the red curve), no number",
            f"E = {g(float(exact['energy'].values[0]))}, f = {g(float(exact['frequency'].values[0]), 5)} Hz",
            "exact two-impact family, first orbit",
        ]
    ]
    resonance = nnm1["branch_point_resonance"].values
    for n, figure in ((3, "Fig 8 e)"), (5, "Fig 9 l)")):
        hits = np.flatnonzero(resonance == n)
        if hits.size:
            k = int(hits[0])
            value = (
                f"E = {g(float(nnm1['branch_point_energy'].values[k]), 6)}, "
                f"f = {g(float(nnm1['branch_point_frequency'].values[k]), 6)} Hz"
            )
        else:
            value = "not located on NNM1"
        rows.append([f"{n}:1 internal resonance (branch point of NNM1)", f"{figure}, no number", value, "located"])
    return _table(["feature", "the paper", "this build", "how"], rows)


def _points_a_b(compare: xr.Dataset, config: dict) -> list:
    rows = []
    points = config.get("compare", {}).get("points", {})
    for code, label in enumerate(("a", "b"), start=1):
        hits = np.flatnonzero(compare["marked"].values == code) if "marked" in compare else []
        if not len(hits):
            rows.append([f"{label})", "Figs 2-4", "not compared", ""])
            continue
        k = int(hits[0])
        counterpart = "" if int(compare["counterpart"].values[k]) == 0 else " (no counterpart)"
        energy, regularized = float(compare["energy"].values[k]), float(compare["frequency_regularized"].values[k])
        exact = float(compare["frequency_exact"].values[k])
        rows.append(
            [
                f"{label})",
                "Figs 2-4, no number",
                f"E = {g(energy)}, f = {g(regularized, 5)} Hz (regularized), {g(exact, 5)} Hz (exact){counterpart}",
                _anchor_text(points.get(label, {})),
            ]
        )
    return _table(["point", "the paper", "this build", "placed by (configuration)"], rows)


def _anchor_text(entry) -> str:
    """How the configuration places a point: an energy, or its anchor keys (``energy_fraction 0.8``)."""
    if not isinstance(entry, dict):
        return f"energy {entry}"
    return ", ".join(f"{key} {value}" for key, value in entry.items() if key not in ("label", "offset"))


def _labelled(data: dict, config: dict) -> list:
    rows = []
    figures = config.get("figures", {})
    for figure, branch in LABELLED.items():
        spec = figures.get(figure)
        if not spec:
            continue
        ds = data[branch]
        if "nnm1_stages" in spec:
            ds = ds.isel(point=np.flatnonzero(np.isin(ds["stage"].values, spec["nnm1_stages"])))
            ds = ds.assign_coords(point=np.arange(ds.sizes["point"]))
        for label in label_specs(spec.get("labels")):
            place = locate_label(ds, label) if ds.sizes["point"] else None
            where = f"Fig {int(figure[3:])} {label.label})"
            if place is None or place.point is None:
                rows.append([where, "no number", f"not on this branch: {place.missing if place else 'no orbit'}", ""])
                continue
            i = place.point
            what = impact_text(ds, i) + identity_text(ds, i)
            rows.append(
                [
                    where,
                    "no number",
                    f"E = {g(float(ds['energy'].values[i]))}, f = {g(float(ds['frequency'].values[i]), 5)} Hz",
                    f"{what}; {label.describe().split(') ', 1)[1]}",
                ]
            )
    return _table(["point", "the paper", "this build", "orbit; placed by (configuration)"], rows)


def paper_table_page(results_dir, config: dict, digests: dict) -> str:
    """The page (MyST Markdown) of the build in ``results_dir``; ``config``: its configuration (``figures``,
    ``compare``); ``digests``: data digest of each dataset read, by path under ``results/``."""
    results_dir = Path(results_dir)
    data = {name: xr.load_dataset(results_dir / path) for name, path in PAPER_TABLE_DATASETS.items()}
    nnm1 = data["nnm1"]
    a = nnm1.attrs
    lines = [
        "# The paper against this build",
        "",
        "<!-- Generated by `snakemake --cores 2 docs` (nnmstop.docpages.paper_table): do not edit by hand. -->",
        "",
        "What the paper (E. H. Moussi, S. Bellizzi, B. Cochelin, I. Nistor, *Nonlinear normal modes of a two degree",
        "of freedom oscillator with a bilateral elastic stop*) states, next to what this build computes from its",
        f"datasets (alpha = {g(a['alpha'])}, beta = {g(a['beta'])}, delta = {g(a['delta'])}, eta = {g(a['eta'])}, "
        f"H = {a['harmonics']}).",
        "The paper gives numbers for three frequencies only; everything else it shows in its figures, so the column",
        '"the paper" names the figure and this build\'s column gives the number. Frequencies in Hz of the',
        "nondimensional time, energies nondimensional. A test checks the digests at the end against the reference",
        "build, so this page cannot fall behind it.",
        "",
        "## Frequencies the paper quotes",
        "",
        *_quoted(nnm1),
        "",
        "## The grazing orbit and the internal resonances",
        "",
        *_features(data["exact_two_impacts"], nnm1),
        "",
        "## Points a) and b) of Figs 2-4",
        "",
        *_points_a_b(data["compare"], config),
        "",
        "## The labelled points of Figs 6-11",
        "",
        "Each placed by the rule of its figure (`figures.figNN.labels`); the orbit column gives its impacts per",
        "period and, where it is not the branch's own mode, what it is (`nnmstop.hbm.identity`).",
        "",
        *_labelled(data, config),
        "",
        *datasets_read(dict(sorted(digests.items()))),
    ]
    return "\n".join(lines) + "\n"
