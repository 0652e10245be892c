"""The numbers of the atlas page (``docs/atlas_numbers.md``), generated from the atlas datasets of a build.

:func:`atlas_numbers_page` reads each map's atlas dataset and writes, per map: the first contact (the lowest
force or gap of its grazing curves and the frequency there), where two stable responses first coexist (the
lowest cusp, or the lowest point of a fold curve), the curves by kind and law, the codimension-two points, the
checks and the share of each region. The page names the datasets it read with their data digests. Run it with
``snakemake --cores 2 atlas_docs`` (task :func:`nnmstop.tasks.atlas.atlas_docs`), which also copies the map
figures into ``docs/``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop.bifurcation_atlas.flags import CODIM2_KINDS, CURVE_KINDS, LAWS, REGIONS

__all__ = ["atlas_numbers_page", "first_contact", "first_coexistence"]

SECOND = {"force": "F", "gap": "gap", "stiffness": "stop stiffness", "damping_ratio": "damping ratio"}


def curve_text(kind: str) -> str:
    return kind.replace("_", " ").replace("neimark sacker", "Neimark-Sacker")


CODIM2_TEXT = {
    "cusp": "cusp",
    "isola": "isola (extremum on a fold curve)",
    "fold_flip": "fold-flip",
    "resonance_1_1": "1:1 resonance",
    "resonance_1_2": "1:2 resonance",
    "grazing": "meets grazing",
    "second_contact": "meets a second contact",
}


def g(value, digits: int = 4) -> str:
    return f"{float(value):.{digits}g}"


def first_contact(ds: xr.Dataset):
    """``(second, frequency Hz)`` at the extreme of the grazing curves where contact starts: their lowest force
    (force plane) or largest gap (gap plane)."""
    grazing = np.flatnonzero(ds["curve_kind"].values == CURVE_KINDS.index("grazing"))
    mask = np.isin(ds["point_curve"].values, grazing)
    second, frequency = ds["second"].values[mask], ds["frequency"].values[mask]
    k = int(np.argmax(second) if ds.attrs["plane"] == "gap" else np.argmin(second))
    return float(second[k]), float(frequency[k])


def first_coexistence(ds: xr.Dataset):
    """``(second, frequency Hz)`` where the exact fold curves reach lowest in force (largest in gap): below it no
    two stable responses coexist."""
    folds = np.flatnonzero(
        (ds["curve_kind"].values == CURVE_KINDS.index("fold"))
        & (ds["curve_law"].values == LAWS.index("piecewise_linear"))
    )
    mask = np.isin(ds["point_curve"].values, folds)
    if not mask.any():
        return None
    second, frequency = ds["second"].values[mask], ds["frequency"].values[mask]
    k = int(np.argmax(second) if ds.attrs["plane"] == "gap" else np.argmin(second))
    return float(second[k]), float(frequency[k])


def _map_section(name: str, ds: xr.Dataset) -> list:
    plane = str(ds.attrs["plane"])
    symbol = SECOND.get(plane, plane)
    lines = [f"### `{name}`", ""]
    contact = first_contact(ds)
    lowest, down = ("lowest", "on") if plane == "force" else ("largest", "down")
    lines.append(
        f"- First contact: the non-impacting response touches the stop from {symbol} = {g(contact[0])} {down} "
        f"(at {g(contact[1], 5)} Hz), the {lowest} point of the grazing curves."
    )
    coexist = first_coexistence(ds)
    if coexist is not None:
        reach = "down" if plane == "force" else "up"
        lines.append(
            f"- Folds: the fold curves reach {reach} to {symbol} = {g(coexist[0])} (at {g(coexist[1], 5)} Hz); beyond, "
            "two stable responses can coexist between them (the response jumps)."
        )
    kinds, laws = ds["curve_kind"].values, ds["curve_law"].values
    counts = [
        f"{int(np.count_nonzero((kinds == k) & (laws == law)))} {curve_text(CURVE_KINDS[k])}"
        + (" (regularized)" if LAWS[law] == "regularized" else "")
        for k in range(len(CURVE_KINDS))
        for law in range(len(LAWS))
        if np.any((kinds == k) & (laws == law))
    ]
    lines.append(f"- Curves: {', '.join(counts)}; {ds.sizes['point']} points.")
    deviation = float(ds["check_deviation"].max()) if ds.sizes.get("check", 0) else float("nan")
    lines.append(
        f"- Checks: {ds.sizes.get('check', 0)} points located by one-parameter responses at other values lie on "
        f"their curves; largest relative distance {deviation:.1e}."
    )
    shares = np.bincount(ds["region"].values.ravel(), minlength=len(REGIONS)) / ds["region"].size
    lines.append(
        "- Regions (share of the map): "
        + ", ".join(f"{REGIONS[k].replace('_', ' ')} {100 * shares[k]:.1f} %" for k in range(len(REGIONS)))
        + "."
    )
    lines += ["", f"| codimension-two point | curve | frequency [Hz] | {symbol} |", "| --- | --- | ---: | ---: |"]
    for kind, curve, f, s in zip(
        ds["codim2_kind"].values, ds["codim2_curve"].values, ds["codim2_frequency"].values, ds["codim2_second"].values
    ):
        curve_kind = curve_text(CURVE_KINDS[int(ds["curve_kind"].values[curve])])
        law = " (regularized)" if LAWS[int(ds["curve_law"].values[curve])] == "regularized" else ""
        lines.append(f"| {CODIM2_TEXT[CODIM2_KINDS[int(kind)]]} | {curve_kind}{law} | {f:.6f} | {s:.6g} |")
    return lines + [""]


def atlas_numbers_page(datasets: dict, digests: dict) -> str:
    """The page from ``datasets`` (map name -> atlas dataset) and their ``digests`` (path -> data digest)."""
    lines = [
        "<!-- Generated by `snakemake --cores 2 atlas_docs` (nnmstop.docpages.atlas): do not edit by hand. -->",
        "",
    ]
    for name, ds in datasets.items():
        lines += _map_section(name, ds)
    lines += ["Datasets read (data digests, `nnmstop.pipeline.verify.data_digest`):", ""]
    lines += ["| dataset | data digest |", "| --- | --- |"]
    lines += [f"| `{path}` | `{digest}` |" for path, digest in sorted(digests.items())]
    return "\n".join(lines) + "\n"


def write_page(paths: list, output) -> Path:
    """Read the atlas datasets ``paths`` (``results/atlas/<map>.nc``) and write the page to ``output``."""
    from nnmstop.atomic import atomic_output
    from nnmstop.netcdf import read_dataset
    from nnmstop.pipeline.verify import data_digest

    datasets = {Path(p).stem: read_dataset(p) for p in paths}
    digests = {str(p): data_digest(Path(p)) for p in paths}
    out = Path(output)
    with atomic_output(out) as tmp:
        tmp.write_text(atlas_numbers_page(datasets, digests))
    return out
