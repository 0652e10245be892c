"""Extra figure: relative frequency error of the regularized NNM1 per impact regime.

Drawn from ``results/compare/nnm1_regimes.nc`` only (:mod:`nnmstop.compare.regimes`):
``|f_reg - f_exact| / f_exact`` against energy, both axes logarithmic, one colour per
impact regime (legend: impacts per period and exact phase sequence). Orbits whose error
is exactly zero cannot sit on a log axis; they are counted in the title, never dropped
silently.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

__all__ = ["regime_error_figure"]

_REQUIRED = ("energy", "relative_frequency_error", "point_regime", "impacts_per_period", "exact_sequence")


def regime_error_figure(ds: xr.Dataset):
    """The figure (not saved) from a regime error dataset with its ``point`` variables.

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`nnmstop.compare.regimes.regime_error_dataset` with ``points=True``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    missing = [name for name in _REQUIRED if name not in ds]
    if missing:
        raise ValueError(f"the regime error dataset lacks {missing} (write it with points=True)")
    energy = ds["energy"].values
    error = np.abs(ds["relative_frequency_error"].values)
    regime = ds["point_regime"].values
    # one colour per regime along the branch; tab10 has enough for the nine regimes of the paper's values
    colors = plt.get_cmap("tab10" if ds.sizes["regime"] <= 10 else "tab20")
    fig, ax = plt.subplots(figsize=(8.0, 4.2))
    zero = 0
    for k in range(ds.sizes["regime"]):
        on = (regime == k) & (error > 0)
        zero += int(np.sum((regime == k) & (error == 0)))
        impacts = int(ds["impacts_per_period"].values[k])
        label = f"{k}: {impacts} impacts/period ({ds['exact_sequence'].values[k]})"
        ax.loglog(energy[on], error[on], ".", ms=3, color=colors(k % colors.N), label=label)
    ax.set_xlabel("energy (nondimensional)")
    ax.set_ylabel("|f_reg - f_exact| / f_exact")
    title = (
        f"Regularization error of NNM1 per impact regime (eta = {ds.attrs.get('eta', float('nan')):g}, "
        f"H = {ds.attrs.get('harmonics', '?')})"
    )
    if zero:
        title += f"; {zero} orbits with zero error not shown"
    if int(ds.attrs.get("unpaired_points", 0)):  # a regime without exact counterpart: said, not a silent gap
        title += f"\nnot compared (no exact regime to pair with): {ds.attrs.get('unpaired_regimes', '?')}"
    ax.set_title(title, fontsize=9)
    # outside the axes: the regimes overlap in energy and a legend inside would hide orbits
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), title="regime", title_fontsize=7)
    fig.tight_layout()
    return fig
