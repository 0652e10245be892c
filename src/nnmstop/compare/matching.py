"""Exact (non-smooth) and regularized NNM1 orbits at the same energy (Section 4.1).

:class:`EnergyMatcher` takes the exact two-impact family (:mod:`nnmstop.exact`) and a
regularized NNM1 branch dataset (:mod:`nnmstop.hbm.dataset`) and finds, at a requested energy,
one orbit of each model at exactly that energy: Newton's method on the closed-form
quarter-period equations plus the energy, and on the HBM equations bordered with the mean
energy over the period, each seeded between the two neighbouring points of the monotone part
of its curve (:func:`exact_increasing_arm`, :func:`regularized_monotone_part`).
:func:`orbit_differences` compares a matched pair on the phase ``t/T`` aligned at the maximum of
``x``: frequencies and the largest differences of ``x``, ``u``, velocities and contact force
(:func:`largest_differences`, refined where they peak).

Method notes (the monotone parts, why the matching adds no interpolation error, the
alignment): ``docs/methods/compare.md``. The comparison dataset of Figs 2-4 is assembled by
:mod:`nnmstop.compare.dataset`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import xarray as xr
from scipy.sparse.linalg import splu

from nnmstop import fourier
from nnmstop.continuation.core import relative_residual
from nnmstop.continuation.newton import newton_solve
from nnmstop.exact.grazing import assess_orbit
from nnmstop.exact.problem import TwoImpactProblem
from nnmstop.hbm.dataset import dataset_unknowns, orbit_variables
from nnmstop.hbm.identity import ORBIT_FORCE_NAMES, content_kind, identity_label, orbit_identity, sampled_shares
from nnmstop.hbm.system import HarmonicBalanceSystem, impacts_per_period
from nnmstop.models.structure import two_dof_parameters, two_dof_structure
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force, total_energy

__all__ = [
    "MAX_IMPACTS",
    "NotComparableError",
    "OutsideRangeError",
    "EnergyMatcher",
    "MatchedOrbits",
    "comparison_gap",
    "exact_increasing_arm",
    "regularized_monotone_part",
    "system_from_dataset",
    "EnergyOperator",
    "hbm_energy",
    "regularized_orbit_on_phase",
    "largest_differences",
    "COUNTERPART_STATUS",
    "orbit_types",
    "orbit_differences",
]

#: One impact per stop per period: at most two excursions beyond the stops.
MAX_IMPACTS = 2
PARAMETER_KEYS = ("alpha", "beta", "delta", "eta")
_NEWTON_MAX_ITER = 30


class NotComparableError(ValueError):
    """The two orbits cannot be compared by this method: an expected outcome, stated with its reason.

    Unlike the other ``ValueError`` of this module (bad input, a failed solve), it says that the
    comparison does not apply, for example an orbit whose ``x`` is not positive at its turning point
    in contact, so that the phase alignment of :func:`orbit_differences` is undefined.
    """


class OutsideRangeError(NotComparableError):
    """The energy lies outside the range where both models have an orbit to compare.

    For example a regularized branch that leaves the two-impact regime before the exact family
    ends (a large ``eta``), or that ends before the family starts.
    """


# --------------------------------------------------------------------------- monotone parts


def exact_increasing_arm(exact: xr.Dataset) -> slice:
    """Points of the exact family from its energy minimum to its end (increasing energy).

    Raises
    ------
    ValueError
        If the energy is not strictly increasing on that part (a dataset this module does
        not know how to match), or the part has fewer than two points.
    """
    energy = np.asarray(exact["energy"].values, dtype=float)
    start = int(np.argmin(energy))
    arm = energy[start:]
    if arm.size < 2:
        raise ValueError(
            f"the exact family has no increasing arm: its energy minimum {energy[start]:.6g} is at its last point"
        )
    bad = np.flatnonzero(np.diff(arm) <= 0)
    if bad.size:
        k = start + int(bad[0])
        raise ValueError(
            f"the energy of the exact family is not increasing after its minimum (point {start}, "
            f"E = {energy[start]:.6g}): it decreases from point {k} (E = {energy[k]:.6g}) to point {k + 1} "
            f"(E = {energy[k + 1]:.6g})"
        )
    return slice(start, energy.size)


def regularized_monotone_part(branch: xr.Dataset) -> slice:
    """Leading points of a regularized branch with increasing energy and at most two impacts.

    The part ends before the first point whose energy does not exceed the previous one or
    that has more than :data:`MAX_IMPACTS` impacts per period.
    """
    energy = np.asarray(branch["energy"].values, dtype=float)
    impacts = np.asarray(branch["impacts_per_period"].values)
    stop = 1
    while stop < energy.size and energy[stop] > energy[stop - 1] and impacts[stop] <= MAX_IMPACTS:
        stop += 1
    if impacts[0] > MAX_IMPACTS or stop < 2:
        raise ValueError(
            "the regularized branch has fewer than two leading points with increasing energy and at "
            f"most {MAX_IMPACTS} impacts per period (energies {energy[:3]}, impacts {impacts[:3]})"
        )
    return slice(0, stop)


def _overlap(exact_energy, hbm_energy, end_margin: float):
    """Overlap of the two monotone parts, the compared range within it, and why there is none ("" if there is)."""
    lo, hi = max(exact_energy[0], hbm_energy[0]), min(exact_energy[-1], hbm_energy[-1])
    if not lo < hi:
        return (
            None,
            None,
            (
                f"the energy ranges do not overlap: exact increasing arm {exact_energy[0]:.6g}.."
                f"{exact_energy[-1]:.6g}, regularized monotone part {hbm_energy[0]:.6g}..{hbm_energy[-1]:.6g}"
            ),
        )
    compared = (float(lo * (1.0 + end_margin)), float(hi * (1.0 - end_margin)))
    if not compared[0] < compared[1]:
        return None, None, f"end_margin {end_margin!r} leaves no energy in the overlap {lo:.6g}..{hi:.6g}"
    return (float(lo), float(hi)), compared, ""


def comparison_gap(exact: xr.Dataset, branch: xr.Dataset, end_margin: float = 0.01) -> str:
    """Why the exact family and the regularized branch cannot be compared (their monotone parts share no
    energy, the regularized orbits stop before grazing, say), or "" when they can (:class:`EnergyMatcher`)."""
    exact_energy = np.asarray(exact["energy"].values[exact_increasing_arm(exact)], dtype=float)
    hbm_energy = np.asarray(branch["energy"].values[regularized_monotone_part(branch)], dtype=float)
    return _overlap(exact_energy, hbm_energy, end_margin)[2]


# --------------------------------------------------------------------------- HBM helpers


def system_from_dataset(branch: xr.Dataset) -> HarmonicBalanceSystem:
    """The HBM system a branch dataset was computed with (parameters, H, samples, basis)."""
    missing = [k for k in (*PARAMETER_KEYS, "harmonics", "time_samples", "basis") if k not in branch.attrs]
    if missing:
        raise ValueError(f"the regularized branch dataset lacks the global attribute(s) {missing}")
    params = ModelParameters(**{k: float(branch.attrs[k]) for k in PARAMETER_KEYS})
    return HarmonicBalanceSystem(
        two_dof_structure(params),
        int(branch.attrs["harmonics"]),
        time_samples=int(branch.attrs["time_samples"]),
        basis=str(branch.attrs["basis"]),
    )


def _energy_samples(system: HarmonicBalanceSystem) -> int:
    """Samples per period of the HBM energy: those of ``HarmonicBalanceSystem.diagnostics``."""
    return max(16 * system.H, 512)


class EnergyOperator:
    """Mean energy over the period of an HBM orbit and its exact gradient.

    Same samples and same formula as :meth:`HarmonicBalanceSystem.diagnostics`, so the
    matched energy is the energy stored in the branch datasets.
    """

    def __init__(self, system: HarmonicBalanceSystem):
        self.system = system
        self.m = _energy_samples(system)
        eye = np.eye(system.nc)
        self.synth = fourier.to_time(eye, system.H, self.m).T  # (m, nc): samples of each kept basis function
        self.dsynth = fourier.to_time(fourier.derivative(eye, system.H), system.H, self.m).T  # d/dtheta of each

    def __call__(self, U, gradient: bool = False):
        s, p = self.system, two_dof_parameters(self.system.structure, "the energy of a 2-DOF orbit")
        x, u, _, _, lam, _ = s.split(U)
        omega = np.sqrt(lam)
        xs, us = self.synth @ x, self.synth @ u
        xd, ud = omega * (self.dsynth @ x), omega * (self.dsynth @ u)
        energy = float(np.mean(total_energy(xs, us, xd, ud, p, model="regularized")))
        if not gradient:
            return energy
        grad = np.zeros(s.n_unknowns)
        force_x = xs + p.beta * (xs - us) + regularized_contact_force(xs, p)  # dV/dx
        grad[s.slices["x"]] = (self.synth.T @ force_x + omega * (self.dsynth.T @ xd)) / self.m
        grad[s.slices["q1"]] = (self.synth.T @ (p.beta * (us - xs)) + p.delta * omega * (self.dsynth.T @ ud)) / self.m
        grad[s.i_lam] = np.mean(0.5 * xd**2 + 0.5 * p.delta * ud**2) / lam  # kinetic energy ~ lam
        return energy, grad


def hbm_energy(system: HarmonicBalanceSystem, U) -> float:
    """Mean total energy over the period of the HBM orbit ``U`` (as in the branch datasets)."""
    return EnergyOperator(system)(U)


# --------------------------------------------------------------------------- matching


@dataclass(frozen=True)
class MatchedOrbits:
    """An exact and a regularized orbit at the same energy.

    Attributes
    ----------
    energy : float
        Requested energy.
    exact : ndarray, shape (4,)
        Exact unknowns ``(xdot0, udot0, tau1, T1)``.
    regularized : ndarray
        HBM unknown vector (layout of the branch's system).
    exact_energy, regularized_energy : float
        Energies of the two orbits as computed by each model.
    exact_residual, regularized_residual : float
        Norm of the quarter-period equations; relative residual of the HBM system.
    exact_newton_iterations, regularized_newton_iterations : int
    interpolation_coefficient_shift : float
        Largest difference between the HBM unknowns and their linear interpolation in
        energy between the neighbouring branch points.
    interpolation_frequency_shift : float
        Frequency of that interpolation minus the frequency of the matched HBM orbit (Hz).
    """

    energy: float
    exact: np.ndarray
    regularized: np.ndarray
    exact_energy: float
    regularized_energy: float
    exact_residual: float
    regularized_residual: float
    exact_newton_iterations: int
    regularized_newton_iterations: int
    interpolation_coefficient_shift: float
    interpolation_frequency_shift: float


def _bracket(energies: np.ndarray, target: float) -> tuple[int, float]:
    """Index ``i`` with ``energies[i] <= target <= energies[i+1]`` and the fraction in between."""
    i = int(np.clip(np.searchsorted(energies, target) - 1, 0, energies.size - 2))
    return i, (target - energies[i]) / (energies[i + 1] - energies[i])


def _bordered(jacobian, row):
    """``[J; row]`` for :func:`~nnmstop.continuation.newton.newton_solve`: the dense matrix, or the
    sparse LU of it when ``J`` is sparse (systems above ``DENSE_MAX_UNKNOWNS`` unknowns)."""
    if sp.issparse(jacobian):
        return splu(sp.vstack([jacobian, sp.csr_matrix(row[None, :])], format="csc"))
    return np.vstack([jacobian, row])


def _check_between(solution, points, i: int, message: str) -> None:
    """Raise ``ValueError(message)`` if ``solution`` strayed from the segment ``points[i:i+2]``.

    Newton started between two neighbouring points of a family must stay within twice
    their spacing of the first one; farther away it has jumped to another part of it.
    """
    step = np.abs(points[i + 1] - points[i]).max()
    if np.abs(solution - points[i]).max() > 2.0 * step + 1e-12:
        raise ValueError(message)


class EnergyMatcher:
    """Exact and regularized NNM1 orbits at prescribed energies (see the module docstring).

    Parameters
    ----------
    exact : xarray.Dataset
        Exact two-impact family (:func:`nnmstop.exact.dataset.two_impact_dataset`).
    branch : xarray.Dataset
        Regularized NNM1 branch or stage dataset (layout of :mod:`nnmstop.hbm.dataset`).
    end_margin : float
        Relative margin kept from both ends of the common energy range, in ``[0, 0.5)``.

    Raises
    ------
    ValueError
        If the two datasets were computed with different ``alpha``, ``beta``, ``delta``,
        if the margin is out of range, or if the energy ranges do not overlap.
    """

    def __init__(self, exact: xr.Dataset, branch: xr.Dataset, end_margin: float = 0.01):
        if not (np.isfinite(end_margin) and 0.0 <= end_margin < 0.5):
            raise ValueError(f"end_margin must be a number in [0, 0.5), got {end_margin!r}")
        for key in ("alpha", "beta", "delta"):
            if key not in exact.attrs:
                raise ValueError(f"the exact family dataset lacks the global attribute {key!r}")
            if not np.isclose(float(exact.attrs[key]), float(branch.attrs.get(key, np.nan)), rtol=1e-12, atol=0):
                raise ValueError(
                    f"{key} differs between the exact family ({exact.attrs[key]!r}) and the regularized "
                    f"branch ({branch.attrs.get(key)!r})"
                )
        self.system = system_from_dataset(branch)
        self.params = two_dof_parameters(self.system.structure, "the comparison with the exact two-impact family")
        self.problem = TwoImpactProblem(self.params)
        self._energy_op = EnergyOperator(self.system)
        self.end_margin = float(end_margin)

        arm = exact_increasing_arm(exact)
        self.exact_arm = arm
        self._exact_energy = np.asarray(exact["energy"].values[arm], dtype=float)
        quarter = np.asarray(exact["period"].values[arm], dtype=float) / 4.0
        self._exact_unknowns = np.column_stack(
            [exact["xdot0"].values[arm], exact["udot0"].values[arm], exact["free_flight_time"].values[arm], quarter]
        )

        part = regularized_monotone_part(branch)
        self.regularized_part = part
        self._hbm_energy = np.asarray(branch["energy"].values[part], dtype=float)
        self._hbm_unknowns = dataset_unknowns(branch, self.system)[part]

        self.overlap, self.energy_range, gap = _overlap(self._exact_energy, self._hbm_energy, end_margin)
        if gap:
            raise OutsideRangeError(gap)

    # ------------------------------------------------------------------ checks

    def check_energy(self, energy) -> float:
        """Return ``energy`` as a float, or raise :class:`OutsideRangeError` if outside :attr:`energy_range`."""
        try:
            value = float(energy)
        except (TypeError, ValueError):
            raise ValueError(f"energy must be a real number, got {energy!r}") from None
        lo, hi = self.energy_range
        if not (np.isfinite(value) and lo <= value <= hi):
            raise OutsideRangeError(
                f"energy {energy!r} is outside the range where exact and regularized NNM1 orbits are "
                f"compared, [{lo:.6g}, {hi:.6g}] (overlap of the exact increasing arm and the regularized "
                f"monotone part, {self.overlap[0]:.6g}..{self.overlap[1]:.6g}, less a relative end margin "
                f"of {self.end_margin:g})"
            )
        return value

    # ------------------------------------------------------------------ one side each

    def exact_orbit(self, energy) -> tuple[np.ndarray, float, int]:
        """Exact orbit at ``energy``: unknowns, residual norm, Newton iterations."""
        energy = self.check_energy(energy)
        i, w = _bracket(self._exact_energy, energy)
        y = self._exact_unknowns[i] + w * (self._exact_unknowns[i + 1] - self._exact_unknowns[i])
        prob, delta = self.problem, self.params.delta

        def system(v):  # quarter-period equations and energy, with their Jacobian
            return np.append(prob.residual(v), prob.energy(v) - energy), np.vstack(
                [prob.jacobian(v), [v[0], delta * v[1], 0.0, 0.0]]
            )

        # one more update after convergence (polish): the residual then sits at round-off
        solved = newton_solve(system, None, y, tol=1e-14, max_iter=_NEWTON_MAX_ITER, polish=True)
        if not solved.converged:
            raise ValueError(f"Newton's method did not converge for the exact orbit at energy {energy!r}")
        y, it = solved.y, solved.iterations
        check = assess_orbit(prob, y)
        if not check.valid:
            raise ValueError(
                f"the exact orbit found at energy {energy!r} violates the two-impact assumptions {check.violated}"
            )
        _check_between(
            y,
            self._exact_unknowns,
            i,
            f"Newton's method left the increasing arm of the exact family at energy {energy!r}",
        )
        return y, float(np.linalg.norm(prob.residual(y))), it

    def regularized_orbit(self, energy, tol: float = 1e-13) -> tuple[np.ndarray, float, int, np.ndarray]:
        """HBM orbit at ``energy``: unknowns, relative residual, Newton iterations, linear interpolation."""
        energy = self.check_energy(energy)
        s = self.system
        i, w = _bracket(self._hbm_energy, energy)
        lin = self._hbm_unknowns[i] + w * (self._hbm_unknowns[i + 1] - self._hbm_unknowns[i])
        scale = max(abs(energy), 1.0)

        def bordered(U):  # HBM equations and mean energy, with their Jacobian
            e, grad = self._energy_op(U, gradient=True)
            return np.append(s.residual(U), (e - energy)), _bordered(s.jacobian(U), grad)

        def converged(U, r, dU):  # small update, HBM residual and energy both at the tolerance
            return (
                dU is not None
                and np.linalg.norm(dU) <= 1e2 * tol * max(np.linalg.norm(U), 1.0)
                and relative_residual(s, U) <= tol
                and abs(r[-1]) <= tol * scale
            )

        solved = newton_solve(bordered, None, lin, tol=tol, max_iter=_NEWTON_MAX_ITER, criterion=converged)
        U, it = solved.y, solved.iterations
        if not solved.converged:
            raise ValueError(
                f"Newton's method did not converge for the regularized orbit at energy {energy!r} "
                f"(relative residual {relative_residual(s, U):.2e}); too close to an energy fold?"
            )
        _check_between(
            U,
            self._hbm_unknowns,
            i,
            f"Newton's method left the regularized branch between its points at energy {energy!r}",
        )
        return U, relative_residual(s, U), it, lin

    def match(self, energy) -> MatchedOrbits:
        """Exact and regularized orbits at ``energy`` (see the module docstring)."""
        energy = self.check_energy(energy)
        y, res_y, it_y = self.exact_orbit(energy)
        U, res_U, it_U, lin = self.regularized_orbit(energy)
        s = self.system
        return MatchedOrbits(
            energy=energy,
            exact=y,
            regularized=U,
            exact_energy=self.problem.energy(y),
            regularized_energy=float(s.diagnostics(U)["energy"]),
            exact_residual=res_y,
            regularized_residual=res_U,
            exact_newton_iterations=it_y,
            regularized_newton_iterations=it_U,
            interpolation_coefficient_shift=float(np.abs(lin - U).max()),
            interpolation_frequency_shift=float(s.frequency_hz(lin) - s.frequency_hz(U)),
        )


# --------------------------------------------------------------------------- orbit differences


def regularized_orbit_on_phase(
    system: HarmonicBalanceSystem, U, phase, shift: float | None = None, synthesis_cache: dict | None = None
):
    """HBM orbit ``U`` on ``phase = t/T``, origin on the symmetry axis where x is maximum.

    Returns the fields (``x, u, xdot, udot, f``) and the applied shift (0 or 0.5 period;
    found here unless given). ``synthesis_cache``: a dict that keeps the synthesis on these phases
    (:class:`nnmstop.fourier.PhaseSynthesis`, keyed by the phases and the shift) for the next
    orbit on the same phases, such as the comparison grid of every matched pair.
    """
    x, u, f, _, lam, _ = system.split(U)
    omega = float(np.sqrt(lam))
    series = {name: fourier.to_cos_sin(c, system.H) for name, c in (("x", x), ("u", u), ("f", f))}
    # t = 0 and t = T/2 are both symmetry axes of a cosine series; take the one in contact (the larger x)
    if shift is None:
        ends = fourier.PhaseSynthesis(np.array([0.0, np.pi]), system.H).values(*series["x"])
        shift = 0.5 if ends[1] > ends[0] else 0.0
    theta = 2.0 * np.pi * (np.asarray(phase) + shift)
    synthesis = None
    if synthesis_cache is not None:
        key = (theta.tobytes(), system.H)
        synthesis = synthesis_cache.get(key)
        if synthesis is None:
            synthesis = synthesis_cache[key] = fourier.PhaseSynthesis(theta, system.H)
    return fourier.fields_at_phases(theta, omega, series, synthesis=synthesis), shift


def largest_differences(first: dict, second: dict, first_on, second_on, keys) -> dict:
    """Largest ``|first[key] - second[key]|`` over one period, refined where it peaks.

    ``first`` and ``second`` hold the fields of two orbits on ``n`` equally spaced phases
    ``t/T = j/n``; ``first_on(phase)`` and ``second_on(phase)`` evaluate them on any phases.
    The maximum on the grid is refined on a grid 256 times finer around it: the force
    difference peaks sharply where the exact orbit enters the stop.
    """
    n = next(iter(first.values())).size
    phase = np.arange(n) / n
    out, refined = {}, {}
    for key in keys:
        diff = np.abs(first[key] - second[key])
        j = int(np.argmax(diff))
        if j not in refined:  # fields that peak at the same grid phase share the fine grid
            local = phase[j] + np.linspace(-1.0, 1.0, 513) / n
            refined[j] = (first_on(local), second_on(local))
        first_fine, second_fine = refined[j]
        fine = np.abs(first_fine[key] - second_fine[key])
        out[key] = float(max(diff[j], fine.max()))
    return out


#: Codes of ``counterpart`` in the comparison dataset: the regularized orbit at the energy of the exact one is of
#: the same type, or not (other contacts with the stop, other harmonic content) and then it is no counterpart.
COUNTERPART_STATUS = ("counterpart", "other_contacts", "other_harmonic_content")


def orbit_types(matched: MatchedOrbits, system: HarmonicBalanceSystem, samples: int = 1024) -> dict:
    """The type of each orbit of a matched pair, and whether they are alike (:data:`COUNTERPART_STATUS`).

    Type: contacts per period with the stop, dominant harmonic and tongue harmonic of the mass-weighted motion
    (:mod:`nnmstop.hbm.identity`): the regularized orbit's from its Fourier coefficients, the exact orbit's from
    ``samples`` instants of its closed-form time history. A contact of the exact orbit is an excursion beyond the
    gap, ``|x| > 1``; one of the regularized orbit an excursion into its law's contact transition,
    ``|x| > 1 - w`` with ``w = sqrt(2 eta / alpha)`` the half-width over which the regularized stiffness goes from
    ``eta`` to ``alpha`` (:meth:`nnmstop.hbm.shooting_refinement.RegularizedDynamics.width`): the regularized
    orbit that meets its smoothed stop there is the exact one's counterpart just above grazing (the paper's
    point a)), while a tongue orbit that stays in the soft part of the law is not. Orbits of different types
    are not compared.

    Returns
    -------
    dict
        ``counterpart`` (code), ``exact_impacts_per_period``, ``regularized_contacts_per_period``, ``exact_*`` and
        ``regularized_*`` ``dominant_harmonic`` and ``tongue_harmonic``, and ``why`` (words, empty for a
        counterpart).
    """
    params = two_dof_parameters(system.structure, "the comparison with the exact two-impact family")
    y = matched.exact
    history = TwoImpactProblem(params).time_history(y, 4.0 * y[3] * np.arange(samples) / samples)
    mass = np.diag([1.0, params.delta])
    dominant, tongue, kind = content_kind(sampled_shares(mass, np.column_stack([history.x, history.u])))
    exact = {"impacts_per_period": impacts_per_period(history.x), "dominant_harmonic": dominant,
             "tongue_harmonic": tongue}  # fmt: skip
    data = orbit_variables(system, np.atleast_2d(matched.regularized))
    ident = orbit_identity(system.structure, *(data[k][1] if k in data else None for k in ORBIT_FORCE_NAMES))
    reg_x = system.to_time(system.split(matched.regularized)[0], samples)  # x: the first block (stop on x)
    regularized = {
        "contacts_per_period": impacts_per_period(reg_x / (1.0 - np.sqrt(2.0 * params.eps))),
        "dominant_harmonic": int(ident["dominant_harmonic"][0]),
        "tongue_harmonic": int(ident["tongue_harmonic"][0]),
    }
    status, why = 0, ""
    if regularized["contacts_per_period"] != exact["impacts_per_period"]:
        status = 1
    elif (regularized["dominant_harmonic"], regularized["tongue_harmonic"]) != (dominant, tongue):
        status = 2
    if status:
        label = identity_label(int(ident["orbit_kind"][0]), int(ident["dominant_mode"][0]),
                               regularized["dominant_harmonic"], regularized["tongue_harmonic"])  # fmt: skip
        exact_label = identity_label(kind, 1, dominant, tongue)
        why = (
            f"no counterpart at E = {matched.energy:.4g}: the regularized orbit is {label} with "
            f"{regularized['contacts_per_period']} contacts per period, the exact one {exact_label} with "
            f"{exact['impacts_per_period']}"
        )
    out = {"counterpart": status, "why": why}
    out.update({f"exact_{k}": v for k, v in exact.items()})
    out.update({f"regularized_{k}": v for k, v in regularized.items()})
    return out


def orbit_differences(
    matched: MatchedOrbits,
    system: HarmonicBalanceSystem,
    phase_samples: int = 4096,
    synthesis_cache: dict | None = None,
) -> dict:
    """Frequency and largest orbit differences of a matched pair (see the module docstring).

    Parameters
    ----------
    matched : MatchedOrbits
    system : HarmonicBalanceSystem
        The system of the regularized orbit (``EnergyMatcher.system``).
    phase_samples : int
        Equally spaced phases ``t/T`` per period (>= 64).
    synthesis_cache : dict, optional
        Keeps the synthesis of the regularized orbits on those phases from one matched pair to the next
        (:func:`regularized_orbit_on_phase`); the same numbers, computed once per comparison.

    Returns
    -------
    dict
        Scalars: frequencies, differences, amplitudes, origin shift and checks.
    """
    if int(phase_samples) != phase_samples or phase_samples < 64:
        raise ValueError(f"phase_samples must be an integer >= 64, got {phase_samples!r}")
    params = two_dof_parameters(system.structure, "the comparison with the exact two-impact family")
    y = matched.exact
    n = int(phase_samples)
    period_exact = 4.0 * y[3]

    def exact_on(phase):  # origin at the turning point T1
        h = TwoImpactProblem(params).time_history(y, y[3] + phase * period_exact)
        return {"x": h.x, "u": h.u, "xdot": h.xdot, "udot": h.udot, "force": h.force}

    phase = np.arange(n) / n
    ex = exact_on(phase)

    def regularized_on(phase, shift=None, cache=None):
        fields, shift = regularized_orbit_on_phase(system, matched.regularized, phase, shift, cache)
        fields["force"] = fields.pop("f")
        return fields, shift

    reg, shift = regularized_on(phase, cache=synthesis_cache)
    frequency_exact = 1.0 / period_exact
    frequency_reg = float(system.frequency_hz(matched.regularized))
    # the origin is the turning point in contact on both orbits: x there is positive (the larger of the two
    # symmetry axes of the cosine series; the exact quarter period ends in contact). It is the maximum of x
    # for the paper's parameters, not for every structure (a secondary oscillation of x may rise above it)
    for name, xs in (("exact", ex["x"]), ("regularized", reg["x"])):
        if not xs[0] > 0:
            raise NotComparableError(
                f"the {name} orbit at energy {matched.energy!r} has x = {xs[0]:.6g} <= 0 at its turning point in "
                "contact; the phase alignment does not apply"
            )
    out = {
        "frequency_exact": frequency_exact,
        "frequency_regularized": frequency_reg,
        "frequency_difference": frequency_reg - frequency_exact,
        "relative_frequency_difference": (frequency_reg - frequency_exact) / frequency_exact,
        "regularized_origin_shift": shift,
        "x_max_exact": float(ex["x"].max()),
        "u_max_exact": float(np.abs(ex["u"]).max()),
        "force_max_exact": float(np.abs(ex["force"]).max()),
    }
    largest = largest_differences(
        reg, ex, lambda local: regularized_on(local, shift)[0], exact_on, ("x", "u", "xdot", "udot", "force")
    )
    out.update({f"max_{key}_difference": value for key, value in largest.items()})
    return out
