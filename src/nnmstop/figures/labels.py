"""Letters beside the points they name: placed after the layout so that none hides a mark, a curve or another.

A figure registers what must stay visible (:func:`mark_obstacle` on the markers it draws) and asks
for its labels (:func:`add_label`); :func:`place_labels` runs once the figure is laid out (the
``after_layout`` hook of :func:`nnmstop.figures.common.save_figure`) and puts each label at the
first free spot of a ring of candidates around its point, its configured offset first: inside the
axes, off every registered mark, every other label and the legend, crossing as few curves as it
can. A short leader joins a label to its point. The choice depends only on the figure, so
rebuilds stay byte-identical. :func:`label_overlaps` lists what still overlaps (for tests).
"""

from __future__ import annotations

import numpy as np
from matplotlib.text import Text
from matplotlib.transforms import Bbox

__all__ = ["LABEL_GID", "MARK_GID", "mark_obstacle", "add_label", "place_labels", "label_overlaps", "mark_boxes"]

LABEL_GID = "point-label"
MARK_GID = "mark"
#: Half the side of the square a mark keeps free around its centre, in points.
MARK_HALF_SIZE = 4.0
#: Directions tried around a point after the configured offset, in degrees (right, then anticlockwise).
DIRECTIONS = (0, 45, 90, 135, 180, 225, 270, 315)
#: Distances of the candidate spots from their point, in points.
RADII = (14.0, 20.0, 28.0)


def mark_obstacle(artist) -> None:
    """Register a marker artist (a ``Line2D`` of markers) as a mark no label may cover."""
    artist.set_gid(MARK_GID)


def add_label(ax, text: str, xy, offset=(6.0, 6.0), fontsize: float = 9.0, circled: bool = True, color="black"):
    """A label beside the data point ``xy`` with a short leader, placed by :func:`place_labels`.

    ``circled``: a bold letter in a circle (the labelled points of the paper's figures); else plain
    text on a pale box (tick-like labels of data points, such as a setting's ``H``).
    """
    if circled:
        box = {"boxstyle": "circle,pad=0.12", "fc": "white", "ec": color, "lw": 0.7}
    else:
        box = {"boxstyle": "square,pad=0.05", "fc": "white", "ec": "none", "alpha": 0.7}
    label = ax.annotate(
        text,
        xy=xy,
        xytext=tuple(float(v) for v in offset),
        textcoords="offset points",
        fontsize=fontsize,
        fontweight="bold" if circled else "normal",
        color=color,
        ha="center",
        va="center",
        zorder=7,
        bbox=box,
        arrowprops={"arrowstyle": "-", "lw": 0.6 if circled else 0.4, "color": color, "shrinkA": 0, "shrinkB": 2.5},
        annotation_clip=False,
    )
    label.set_gid(LABEL_GID)
    label.set_in_layout(False)
    return label


def _labels(ax) -> list:
    return [t for t in ax.texts if t.get_gid() == LABEL_GID]


def mark_boxes(ax) -> list:
    """Display boxes of the registered marks of ``ax`` (one per marker)."""
    half = MARK_HALF_SIZE * ax.figure.dpi / 72.0
    boxes = []
    for line in ax.lines:
        if line.get_gid() != MARK_GID or not line.get_visible():
            continue
        for x, y in ax.transData.transform(np.column_stack(line.get_data())):
            boxes.append(Bbox.from_extents(x - half, y - half, x + half, y + half))
    return boxes


def _label_box(label, renderer) -> Bbox:
    """Display box of a label's letter and its circle (not its leader)."""
    label.update_positions(renderer)
    box = Text.get_window_extent(label, renderer)
    patch = label.get_bbox_patch()
    if patch is None:
        return box
    label.update_bbox_position_size(renderer)
    return Bbox.union([box, patch.get_window_extent(renderer)])


def _candidates(offset) -> list[tuple[float, float]]:
    first = (float(offset[0]), float(offset[1]))
    spots = [first]
    for radius in RADII:
        for angle in np.radians(DIRECTIONS):
            spots.append((round(radius * np.cos(angle), 6), round(radius * np.sin(angle), 6)))
    return spots


def _curves(ax) -> list:
    """Paths (display coordinates) of the drawn curves a label should avoid crossing."""
    paths = []
    for line in ax.lines:
        if line.get_gid() in (MARK_GID, LABEL_GID) or line.get_linestyle() in ("None", "none", ""):
            continue
        paths.append(line.get_transform().transform_path(line.get_path()))
    return paths


def place_labels(fig) -> None:
    """Move every label of ``fig`` to its first free candidate spot (see the module docstring)."""
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        labels = _labels(ax)
        if not labels:
            continue
        frame = ax.get_window_extent(renderer)
        taken = list(mark_boxes(ax))
        legend = ax.get_legend()
        if legend is not None:
            box = legend.get_window_extent(renderer)
            # fixed where it is: a "best" legend would move away from the labels onto data at the next draw
            legend.set_loc(tuple(float(v) for v in ax.transAxes.inverted().transform((box.x0, box.y0))))
            taken.append(box)
        curves = _curves(ax)
        for label in labels:
            best, best_key = None, None
            for rank, spot in enumerate(_candidates(label.xyann)):
                label.xyann = spot
                box = _label_box(label, renderer)
                inside = frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1)
                blocked = sum(box.overlaps(other) for other in taken)
                crossed = sum(path.intersects_bbox(box, filled=False) for path in curves)
                key = (not inside, blocked, crossed, rank)
                if best_key is None or key < best_key:
                    best, best_key = spot, key
            label.xyann = best
            taken.append(_label_box(label, renderer))


def label_overlaps(fig) -> list[str]:
    """What the labels of ``fig`` overlap (marks, other labels, the legend, the axes' edge), as text lines."""
    renderer = fig.canvas.get_renderer()
    found = []
    for ax in fig.axes:
        labels = _labels(ax)
        boxes = [_label_box(label, renderer) for label in labels]
        frame = ax.get_window_extent(renderer)
        legend = ax.get_legend()
        for i, (label, box) in enumerate(zip(labels, boxes)):
            name = label.get_text()
            if not (frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1)):
                found.append(f"{name} leaves its axes")
            found.extend(f"{name} covers a mark" for mark in mark_boxes(ax) if box.overlaps(mark))
            found.extend(f"{name} overlaps {labels[j].get_text()}" for j in range(i) if box.overlaps(boxes[j]))
            if legend is not None and box.overlaps(legend.get_window_extent(renderer)):
                found.append(f"{name} overlaps the legend")
    return found
