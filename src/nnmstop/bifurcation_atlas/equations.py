r"""Periodic-orbit equations ``G(x; Omega, F, p) = 0`` of a forced response, as the atlas augments them.

Whatever formulation computes a family of periodic responses, the atlas needs from it the same few things
(:class:`OrbitEquations`): the residual of its ``n`` equations in its state ``x`` (``n`` unknowns, the
parameters held), its Jacobian in the state and in the three parameters ``(Omega, F, p)``, the map whose
eigenvalues are the Floquet multipliers (the monodromy, or the half-period map of the symmetric responses)
with the derivatives of that map, the validity margins of the formulation's assumptions and the orbit of a
state. Two formulations provide them, on the public functions of the forced path as they are:

* :class:`ExactContactEquations`: the exact responses of a piecewise-linear stop with one contact phase per
  period (:class:`nnmstop.exact.forced.ForcedResponseProblem` with the sequence ``[{contact}, {}]``:
  ``x = [z0, theta0, d0]``, ``n = 2N + 2``), any stop: one-sided, unequal gaps (two one-sided stops), relative;
  its analytic Jacobian; ``G`` is affine in ``F`` (each phase's particular solution is proportional to the
  force), so ``dG/dF`` and ``G`` at any ``F`` follow exactly from two forced problems; the map is the monodromy
  ``exp(A_F t_F) exp(A_R t_R)`` over the full period, or, where the half-wave reduction applies (odd laws,
  mirror contacts), the half-period map ``N = -exp(A_F t_F) exp(A_R t_R)``; it depends on ``(d0, Omega)`` only
  and its derivatives are analytic (``d exp(A t)/dt = A exp(A t)``); the structural parameter enters by central
  differences. :class:`ExactSymmetricEquations` is its half-wave form for bilateral stops
  (:class:`nnmstop.exact.forced.SymmetricContactProblem`, the paper's responses), and :func:`exact_equations`
  picks the formulation of a structure;
* :class:`HarmonicBalanceEquations`: the regularized responses by harmonic balance
  (:class:`nnmstop.hbm.forced.ForcedHarmonicBalanceSystem`: ``x`` the unknowns without ``Omega``), its
  Jacobian (the Hill matrix at zero Floquet exponent); the residual is affine in ``F`` (the force enters the
  first cosine coefficients); the monodromy of the damped variational equation by Magnus steps
  (:class:`nnmstop.hbm.forced.ForcedLinearization`), which depends on the state only through the stop
  coordinates' Fourier coefficients and ``Omega``: its derivatives by central differences in those
  directions only.

A later formulation (other contact laws, several contact phases per period) joins by providing the same
methods. The circular clearance is not piecewise linear: no exact formulation (ValueError naming it).
Method note: ``docs/methods/atlas.md``.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from nnmstop.bifurcation_atlas.parameters import check_structural, parameter_value, with_parameters
from nnmstop.exact.forced import (
    ForcedResponseProblem,
    StruckStop,
    SymmetricContactProblem,
    mirror_contacts,
    structure_contacts,
)
from nnmstop.exact.grazing import MarginChecks
from nnmstop.models.excitation import Excitation

__all__ = [
    "OrbitEquations",
    "Margins",
    "ExactContactEquations",
    "ExactSymmetricEquations",
    "exact_equations",
    "half_wave_applies",
    "contact_entered",
    "HarmonicBalanceEquations",
    "fourier_orbit",
    "harmonic_orbit",
    "ORBIT_HARMONICS",
]

#: Relative step of the central differences in a structural parameter.
PARAMETER_STEP = 1e-6
#: Harmonics of the orbit stored at each atlas point (x and u, cosine and sine): the exact orbits are C^2 with a
#: jump of the third derivative at each switch, so their coefficients fall as k^-4; a plot needs no more.
ORBIT_HARMONICS = 24


class Margins(MarginChecks):
    """Validity margins (each > 0 while its assumption holds), with ``valid``, ``violated`` and ``margins``
    (:class:`~nnmstop.exact.grazing.MarginChecks` over a dict of floats)."""

    def __init__(self, margins: dict):
        self.margins = {key: float(value) for key, value in margins.items()}


class _Cache(OrderedDict):
    """A small least-recently-used cache of objects built from a key."""

    def __init__(self, build, size: int = 8):
        super().__init__()
        self.build, self.size = build, size

    def get(self, key):
        if key in self:
            self.move_to_end(key)
            return self[key]
        value = self[key] = self.build(key)
        if len(self) > self.size:
            self.popitem(last=False)
        return value


class OrbitEquations:
    """The interface the atlas augments (see the module docstring); parameters ``params = [Omega, F, p]``.

    Attributes
    ----------
    n : int
        Size of the state and number of equations.
    half_period : bool
        Whether :meth:`monodromy` is the half-period map of a symmetric response (multipliers ``nu**2``).
    law : str
        ``"piecewise_linear"`` or ``"regularized"``.
    parameter : str or None
        The structural parameter ``p`` (:data:`nnmstop.bifurcation_atlas.parameters.STRUCTURAL`); None: ``p`` is unused.
    """

    n: int
    half_period: bool
    law: str
    parameter: str | None

    def residual(self, x, params) -> np.ndarray:
        raise NotImplementedError

    def jacobian(self, x, params) -> np.ndarray:
        """``[G_x | G_Omega, G_F, G_p]``, shape ``(n, n + 3)``."""
        raise NotImplementedError

    def monodromy(self, x, params) -> np.ndarray:
        raise NotImplementedError

    def monodromy_derivatives(self, x, params):
        """``(indices, d_state, d_params)``: the state indices on which the map depends, its derivatives along
        them ``(k, m, m)`` and along the parameters ``(3, m, m)``."""
        raise NotImplementedError

    def assess(self, x, params) -> Margins:
        raise NotImplementedError

    def excitation_at(self, params) -> Excitation:
        raise NotImplementedError


def _state_split(y):
    return np.asarray(y[:-1], dtype=float), float(y[-1])


def half_wave_applies(structure) -> bool:
    """Whether the one-contact responses of ``structure`` are the half-wave symmetric ones: every law odd and every
    contact with its mirror image (bilateral stops, relative stops on both sides), as
    :func:`nnmstop.exact.forced.grazing_problem` decides for the forced responses."""
    return bool(structure.contact.odd and mirror_contacts(structure_contacts(structure)) is not None)


def exact_equations(excitation: Excitation, parameter: str | None = None, contact: int | None = None):
    """The exact formulation of the responses with one contact phase per period (or half period) of ``contact``
    (index into :func:`~nnmstop.exact.forced.structure_contacts`; None: the first contact of the first stop).

    Bilateral stops only: :class:`ExactSymmetricEquations` of the contact's stop (the half-period map);
    otherwise :class:`ExactContactEquations`, half-wave where :func:`half_wave_applies` (relative stops on both
    sides), else over the full period (one-sided stops, unequal gaps, one-sided relative stops, any mix).

    Raises
    ------
    ValueError
        For a structure with a stop that is not piecewise linear (the circular clearance), naming it.
    """
    structure = excitation.structure
    contacts = structure_contacts(structure)
    contact = next(i for i, c in enumerate(contacts) if c.stop == 0) if contact is None else int(contact)
    if not 0 <= contact < len(contacts):
        raise ValueError(f"contact must index one of the structure's {len(contacts)} contacts, got {contact!r}")
    if all(s.kind == "bilateral" for s in structure.stops):
        if contacts[contact].side != 1:
            raise ValueError(
                "the symmetric responses of a bilateral stop are written from their entry on its positive side, not "
                f"from contact {contact} (its negative side)"
            )
        return ExactSymmetricEquations(excitation, parameter, contacts[contact].stop)
    return ExactContactEquations(excitation, parameter, contact, half_wave_applies(structure))


def contact_entered(excitation: Excitation, y) -> int:
    """The contact a state ``y = [z0, theta0, d0, ...]`` of a one-contact formulation enters at ``z0``: the one
    whose coordinate is at its gap there (``n . q0 = g``; a state of a solution is at round-off of it)."""
    contacts = structure_contacts(excitation.structure)
    n = excitation.structure.n_dofs
    q0 = np.asarray(y, dtype=float)[:n]
    misfit = [abs(c.normal(n) @ q0 - c.gap) / c.gap for c in contacts]
    best = int(np.argmin(misfit))
    if not misfit[best] <= 1e-6:
        raise ValueError(
            f"the state enters no contact of the structure (its nearest, contact {best}, is {misfit[best]:.3g} of its "
            "gap away): not a state of a one-contact response"
        )
    return best


class ExactContactEquations(OrbitEquations):
    """The exact responses with one contact phase per period of one contact, any piecewise-linear stop:
    :class:`~nnmstop.exact.forced.ForcedResponseProblem` with the sequence ``[{contact}, {}]``.

    ``x = [z0, theta0, d0]`` (``n = 2N + 2``): the state entering the contact, its phase and the contact's phase
    duration, as for the symmetric responses. Over the full period (``half_wave`` False: one-sided stops, unequal
    gaps, one-sided relative stops) the map is the monodromy ``exp(A_F t_F) exp(A_R t_R)``,
    ``t_F = (2 pi - d0) / Omega``; with ``half_wave`` (odd laws, mirror contacts: a relative stop on both sides)
    it is the half-period map ``-exp(A_F t_F) exp(A_R t_R)``, ``t_F = (pi - d0) / Omega``. ``G`` is affine in
    ``F`` (each phase's particular solution is proportional to the force), the Jacobian analytic in ``x`` and
    ``Omega``; the structural parameter (of the first stop) enters by central differences.

    Parameters
    ----------
    excitation : Excitation
        Structure, damping and force pattern; its force amplitude is the reference of the affine dependence.
    parameter : str, optional
        The structural parameter ``p`` of the atlas.
    contact : int
        The struck contact (index into :func:`~nnmstop.exact.forced.structure_contacts`).
    half_wave : bool

    Examples
    --------
    A one-sided stop on the first mass of a 2-DOF chain: full period, its grazing orbit a solution.

    >>> import numpy as np
    >>> from nnmstop.models.contact import Stop
    >>> from nnmstop.models.structure import Structure
    >>> from nnmstop.models.excitation import Damping, Excitation, HarmonicForce
    >>> from nnmstop.exact.forced import grazing_frequencies, grazing_problem
    >>> stop = Stop(kind="one_sided", dof=0, side="positive", gap=1.0, stiffness=20.0, eta=0.05)
    >>> chain = Structure(np.eye(2), [[2.0, -1.0], [-1.0, 2.0]], [stop])
    >>> excitation = Excitation(chain, Damping.from_modal_ratios(chain, [0.02, 0.02]), HarmonicForce(0.2, [0]))
    >>> equations = exact_equations(excitation)
    >>> type(equations).__name__, equations.half_period, equations.n
    ('ExactContactEquations', False, 6)
    >>> omega = grazing_frequencies(excitation, 0.6, 1.2)[0]
    >>> y = grazing_problem(excitation, omega)[1]
    >>> bool(np.abs(equations.residual(y[:-1], (omega, 0.2, 0.0))).max() < 1e-13)
    True
    """

    law = "piecewise_linear"

    def __init__(self, excitation: Excitation, parameter: str | None = None, contact: int = 0, half_wave=False):
        self.excitation = excitation
        self.parameter = check_structural(parameter)
        self.p0 = parameter_value(excitation, parameter) if parameter else 0.0
        self.force0 = float(excitation.force.amplitude)
        self.n = 2 * excitation.structure.n_dofs + 2
        self.contact = int(contact)
        self.half_period = bool(half_wave)
        self.span = np.pi if self.half_period else 2 * np.pi
        self._pairs = _Cache(self._build_pair)
        self._problems = _Cache(lambda key: self._problem_of(self.excitation_at((1.0,) + key)))

    def _problem_of(self, excitation: Excitation):
        return ForcedResponseProblem(excitation, [{self.contact}, set()], half_wave=self.half_period)

    def excitation_at(self, params) -> Excitation:
        _, force, p = params
        return with_parameters(self.excitation, force, self.parameter, p if self.parameter else None)

    def _build_pair(self, p):
        return tuple(self._problem_of(self.excitation_at((1.0, f, p))) for f in (self.force0, 2 * self.force0))

    def problem(self, params):
        """The forced problem at ``(F, p)`` (for validity, multipliers and orbits)."""
        return self._problems.get((float(params[1]), float(params[2])))

    def _affine(self, x, params, what):
        """``what(problem, y)`` at ``F`` from the problems at ``F0`` and ``2 F0`` (exact: affine in ``F``), and its
        ``F`` derivative."""
        omega, force, p = (float(v) for v in params)
        y = np.append(np.asarray(x, dtype=float), omega)
        one, two = (what(problem, y) for problem in self._pairs.get(p))
        slope = (two - one) / self.force0
        return one + (force - self.force0) * slope, slope

    def residual(self, x, params) -> np.ndarray:
        return self._affine(x, params, lambda problem, y: problem.residual(y))[0]

    def jacobian(self, x, params) -> np.ndarray:
        J, _ = self._affine(x, params, lambda problem, y: problem.jacobian(y))
        _, d_force = self._affine(x, params, lambda problem, y: problem.residual(y))
        d_p = np.zeros(self.n)
        if self.parameter:
            h = PARAMETER_STEP * abs(params[2])
            up, down = (self.residual(x, (params[0], params[1], params[2] + s)) for s in (h, -h))
            d_p = (up - down) / (2 * h)
        return np.column_stack([J, d_force, d_p])

    def monodromy(self, x, params) -> np.ndarray:
        y = np.append(np.asarray(x, dtype=float), float(params[0]))
        return self._pairs.get(float(params[2]))[0].period_map(y)

    def monodromy_derivatives(self, x, params):
        """The map ``S exp(A_F t_F) exp(A_R t_R)`` (``S = -1`` for the half-period map) depends on ``d0`` and
        ``Omega`` (analytic: ``d exp(A t)/dt = A exp(A t)``) and on ``p`` (central differences)."""
        delta, omega = float(x[-1]), float(params[0])
        problem = self._pairs.get(float(params[2]))[0]
        contact, free = problem.phase_list
        t_free, t_contact = (self.span - delta) / omega, delta / omega
        E_F, E_R = free.exponential(t_free), contact.exponential(t_contact)
        AFER = free.A @ E_F @ E_R
        EFAR = E_F @ contact.A @ E_R
        d_delta = (AFER - EFAR) / omega
        d_omega = (t_free * AFER + t_contact * EFAR) / omega
        if not self.half_period:  # the monodromy without the half-period map's sign
            d_delta, d_omega = -d_delta, -d_omega
        d_p = np.zeros_like(d_delta)
        if self.parameter:
            h = PARAMETER_STEP * abs(params[2])
            up, down = (self.monodromy(x, (params[0], params[1], params[2] + s)) for s in (h, -h))
            d_p = (up - down) / (2 * h)
        return np.array([self.n - 1]), d_delta[None], np.array([d_omega, np.zeros_like(d_omega), d_p])

    def assess(self, x, params) -> Margins:
        y = np.append(np.asarray(x, dtype=float), float(params[0]))
        return Margins(self.problem(params).assess(y).margins)

    def amplitudes(self, x, params) -> np.ndarray:
        """``max |q_j|`` over the period of every DOF."""
        return self.problem(params).amplitudes(np.append(np.asarray(x, dtype=float), float(params[0])))

    def multipliers(self, x, params) -> np.ndarray:
        """Floquet multipliers over one period (``nu**2`` of the half-period map)."""
        nu = np.linalg.eigvals(self.monodromy(x, params))
        return nu * nu if self.half_period else nu

    def orbit(self, x, params, harmonics: int = ORBIT_HARMONICS) -> np.ndarray:
        """Fourier coefficients ``(N, 2 harmonics + 1)`` of ``q`` against the phase of the force ``Omega t``
        (``[mean, cos 1..K, sin 1..K]``)."""
        y = np.append(np.asarray(x, dtype=float), float(params[0]))
        history = self.problem(params).time_history(y, samples=8 * harmonics)
        return fourier_orbit(history["theta"], history["q"], harmonics)

    def contact_gap(self, params, contact: int | None = None) -> float:
        """The gap of ``contact`` (the struck one by default) at ``params``."""
        return float(self.problem(params).gaps[self.contact if contact is None else int(contact)])

    def stop_state(self, x, params, theta: float, phase: str, contact: int | None = None):
        """``(n . q, n . qdot)`` of the coordinate of ``contact`` (the struck one by default) at the phase ``theta``
        of the force, computed in ``phase`` ("R": the contact from ``theta0``, "F": the free flight from
        ``theta0 + d0``; closed form, any ``theta``)."""
        problem = self.problem(params)
        omega = float(params[0])
        y = np.append(np.asarray(x, dtype=float), omega)
        z1, z2, _ = problem.switch_states(y)
        theta1, delta = float(x[-2]), float(x[-1])
        start, start_phase = (z1, theta1) if phase == "R" else (z2, theta1 + delta)
        state = problem.phase_list[0 if phase == "R" else 1].states(start, start_phase, omega, theta)
        normal = problem.normals[self.contact if contact is None else int(contact)]
        n = problem.n
        return float(normal @ state[:n]), float(normal @ state[n:])

    def phase_interval(self, x, phase: str):
        """``(start, end)`` phases of the contact ("R") or of the free flight ("F") of the span."""
        theta1, delta = float(x[-2]), float(x[-1])
        return (theta1, theta1 + delta) if phase == "R" else (theta1 + delta, theta1 + self.span)


class ExactSymmetricEquations(ExactContactEquations):
    """The exact symmetric one-contact responses of a bilateral stop
    (:class:`~nnmstop.exact.forced.SymmetricContactProblem`): :class:`ExactContactEquations` with the half-wave
    reduction (the paper's responses), the struck coordinate ``q_c`` the stop's degree of freedom.

    Parameters
    ----------
    excitation : Excitation
        The structure (its stop ``stop`` is the struck one), damping and force pattern; its force amplitude is
        the reference of the affine dependence on ``F``.
    parameter : str, optional
        The structural parameter ``p`` of the atlas.
    stop : int
        The struck stop (bilateral).
    """

    def __init__(self, excitation: Excitation, parameter: str | None = None, stop: int = 0):
        self.stop = StruckStop.of(excitation, stop)
        self.stop_index = int(stop)
        contacts = structure_contacts(excitation.structure)
        right = next(i for i, c in enumerate(contacts) if c.stop == stop and c.side == 1)
        super().__init__(excitation, parameter, right, half_wave=True)

    def _problem_of(self, excitation: Excitation):
        return SymmetricContactProblem(excitation, self.stop_index)

    def penetration(self, x, params) -> float:
        """Largest penetration ``max |q_c| - gap`` of the struck stop."""
        gap = self.problem(params).stop.gap
        return float(self.amplitudes(x, params)[self.stop.dof] - gap)


def fourier_orbit(theta, q, harmonics: int) -> np.ndarray:
    """Coefficients ``[mean, cos 1..K, sin 1..K]`` (in ``theta``) of samples ``q (N, m)`` over one period of ``theta``
    (uniform samples; any start): the discrete Fourier transform, rotated so that the phase is that of ``theta``."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    m = q.shape[1]
    spectrum = np.fft.rfft(q, axis=1) / m
    k = np.arange(1, harmonics + 1)
    shifted = spectrum[:, 1 : harmonics + 1] * np.exp(-1j * k * float(theta[0]))
    return np.concatenate([spectrum[:, :1].real, 2 * shifted.real, -2 * shifted.imag], axis=1)


class HarmonicBalanceEquations(OrbitEquations):
    """The regularized responses by harmonic balance (:class:`~nnmstop.hbm.forced.ForcedHarmonicBalanceSystem`).

    The state is the unknown vector without ``Omega`` (``x = U[:-1]``). Parameters: ``excitation``, ``harmonics``
    (``H``), ``parameter`` (the structural ``p``), ``steps`` (Magnus steps of the monodromy), ``max_truncation``
    (the validity margin: the top tenth of the harmonics must carry less).
    """

    half_period = False
    law = "regularized"

    def __init__(
        self,
        excitation: Excitation,
        harmonics: int,
        parameter: str | None = None,
        steps: int = 128,
        max_truncation: float = 1e-3,
    ):
        from nnmstop.floquet import check_power_of_two

        check_power_of_two("steps", steps, 16)
        self.excitation = excitation
        self.harmonics = int(harmonics)
        self.parameter = check_structural(parameter)
        self.p0 = parameter_value(excitation, parameter) if parameter else 0.0
        self.force0 = float(excitation.force.amplitude)
        self.steps = int(steps)
        self.max_truncation = float(max_truncation)
        self._systems = _Cache(self._build)
        system = self.system((0.0, self.force0, self.p0))
        self.n = system.n_unknowns - 1
        zero = np.zeros(system.n_unknowns)
        self.d_force = (self._systems.get((2 * self.force0, self.p0))[0].residual(zero) - system.residual(zero)) / (
            self.force0
        )
        # every DOF a stop reads (both of a relative stop or a circular clearance), not only its first
        dofs = sorted({int(d) for s in excitation.structure.stops for d in s.dofs})
        self.stop_indices = np.concatenate([d * system.nc + np.arange(system.nc) for d in dofs])

    def _build(self, key):
        from nnmstop.hbm.forced import ForcedHarmonicBalanceSystem, ForcedLinearization

        force, p = key
        excitation = with_parameters(self.excitation, force, self.parameter, p if self.parameter else None)
        system = ForcedHarmonicBalanceSystem(excitation, self.harmonics, linear_algebra="dense")
        return system, ForcedLinearization(system)

    def excitation_at(self, params) -> Excitation:
        _, force, p = params
        return with_parameters(self.excitation, force, self.parameter, p if self.parameter else None)

    def system(self, params):
        """The harmonic-balance system at the reference force and ``p``."""
        return self._systems.get((self.force0, float(params[2])))[0]

    def unknowns(self, x, params) -> np.ndarray:
        return np.append(np.asarray(x, dtype=float), float(params[0]))

    def residual(self, x, params) -> np.ndarray:
        U = self.unknowns(x, params)
        return self.system(params).residual(U) + (float(params[1]) - self.force0) * self.d_force

    def jacobian(self, x, params) -> np.ndarray:
        U = self.unknowns(x, params)
        J = self.system(params).jacobian(U)
        J = J.toarray() if hasattr(J, "toarray") else np.asarray(J)
        d_p = np.zeros(self.n)
        if self.parameter:
            h = PARAMETER_STEP * abs(params[2])
            up, down = (self.residual(x, (params[0], params[1], params[2] + s)) for s in (h, -h))
            d_p = (up - down) / (2 * h)
        return np.column_stack([J, self.d_force, d_p])

    def _linearization(self, params):
        return self._systems.get((self.force0, float(params[2])))[1]

    def monodromy(self, x, params) -> np.ndarray:
        return self._linearization(params).monodromy(self.unknowns(x, params)[None], self.steps)[0]

    def monodromy_derivatives(self, x, params):
        """Central differences along the stop coordinates' coefficients, ``Omega`` and ``p``, in one batch."""
        U = self.unknowns(x, params)
        directions = list(self.stop_indices) + [len(U) - 1]
        scale = max(1.0, float(np.abs(U[self.stop_indices]).max()))
        steps = np.array([1e-6 * scale] * len(self.stop_indices) + [1e-6 * abs(U[-1])])
        batch = np.repeat(U[None], 2 * len(directions), axis=0)
        for k, (i, h) in enumerate(zip(directions, steps)):
            batch[2 * k, i] += h
            batch[2 * k + 1, i] -= h
        maps = self._linearization(params).monodromy(batch, self.steps)
        derivatives = (maps[0::2] - maps[1::2]) / (2 * steps[:, None, None])
        d_p = np.zeros_like(derivatives[0])
        if self.parameter:
            h = PARAMETER_STEP * abs(params[2])
            up, down = (self.monodromy(x, (params[0], params[1], params[2] + s)) for s in (h, -h))
            d_p = (up - down) / (2 * h)
        d_params = np.array([derivatives[-1], np.zeros_like(d_p), d_p])
        return self.stop_indices, derivatives[:-1], d_params

    def multipliers(self, x, params) -> np.ndarray:
        return np.linalg.eigvals(self.monodromy(x, params))

    def multiplier_error(self, x, params) -> float:
        """Change of the multipliers with twice the Magnus steps (their integration error)."""
        from nnmstop.floquet import match_nearest

        U = self.unknowns(x, params)[None]
        linearization = self._linearization(params)
        coarse, fine = (np.linalg.eigvals(linearization.monodromy(U, s)) for s in (self.steps, 2 * self.steps))
        return float(np.abs(fine - match_nearest(fine, coarse)).max())

    def assess(self, x, params) -> Margins:
        U = self.unknowns(x, params)
        return Margins({"truncation": self.max_truncation - self.system(params).truncation(U)})

    def amplitudes(self, x, params) -> np.ndarray:
        from nnmstop.hbm.forced import response_amplitudes

        return response_amplitudes(self.system(params), self.unknowns(x, params)[None])[0]

    def orbit(self, x, params, harmonics: int = ORBIT_HARMONICS) -> np.ndarray:
        """Fourier coefficients ``(N, 2 harmonics + 1)`` of ``q`` (``[mean, cos 1..K, sin 1..K]``)."""
        return harmonic_orbit(self.system(params), self.unknowns(x, params), harmonics)


def harmonic_orbit(system, U, harmonics: int = ORBIT_HARMONICS) -> np.ndarray:
    """Fourier coefficients ``(N, 2 harmonics + 1)`` of ``q`` (``[mean, cos 1..K, sin 1..K]``) of the
    harmonic-balance unknowns ``U`` of ``system`` (its first ``harmonics``, zero beyond its own)."""
    from nnmstop import fourier

    Q = fourier.to_full(np.asarray(U)[: system.n_dofs * system.nc].reshape(system.n_dofs, system.nc), system.H)
    K = min(harmonics, system.H)
    out = np.zeros((system.n_dofs, 2 * harmonics + 1))
    out[:, : K + 1] = Q[:, : K + 1]
    out[:, harmonics + 1 : harmonics + 1 + K] = Q[:, system.H + 1 : system.H + 1 + K]
    return out
