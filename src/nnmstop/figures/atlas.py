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
from matplotlib.colors import ListedColormap
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


def _regions(ax, ds: xr.Dataset):
    cmap = ListedColormap([REGION_COLORS[r] for r in REGIONS])
    ax.pcolormesh(
        _edges(ds["grid_frequency"].values),
        _edges(ds["slice_value"].values),
        ds["region"].values,
        cmap=cmap,
        vmin=-0.5,
        vmax=len(REGIONS) - 0.5,
        shading="flat",
        rasterized=True,
        zorder=0,
    )
    uncovered = np.ma.masked_where(ds["region"].values != REGIONS.index("not_covered"), ds["region"].values)
    ax.pcolor(
        _edges(ds["grid_frequency"].values),
        _edges(ds["slice_value"].values),
        uncovered,
        hatch="///",
        alpha=0.0,
        zorder=0.5,
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
            k = np.flatnonzero(mask)[int(0.6 * mask.sum())]
            label_points.append((frequency[k], second[k], kind))
    return drawn


def _codim2(ax, ds: xr.Dataset, size: float = 7):
    drawn = set()
    for kind, f, s in zip(ds["codim2_kind"].values, ds["codim2_frequency"].values, ds["codim2_second"].values):
        name = CODIM2_KINDS[int(kind)]
        marker, _ = CODIM2_MARKERS[name]
        ax.plot(f, s, marker, ms=size, mfc="white", mec="black", mew=1.1, zorder=5)
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
    fw = max(np.ptp(f[best]), 1e-4 * span_f) * 1.6
    sw = max(np.ptp(s[best]), 1e-4 * span_s) * 1.6
    return (f[best].mean() - fw, f[best].mean() + fw), (s[best].mean() - sw, s[best].mean() + sw)


def atlas_figure(ds: xr.Dataset, pdf_path, png_dpi: int = 150, title: str = "", backbone=None):
    """The atlas ``ds`` (an ``atlas`` dataset) as a map (module docstring); ``backbone``: its backbones' dataset."""
    plane = str(ds.attrs["plane"])
    fig = plt.figure(figsize=(11.0, 7.0), layout="constrained")
    grid = fig.add_gridspec(1, 2, width_ratios=[3.2, 1.0])
    ax = fig.add_subplot(grid[0, 0])
    _regions(ax, ds)
    labels = []
    drawn_curves = _curves(ax, ds, labels)
    drawn_codim2 = _codim2(ax, ds)
    has_backbone = _backbone(ax, ds, backbone)
    for f, s, kind in labels:
        ax.annotate(
            CURVE_LABELS[kind].split(" (")[0],
            (f, s),
            xytext=(4, 4),
            textcoords="offset points",
            fontsize=8,
            color=CURVE_STYLES[kind]["color"],
            zorder=6,
        )
    ax.set_xlim(*ds.attrs["frequency_range"])
    ax.set_ylim(_edges(ds["slice_value"].values)[[0, -1]])
    ax.set_xlabel("forcing frequency (Hz of the nondimensional time)")
    fixed = "" if plane == "force" else f" (force {ds.attrs['forcing_amplitude']:g})"
    ax.set_ylabel(SECOND_LABELS.get(plane, plane) + fixed)
    ax.set_title(title or f"Bifurcation atlas: {ds.attrs['atlas_map']}", fontsize=11)
    side = grid[0, 1].subgridspec(2, 1, height_ratios=[1.0, 1.3])
    window = _cluster(ds)
    inset = fig.add_subplot(side[0, 0])
    if window is not None:
        _regions(inset, ds)
        _curves(inset, ds, [])
        _codim2(inset, ds, size=6)
        inset.set_xlim(*window[0])
        inset.set_ylim(*window[1])
        inset.set_title("enlarged: codimension-two points", fontsize=9)
        inset.tick_params(labelsize=7)
        inset.ticklabel_format(useOffset=False)
        ax.add_patch(
            plt.Rectangle(
                (window[0][0], window[1][0]),
                np.ptp(window[0]),
                np.ptp(window[1]),
                fill=False,
                ec="black",
                lw=0.8,
                zorder=6,
            )
        )
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
    legend_ax.legend(handles=handles, loc="upper left", fontsize=7.5, frameon=False)
    description = (
        f"Bifurcation atlas {ds.attrs['atlas_map']}: regions from {ds.sizes['slice']} slices, "
        f"{ds.sizes['curve']} curves, {ds.sizes['codim2']} codimension-two points"
    )
    return save_figure(fig, pdf_path, png_dpi, description=description)
