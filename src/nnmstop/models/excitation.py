"""Viscous damping and a harmonic force on a :class:`~nnmstop.models.structure.Structure`.

The forced, damped problem is ``M q'' + C q' + K q + sum_s e_s f_s(q_s / e_s) = F cos(Omega t) b``:
:class:`Damping` gives ``C`` (Rayleigh ``C = a M + b K`` on the linear, no-contact stiffness, from its
coefficients or from damping ratios of two linear modes), :class:`HarmonicForce` gives ``F`` and the unit
pattern ``b`` on chosen degrees of freedom, and :class:`Excitation` holds both with the structure they
apply to. :func:`linear_response` is the closed-form frequency response of the linear (no-contact)
structure, the reference the forced responses reduce to below grazing. Method notes: docs/forced.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse

from nnmstop.models.structure import Structure, normal_modes

__all__ = ["Damping", "HarmonicForce", "Excitation", "rayleigh_from_ratios", "linear_response", "modal_damping_ratios"]


def _finite(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    if not np.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return float(value)


def rayleigh_from_ratios(omega_1: float, omega_2: float, zeta_1: float, zeta_2: float) -> tuple[float, float]:
    """Rayleigh coefficients ``(a, b)`` giving damping ratio ``zeta_i`` at angular frequency ``omega_i``.

    A mode of angular frequency ``omega`` has the ratio ``zeta = (a / omega + b omega) / 2``; two modes fix both.

    Examples
    --------
    >>> a, b = rayleigh_from_ratios(1.0, 2.0, 0.01, 0.01)
    >>> round((a / 1.0 + b * 1.0) / 2, 12), round((a / 2.0 + b * 2.0) / 2, 12)
    (0.01, 0.01)
    """
    if not (omega_1 > 0 and omega_2 > 0 and omega_1 != omega_2):
        raise ValueError(f"the two angular frequencies must be distinct and > 0, got {omega_1!r} and {omega_2!r}")
    system = np.array([[1.0 / omega_1, omega_1], [1.0 / omega_2, omega_2]])
    a, b = np.linalg.solve(system, 2.0 * np.array([zeta_1, zeta_2]))
    return float(a), float(b)


@dataclass(frozen=True)
class Damping:
    """Rayleigh damping ``C = mass_coefficient M + stiffness_coefficient K`` (both >= 0, not both 0).

    Build it from its coefficients, or from the damping ratios of two linear modes with
    :meth:`from_modal_ratios`; ``ratios`` then records them (for datasets).
    """

    mass_coefficient: float
    stiffness_coefficient: float
    ratios: tuple | None = None

    def __post_init__(self):
        a = _finite("damping mass_coefficient", self.mass_coefficient)
        b = _finite("damping stiffness_coefficient", self.stiffness_coefficient)
        if a < 0 or b < 0:
            raise ValueError(f"damping coefficients must be >= 0 (no negative damping), got a = {a!r}, b = {b!r}")
        if a == 0 and b == 0:
            raise ValueError("damping coefficients are both 0: a forced response needs some damping")
        object.__setattr__(self, "mass_coefficient", a)
        object.__setattr__(self, "stiffness_coefficient", b)

    @classmethod
    def from_modal_ratios(cls, structure: Structure, ratios, modes=(1, 2)) -> Damping:
        """Rayleigh damping with ``ratios[i]`` on linear (no-contact) mode ``modes[i]`` (1-based), two modes.

        One mode and one ratio give mass-proportional damping, ``C = 2 zeta omega M``.
        """
        ratios = tuple(_finite("damping ratio", r) for r in np.atleast_1d(ratios))
        modes = tuple(int(m) for m in np.atleast_1d(modes))
        if any(r <= 0 for r in ratios):
            raise ValueError(f"damping ratios must be > 0 (no negative damping), got {list(ratios)}")
        if len(ratios) != len(modes) or len(modes) not in (1, 2):
            raise ValueError(f"give one damping ratio per mode, one or two modes; got ratios {ratios}, modes {modes}")
        if any(not 1 <= m <= structure.n_dofs for m in modes):
            raise ValueError(f"damping modes must lie in 1..{structure.n_dofs}, got {list(modes)}")
        omega = normal_modes(structure, max(modes))[0]
        if len(modes) == 1:
            return cls(2.0 * ratios[0] * omega[modes[0] - 1], 0.0, ratios=ratios)
        a, b = rayleigh_from_ratios(omega[modes[0] - 1], omega[modes[1] - 1], *ratios)
        if a < 0 or b < 0:
            raise ValueError(
                f"damping ratios {list(ratios)} on modes {list(modes)} need a negative Rayleigh coefficient "
                f"(a = {a:.4g}, b = {b:.4g})"
            )
        return cls(a, b, ratios=ratios)

    def matrix(self, structure: Structure):
        """``C = a M + b K`` (sparse when the structure is)."""
        return self.mass_coefficient * structure.mass + self.stiffness_coefficient * structure.stiffness

    def as_attrs(self) -> dict:
        """Dataset attributes: the Rayleigh coefficients, and the modal ratios when they defined them."""
        attrs = {
            "rayleigh_mass_coefficient": self.mass_coefficient,
            "rayleigh_stiffness_coefficient": self.stiffness_coefficient,
        }
        if self.ratios is not None:
            attrs["damping_ratio"] = np.array(self.ratios, dtype=float)
        return attrs


@dataclass(frozen=True)
class HarmonicForce:
    """The force ``amplitude cos(Omega t) b`` with ``b`` the sum of the unit vectors of ``dofs`` (times ``weights``)."""

    amplitude: float
    dofs: tuple
    weights: tuple | None = None

    def __post_init__(self):
        amplitude = _finite("forcing amplitude", self.amplitude)
        if amplitude <= 0:
            raise ValueError(f"forcing amplitude must be > 0, got {amplitude!r}")
        dofs = tuple(np.atleast_1d(self.dofs).tolist())
        if not dofs or any(isinstance(d, bool) or not isinstance(d, int) or d < 0 for d in dofs):
            raise ValueError(f"forcing dofs must be a non-empty list of integers >= 0, got {self.dofs!r}")
        if len(set(dofs)) != len(dofs):
            raise ValueError(f"forcing dofs must be distinct, got {list(dofs)}")
        weights = (
            (1.0,) * len(dofs) if self.weights is None else tuple(_finite("forcing weight", w) for w in self.weights)
        )
        if len(weights) != len(dofs):
            raise ValueError(f"give one forcing weight per dof, got {len(weights)} weights for {len(dofs)} dofs")
        object.__setattr__(self, "amplitude", amplitude)
        object.__setattr__(self, "dofs", dofs)
        object.__setattr__(self, "weights", weights)

    def pattern(self, n_dofs: int) -> np.ndarray:
        """The vector ``b`` (length ``n_dofs``); a dof off the model is named in the error."""
        off = [d for d in self.dofs if d >= n_dofs]
        if off:
            raise ValueError(
                f"forcing dof(s) {off} are off the model: it has {n_dofs} degrees of freedom (0..{n_dofs - 1})"
            )
        b = np.zeros(n_dofs)
        b[list(self.dofs)] = self.weights
        return b

    def with_amplitude(self, amplitude: float) -> HarmonicForce:
        return HarmonicForce(amplitude, self.dofs, self.weights)


@dataclass(frozen=True, eq=False)
class Excitation:
    """A structure with its damping and harmonic force: ``M q'' + C q' + K q + contact = F cos(Omega t) b``."""

    structure: Structure
    damping: Damping
    force: HarmonicForce

    def __post_init__(self):
        if not isinstance(self.structure, Structure):
            raise TypeError(f"structure must be a Structure, got {type(self.structure).__name__}")
        if not isinstance(self.damping, Damping) or not isinstance(self.force, HarmonicForce):
            raise TypeError("damping must be a Damping and force a HarmonicForce")
        self.force.pattern(self.structure.n_dofs)  # checks the dofs

    @property
    def damping_matrix(self):
        return self.damping.matrix(self.structure)

    @property
    def load(self) -> np.ndarray:
        """``F b``, the amplitude of the force on each degree of freedom."""
        return self.force.amplitude * self.force.pattern(self.structure.n_dofs)

    def with_amplitude(self, amplitude: float) -> Excitation:
        return Excitation(self.structure, self.damping, self.force.with_amplitude(amplitude))

    def as_attrs(self) -> dict:
        """Dataset attributes: forcing amplitude and dofs, damping."""
        return {
            "forcing_amplitude": self.force.amplitude,
            "forcing_dofs": np.array(self.force.dofs, dtype=np.int32),
            **self.damping.as_attrs(),
        }


def _dense(matrix) -> np.ndarray:
    return matrix.toarray() if scipy.sparse.issparse(matrix) else np.asarray(matrix, dtype=float)


def linear_response(excitation: Excitation, omega, extra_stiffness=None) -> np.ndarray:
    """Complex amplitudes ``Q`` of the steady response ``q(t) = Re(Q exp(i Omega t))`` of the linear structure.

    ``(K + extra_stiffness - Omega**2 M + i Omega C) Q = F b``, solved at each ``omega`` (rad per unit time);
    ``extra_stiffness`` (N x N) adds e.g. the regularized contact stiffness near rest. Returns shape
    ``np.shape(omega) + (N,)``.
    """
    structure = excitation.structure
    M, K = structure.dense_matrices()
    if extra_stiffness is not None:
        K = K + np.asarray(extra_stiffness, dtype=float)
    C = _dense(excitation.damping_matrix)
    omega = np.asarray(omega, dtype=float)
    flat = omega.ravel()
    out = np.array([np.linalg.solve(K - w * w * M + 1j * w * C, excitation.load.astype(complex)) for w in flat])
    return out.reshape(omega.shape + (structure.n_dofs,))


def modal_damping_ratios(excitation: Excitation, n_modes: int) -> np.ndarray:
    """Damping ratio ``phi^T C phi / (2 omega)`` of the ``n_modes`` lowest linear modes (mass-normalized ``phi``)."""
    omega, shapes = normal_modes(excitation.structure, n_modes)
    C = _dense(excitation.damping_matrix)
    return np.einsum("ij,ik,kj->j", shapes, C, shapes) / (2.0 * omega)
