"""Floquet multipliers of a 4 x 4 symplectic monodromy with a trivial pair at +1.

The monodromy matrix of a periodic orbit of a conservative autonomous 2-DOF system has
the multipliers ``{1, 1, mu, 1/mu}``; the non-trivial pair is decided by the invariant
``s = mu + 1/mu`` (elliptic, on the unit circle, when ``|s| <= 2``). Shared by the exact
orbits (:mod:`nnmstop.exact.stability`) and the regularized ones
(:mod:`nnmstop.hbm.monodromy`); the derivations are in ``docs/methods/exact_stability.md``
and ``docs/methods/monodromy.md``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["multipliers_from_invariant", "transition_matrix"]


def multipliers_from_invariant(s):
    """``[1, 1, mu_1, mu_2]`` from ``s = mu + 1/mu`` (``|mu_1| >= |mu_2|``).

    Elliptic pair (``|s| <= 2``): ``mu_1 = s/2 + i sqrt(1 - s**2/4)`` (non-negative imaginary
    part) and its conjugate; hyperbolic pair: the root of larger modulus computed without
    cancellation, the other its inverse.

    Parameters
    ----------
    s : float or array_like

    Returns
    -------
    ndarray of complex, shape ``np.shape(s) + (4,)``
    """
    s = np.asarray(s, dtype=float)
    out = np.ones(s.shape + (4,), dtype=complex)
    elliptic = np.abs(s) <= 2.0
    root = np.sqrt(np.abs(0.25 * s * s - 1.0))
    big = 0.5 * s + np.sign(s) * root
    out[..., 2] = np.where(elliptic, 0.5 * s + 1j * root, big)
    out[..., 3] = np.where(elliptic, 0.5 * s - 1j * root, 1.0 / np.where(elliptic, 1.0, big))
    return out


def transition_matrix(step_matrices):
    """Ordered product ``M_{n-1} ... M_1 M_0`` along axis -3, pairwise (a tree of batched products).

    The monodromy (or a part of it) from the step maps of a one-step integrator; used by
    :mod:`nnmstop.hbm.monodromy` (Magnus steps) and :mod:`nnmstop.hbm.shooting_refinement`
    (Runge-Kutta steps).
    """
    mats = np.asarray(step_matrices)
    while mats.shape[-3] > 1:
        if mats.shape[-3] % 2:
            pad = np.broadcast_to(np.eye(mats.shape[-1]), mats.shape[:-3] + (1,) + mats.shape[-2:])
            mats = np.concatenate([mats, pad], axis=-3)
        mats = np.matmul(mats[..., 1::2, :, :], mats[..., 0::2, :, :])
    return mats[..., 0, :, :]
