"""Stability of a regularized (harmonic-balance) forced response and its located stability changes.

The multipliers of every point come from :func:`nnmstop.hbm.forced.forced_multipliers`; a change of the
number of multipliers outside the unit circle is located on the ANM step between two points
(:func:`nnmstop.forced.stability_changes.locate_stability_changes`). A multiplier through +1 is a
symmetry-breaking branch point where the continuation flagged a simple branch point (the full-basis
harmonic balance holds both the symmetric and the asymmetric responses), else a fold.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from nnmstop.continuation.anm import ANMSettings, ANMStepper
from nnmstop.forced.responses import path_between
from nnmstop.forced.stability_changes import locate_stability_changes
from nnmstop.hbm.forced import forced_multipliers

__all__ = ["regularized_stability"]


def regularized_stability(system, branch, anm: ANMSettings, spec: dict):
    """Multipliers (points, 2N) of every point of ``branch``, their error estimates and the located changes.

    ``spec``: the ``forced.stability`` settings (``steps``, ``max_steps``, ``tolerance``).
    """
    U = np.asarray(branch.points)
    options = dict(steps=int(spec["steps"]), max_steps=int(spec["max_steps"]), tol=float(spec["tolerance"]))
    multipliers, errors = forced_multipliers(system, U, **options)
    stepper = ANMStepper(anm)
    changes = locate_stability_changes(
        U,
        multipliers,
        lambda V: forced_multipliers(system, V[None], **options)[0][0],
        lambda i: path_between(system, stepper, U, i),
        half_period=False,
    )
    # a multiplier through +1 is a fold of the symmetric responses unless the continuation crossed a simple
    # branch point there (sign change of det [J; t^T]: the symmetry-breaking pitchfork of the full basis)
    flagged = set(branch.branch_points)
    typed = []
    for change in changes:
        near = {change.after_point + k for k in (0, 1, 2)}
        if change.kind == "fold" and near & flagged:
            change = dataclasses.replace(change, kind="symmetry_breaking")
        typed.append(change)
    return multipliers, errors, typed
