"""The two-degree-of-freedom oscillator with a bilateral elastic stop.

Nondimensional equations (3)-(4) of Moussi et al.::

    x'' + x + beta (x - u) + f(x) = 0
    delta u'' + beta (u - x)       = 0

with the gap equal to 1. ``x`` is the first mass (the one that strikes the stops),
``u`` the second one.

Two contact laws are provided:

* the piecewise-linear law of Eq. (4), :func:`piecewise_contact_force`;
* the regularized law of Eq. (5) (with the sign slip corrected, see the project
  NOTES), :func:`regularized_contact_force`: the admissible root of::

      f (f - alpha (x - 1)) (f - alpha (x + 1)) = -eta alpha**2 x.

The regularized law is evaluated through an exact rational parametrization of the cubic
(overflow-free for tiny and huge ``|x|``); its derivation is in ``docs/methods/contact_law.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "ModelParameters",
    "piecewise_contact_force",
    "piecewise_contact_potential",
    "regularized_contact_force",
    "regularized_contact_stiffness",
    "regularized_contact_potential",
    "regularized_force_and_potential",
    "regularized_vector_field",
    "total_energy",
    "mass_matrix",
    "stiffness_matrix",
    "linear_modes",
]


@dataclass(frozen=True)
class ModelParameters:
    """Nondimensional parameters of Eqs. (3)-(7).

    Parameters
    ----------
    alpha : float
        Stop stiffness over the stiffness of the first spring, ``K/k1`` (> 0).
    beta : float
        Coupling stiffness ratio ``k2/k1`` (> 0).
    delta : float
        Mass ratio ``m2/m1`` (> 0).
    eta : float
        Regularization parameter (0 < eta < alpha); only used by the regularized model.

    Examples
    --------
    >>> p = ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
    >>> p.eps
    0.0033333333333333335
    """

    alpha: float = 30.0
    beta: float = 1.0
    delta: float = 1.0
    eta: float = 0.1

    def __post_init__(self):
        for name in ("alpha", "beta", "delta", "eta"):
            value = getattr(self, name)
            if not isinstance(value, (int, float, np.floating, np.integer)) or isinstance(value, bool):
                raise TypeError(f"{name} must be a real number, got {value!r}")
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        if self.eta >= self.alpha:
            raise ValueError(
                f"eta must be smaller than alpha for the regularized force to have an admissible "
                f"branch through the origin, got eta={self.eta!r} >= alpha={self.alpha!r}"
            )

    @property
    def eps(self) -> float:
        """``eta / alpha``, the relative softness of the regularization."""
        return self.eta / self.alpha

    @classmethod
    def from_config(cls, model_config: dict) -> ModelParameters:
        """Build from the ``model:`` section of the configuration."""
        return cls(**{k: float(model_config[k]) for k in ("alpha", "beta", "delta", "eta")})

    def as_attrs(self) -> dict:
        """The parameters as NetCDF global attributes."""
        return {"alpha": self.alpha, "beta": self.beta, "delta": self.delta, "eta": self.eta}


# --------------------------------------------------------------------------- piecewise law


def piecewise_contact_force(x, alpha):
    """Contact force of the non-smooth model, Eq. (4).

    ``alpha (x - sgn(x))`` beyond the stops (``|x| > 1``), zero inside the gap.

    Examples
    --------
    >>> piecewise_contact_force([0.5, 2.0, -3.0], 30.0).tolist()
    [0.0, 30.0, -60.0]
    """
    x = np.asarray(x, dtype=float)
    return alpha * np.sign(x) * np.maximum(np.abs(x) - 1.0, 0.0)


def piecewise_contact_potential(x, alpha):
    """Potential of the piecewise-linear force: ``alpha/2 (|x| - 1)**2`` for ``|x| > 1``."""
    x = np.asarray(x, dtype=float)
    return 0.5 * alpha * np.maximum(np.abs(x) - 1.0, 0.0) ** 2


# --------------------------------------------------------------------------- regularized law


def _branch_coordinate(abs_x, params: ModelParameters):
    """Solve ``x(y) = abs_x`` for ``y = -g`` in ``[0, min(abs_x, sqrt(c)))``.

    ``psi(y) = y + eps*y/(c - y**2) - x`` is increasing and convex on ``[0, sqrt(c))``
    (``psi'' > 0``), negative at 0 and positive (or infinite) at ``min(x, sqrt(c))``.
    Newton's method on a convex increasing function converges monotonically once an
    iterate lies right of the root, which the first step ensures; a step leaving the
    bracket is replaced by bisection. Returns ``y`` and ``s = c - y**2`` computed
    without cancellation.
    """
    eps = params.eps
    c = 1.0 - eps
    sqrt_c = np.sqrt(c)
    lo = np.zeros_like(abs_x)
    hi = np.minimum(abs_x, sqrt_c)
    # Start from the linear law inside the gap, from the far-field asymptote outside.
    with np.errstate(divide="ignore", invalid="ignore"):
        s_guess = eps * sqrt_c / np.maximum(abs_x - sqrt_c, np.sqrt(eps))
    y = np.where(abs_x < 1.0, abs_x * c / (c + eps), np.sqrt(np.maximum(c - s_guess, 0.0)))
    y = np.clip(y, lo, hi)
    tiny = np.finfo(float).tiny
    for _ in range(100):
        gap = (sqrt_c - y) * (sqrt_c + y)  # c - y**2, accurate near sqrt(c)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            psi = y + eps * y / gap - abs_x
            dpsi = 1.0 + eps * (c + y * y) / (gap * gap)
            y_new = y - psi / dpsi
        lo = np.where(psi < 0, y, lo)
        hi = np.where(psi >= 0, y, hi)
        outside = ~((y_new >= lo) & (y_new <= hi)) | ~np.isfinite(y_new)
        y_new = np.where(outside, 0.5 * (lo + hi), y_new)
        done = np.abs(y_new - y) <= 4 * np.finfo(float).eps * np.maximum(y, tiny)
        y = y_new
        if np.all(done):
            break
    # s = c - y^2 loses its digits when y -> sqrt(c) (large |x|); there the branch
    # relation s = eps*y/(x - y) is exact and free of cancellation.
    with np.errstate(divide="ignore", invalid="ignore"):
        s_far = eps * y / (abs_x - y)
    s = np.where(abs_x > 1.0, s_far, (sqrt_c - y) * (sqrt_c + y))
    return y, s


def _odd_extension(x):
    x = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(x)):
        raise ValueError("x must be finite")
    return x, np.sign(x), np.abs(x)


def regularized_contact_force(x, params: ModelParameters):
    """Regularized contact force ``f(x; alpha, eta)``: the admissible root of the corrected cubic.

    Vectorized; relative accuracy near round-off for any ``x`` (``1e-12`` to ``1e12``
    included). Odd in ``x``; ``f ~ eta x`` near 0 and ``f ~ alpha (x - sgn x)`` far out.

    Examples
    --------
    >>> p = ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
    >>> f = regularized_contact_force([1e-6, 1.0, 10.0], p)
    >>> bool(abs(f[0] / 1e-6 - 0.1) < 1e-9), bool(abs(f[2] - 270.0) < 0.1)
    (True, True)
    """
    x, sign, abs_x = _odd_extension(x)
    y, s = _branch_coordinate(abs_x, params)
    return sign * _force_magnitude(abs_x, y, s, params)


def _force_magnitude(abs_x, y, s, params: ModelParameters):
    near = params.eta * y / np.where(abs_x > 1.0, 1.0, s)
    far = params.alpha * (abs_x - y)
    return np.where(abs_x > 1.0, far, near)


def _potential(abs_x, y, s, params: ModelParameters):
    c = 1.0 - params.eps
    f = np.where(abs_x > 1.0, params.alpha * (abs_x - y), params.eta * y / np.where(abs_x > 1.0, 1.0, s))
    log_ratio = np.where(abs_x > 1.0, np.log(s / c), np.log1p(-(y * y) / c))
    return f * f / (2.0 * params.alpha) - 0.5 * params.eta * log_ratio


def regularized_contact_stiffness(x, params: ModelParameters):
    """Derivative ``df/dx`` of the regularized force (``eta`` at 0, ``alpha`` far out)."""
    x, _, abs_x = _odd_extension(x)
    y, s = _branch_coordinate(abs_x, params)
    q = (1.0 - params.eps) + y * y
    return params.eta * q / (s * s + params.eps * q)


def regularized_vector_field(states, params: ModelParameters):
    """Right-hand side of the regularized equations (7) at the states ``(x, u, xdot, udot)`` (last axis).

    Examples
    --------
    >>> p = ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
    >>> regularized_vector_field([0.0, 1.0, 2.0, 3.0], p).tolist()  # at x = 0 the stop exerts no force
    [2.0, 3.0, 1.0, -1.0]
    """
    states = np.asarray(states, dtype=float)
    x, u = states[..., 0], states[..., 1]
    b, d = params.beta, params.delta
    acceleration_x = -(1.0 + b) * x + b * u - regularized_contact_force(x, params)
    return np.stack([states[..., 2], states[..., 3], acceleration_x, (b / d) * (x - u)], axis=-1)


def regularized_contact_potential(x, params: ModelParameters):
    """Potential ``P(x) = int_0^x f(s) ds`` of the regularized force, in closed form.

    ``P = f**2/(2 alpha) - eta/2 * log(s/c)`` (see the module docstring).
    """
    x, _, abs_x = _odd_extension(x)
    y, s = _branch_coordinate(abs_x, params)
    return _potential(abs_x, y, s, params)


def regularized_force_and_potential(x, params: ModelParameters):
    """``(f(x), P(x))`` of :func:`regularized_contact_force` and
    :func:`regularized_contact_potential` from one solve of the branch coordinate.

    Both come from the same root ``y(|x|)``, which costs far more than either closed
    form; the values are those of the two functions, bit for bit.
    """
    x, sign, abs_x = _odd_extension(x)
    y, s = _branch_coordinate(abs_x, params)
    return sign * _force_magnitude(abs_x, y, s, params), _potential(abs_x, y, s, params)


# --------------------------------------------------------------------------- energy, linear limits


def total_energy(x, u, xdot, udot, params: ModelParameters, model: str = "regularized", potential=None):
    """Total (conserved) energy of either model.

    ``1/2 xdot**2 + 1/2 delta udot**2 + 1/2 x**2 + 1/2 beta (x - u)**2 + P(x)``, with
    ``P`` the potential of the piecewise-linear (``model="piecewise"``) or the
    regularized (``model="regularized"``) contact force; ``potential`` may pass
    ``P(x)`` when the caller has it (see :func:`regularized_force_and_potential`).
    """
    x, u, xdot, udot = (np.asarray(v, dtype=float) for v in (x, u, xdot, udot))
    if potential is not None:
        potential = np.asarray(potential, dtype=float)
    elif model == "piecewise":
        potential = piecewise_contact_potential(x, params.alpha)
    elif model == "regularized":
        potential = regularized_contact_potential(x, params)
    else:
        raise ValueError(f"model must be 'piecewise' or 'regularized', got {model!r}")
    return 0.5 * xdot**2 + 0.5 * params.delta * udot**2 + 0.5 * x**2 + 0.5 * params.beta * (x - u) ** 2 + potential


def mass_matrix(params: ModelParameters) -> np.ndarray:
    """Mass matrix of (x, u): ``diag(1, delta)``."""
    return np.diag([1.0, params.delta])


def stiffness_matrix(params: ModelParameters, added_stiffness: float = 0.0) -> np.ndarray:
    """Stiffness matrix of (x, u) with ``added_stiffness`` acting on x alone."""
    b = params.beta
    return np.array([[1.0 + b + added_stiffness, -b], [-b, b]])


LINEAR_LIMITS = ("no_contact", "regularized", "gap_zero")


def linear_modes(params: ModelParameters, limit: str = "no_contact"):
    """Angular frequencies (rad per unit time) and mode shapes of a linear limit.

    Parameters
    ----------
    limit : {"no_contact", "regularized", "gap_zero"}
        ``"no_contact"``: the underlying linear system (e = infinity);
        ``"regularized"``: the regularized system near equilibrium (added stiffness eta);
        ``"gap_zero"``: the stop always engaged (added stiffness alpha).

    Returns
    -------
    omega : ndarray, shape (2,)
        Increasing angular frequencies; divide by ``2 pi`` for Hz.
    shapes : ndarray, shape (2, 2)
        Column ``j`` is mode ``j``, normalized so that its x component is 1.

    Examples
    --------
    >>> omega, _ = linear_modes(ModelParameters(), "no_contact")
    >>> [round(float(w), 3) for w in omega]
    [0.618, 1.618]
    """
    added = {"no_contact": 0.0, "regularized": params.eta, "gap_zero": params.alpha}
    if limit not in added:
        raise ValueError(f"limit must be one of {LINEAR_LIMITS}, got {limit!r}")
    from scipy.linalg import eigh

    lam, vec = eigh(stiffness_matrix(params, added[limit]), mass_matrix(params))
    return np.sqrt(lam), vec / vec[0]
