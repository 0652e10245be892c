"""What ``verify`` checks of an atlas dataset beyond the generic checks (:mod:`nnmstop.pipeline.verify`).

The generic checks compare an atlas with the reference's: its structure and attributes, and the numbers off
the curves within the tolerance of located points (the codimension-two points, the checked points, the
curves' kinds, ends and seeds) or exactly (the regions). A curve's points follow the continuation's steps
(another CPU stores other points of the same curve), so they are not compared point by point; what makes them
right is checked here, on the build itself: every checked point lies on its curve within the stated tolerance
of its law, and every curve point is inside the map's window.
"""

from __future__ import annotations

import numpy as np

from nnmstop.bifurcation_atlas.flags import LAWS

__all__ = ["atlas_rows"]


def atlas_rows(name: str, ds, row, within: str, discrepant: str) -> list:
    """Rows of the verification table (``row(file, quantity, reference, build, difference, tolerance, verdict)``
    builds one) for the atlas dataset ``ds``."""
    rows = []
    if ds.sizes.get("check", 0):
        laws = ds["curve_law"].values[ds["check_curve"].values]
        tolerance = np.where(
            laws == LAWS.index("regularized"),
            float(ds.attrs.get("regularized_check_tolerance", ds.attrs["check_tolerance"])),
            float(ds.attrs["check_tolerance"]),
        )
        excess = ds["check_deviation"].values / tolerance
        worst = int(np.argmax(excess))
        ok = bool(np.all(excess <= 1.0))
        rows.append(
            row(
                name,
                f"{ds.sizes['check']} located points on their curves (relative distance)",
                "on the curve",
                f"{ds['check_deviation'].values[worst]:.3g}",
                float(ds["check_deviation"].values[worst]),
                float(tolerance[worst]),
                within if ok else discrepant,
            )
        )
    if ds.sizes.get("point", 0):
        low, high = (float(v) for v in ds.attrs["frequency_range"])
        f = ds["frequency"].values
        outside = int(np.count_nonzero((f < low * (1 - 1e-9)) | (f > high * (1 + 1e-9))))
        rows.append(
            row(
                name,
                "curve points inside the frequency window",
                "0 outside",
                f"{outside} outside",
                float(outside),
                0.0,
                within if outside == 0 else discrepant,
            )
        )
    return rows
