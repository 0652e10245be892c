r"""Contact laws: each kind of stop is one small object, and the engines ask it for nothing else.

A stop reads ``m`` coordinates of the structure (``m = 1``, or 2 for the circular clearance), a linear map of
the degrees of freedom: ``c = A q`` (``A`` of shape ``(m, N)`` with entries 0 and +-1), and the engines work in
its scaled coordinates ``x = c / gap`` where the gap is 1. The stop's force on the structure is the generalized
force ``gap A^T f(x)``, ``f`` the force of its law in the scaled coordinates, so that the piecewise-linear force
``alpha (c - gap)`` beyond the gap is ``gap alpha (x - 1)``. What a law provides:

* **geometry**: :attr:`~Stop.dofs`, :attr:`~Stop.n_components`, :attr:`~Stop.coordinate_terms` (the map ``A``),
  :meth:`~Stop.coordinate_matrix`, :meth:`~Stop.coordinates`;
* **the regularized law** (harmonic balance, energies, time integration) in the scaled coordinates:
  :meth:`~Stop.force`, :meth:`~Stop.potential`, :meth:`~Stop.force_and_potential` and its derivative
  :meth:`~Stop.jacobian` (the Jacobian ``df/dx``, ``(m, m, ...)``: monodromy, Hill, shooting), the slope at rest
  :attr:`~Stop.stiffness_at_rest` (the regularized linear modes near rest) and :attr:`~Stop.engaged_stiffness`;
* **its quadratic recast** (harmonic balance and the ANM): :attr:`~Stop.recast`, a :class:`Recast` that says
  which auxiliary fields the law adds and the coefficients of its equations; the HBM system evaluates the two
  recast families below for any mix of laws (:mod:`nnmstop.hbm.system`);
* **the piecewise-linear law** (exact orbits): :meth:`~Stop.piecewise_force`, :meth:`~Stop.piecewise_potential`
  in the physical coordinate, and its half-space contacts :meth:`~Stop.contacts` (each a :class:`Contact`:
  active where ``n . q >= gap``, adding the stiffness ``alpha n n^T`` and the force ``alpha gap n``), the phases
  of every exact engine; the circular clearance is not piecewise linear in Cartesian coordinates and says so;
* **labels and counts**: :attr:`~Stop.label`, :meth:`~Stop.metadata` (dataset variables), :meth:`~Stop.impacts`
  (entries into contact per period), :attr:`~Stop.odd` (``f(-x) = -f(x)``: orbits may have the half-wave
  symmetry);
* for wear (:mod:`nnmstop.wear`): :meth:`~Stop.penetration` (beyond the gap, scaled: the stop is touched where
  it is positive) and its rate :meth:`~Stop.penetration_rate`, :meth:`~Stop.normal_force` and
  :meth:`~Stop.sliding_velocity`.

Kinds (``kind`` in the configuration; ``Stop(kind=..., ...)`` builds the right class):

* :class:`BilateralStop` (``bilateral``, the default): the paper's stop on one DOF, the regularized law of
  Eq. (5) with the sign slip corrected, results unchanged;
* :class:`OneSidedStop` (``one_sided``, ``side: positive | negative``): a stop on one side of one DOF;
  unequal gaps are two one-sided stops on one DOF;
* :class:`RelativeStop` (``relative``, ``dofs: [i, j]``): the gap closes on ``q_i - q_j`` (force ``+F`` on
  ``i``, ``-F`` on ``j``), on both sides, or on one (``side``);
* :class:`CircularStop` (``circular``, ``dofs: [i, j]``): a circular clearance of radius ``gap`` in the plane of
  two DOFs, radial stiffness ``alpha``.

The two recast families (``g = f / alpha - x`` for each component):

* ``squared_gap`` (bilateral, relative on both sides, circular): ``f - eta x - f z = 0``, ``z = sum g**2`` over
  the stop's components (Eq. (12) of the paper; for the circular clearance it is the bilateral law of the
  radius, ``f = f_b(r) x / r``);
* ``linear_gap`` (one-sided): ``f - eta x + kappa f z = 0``, ``z = g``, ``kappa = 1 - 2 eta / alpha``: the
  hyperbola through the origin of slope ``eta`` whose asymptotes are ``f = -eta / kappa`` (far from the stop)
  and ``f = alpha (x - 1) - eta / kappa`` (deep in contact); it tends to ``alpha (x - 1)_+`` as ``eta -> 0``.

Method notes: ``docs/methods/contact_law.md`` (bilateral), ``docs/methods/one_sided_law.md``,
``docs/methods/relative_stop.md``, ``docs/methods/circular_clearance.md``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, fields, replace
from typing import ClassVar, NamedTuple

import numpy as np

from nnmstop.models.two_dof import (
    ModelParameters,
    regularized_contact_force,
    regularized_contact_potential,
    regularized_contact_stiffness,
    regularized_force_and_potential,
)

__all__ = [
    "KINDS",
    "SIDES",
    "Stop",
    "BilateralStop",
    "OneSidedStop",
    "RelativeStop",
    "CircularStop",
    "Contact",
    "Recast",
    "StopSet",
    "one_sided_force",
    "one_sided_stiffness",
    "one_sided_potential",
]

#: The kinds of stop, as named in the configuration.
KINDS = ("bilateral", "one_sided", "relative", "circular")
#: The sides of a one-sided stop.
SIDES = ("positive", "negative")


def _real_number(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    if not np.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return float(value)


def _dof_index(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if value < 0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return int(value)


class Contact(NamedTuple):
    """One half-space of a piecewise-linear law: active where ``normal . q >= gap``.

    While active it adds ``alpha (normal . q - gap)`` along ``normal``: the stiffness ``alpha n n^T`` and the
    constant force ``alpha gap n`` on the right-hand side (``M q'' + (K + alpha n n^T) q = alpha gap n``).

    Attributes
    ----------
    terms : tuple of (int, float)
        ``(dof, sign)`` pairs: ``n = sum sign e_dof``.
    gap, alpha : float
    stop : int
        Index of the stop (in ``Structure.stops``) the contact belongs to, -1 when not set.
    side : int
        +1 or -1: which side of its stop (for a bilateral stop, the sign of its coordinate in contact).
    """

    terms: tuple
    gap: float
    alpha: float
    stop: int = -1
    side: int = 1

    def normal(self, n_dofs: int) -> np.ndarray:
        """``n`` as a vector of length ``n_dofs``."""
        out = np.zeros(n_dofs)
        for dof, sign in self.terms:
            out[dof] += sign
        return out

    def coordinate(self, q) -> np.ndarray:
        """``n . q`` of states ``q`` (DOFs on the last axis)."""
        q = np.asarray(q, dtype=float)
        (dof, sign), rest = self.terms[0], self.terms[1:]
        out = q[..., dof] if sign == 1 else sign * q[..., dof]
        for dof, sign in rest:
            out = out + sign * q[..., dof]
        return out


@dataclass(frozen=True)
class Recast:
    """A law's quadratic recast for harmonic balance (auxiliary fields and coefficients of its equations).

    Each stop adds its ``n_components`` force fields ``f_c`` and one internal field ``z``; with
    ``g_c = f_c / alpha - x_c`` its equations are, per component, ``f_c - eta x_c + coefficient f_c z = 0``
    and, per stop, ``z = sum_c g_c**2`` (``family = "squared_gap"``) or ``z = g`` (``"linear_gap"``, one
    component). Every equation is linear plus quadratic, so the asymptotic numerical method applies.

    Attributes
    ----------
    family : {"squared_gap", "linear_gap"}
    coefficient : float
        Of the product ``f z`` in the force equations: -1 for ``squared_gap``, ``kappa`` for ``linear_gap``.
    n_components : int
    """

    family: str
    coefficient: float
    n_components: int = 1

    @property
    def n_fields(self) -> int:
        """Auxiliary fields the law adds to the harmonic-balance unknowns: its forces and ``z``."""
        return self.n_components + 1


class Stop:
    """A stop: the contact law behind the one interface every engine uses (see the module docstring).

    ``Stop(dof=..., gap=..., stiffness=..., eta=...)`` is the paper's bilateral stop (:class:`BilateralStop`);
    ``kind`` chooses another: ``Stop(kind="one_sided", dof=0, side="negative", ...)``,
    ``Stop(kind="relative", dofs=[0, 1], ...)``, ``Stop(kind="circular", dofs=[0, 1], ...)``. A key the kind
    does not have, or a missing one, is refused with its name (ValueError).

    Examples
    --------
    >>> Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1).kind
    'bilateral'
    >>> s = Stop(kind="one_sided", dof=2, side="negative", gap=0.5, stiffness=10.0, eta=0.05)
    >>> type(s).__name__, s.dofs, s.coordinate_terms
    ('OneSidedStop', (2,), (((2, -1.0),),))
    >>> Stop(kind="circular", dofs=[0, 1], side="positive", gap=1.0, stiffness=10.0, eta=0.1)
    Traceback (most recent call last):
    ...
    ValueError: stop key 'side' is not allowed for a circular stop (its keys: kind, dofs, gap, stiffness, eta)
    """

    KIND: ClassVar[str] = ""
    #: Keys a stop of the kind must have (besides ``kind``).
    REQUIRED: ClassVar[tuple] = ()

    def __new__(cls, *args, **kwargs):
        if cls is Stop:
            kind = kwargs.get("kind", "bilateral")
            if kind not in _CLASSES:
                raise ValueError(f"stop kind must be one of {KINDS}, got {kind!r}")
            cls = _CLASSES[kind]
            keys = [f.name for f in fields(cls)]
            for key in kwargs:
                if key not in keys:
                    allowed = ", ".join(["kind"] + [k for k in keys if k != "kind"])
                    raise ValueError(f"stop key {key!r} is not allowed for a {kind} stop (its keys: {allowed})")
            given = set(kwargs) | set(keys[: len(args)])
            for key in cls.REQUIRED:
                if key not in given:
                    raise ValueError(f"a {kind} stop needs the key {key!r}{cls._KEY_HINTS.get(key, '')}")
        return object.__new__(cls)

    _KEY_HINTS: ClassVar[dict] = {}

    # ------------------------------------------------------------------ validation shared by the kinds

    def _check_kind(self):
        if self.kind != self.KIND:
            raise ValueError(f"stop kind of a {type(self).__name__} is {self.KIND!r}, got {self.kind!r}")

    def _check_law(self, eta_bound: float = 1.0):
        for name in ("gap", "stiffness", "eta"):
            value = _real_number(f"stop {name}", getattr(self, name))
            if value <= 0:
                raise ValueError(f"stop {name} must be > 0, got {value!r}")
            object.__setattr__(self, name, value)
        if self.eta >= eta_bound * self.stiffness:
            if eta_bound == 1.0:
                raise ValueError(
                    f"stop eta must be smaller than its stiffness alpha (0 < eta < alpha), got eta={self.eta!r} "
                    f">= alpha={self.stiffness!r}"
                )
            raise ValueError(
                f"stop eta of a one-sided law must be smaller than half its stiffness (0 < eta < alpha/2, kappa = "
                f"1 - 2 eta/alpha > 0), got eta={self.eta!r} >= alpha/2={0.5 * self.stiffness!r}"
            )

    def _check_pair(self):
        dofs = self.dofs
        if isinstance(dofs, (str, bytes)) or not hasattr(dofs, "__len__"):
            raise ValueError(f"{self.kind} stop dofs must be a list of two degrees of freedom [i, j], got {dofs!r}")
        dofs = tuple(_dof_index(f"{self.kind} stop dofs entry", d) for d in dofs)
        if len(dofs) != 2:
            raise ValueError(
                f"{self.kind} stop dofs must be a list of two degrees of freedom [i, j], got {list(dofs)} "
                f"({'a stop on one degree of freedom is bilateral or one_sided' if len(dofs) == 1 else 'not two'})"
            )
        if dofs[0] == dofs[1]:
            raise ValueError(f"{self.kind} stop dofs must be two distinct degrees of freedom, got {list(dofs)}")
        object.__setattr__(self, "dofs", dofs)

    # ------------------------------------------------------------------ geometry

    @property
    def n_components(self) -> int:
        """Number of coordinates the stop reads (1, or 2 for the circular clearance)."""
        return len(self.coordinate_terms)

    @property
    def coordinate_terms(self) -> tuple:
        """Per component, the ``(dof, sign)`` pairs of its row of ``A``: ``c_k = sum sign q_dof``."""
        raise NotImplementedError

    def coordinate_matrix(self, n_dofs: int) -> np.ndarray:
        """``A``, shape ``(n_components, n_dofs)``: the physical coordinates ``c = A q``."""
        A = np.zeros((self.n_components, n_dofs))
        for k, terms in enumerate(self.coordinate_terms):
            for dof, sign in terms:
                A[k, dof] += sign
        return A

    def coordinates(self, q, axis: int = 0) -> np.ndarray:
        """Scaled coordinates ``x = A q / gap``, shape ``(n_components,) + q`` without ``axis``."""
        q = np.moveaxis(np.asarray(q, dtype=float), axis, 0)
        out = []
        for terms in self.coordinate_terms:
            (dof, sign), rest = terms[0], terms[1:]
            c = q[dof] if sign == 1 else sign * q[dof]
            for dof, sign in rest:
                c = c + sign * q[dof]
            out.append(c / self.gap)
        return np.stack(out)

    @property
    def label(self) -> str:
        """A short description, e.g. ``"bilateral stop on q0"``."""
        raise NotImplementedError

    def on_dofs(self, position) -> Stop:
        """The same law acting on renumbered degrees of freedom: each DOF it reads replaced by ``position[dof]``
        (a mapping; a reduction of the structure onto its contact DOFs, :mod:`nnmstop.models.reduction`)."""
        names = {f.name for f in fields(self)}
        if "dofs" in names:
            return replace(self, dofs=tuple(int(position[d]) for d in self.dofs))
        return replace(self, dof=int(position[self.dof]))

    def metadata(self) -> dict:
        """What describes the stop in a dataset: ``kind``, ``side`` (+1, -1, or 0 for both sides) and ``dofs``."""
        return {"kind": self.kind, "side": self.side_sign, "dofs": self.dofs}

    @property
    def side_sign(self) -> int:
        """+1 or -1 for a one-sided law (the sign of the physical coordinate in contact), 0 for both sides."""
        return 0

    # ------------------------------------------------------------------ the regularized law (scaled)

    @property
    def odd(self) -> bool:
        """Whether ``f(-x) = -f(x)``: only then may orbits have the half-wave symmetry ``q(t + T/2) = -q(t)``."""
        return True

    @property
    def stiffness_at_rest(self) -> float:
        """Slope of the regularized force at rest (``df/dx`` at ``x = 0``, isotropic): ``eta``."""
        return float(self.eta)

    @property
    def engaged_stiffness(self) -> float:
        """Stiffness of the law in contact, ``alpha``: the gap-0 linear limit
        (:func:`~nnmstop.models.structure.limit_stiffness`)."""
        return float(self.stiffness)

    def force(self, x) -> np.ndarray:
        """Regularized force ``f(x)`` at scaled coordinates ``x`` (``(n_components, ...)``), same shape."""
        raise NotImplementedError

    def potential(self, x) -> np.ndarray:
        """Potential ``P(x)`` of :meth:`force` (zero at rest), shape ``x.shape[1:]``."""
        return self.force_and_potential(x)[1]

    def force_and_potential(self, x):
        """``(force(x), potential(x))`` from one evaluation of the law."""
        raise NotImplementedError

    def jacobian(self, x) -> np.ndarray:
        """Jacobian ``df/dx`` of the regularized force, shape ``(n_components, n_components) + x.shape[1:]``."""
        raise NotImplementedError

    def impacts(self, x) -> int:
        """Entries into contact (scaled coordinate beyond the gap) over periodic samples ``x`` (``(m, samples)``)."""
        raise NotImplementedError

    def normal_force(self, x) -> np.ndarray:
        """Normal (compressive) contact force of the regularized law at ``x``, shape ``x.shape[1:]``."""
        raise NotImplementedError

    def sliding_velocity(self, x, xdot) -> np.ndarray:
        """Tangential (sliding) velocity of the contact, scaled: zero for a stop with one component (its model has
        no motion along the contact surface)."""
        return np.zeros(np.shape(x)[1:])

    def penetration(self, x) -> np.ndarray:
        """How far the scaled coordinates ``x`` are beyond the gap (scaled; negative inside the clearance), shape
        ``x.shape[1:]``: the stop is touched where it is positive. The piecewise-linear normal force is ``alpha``
        times its positive part."""
        raise NotImplementedError

    def penetration_rate(self, x, xdot) -> np.ndarray:
        """Time derivative of :meth:`penetration` along a motion with velocities ``xdot`` (scaled)."""
        raise NotImplementedError

    @property
    def recast(self) -> Recast:
        """The law's quadratic recast (:class:`Recast`)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ the piecewise-linear law (physical)

    @property
    def piecewise_linear(self) -> bool:
        """Whether the non-smooth law is piecewise linear in the degrees of freedom (exact orbits exist)."""
        return True

    def contacts(self, stop: int = -1) -> tuple:
        """The half-spaces of the piecewise-linear law (:class:`Contact`), tagged with the stop index ``stop``."""
        raise NotImplementedError

    def piecewise_force(self, c) -> np.ndarray:
        """Piecewise-linear force at the physical coordinate ``c = A q`` (an array; ``(2, ...)`` if circular)."""
        raise NotImplementedError

    def piecewise_potential(self, c) -> np.ndarray:
        """Potential of :meth:`piecewise_force`: ``alpha/2 (penetration)**2`` in contact."""
        raise NotImplementedError


def _bilateral_impacts(x) -> int:
    x = np.asarray(x, dtype=float)
    above, below = x > 1.0, x < -1.0
    return int(np.count_nonzero(above & ~np.roll(above, 1)) + np.count_nonzero(below & ~np.roll(below, 1)))


def _entries(inside) -> int:
    return int(np.count_nonzero(inside & ~np.roll(inside, 1)))


class _ScalarLaw(Stop):
    """A law of one scaled coordinate: the bilateral law of Eq. (5) or the one-sided hyperbola."""

    @functools.cached_property
    def _params(self) -> ModelParameters:
        return ModelParameters(alpha=self.stiffness, eta=self.eta)

    def _law_side(self) -> int:
        """0: bilateral law of the coordinate; +1: one-sided (contact for x > 1)."""
        return 0

    def force(self, x):
        x = np.asarray(x, dtype=float)
        if self._law_side():
            return one_sided_force(x, self.stiffness, self.eta)
        return regularized_contact_force(x, self._params)

    def force_and_potential(self, x):
        x = np.asarray(x, dtype=float)
        if self._law_side():
            return one_sided_force(x, self.stiffness, self.eta), one_sided_potential(x[0], self.stiffness, self.eta)
        f, p = regularized_force_and_potential(x[0], self._params)
        return f[None], p

    def potential(self, x):
        x = np.asarray(x, dtype=float)
        if self._law_side():
            return one_sided_potential(x[0], self.stiffness, self.eta)
        return regularized_contact_potential(x[0], self._params)

    def jacobian(self, x):
        x = np.asarray(x, dtype=float)
        if self._law_side():
            return one_sided_stiffness(x, self.stiffness, self.eta)[None]
        return regularized_contact_stiffness(x, self._params)[None]

    def impacts(self, x) -> int:
        x = np.asarray(x, dtype=float).reshape(-1)
        return _entries(x > 1.0) if self._law_side() else _bilateral_impacts(x)

    def normal_force(self, x):
        f = self.force(x)[0]
        return f if self._law_side() else np.abs(f)

    def penetration(self, x):
        x = np.asarray(x, dtype=float)[0]
        return x - 1.0 if self._law_side() else np.abs(x) - 1.0

    def penetration_rate(self, x, xdot):
        x, xdot = np.asarray(x, dtype=float)[0], np.asarray(xdot, dtype=float)[0]
        return xdot if self._law_side() else np.sign(x) * xdot

    @property
    def odd(self) -> bool:
        return not self._law_side()

    @property
    def recast(self) -> Recast:
        if self._law_side():
            return Recast("linear_gap", 1.0 - 2.0 * self.eta / self.stiffness)
        return Recast("squared_gap", -1.0)

    def contacts(self, stop: int = -1) -> tuple:
        (terms,) = self.coordinate_terms
        sides = (1,) if self._law_side() else (1, -1)
        out = []
        for side in sides:
            normal = tuple((dof, side * sign) for dof, sign in terms)
            out.append(Contact(normal, self.gap, self.stiffness, stop, side * self._physical_side()))
        return tuple(out)

    def _physical_side(self) -> int:
        return 1

    def piecewise_force(self, c):
        c = np.asarray(c, dtype=float)
        s = self._physical_side()
        if self._law_side():  # (+ 0.0: no negative zeros out of the gap)
            return s * self.stiffness * np.maximum(s * c - self.gap, 0.0) + 0.0
        return self.stiffness * np.sign(c) * np.maximum(np.abs(c) - self.gap, 0.0)

    def piecewise_potential(self, c):
        c = np.asarray(c, dtype=float)
        if self._law_side():
            return 0.5 * self.stiffness * np.maximum(self._physical_side() * c - self.gap, 0.0) ** 2
        return 0.5 * self.stiffness * np.maximum(np.abs(c) - self.gap, 0.0) ** 2


@dataclass(frozen=True)
class BilateralStop(_ScalarLaw):
    """The paper's bilateral elastic stop on one degree of freedom.

    The piecewise-linear force is ``stiffness (q - sgn(q) gap)`` for ``|q| > gap`` and 0 inside the gap (Eq. 4
    with a gap that need not be 1); the regularized law is Eq. (5) with the sign slip corrected, in the scaled
    coordinate ``x = q / gap`` (:func:`nnmstop.models.two_dof.regularized_contact_force`).

    Parameters
    ----------
    dof : int
        Index of the degree of freedom ``q`` that meets the stop (>= 0).
    gap : float
        Clearance (> 0).
    stiffness : float
        Stop stiffness ``alpha`` (> 0).
    eta : float
        Regularization: the slope of the regularized force at rest, ``0 < eta < stiffness``.
    kind : str
        ``"bilateral"``.

    Examples
    --------
    >>> stop = BilateralStop(dof=0, gap=0.5, stiffness=10.0, eta=0.1)
    >>> stop.piecewise_force([0.25, 1.0, -1.0]).tolist()
    [0.0, 5.0, -5.0]
    """

    dof: int
    gap: float
    stiffness: float
    eta: float
    kind: str = "bilateral"

    KIND: ClassVar[str] = "bilateral"
    REQUIRED: ClassVar[tuple] = ("dof", "gap", "stiffness", "eta")

    def __post_init__(self):
        self._check_kind()
        if isinstance(self.dof, bool) or not isinstance(self.dof, (int, np.integer)):
            raise TypeError(f"stop dof must be an integer, got {self.dof!r}")
        if self.dof < 0:
            raise ValueError(f"stop dof must be >= 0, got {self.dof!r}")
        object.__setattr__(self, "dof", int(self.dof))
        self._check_law()

    @property
    def dofs(self) -> tuple:
        """The degrees of freedom the stop reads: ``(dof,)``."""
        return (self.dof,)

    @property
    def coordinate_terms(self) -> tuple:
        return (((self.dof, 1.0),),)

    @property
    def label(self) -> str:
        return f"bilateral stop on q{self.dof}"


@dataclass(frozen=True)
class OneSidedStop(_ScalarLaw):
    """A stop on one side of one degree of freedom: contact where ``q > gap`` (positive) or ``q < -gap`` (negative).

    The piecewise-linear force is ``alpha (q - gap)`` for ``q > gap`` (positive side; ``alpha (q + gap)`` for
    ``q < -gap`` on the negative side), 0 elsewhere. Regularized in its own coordinate ``x = +-q / gap`` (contact
    for ``x > 1``) by the hyperbola ``f - eta x + kappa f (f / alpha - x) = 0``, ``kappa = 1 - 2 eta / alpha``
    (:func:`one_sided_force`): ``f ~ eta x`` near rest, ``f -> -eta / kappa`` far from the stop and
    ``f ~ alpha (x - 1) - eta / kappa`` in contact. Unequal gaps are two one-sided stops on one DOF.

    Parameters
    ----------
    dof : int
    side : {"positive", "negative"}
    gap, stiffness : float
        ``> 0``.
    eta : float
        ``0 < eta < stiffness / 2``.
    kind : str
        ``"one_sided"``.

    Examples
    --------
    >>> stop = OneSidedStop(dof=0, side="negative", gap=1.0, stiffness=10.0, eta=0.1)
    >>> stop.piecewise_force([-3.0, 0.5, 3.0]).tolist()
    [-20.0, 0.0, 0.0]
    """

    dof: int
    side: str
    gap: float
    stiffness: float
    eta: float
    kind: str = "one_sided"

    KIND: ClassVar[str] = "one_sided"
    REQUIRED: ClassVar[tuple] = ("dof", "side", "gap", "stiffness", "eta")
    _KEY_HINTS: ClassVar[dict] = {"side": " (positive or negative)"}

    def __post_init__(self):
        self._check_kind()
        object.__setattr__(self, "dof", _dof_index("stop dof", self.dof))
        if self.side not in SIDES:
            raise ValueError(f"one_sided stop side must be one of {SIDES}, got {self.side!r}")
        self._check_law(eta_bound=0.5)

    def _law_side(self) -> int:
        return 1

    def _physical_side(self) -> int:
        return 1 if self.side == "positive" else -1

    @property
    def side_sign(self) -> int:
        return self._physical_side()

    @property
    def dofs(self) -> tuple:
        return (self.dof,)

    @property
    def coordinate_terms(self) -> tuple:
        return (((self.dof, float(self._physical_side())),),)

    @property
    def label(self) -> str:
        return f"one-sided stop ({self.side} side) on q{self.dof}"


@dataclass(frozen=True)
class RelativeStop(_ScalarLaw):
    """A stop between two moving degrees of freedom: the gap closes on ``q_i - q_j``.

    The force ``F`` of the law acts as ``+F`` on ``i`` and ``-F`` on ``j``. Both sides (``side`` None: the
    bilateral law of ``(q_i - q_j) / gap``) or one: ``positive`` (contact where ``q_i - q_j > gap``) or
    ``negative`` (contact where ``q_i - q_j < -gap``), with the one-sided law.

    Parameters
    ----------
    dofs : sequence of two int
        ``[i, j]``, distinct.
    gap, stiffness, eta : float
        As for :class:`BilateralStop` (``eta < stiffness / 2`` with a side).
    side : {None, "positive", "negative"}
    kind : str
        ``"relative"``.

    Examples
    --------
    >>> stop = RelativeStop(dofs=[0, 1], gap=1.0, stiffness=10.0, eta=0.1)
    >>> stop.coordinate_matrix(3).tolist()
    [[1.0, -1.0, 0.0]]
    """

    dofs: tuple
    gap: float
    stiffness: float
    eta: float
    side: str | None = None
    kind: str = "relative"

    KIND: ClassVar[str] = "relative"
    REQUIRED: ClassVar[tuple] = ("dofs", "gap", "stiffness", "eta")

    def __post_init__(self):
        self._check_kind()
        self._check_pair()
        if self.side is not None and self.side not in SIDES:
            raise ValueError(f"relative stop side must be one of {SIDES} or absent (both sides), got {self.side!r}")
        self._check_law(eta_bound=1.0 if self.side is None else 0.5)

    def _law_side(self) -> int:
        return 0 if self.side is None else 1

    def _physical_side(self) -> int:
        return -1 if self.side == "negative" else 1

    @property
    def side_sign(self) -> int:
        return 0 if self.side is None else self._physical_side()

    @property
    def coordinate_terms(self) -> tuple:
        s = float(self._physical_side())
        return (((self.dofs[0], s), (self.dofs[1], -s)),)

    @property
    def label(self) -> str:
        sides = "" if self.side is None else f" ({self.side} side)"
        return f"relative stop{sides} on q{self.dofs[0]} - q{self.dofs[1]}"


@dataclass(frozen=True)
class CircularStop(Stop):
    """A circular clearance: two degrees of freedom ``(q_i, q_j)`` move in a hole of radius ``gap``.

    Piecewise-linear law of the radius ``r = |(q_i, q_j)|``: the radial force ``alpha (r - gap)`` beyond the
    clearance, along ``(q_i, q_j) / r``. Regularized by the bilateral law of Eq. (5) applied to the scaled
    radius (same ``eta``: the isotropic slope at rest), ``f = f_b(r) x / r``: along any diameter it is the
    bilateral stop. Its recast is the bilateral one with ``z = |f / alpha - x|**2``. It is not piecewise linear
    in the Cartesian coordinates: no exact orbits (:meth:`contacts` says so).

    Parameters
    ----------
    dofs : sequence of two int
        ``[i, j]``: the two transverse directions, distinct.
    gap : float
        Radial clearance (> 0).
    stiffness : float
        Radial stiffness ``alpha`` (> 0).
    eta : float
        ``0 < eta < stiffness``.
    kind : str
        ``"circular"``.

    Examples
    --------
    >>> hole = CircularStop(dofs=[0, 1], gap=1.0, stiffness=10.0, eta=0.1)
    >>> hole.piecewise_force([[3.0], [4.0]]).ravel().tolist()  # r = 5: radial force 40 along (3, 4) / 5
    [24.0, 32.0]
    """

    dofs: tuple
    gap: float
    stiffness: float
    eta: float
    kind: str = "circular"

    KIND: ClassVar[str] = "circular"
    REQUIRED: ClassVar[tuple] = ("dofs", "gap", "stiffness", "eta")

    def __post_init__(self):
        self._check_kind()
        self._check_pair()
        self._check_law()

    @functools.cached_property
    def _params(self) -> ModelParameters:
        return ModelParameters(alpha=self.stiffness, eta=self.eta)

    @property
    def coordinate_terms(self) -> tuple:
        return (((self.dofs[0], 1.0),), ((self.dofs[1], 1.0),))

    @property
    def label(self) -> str:
        return f"circular clearance of q{self.dofs[0]}, q{self.dofs[1]}"

    @property
    def piecewise_linear(self) -> bool:
        return False

    @property
    def recast(self) -> Recast:
        return Recast("squared_gap", -1.0, 2)

    def _radial(self, x):
        x = np.asarray(x, dtype=float)
        r = np.hypot(x[0], x[1])
        return x, r

    def force(self, x):
        x, r = self._radial(x)
        f_r = regularized_contact_force(r, self._params)
        with np.errstate(divide="ignore", invalid="ignore"):
            secant = np.where(r > 0, f_r / np.where(r > 0, r, 1.0), self.eta)
        return secant * x

    def force_and_potential(self, x):
        x, r = self._radial(x)
        f_r, p = regularized_force_and_potential(r, self._params)
        secant = np.where(r > 0, f_r / np.where(r > 0, r, 1.0), self.eta)
        return secant * x, p

    def potential(self, x):
        return regularized_contact_potential(self._radial(x)[1], self._params)

    def jacobian(self, x):
        x, r = self._radial(x)
        f_r = regularized_contact_force(r, self._params)
        k_r = regularized_contact_stiffness(r, self._params)
        positive = r > 0
        safe = np.where(positive, r, 1.0)
        secant = np.where(positive, f_r / safe, self.eta)
        n = np.where(positive, x / safe, np.array([1.0, 0.0]).reshape((2,) + (1,) * r.ndim))
        out = (k_r - secant) * n[:, None] * n[None, :]
        out[0, 0] += secant
        out[1, 1] += secant
        return out

    def impacts(self, x) -> int:
        x = np.asarray(x, dtype=float).reshape(2, -1)
        return _entries(np.hypot(x[0], x[1]) > 1.0)

    def normal_force(self, x):
        return regularized_contact_force(self._radial(x)[1], self._params)

    def penetration(self, x):
        return self._radial(x)[1] - 1.0

    def penetration_rate(self, x, xdot):
        """Radial velocity ``(x_0 xdot_0 + x_1 xdot_1) / r`` (scaled), zero at the centre."""
        x, r = self._radial(x)
        xdot = np.asarray(xdot, dtype=float)
        dot = x[0] * xdot[0] + x[1] * xdot[1]
        return np.where(r > 0, dot / np.where(r > 0, r, 1.0), 0.0)

    def sliding_velocity(self, x, xdot):
        """Circumferential velocity ``(x_0 xdot_1 - x_1 xdot_0) / r`` (scaled), zero at the centre."""
        x, r = self._radial(x)
        xdot = np.asarray(xdot, dtype=float)
        cross = x[0] * xdot[1] - x[1] * xdot[0]
        return np.where(r > 0, cross / np.where(r > 0, r, 1.0), 0.0)

    def contacts(self, stop: int = -1) -> tuple:
        raise ValueError(
            f"the {self.label} is not piecewise linear in the Cartesian coordinates (its contact is a circle): exact "
            "orbits are not available for it; use the regularized engine (harmonic balance)"
        )

    def piecewise_force(self, c):
        c = np.asarray(c, dtype=float)
        r = np.hypot(c[0], c[1])
        radial = self.stiffness * np.maximum(r - self.gap, 0.0)
        return np.where(r > 0, radial / np.where(r > 0, r, 1.0), 0.0) * c

    def piecewise_potential(self, c):
        c = np.asarray(c, dtype=float)
        return 0.5 * self.stiffness * np.maximum(np.hypot(c[0], c[1]) - self.gap, 0.0) ** 2


_CLASSES = {cls.KIND: cls for cls in (BilateralStop, OneSidedStop, RelativeStop, CircularStop)}


# --------------------------------------------------------------------------- the one-sided law


def _one_sided_root(x, alpha: float, eta: float):
    """``(f, sqrt(D))`` of the one-sided law at scaled coordinates ``x``, ``D`` its discriminant.

    ``kappa f**2 / alpha + f (1 - kappa x) - eta x = 0`` has the discriminant
    ``D = kappa**2 (x - 1)**2 + 1 - kappa**2 > 0`` and its admissible root (through the origin) is
    ``f = alpha (kappa x - 1 + sqrt(D)) / (2 kappa)``, written as ``2 eta x / (sqrt(D) + 1 - kappa x)`` where
    ``kappa x < 1`` so that neither form cancels.
    """
    x = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(x)):
        raise ValueError("x must be finite")
    eps = eta / alpha
    kappa = 1.0 - 2.0 * eps
    root = np.hypot(kappa * (x - 1.0), np.sqrt(4.0 * eps * (1.0 - eps)))
    lever = (1.0 - x) + 2.0 * eps * x  # 1 - kappa x, with 1 - x exact near the stop
    with np.errstate(divide="ignore", invalid="ignore"):
        inside = 2.0 * eta * x / (root + lever)
        beyond = alpha * (root - lever) / (2.0 * kappa)
    return np.where(lever > 0, inside, beyond), root


def one_sided_force(x, alpha: float, eta: float):
    """Regularized one-sided force at scaled coordinates ``x`` (contact for ``x > 1``).

    The root through the origin of ``f - eta x + kappa f (f / alpha - x) = 0``, ``kappa = 1 - 2 eta / alpha``
    (``0 < eta < alpha / 2``): ``f ~ eta x`` near 0, ``-> -eta / kappa`` as ``x -> -inf``,
    ``~ alpha (x - 1) - eta / kappa`` as ``x -> +inf``. Accurate to round-off for any finite ``x``.

    Examples
    --------
    >>> f = one_sided_force([-1e6, 0.0, 1e-6, 11.0], 10.0, 0.1)
    >>> [round(float(v), 6) for v in f]  # -eta / kappa far away; alpha (x - 1) - eta / kappa + O(eta / x) beyond
    [-0.102041, 0.0, 0.0, 99.908266]
    """
    return _one_sided_root(x, alpha, eta)[0]


def one_sided_stiffness(x, alpha: float, eta: float):
    """Slope ``df/dx = (eta + kappa f) / sqrt(D)`` of :func:`one_sided_force` (``eta`` at 0, ``alpha`` in contact)."""
    f, root = _one_sided_root(x, alpha, eta)
    return (eta + (1.0 - 2.0 * eta / alpha) * f) / root


def _u_minus_log1p(u):
    """``u - log(1 + u)`` for ``u > -1`` without cancellation near 0 (series below ``|u| < 0.01``)."""
    u = np.asarray(u, dtype=float)
    small = np.abs(u) < 1e-2
    series = np.zeros_like(u)
    power = u * u
    for k in range(2, 11):
        series = series + (power / k if k % 2 == 0 else -power / k)
        power = power * u
    with np.errstate(divide="ignore", invalid="ignore"):
        direct = u - np.log1p(u)
    return np.where(small, series, direct)


def one_sided_potential(x, alpha: float, eta: float):
    """Potential ``P(x) = int_0^x f`` of :func:`one_sided_force`, in closed form.

    With ``x(f) = f (1 + kappa f / alpha) / (kappa f + eta)``, ``P = f x - int_0^f x(s) ds`` and
    ``int_0^f x = f**2 / (2 alpha) + (alpha - eta) eta / (alpha kappa**2) (u - log(1 + u))``, ``u = kappa f / eta``.
    """
    x = np.asarray(x, dtype=float)
    f = one_sided_force(x, alpha, eta)
    kappa = 1.0 - 2.0 * eta / alpha
    u = kappa * f / eta
    integral = f * f / (2.0 * alpha) + (alpha - eta) * eta / (alpha * kappa * kappa) * _u_minus_log1p(u)
    return f * x - integral


# --------------------------------------------------------------------------- all the stops of a structure


class StopSet:
    """The stops of a structure as the engines see them: every component's coordinate, force and slope at once.

    Components are numbered stop after stop (a circular clearance has two). Scaled coordinates of degrees of
    freedom ``q`` (DOFs on the first axis) are :meth:`coordinates`; the generalized force of the stops' forces
    :meth:`apply`; the regularized forces, potentials and Jacobians of all stops :meth:`forces`,
    :meth:`potential`, :meth:`slopes`.

    Parameters
    ----------
    stops : sequence of Stop
    n_dofs : int

    Attributes
    ----------
    owner : ndarray of int
        Stop of each component.
    terms : list of list of (int, float)
        ``(dof, sign)`` pairs of each component.
    gaps, alphas, etas : ndarray
        Per component (the stop's values).
    first : slice per stop
        Each stop's components.
    grounded : bool
        Every component reads one DOF with sign +1 (the paper's and the bilateral stops' fast paths).
    """

    def __init__(self, stops, n_dofs: int):
        self.stops = tuple(stops)
        self.n_dofs = int(n_dofs)
        self.owner, self.terms, self.components = [], [], []
        start = 0
        for i, stop in enumerate(self.stops):
            m = stop.n_components
            self.components.append(slice(start, start + m))
            for terms in stop.coordinate_terms:
                self.owner.append(i)
                self.terms.append(list(terms))
            start += m
        self.owner = np.array(self.owner, dtype=int)
        self.n_components = start
        self.gaps = np.array([self.stops[i].gap for i in self.owner], dtype=float)
        self.alphas = np.array([self.stops[i].stiffness for i in self.owner], dtype=float)
        self.etas = np.array([self.stops[i].eta for i in self.owner], dtype=float)
        self.grounded = all(len(t) == 1 and t[0][1] == 1.0 for t in self.terms)
        self.first_dofs = np.array([t[0][0] for t in self.terms], dtype=int)
        self.dofs = np.unique(np.concatenate([list(s.dofs) for s in self.stops])) if self.stops else np.zeros(0, int)

    def __len__(self) -> int:
        return len(self.stops)

    @property
    def odd(self) -> bool:
        """Every law odd: the half-wave symmetric orbits form an invariant subspace."""
        return all(s.odd for s in self.stops)

    def contacts(self) -> tuple:
        """Every half-space contact of every stop (:meth:`Stop.contacts`), stop after stop, each tagged with its stop's
        index: the phases of the exact engines. Raises ValueError for a law that is not piecewise linear (the circular
        clearance)."""
        return tuple(c for i, stop in enumerate(self.stops) for c in stop.contacts(i))

    def matrix(self) -> np.ndarray:
        """``A`` of every component (rows, ``(n_components, n_dofs)``), physical coordinates ``c = A q``."""
        return np.vstack([s.coordinate_matrix(self.n_dofs) for s in self.stops])

    def scaled_matrix(self) -> np.ndarray:
        """``A / gap`` of every component: the scaled coordinates ``x = (A / gap) q``."""
        return self.matrix() / self.gaps[:, None]

    def coordinates(self, Q) -> np.ndarray:
        """Scaled coordinates ``x_c`` of every component from ``Q`` (DOFs on the first axis), ``(n_components, ...)``.

        ``q_d / gap`` for a component that reads one DOF with sign +1 (as the paper's engines always computed it);
        ``(sum sign q_d) / gap`` otherwise.
        """
        Q = np.asarray(Q)
        if self.grounded:
            return Q[self.first_dofs] / self.gaps.reshape((-1,) + (1,) * (Q.ndim - 1))
        out = []
        for terms in self.terms:
            (dof, sign), rest = terms[0], terms[1:]
            c = Q[dof] if sign == 1 else sign * Q[dof]
            for dof, sign in rest:
                c = c + sign * Q[dof]
            out.append(c)
        return np.stack(out) / self.gaps.reshape((-1,) + (1,) * (Q.ndim - 1))

    def apply(self, out, F) -> None:
        """Add the generalized forces ``gap_c A_c^T F_c`` of component forces ``F`` (``(n_components, ...)``) to ``out``
        (DOFs on the first axis), in place."""
        F = np.asarray(F)
        scaled = self.gaps.reshape((-1,) + (1,) * (F.ndim - 1)) * F
        if self.grounded and len(np.unique(self.first_dofs)) == len(self.first_dofs):
            out[self.first_dofs] += scaled
            return
        for c, terms in enumerate(self.terms):
            for dof, sign in terms:
                out[dof] += scaled[c] if sign == 1 else sign * scaled[c]

    def forces(self, x) -> np.ndarray:
        """Regularized force of every component at scaled coordinates ``x`` (``(n_components, ...)``)."""
        x = np.asarray(x, dtype=float)
        return np.concatenate([s.force(x[sl]) for s, sl in zip(self.stops, self.components)])

    def forces_and_potentials(self, x):
        """Forces (``(n_components, ...)``) and each stop's potential (``(n_stops, ...)``, scaled: times ``gap**2``
        for the structure's energy) at scaled coordinates ``x``."""
        x = np.asarray(x, dtype=float)
        parts = [s.force_and_potential(x[sl]) for s, sl in zip(self.stops, self.components)]
        return np.concatenate([p[0] for p in parts]), np.stack([p[1] for p in parts])

    def potential(self, x) -> np.ndarray:
        """Energy of all the stops, ``sum_s gap_s**2 P_s(x_s)``, at scaled coordinates ``x``."""
        total = 0.0
        for s, sl in zip(self.stops, self.components):
            total = total + s.gap**2 * s.potential(np.asarray(x, dtype=float)[sl])
        return total

    def slopes(self, x) -> list:
        """Per stop, the Jacobian ``df/dx`` of its law (``(m, m, ...)``) at scaled coordinates ``x``."""
        x = np.asarray(x, dtype=float)
        return [s.jacobian(x[sl]) for s, sl in zip(self.stops, self.components)]

    def pairs(self) -> list:
        """``(stop, a, b)`` component pairs of every stop's Jacobian: ``(c, c)`` for a one-component law, all four
        for the circular clearance (global component indices)."""
        out = []
        for i, sl in enumerate(self.components):
            comps = range(sl.start, sl.stop)
            out += [(i, a, b) for a in comps for b in comps]
        return out

    def pair_slopes(self, x) -> np.ndarray:
        """The entries of :meth:`slopes` in the order of :meth:`pairs`, ``(n_pairs, ...)``."""
        slopes = self.slopes(x)
        out = []
        for i, a, b in self.pairs():
            start = self.components[i].start
            out.append(slopes[i][a - start, b - start])
        return np.stack(out)

    def impacts(self, x) -> list:
        """Entries into contact of every stop over periodic samples of the scaled coordinates ``x``
        (``(n_components, samples)``)."""
        x = np.asarray(x, dtype=float)
        return [s.impacts(x[sl]) for s, sl in zip(self.stops, self.components)]

    def stiffness_matrix(self, values) -> np.ndarray:
        """``sum_s k_s A_s^T A_s`` for one isotropic stiffness ``k_s`` per stop, dense ``(n_dofs, n_dofs)``."""
        out = np.zeros((self.n_dofs, self.n_dofs))
        for s, k in zip(self.stops, values):
            A = s.coordinate_matrix(self.n_dofs)
            out += k * (A.T @ A)
        return out

    def limit_entries(self, values):
        """``(rows, cols, values)`` of ``sum_s k_s A_s^T A_s`` (duplicates to be summed), for sparse assembly."""
        rows, cols, vals = [], [], []
        for s, k in zip(self.stops, values):
            for terms in s.coordinate_terms:
                for d1, s1 in terms:
                    for d2, s2 in terms:
                        rows.append(d1)
                        cols.append(d2)
                        vals.append(k if s1 * s2 == 1 else -k)
        return vals, rows, cols
