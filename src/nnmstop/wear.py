r"""Wear of the stops along periodic orbits: normal contact force, sliding speed, wear power and impact work rate.

Fretting wear of a tube in its support is driven by the normal contact force ``F_N`` and the sliding speed ``v_t``
of the tube on the support. Archard's law makes the worn volume proportional to the normal force times the sliding
distance, so its rate is proportional to the **wear power**, the time average over the motion of the product of
the norms (the quantity the code_aster operator ``POST_USURE`` reads, there from a transient response)::

    P_w = < |F_N| |v_t| > = 1/T int_0^T |F_N(t)| |v_t(t)| dt.

For a periodic orbit the average over one period is the average over any long time. The **impact work rate** is
the work the normal force does on the stop while it is compressed, per unit time,
``P_i = 1/T int_0^T (F_N v_N)_+ dt`` (``v_N`` the rate of penetration): an elastic stop gives that work back as
it is unloaded, and for a law with a potential ``P`` it is the sum of the rises of ``P`` beyond the gap over the
period, which is how it is computed here (exact between samples; the missed top of each peak is second order in
the sampling step). It measures impacting, as the wear power measures sliding.

What each kind of stop gives (:mod:`nnmstop.models.contact`; per stop, in the structure's nondimensional units:
forces in ``k0 L0``, speeds in ``L0 / T0``, powers in ``k0 L0^2 / T0``, ``docs/structures.md``):

* a stop is *touched* where its coordinates are beyond the gap (:meth:`~nnmstop.models.contact.Stop.penetration`
  positive, the convention of the impact counts); there ``F_N`` is the law's normal force (the regularized law's,
  or ``alpha`` times the penetration for the piecewise-linear one), elsewhere zero: the regularized law's small
  force inside the clearance (slope ``eta`` at rest) is its regularization, not a contact. An orbit that touches
  no stop has no contact force, no wear power and no impact work;
* the **circular clearance**: ``F_N`` radial, ``v_t`` the circumferential speed ``|x_1 x_2' - x_2 x_1'| / r``
  of the body in the hole (times the gap), ``v_N`` the radial speed. For the whirling orbit of radius ``R >= g``
  and angular frequency ``omega`` they are constant: ``P_w = F_N(R) omega R`` (``k_s (R - g) omega R`` for the
  piecewise-linear law) and ``P_i = 0`` (no impact: the contact is permanent);
* **stops on one coordinate** (bilateral, one-sided, relative): the models carry no motion along the contact
  surface, so ``v_t = 0`` and the wear power is zero; the impact work rate is what they give (for a bilateral
  stop struck twice per period at the penetration ``A - g``, ``k_s (A - g)^2 / T``).

Method note: ``docs/methods/wear.md``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["WEAR_VARIABLES", "LAWS", "stop_wear", "structure_wear", "orbit_wear"]

#: The per-orbit, per-stop quantities, in the order of the datasets.
WEAR_VARIABLES = ("contact_force_max", "contact_force_mean", "sliding_speed_max", "wear_power", "impact_work_rate")
#: The laws the normal force can be taken from.
LAWS = ("regularized", "piecewise_linear")
#: Samples of the orbits' time histories held at once by :func:`orbit_wear` (values of every field).
CHUNK_VALUES = 4_000_000
#: Rises of the stored contact energy below this many round-offs of its largest value are not rises (a constant
#: penetration, as on a whirling orbit, computed with round-off).
ROUND_OFF_RISES = 64


def stop_wear(stop, x, xdot, period, law: str = "regularized") -> dict:
    """Wear quantities of one stop along orbits sampled uniformly over one period.

    Parameters
    ----------
    stop : nnmstop.models.contact.Stop
    x, xdot : array_like, shape (m, ..., samples)
        The stop's scaled coordinates (``A q / gap``) and their time derivatives.
    period : array_like, shape (...)
        Period of each orbit (nondimensional time).
    law : {"regularized", "piecewise_linear"}
        Whose normal force: the regularized law of the stop or its piecewise-linear law.

    Returns
    -------
    dict
        :data:`WEAR_VARIABLES` -> arrays of shape ``(...)``.

    Examples
    --------
    A body whirling at radius 1.5 (scaled) in a hole of gap 2, radial stiffness 10, with angular frequency 3:

    >>> from nnmstop.models.contact import Stop
    >>> hole = Stop(kind="circular", dofs=[0, 1], gap=2.0, stiffness=10.0, eta=0.1)
    >>> theta = 2 * np.pi * np.arange(64) / 64
    >>> x = 1.5 * np.array([np.cos(theta), np.sin(theta)])
    >>> xdot = 3.0 * 1.5 * np.array([-np.sin(theta), np.cos(theta)])
    >>> wear = stop_wear(hole, x, xdot, 2 * np.pi / 3, law="piecewise_linear")
    >>> float(wear["wear_power"]), 10.0 * (3.0 - 2.0) * 3.0 * 3.0  # k_s (R - g) omega R, R = 3
    (90.0, 90.0)
    >>> float(wear["impact_work_rate"])
    0.0
    """
    if law not in LAWS:
        raise ValueError(f"law must be one of {LAWS}, got {law!r}")
    x, xdot = np.asarray(x, dtype=float), np.asarray(xdot, dtype=float)
    gap, alpha = stop.gap, stop.stiffness
    depth = stop.penetration(x)
    touched = depth > 0
    if law == "regularized":
        boundary = np.zeros((x.shape[0],) + (1,) * (x.ndim - 1))
        boundary[0] = 1.0  # a point on the gap: where the law's potential starts to count as stored contact energy
        force = gap * np.where(touched, stop.normal_force(x), 0.0)
        stored = gap**2 * np.where(touched, stop.potential(x) - stop.potential(boundary), 0.0)
    else:
        inside = np.maximum(depth, 0.0)
        force = gap * alpha * inside
        stored = 0.5 * gap**2 * alpha * inside**2
    sliding = gap * np.abs(stop.sliding_velocity(x, xdot))
    # rises of the stored energy from sample to sample (periodic), those of round-off on a constant one left out
    rise = np.roll(stored, -1, axis=-1) - stored
    # (a round-off of the coordinates, eps gap |x|, changes it by about the force times that)
    size = gap * np.abs(x).max(axis=(0, -1))[..., None]
    noise = (
        ROUND_OFF_RISES
        * np.finfo(float).eps
        * (stored.max(axis=-1, keepdims=True) + force.max(axis=-1, keepdims=True) * size)
    )
    rises = np.where(rise > noise, rise, 0.0).sum(axis=-1)
    return {
        "contact_force_max": force.max(axis=-1),
        "contact_force_mean": force.mean(axis=-1),
        "sliding_speed_max": np.where(touched, sliding, 0.0).max(axis=-1),
        "wear_power": (force * sliding).mean(axis=-1),
        "impact_work_rate": rises / np.asarray(period, dtype=float),
    }


def structure_wear(structure, q, qdot, period, law: str = "regularized") -> dict:
    """:func:`stop_wear` of every stop of ``structure`` from degree-of-freedom samples.

    ``q``, ``qdot``: shape ``(N, ..., samples)`` (DOFs first), one period sampled uniformly; ``period``: ``(...)``.
    Returns :data:`WEAR_VARIABLES` -> arrays of shape ``(..., n_stops)``.
    """
    contact = structure.contact
    x, xdot = contact.coordinates(np.asarray(q, dtype=float)), contact.coordinates(np.asarray(qdot, dtype=float))
    per_stop = [
        stop_wear(stop, x[components], xdot[components], period, law)
        for stop, components in zip(structure.stops, contact.components)
    ]
    return {name: np.stack([w[name] for w in per_stop], axis=-1) for name in WEAR_VARIABLES}


def orbit_wear(system, U, samples: int | None = None) -> dict:
    """:func:`structure_wear` of harmonic-balance orbits ``U`` (points, n_unknowns) with the regularized laws.

    Sampled on ``samples`` instants per period (default ``max(16 H, 1024)``) by
    :meth:`~nnmstop.hbm.system.HarmonicBalanceSystem.time_history` (NNM or forced systems alike). Returns
    :data:`WEAR_VARIABLES` -> arrays of shape ``(points, n_stops)``.
    """
    U = np.atleast_2d(np.asarray(U, dtype=float))
    samples = samples or max(16 * system.H, 1024)
    parts = [{name: np.zeros((0, system.n_stops)) for name in WEAR_VARIABLES}]
    chunk = max(1, CHUNK_VALUES // (samples * (2 * system.n_dofs + 2 * system.n_components + system.n_stops)))
    for start in range(0, len(U), chunk):
        history = system.time_history(U[start : start + chunk], samples)
        period = history["t"][..., 1] * samples  # t_k = k T / samples
        q, qdot = (np.moveaxis(history[key], -2, 0) for key in ("q", "qdot"))
        parts.append(structure_wear(system.structure, q, qdot, period))
    return {name: np.concatenate([part[name] for part in parts]) for name in WEAR_VARIABLES}
