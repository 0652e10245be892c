"""The atlas figure (paper_figures/atlas_<map>.*), drawn from the atlas dataset only.

The plane of frequency and force (or of frequency and a structural parameter), shaded by region as the slices
read them (no contact; impacting with one stable response; coexisting stable responses, where the response
jumps; no stable periodic response; not covered), the curves over them (grazing, folds, Neimark-Sacker, flip,
second contact; exact solid, regularized thin dashed), the codimension-two points marked by kind, the
backbone's prediction of the resonance peak, and an enlargement of the densest cluster of codimension-two
points.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from nnmstop.bifurcation_atlas.flags import CODIM2_KINDS, CURVE_KINDS, LAWS, REGIONS
from nnmstop.figures.common import save_figure

__all__ = ["atlas_figure", "REGION_COLORS", "REGION_LABELS"]

#: Shade and legend text of each region.
REGION_COLORS = {
    "no_contact": "#f4f4f4",
    "impacting": "#cfe3f3",
    "coexisting": "#f7c98b",
    "no_stable_periodic": "#ef8a8a",
    "not_covered": "#bdbdbd",
}
REGION_LABELS = {
    "no_contact": "no contact (one stable response)",
    "impacting": "impacting, one stable response",
    "coexisting": "two stable responses coexist (jumps)",
    "no_stable_periodic": "no stable periodic response",
    "not_covered": "more contacts per period (not computed)",
}
CURVE_STYLES = {
    "grazing": dict(color="black", lw=1.8, ls="-"),
    "fold": dict(color="#1f4e9c", lw=1.5, ls="-"),
    "neimark_sacker": dict(color="#c0281f", lw=1.5, ls="--"),
    "flip": dict(color="#7b3294", lw=1.5, ls="-."),
    "second_contact": dict(color="#555555", lw=1.3, ls=":"),
}
CURVE_LABELS = {
    "grazing": "grazing (first contact)",
    "fold": "fold (jump)",
    "neimark_sacker": "Neimark-Sacker (torus)",
    "flip": "flip (symmetry breaking)",
    "second_contact": "second contact per period",
}
CODIM2_MARKERS = {
    "cusp": ("^", "cusp"),
    "isola": ("D", "isola (extremum on a fold curve)"),
    "fold_flip": ("s", "fold-flip"),
    "resonance_1_1": ("*", "1:1 resonance"),
    "resonance_1_2": ("X", "1:2 resonance"),
    "grazing": ("o", "meets grazing"),
    "second_contact": ("P", "meets a second contact"),
}
SECOND_LABELS = {
    "force": "force amplitude F",
    "gap": "gap",
    "stiffness": "stop stiffness",
    "damping_ratio": "damping ratio",
}


def _edges(values) -> np.ndarray:
    values = np.asarray(values, dtype=float)
    if len(values) == 1:
        return np.array([values[0] * 0.9, values[0] * 1.1])
    middle = 0.5 * (values[1:] + values[:-1])
    return np.concatenate([[values[0] - (middle[0] - values[0])], middle, [values[-1] + (values[-1] - middle[-1])]])


def _runs(row, edges) -> list:
    """``(start, end, region)`` of the runs of equal region along one slice row (cell edges)."""
    out, start = [], 0
    for j in range(1, len(row) + 1):
        if j == len(row) or row[j] != row[start]:
            out.append((edges[start], edges[j], int(row[start])))
            start = j
    return out


def _regions(ax, ds: xr.Dataset):
    """The regions as polygons: between two slices whose rows have the same sequence of regions, each region's
    edges run straight from one row to the next (the boundaries are the curves, crossed by both rows); where the
    sequence changes, each row's runs fill half the band. Cells of the not-covered region hatched."""
    from matplotlib.collections import PolyCollection

    region = ds["region"].values
    edges = _edges(ds["grid_frequency"].values)
    values = ds["slice_value"].values
    bounds = _edges(values)
    rows = [_runs(row, edges) for row in region]
    polygons, colors, hatched = [], [], []

    def add(polygon, kind):
        polygons.append(polygon)
        colors.append(REGION_COLORS[REGIONS[kind]])
        if REGIONS[kind] == "not_covered":
            hatched.append(polygon)

    for k, runs in enumerate(rows):
        if k == 0:  # below the first row: down to the map's lower edge
            for a, b, kind in runs:
                add([(a, bounds[0]), (b, bounds[0]), (b, values[0]), (a, values[0])], kind)
        if k + 1 == len(rows):
            for a, b, kind in runs:
                add([(a, values[k]), (b, values[k]), (b, bounds[k + 1]), (a, bounds[k + 1])], kind)
            continue
        upper = rows[k + 1]
        if [r[2] for r in runs] == [r[2] for r in upper]:
            for (a, b, kind), (c, d, _) in zip(runs, upper):
                add([(a, values[k]), (b, values[k]), (d, values[k + 1]), (c, values[k + 1])], kind)
        else:
            middle = 0.5 * (values[k] + values[k + 1])
            for a, b, kind in runs:
                add([(a, values[k]), (b, values[k]), (b, middle), (a, middle)], kind)
            for c, d, kind in upper:
                add([(c, middle), (d, middle), (d, values[k + 1]), (c, values[k + 1])], kind)
    ax.add_collection(PolyCollection(polygons, facecolors=colors, edgecolors="face", linewidths=0.3, zorder=0))
    if hatched:
        ax.add_collection(
            PolyCollection(hatched, facecolors="none", edgecolors="0.45", hatch="///", linewidths=0, zorder=0.5)
        )


def _curves(ax, ds: xr.Dataset, label_points: list):
    kinds, laws = ds["curve_kind"].values, ds["curve_law"].values
    curve_of = ds["point_curve"].values
    frequency, second = ds["frequency"].values, ds["second"].values
    drawn = set()
    for j in range(ds.sizes["curve"]):
        kind, law = CURVE_KINDS[int(kinds[j])], LAWS[int(laws[j])]
        style = dict(CURVE_STYLES[kind])
        if law == "regularized":
            style.update(lw=1.0, ls=(0, (4, 2)), alpha=0.8)
        mask = curve_of == j
        ax.plot(frequency[mask], second[mask], zorder=3, **style)
        drawn.add((kind, law))
        if law == "piecewise_linear" and mask.any():
            label_points.append((int(mask.sum()), j, kind))
    return drawn


def _labels(ax, ds: xr.Dataset, label_points: list):
    """One label per kind of exact curve, along its longest curve (a fifth of the way for the grazing curve, which
    runs down to the first contact, three fifths for the others)."""
    frequency, second, curve_of = ds["frequency"].values, ds["second"].values, ds["point_curve"].values
    longest = {}
    for size, j, kind in label_points:
        if size > longest.get(kind, (0, None))[0]:
            longest[kind] = (size, j)
    for kind, (size, j) in longest.items():
        k = np.flatnonzero(curve_of == j)[int((0.2 if kind == "grazing" else 0.6) * size)]
        ax.annotate(
            CURVE_LABELS[kind].split(" (")[0],
            (frequency[k], second[k]),
            xytext=(5, -3),
            textcoords="offset points",
            fontsize=8.5,
            color=CURVE_STYLES[kind]["color"],
            zorder=6,
            bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.75),
        )


def _codim2(ax, ds: xr.Dataset, size: float = 7):
    """Codimension-two points: white on the exact curves, grey on the regularized ones."""
    drawn = set()
    laws = ds["curve_law"].values[ds["codim2_curve"].values]
    for kind, f, s, law in zip(
        ds["codim2_kind"].values, ds["codim2_frequency"].values, ds["codim2_second"].values, laws
    ):
        name = CODIM2_KINDS[int(kind)]
        marker, _ = CODIM2_MARKERS[name]
        face = "0.7" if LAWS[int(law)] == "regularized" else "white"
        ax.plot(f, s, marker, ms=size, mfc=face, mec="black", mew=1.1, zorder=5)
        drawn.add(name)
    return drawn


def _backbone(ax, ds: xr.Dataset, backbone) -> bool:
    """The backbones' predicted peaks: the required force against the frequency (force plane), or the gap at
    the map's force ``g0 F / F_required`` (gap plane: the equations are homogeneous in the motion, gap and force)."""
    if backbone is None or str(ds.attrs["plane"]) not in ("force", "gap"):
        return False
    frequency, required = backbone["backbone_frequency"].values, backbone["required_force"].values
    if str(ds.attrs["plane"]) == "force":
        second = required
    else:
        second = float(ds.attrs["stop_gap"]) * float(ds.attrs["forcing_amplitude"]) / required
    for mode in np.unique(backbone["backbone_mode"].values):
        mask = backbone["backbone_mode"].values == mode
        ax.plot(frequency[mask], second[mask], color="#238b45", lw=1.4, ls=(0, (1, 1.5)), zorder=4)
    return True


def _title(ds: xr.Dataset) -> str:
    """Where the structure touches, jumps and stops being periodic, with its damping and force."""
    ratio = ds.attrs.get("damping_ratio")
    damping = f", damping ratio {float(np.atleast_1d(ratio)[0]):g}" if ratio is not None else ""
    return f"Atlas {ds.attrs['atlas_map']}: contact, jumps and loss of periodic stability{damping}"


def _cluster(ds: xr.Dataset):
    """The window around the densest group of codimension-two points (None when there is no group)."""
    f, s = ds["codim2_frequency"].values, ds["codim2_second"].values
    if len(f) < 3:
        return None
    span_f = np.ptp(ds["grid_frequency"].values)
    span_s = np.ptp(ds["slice_value"].values)
    best = None
    for i in range(len(f)):
        near = (np.abs(f - f[i]) < 0.01 * span_f) & (np.abs(s - s[i]) < 0.01 * span_s)
        if near.sum() >= 3 and (best is None or near.sum() > best.sum()):
            best = near
    if best is None:
        return None
    fw = max(np.ptp(f[best]), 1e-3 * span_f)
    sw = max(np.ptp(s[best]), 1e-4 * span_s)
    f_mid, s_mid = 0.5 * (f[best].min() + f[best].max()), 0.5 * (s[best].min() + s[best].max())
    return (f_mid - 1.2 * fw, f_mid + 1.2 * fw), (s_mid - 1.5 * sw, s_mid + 1.5 * sw)


def atlas_figure(ds: xr.Dataset, pdf_path, png_dpi: int = 150, title: str = "", backbone=None):
    """The atlas ``ds`` (an ``atlas`` dataset) as a map (module docstring); ``backbone``: its backbones' dataset."""
    plane = str(ds.attrs["plane"])
    fig = plt.figure(figsize=(12.5, 7.2), layout="constrained")
    grid = fig.add_gridspec(1, 2, width_ratios=[3.0, 1.35])
    ax = fig.add_subplot(grid[0, 0])
    _regions(ax, ds)
    labels = []
    drawn_curves = _curves(ax, ds, labels)
    drawn_codim2 = _codim2(ax, ds)
    has_backbone = _backbone(ax, ds, backbone)
    _labels(ax, ds, labels)
    ax.set_xlim(*ds.attrs["frequency_range"])
    ax.set_ylim(_edges(ds["slice_value"].values)[[0, -1]])
    ax.set_xlabel("forcing frequency (Hz of the nondimensional time)")
    fixed = "" if plane == "force" else f" (force {ds.attrs['forcing_amplitude']:g})"
    ax.set_ylabel(SECOND_LABELS.get(plane, plane) + fixed)
    ax.set_title(title or _title(ds), fontsize=11)
    side = grid[0, 1].subgridspec(2, 1, height_ratios=[1.0, 1.25])
    window = _cluster(ds)
    inset = fig.add_subplot(side[0, 0])
    if window is not None:
        _regions(inset, ds)
        _curves(inset, ds, [])
        _codim2(inset, ds, size=7)
        inset.set_xlim(*window[0])
        inset.set_ylim(*window[1])
        inset.set_title("enlarged (box): codimension-two points", fontsize=9)
        inset.tick_params(labelsize=7)
        inset.xaxis.set_major_locator(plt.MaxNLocator(3))
        inset.yaxis.set_major_locator(plt.MaxNLocator(4))
        inset.ticklabel_format(useOffset=False)
        inset.set_xlabel("Hz", fontsize=8)
        ax.annotate(
            "enlarged at right",
            (window[0][1], window[1][1]),
            xytext=(30, 25),
            textcoords="offset points",
            fontsize=8,
            arrowprops=dict(arrowstyle="->", lw=0.8),
            bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.75),
            zorder=6,
        )
        ax.add_patch(
            plt.Rectangle(
                (window[0][0], window[1][0]), np.ptp(window[0]), np.ptp(window[1]), fill=False, ec="black", lw=0.8,
                zorder=6,
            )
        )  # fmt: skip
    else:
        inset.axis("off")
    legend_ax = fig.add_subplot(side[1, 0])
    legend_ax.axis("off")
    handles = [
        Patch(fc=REGION_COLORS[r], ec="0.5", label=REGION_LABELS[r], hatch="///" if r == "not_covered" else None)
        for r in REGIONS
    ]
    for kind in CURVE_KINDS:
        for law in LAWS:
            if (kind, law) in drawn_curves:
                style = dict(CURVE_STYLES[kind])
                if law == "regularized":
                    style.update(lw=1.0, ls=(0, (4, 2)))
                text = CURVE_LABELS[kind] + (" (regularized)" if law == "regularized" else "")
                handles.append(Line2D([], [], label=text, **style))
    if has_backbone:
        handles.append(Line2D([], [], color="#238b45", lw=1.4, ls=(0, (1, 1.5)), label="backbone: predicted peak"))
    for name in CODIM2_KINDS:
        if name in drawn_codim2:
            marker, text = CODIM2_MARKERS[name]
            handles.append(Line2D([], [], ls="", marker=marker, mfc="white", mec="black", label=text))
    if "regularized" in {LAWS[int(law)] for law in ds["curve_law"].values}:
        handles.append(
            Line2D([], [], ls="", marker="o", mfc="0.7", mec="black", label="(grey: on a regularized curve)")
        )
    legend_ax.legend(handles=handles, loc="upper left", fontsize=8, frameon=False)
    description = (
        f"Bifurcation atlas {ds.attrs['atlas_map']}: regions from {ds.sizes['slice']} slices, "
        f"{ds.sizes['curve']} curves, {ds.sizes['codim2']} codimension-two points"
    )
    return save_figure(fig, pdf_path, png_dpi, description=description)
