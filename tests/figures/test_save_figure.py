"""save_figure: the PDF and its PNG share one constrained layout, and that layout fits the figure's text."""

import matplotlib.pyplot as plt
import numpy as np

from nnmstop.figures.common import save_figure


def _crowded_figure():
    """Constrained layout with text it must make room for: log ticks, long labels, a suptitle, square panels."""
    fig = plt.figure(figsize=(6.0, 5.0), layout="constrained")
    grid = fig.add_gridspec(2, 2, height_ratios=[3.0, 2.0])
    top = fig.add_subplot(grid[0, :])
    energy = np.logspace(-2, 4, 50)
    top.plot(energy, 0.1 + 0.05 * np.tanh(np.log10(energy)))
    top.set_xscale("log")
    top.set_xlabel("energy (nondimensional)")
    top.set_ylabel("frequency (Hz, nondimensional time)")
    for column in range(2):
        panel = fig.add_subplot(grid[1, column])
        panel.plot(np.sin(np.linspace(0, 6, 40)), 40 * np.cos(np.linspace(0, 6, 40)))
        panel.set_box_aspect(1.0)
        panel.set_title(f"{column}) a title\nof two lines", fontsize=7.5)
    title = fig.suptitle("A long suptitle that the layout has to keep inside the figure\nsecond line")
    return fig, title


def test_pdf_and_png_share_one_layout_that_fits(tmp_path, monkeypatch):
    fig, title = _crowded_figure()
    default = [ax.get_position().bounds for ax in fig.axes]  # gridspec positions before any layout
    saved = {}
    savefig = fig.savefig

    def recording_savefig(path, **kwargs):
        savefig(path, **kwargs)
        renderer = fig.canvas.get_renderer()
        saved[str(path).rsplit(".", 1)[-1]] = {
            "axes": [ax.get_position().bounds for ax in fig.axes],
            "suptitle": title.get_position(),
            "boxes": [ax.get_tightbbox(renderer) for ax in fig.axes] + [title.get_window_extent(renderer)],
        }

    monkeypatch.setattr(fig, "savefig", recording_savefig)
    pdf, png = save_figure(fig, tmp_path / "crowded.pdf", png_dpi=60)
    assert pdf.is_file() and png.is_file()
    assert set(saved) == {"pdf", "png"}
    # one layout for both formats: the same axes and suptitle positions, exactly
    assert saved["pdf"]["axes"] == saved["png"]["axes"]
    assert saved["pdf"]["suptitle"] == saved["png"]["suptitle"]
    # and it is a real layout: the axes moved away from the bare gridspec positions ...
    assert not np.allclose(saved["png"]["axes"], default)
    # ... to where every label, tick label and title lies inside the figure, overlapping no other panel
    width, height = fig.bbox.width, fig.bbox.height
    boxes = saved["png"]["boxes"]
    for box in boxes:
        assert box.x0 >= 0 and box.y0 >= 0 and box.x1 <= width and box.y1 <= height, (box, width, height)
    panels = boxes[:-1]
    for i, a in enumerate(panels):
        for b in panels[i + 1 :]:
            overlap_x = min(a.x1, b.x1) - max(a.x0, b.x0)
            overlap_y = min(a.y1, b.y1) - max(a.y0, b.y0)
            assert overlap_x <= 0 or overlap_y <= 0, (a, b)
