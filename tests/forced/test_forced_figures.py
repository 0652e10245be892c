"""The forced figures draw what the datasets say: a verdict the multipliers cannot resolve is drawn apart."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from nnmstop.figures.forced import _draw_response  # noqa: E402


def test_unresolved_verdicts_are_drawn_dotted_not_as_stable_or_unstable():
    """Stable points solid, unstable dashed, points whose verdict is unresolved dotted whatever ``stable`` says."""
    ds = xr.Dataset(
        {
            "frequency": ("point", np.linspace(0.1, 0.2, 9)),
            "stable": ("point", np.array([1, 1, 1, 1, 0, 0, 0, 1, 1], dtype=np.int8)),
            "stability_resolved": ("point", np.array([1, 1, 0, 0, 1, 1, 1, 1, 1], dtype=np.int8)),
            "segment": ("point", np.zeros(9, dtype=np.int32)),
        }
    )
    fig, ax = plt.subplots()
    try:
        _draw_response(ax, ds, np.arange(9.0), "C0", 1.0, 1)
        drawn = {}
        for line in ax.get_lines():
            drawn.setdefault(line.get_linestyle(), set()).update(line.get_xdata())
    finally:
        plt.close(fig)
    f = ds["frequency"].values
    assert set(drawn) == {"-", ":", "--"}
    # each run of one class is drawn to the first point of the next, so a run's inner points are its own
    assert {style for style, xs in drawn.items() if f[3] in xs} == {":"}
    assert {style for style, xs in drawn.items() if f[5] in xs} == {"--"}
    assert {style for style, xs in drawn.items() if f[0] in xs} == {"-"}
