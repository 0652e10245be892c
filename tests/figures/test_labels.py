"""Letters beside their points: placed off marks, other letters and the legend, at the configured spot when free."""

import matplotlib.pyplot as plt
import numpy as np

from nnmstop.figures.common import save_figure
from nnmstop.figures.labels import add_label, label_overlaps, mark_obstacle, place_labels


def _crowded(tmp_path, name, place):
    """Two marks close together, a letter asked right on each, a legend in a corner."""
    fig, ax = plt.subplots(figsize=(4, 3), layout="constrained")
    e = np.linspace(1.0, 10.0, 50)
    ax.plot(e, np.log(e), color="tab:blue", label="curve")
    points = [(4.0, np.log(4.0)), (4.3, np.log(4.3))]
    mark_obstacle(ax.plot(*np.transpose(points), marker="x", ls="none", color="black")[0])
    labels = [add_label(ax, letter, xy, offset=(0.0, 0.0)) for letter, xy in zip("ef", points)]
    ax.legend(loc="upper left")
    found = {}

    def inspect(figure):
        if place:
            place_labels(figure)
        found["overlaps"] = label_overlaps(figure)
        found["offsets"] = [label.xyann for label in labels]

    save_figure(fig, tmp_path / f"{name}.pdf", png_dpi=80, after_layout=inspect)
    return found


def test_letters_asked_on_their_marks_are_moved_beside_them(tmp_path):
    before = _crowded(tmp_path, "before", place=False)
    assert "e covers a mark" in before["overlaps"] and "f overlaps e" in before["overlaps"]  # the check can fail
    after = _crowded(tmp_path, "after", place=True)
    assert after["overlaps"] == []
    assert all(np.hypot(*offset) > 0 for offset in after["offsets"])


def test_a_free_configured_spot_is_kept(tmp_path):
    fig, ax = plt.subplots(figsize=(4, 3), layout="constrained")
    ax.plot([1.0, 2.0], [1.0, 2.0])
    label = add_label(ax, "a", (1.5, 1.5), offset=(-12.0, 9.0))
    save_figure(fig, tmp_path / "free.pdf", png_dpi=80, after_layout=place_labels)
    assert label.xyann == (-12.0, 9.0)


def test_placement_is_byte_reproducible(tmp_path):
    _crowded(tmp_path / "a", "fig", place=True)
    _crowded(tmp_path / "b", "fig", place=True)
    for suffix in (".pdf", ".png"):
        assert (tmp_path / "a" / f"fig{suffix}").read_bytes() == (tmp_path / "b" / f"fig{suffix}").read_bytes()
