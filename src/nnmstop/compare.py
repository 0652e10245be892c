"""Exact (non-smooth) versus regularized NNM1 at matched energies: Section 4.1, Figs 2-4.

What is compared
----------------
On one side the exact two-impact NNM1 family of the non-smooth system, Eqs. (3)-(4)
(:mod:`nnmstop.exact`, closed form); on the other the regularized NNM1 of Eq. (7)
computed by harmonic balance with ``H`` harmonics and the ANM (stage 1 of the branch,
:mod:`nnmstop.branches`: from the linear mode up to the first orbit with more than
one impact per stop). At each compared energy ``E`` the module finds one orbit of each
model **at exactly that energy** and records

* the frequencies ``1/T`` (Hz of the nondimensional time) and their difference,
  absolute (regularized minus exact) and relative to the exact frequency;
* the largest differences over one period of ``x``, ``u``, ``xdot``, ``udot`` and of the
  contact force: the HBM force ``f`` (the Fourier series of the unknown ``f`` of the
  quadratic recast, Eq. 13) against the piecewise-linear law, Eq. (4), evaluated on the
  exact orbit, ``alpha (x - sgn x)`` beyond the stops;
* the orbits themselves (exact unknowns ``(xdot0, udot0, tau1, T1)`` and the HBM
  Fourier coefficients), so that Figs 2-4 redraw them without solving anything.

Energies
--------
The energy is the conserved total energy of each model (kinetic + spring potentials +
contact potential; the piecewise potential ``alpha/2 (|x|-1)^2`` for the exact orbit, the
potential of the regularized force for the HBM orbit). An HBM orbit conserves its
energy only up to the truncation of the series: its energy is the mean over the period,
exactly as in the branch datasets (``energy`` there), and its relative variation over
the period is stored (``regularized_energy_spread``) as the residual ambiguity of
"same energy" on the regularized side.

How energies are matched (non-monotone parts)
---------------------------------------------
The energy is not monotone along either curve near its ends:

* the exact family leaves the grazing orbit (``E_g``, about 0.691 for the paper values)
  with *decreasing* energy down to a fold (about 0.675) and only then gains energy; for
  ``E`` in between there are two exact orbits. The comparison uses the increasing arm,
  from the energy minimum to the end of the family (the orbits with a real contact
  phase, which continue into the rest of the family); the short grazing arm is drawn in
  Fig 2 but not compared;
* the regularized branch is used from its start up to the last point before the first
  energy decrease or the first orbit with more than two impacts per period (stage 1 ends
  with an energy fold just before the secondary oscillation of ``x`` reaches the other
  stop).

On these monotone parts an energy determines one orbit on each side. The common range
is the overlap of their energy ranges, shrunk by the relative ``end_margin`` at both
ends (both ends are energy folds, where fixing the energy is ill-conditioned). A
requested energy outside it raises :class:`ValueError`.

At a matched energy ``E``:

* **exact orbit**: Newton's method on the closed-form quarter-period equations plus
  ``E(y) = E`` (four equations, four unknowns, analytic Jacobian), seeded by linear
  interpolation of the family's unknowns between the two neighbouring orbits of the
  increasing arm; the residual and the energy are at round-off after convergence and the
  orbit is checked with :func:`nnmstop.exact.assess_orbit`;
* **regularized orbit**: Newton's method on the HBM equations ``S(U) = 0`` bordered with
  ``E(U) = E`` (mean energy over the period, analytic gradient), seeded by linear
  interpolation of the unknowns between the two neighbouring branch points. So the
  comparison adds *no* interpolation error: the HBM orbit solves the same balanced
  equations as the branch points (relative residual at round-off) at the requested
  energy. For the record, ``interpolation_frequency_shift`` and
  ``interpolation_coefficient_shift`` store how far the plain linear interpolation
  between neighbouring branch points is from that solution, i.e. the error a comparison
  based on interpolated branch points would have carried.

Orbit differences
-----------------
The orbits are compared on the phase ``t/T`` (each orbit on its own period), with the
time origin on the symmetry axis where both velocities vanish and ``x`` is at its
maximum: the turning point ``t = T1`` of the exact quarter-period construction, and
``t = 0`` or ``t = T/2`` of the cosine series (``x'(0) = 0`` in that basis; ``t = 0``
is either the maximum or the minimum of ``x``, the shift of half a period is applied
in the second case and recorded in ``regularized_origin_shift``). That the origin
really is the global maximum of ``x`` is checked on both orbits. The differences are
maxima over ``phase_samples`` equally spaced phases, each refined on a grid 256 times
finer around the sampled maximum: the force difference peaks sharply where the exact
orbit enters the stop (the kink of the piecewise law), and a plain grid of 4096 phases
would miss a few per cent of it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from .branches import dataset_unknowns
from .continuation import relative_residual
from .datasets import write_dataset
from .exact import TwoImpactProblem, assess_orbit, time_history
from .hbm import HarmonicBalanceSystem
from .models.structure import two_dof_structure
from .model import ModelParameters, regularized_contact_force, total_energy

__all__ = [
    "MAX_IMPACTS",
    "EnergyMatcher",
    "MatchedOrbits",
    "exact_increasing_arm",
    "regularized_monotone_part",
    "system_from_dataset",
    "hbm_energy",
    "orbit_differences",
    "comparison_energies",
    "comparison_dataset",
    "build_comparison_dataset",
]

logger = logging.getLogger("nnmstop.compare")

#: One impact per stop per period: at most two excursions beyond the stops.
MAX_IMPACTS = 2
PARAMETER_KEYS = ("alpha", "beta", "delta", "eta")
_NEWTON_MAX_ITER = 30


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


# --------------------------------------------------------------------------- HBM helpers


def system_from_dataset(branch: xr.Dataset) -> HarmonicBalanceSystem:
    """The HBM system a branch dataset was computed with (parameters, H, samples, basis)."""
    missing = [k for k in (*PARAMETER_KEYS, "harmonics", "time_samples", "basis") if k not in branch.attrs]
    if missing:
        raise ValueError(f"the regularized branch dataset lacks the global attribute(s) {missing}")
    params = ModelParameters(**{k: float(branch.attrs[k]) for k in PARAMETER_KEYS})
    return HarmonicBalanceSystem(
        two_dof_structure(params), int(branch.attrs["harmonics"]), time_samples=int(branch.attrs["time_samples"]),
        basis=str(branch.attrs["basis"]),
    )


def _energy_samples(system: HarmonicBalanceSystem) -> int:
    """Samples per period of the HBM energy: those of ``HarmonicBalanceSystem.diagnostics``."""
    return max(16 * system.H, 512)


class _EnergyOperator:
    """Mean energy over the period of an HBM orbit and its exact gradient.

    Same samples and same formula as :meth:`HarmonicBalanceSystem.diagnostics`, so the
    matched energy is the energy stored in the branch datasets.
    """

    def __init__(self, system: HarmonicBalanceSystem):
        self.system = system
        self.m = _energy_samples(system)
        eye = np.eye(system.nc)
        self.synth = system.to_time(eye, self.m).T  # (m, nc): samples of each kept basis function
        self.dsynth = system.to_time(system.derivative(eye), self.m).T  # d/dtheta of each

    def __call__(self, U, gradient: bool = False):
        s, p = self.system, self.system.params
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
        grad[s.slices["u"]] = (self.synth.T @ (p.beta * (us - xs)) + p.delta * omega * (self.dsynth.T @ ud)) / self.m
        grad[s.i_lam] = np.mean(0.5 * xd**2 + 0.5 * p.delta * ud**2) / lam  # kinetic energy ~ lam
        return energy, grad


def hbm_energy(system: HarmonicBalanceSystem, U) -> float:
    """Mean total energy over the period of the HBM orbit ``U`` (as in the branch datasets)."""
    return _EnergyOperator(system)(U)


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
        Exact two-impact family (:func:`nnmstop.exact.family_dataset`).
    branch : xarray.Dataset
        Regularized NNM1 branch or stage dataset (layout of :mod:`nnmstop.branches`).
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
        self.params = self.system.params
        self.problem = TwoImpactProblem(self.params)
        self._energy_op = _EnergyOperator(self.system)
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

        lo = max(self._exact_energy[0], self._hbm_energy[0])
        hi = min(self._exact_energy[-1], self._hbm_energy[-1])
        if not lo < hi:
            raise ValueError(
                f"the energy ranges do not overlap: exact increasing arm {self._exact_energy[0]:.6g}.."
                f"{self._exact_energy[-1]:.6g}, regularized monotone part {self._hbm_energy[0]:.6g}.."
                f"{self._hbm_energy[-1]:.6g}"
            )
        self.overlap = (float(lo), float(hi))
        self.energy_range = (float(lo * (1.0 + end_margin)), float(hi * (1.0 - end_margin)))
        if not self.energy_range[0] < self.energy_range[1]:
            raise ValueError(
                f"end_margin {end_margin!r} leaves no energy in the overlap {lo:.6g}..{hi:.6g}"
            )

    # ------------------------------------------------------------------ checks

    def check_energy(self, energy) -> float:
        """Return ``energy`` as a float, or raise ``ValueError`` if outside :attr:`energy_range`."""
        try:
            value = float(energy)
        except (TypeError, ValueError):
            raise ValueError(f"energy must be a real number, got {energy!r}") from None
        lo, hi = self.energy_range
        if not (np.isfinite(value) and lo <= value <= hi):
            raise ValueError(
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

        def system(v):
            return np.append(prob.residual(v), prob.energy(v) - energy), np.vstack(
                [prob.jacobian(v), [v[0], delta * v[1], 0.0, 0.0]]
            )

        converged = False
        for it in range(1, _NEWTON_MAX_ITER + 1):
            r, J = system(y)
            dy = np.linalg.solve(J, -r)
            y = y + dy
            if converged:  # one more iteration after convergence: residual at round-off
                break
            converged = np.linalg.norm(dy) <= 1e-14 * (1.0 + np.linalg.norm(y))
        if not converged:
            raise ValueError(f"Newton's method did not converge for the exact orbit at energy {energy!r}")
        check = assess_orbit(y, self.params, prob)
        if not check.valid:
            raise ValueError(
                f"the exact orbit found at energy {energy!r} violates the two-impact assumptions "
                f"{check.violated}"
            )
        _check_between(y, self._exact_unknowns, i, f"Newton's method left the increasing arm of the exact family at energy {energy!r}")
        return y, float(np.linalg.norm(prob.residual(y))), it

    def regularized_orbit(self, energy, tol: float = 1e-13) -> tuple[np.ndarray, float, int, np.ndarray]:
        """HBM orbit at ``energy``: unknowns, relative residual, Newton iterations, linear interpolation."""
        energy = self.check_energy(energy)
        s = self.system
        i, w = _bracket(self._hbm_energy, energy)
        lin = self._hbm_unknowns[i] + w * (self._hbm_unknowns[i + 1] - self._hbm_unknowns[i])
        U = lin.copy()
        scale = max(abs(energy), 1.0)
        for it in range(1, _NEWTON_MAX_ITER + 1):
            e, grad = self._energy_op(U, gradient=True)
            r = np.append(s.residual(U), (e - energy))
            dU = np.linalg.solve(np.vstack([s.jacobian(U), grad]), -r)
            U = U + dU
            if (
                np.linalg.norm(dU) <= 1e2 * tol * max(np.linalg.norm(U), 1.0)
                and relative_residual(s, U) <= tol
                and abs(self._energy_op(U) - energy) <= tol * scale
            ):
                break
        else:
            raise ValueError(
                f"Newton's method did not converge for the regularized orbit at energy {energy!r} "
                f"(relative residual {relative_residual(s, U):.2e}); too close to an energy fold?"
            )
        _check_between(U, self._hbm_unknowns, i, f"Newton's method left the regularized branch between its points at energy {energy!r}")
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


def _regularized_on_phase(system: HarmonicBalanceSystem, U, phase: np.ndarray, shift: float | None = None):
    """HBM orbit on ``phase = t/T``, origin on the symmetry axis where x is maximum.

    Returns the fields (``x, u, xdot, udot, f``) and the applied shift (0 or 0.5 period;
    found here unless given).
    """
    x, u, f, _, lam, _ = system.split(U)
    omega = float(np.sqrt(lam))
    H = system.H
    k = np.arange(H + 1)
    full = {name: system.to_full(c) for name, c in (("x", x), ("u", u), ("f", f))}

    def at(theta):
        c, s = np.cos(np.outer(theta, k)), np.sin(np.outer(theta, k))
        out = {}
        for name, coef in full.items():
            a = coef[: H + 1]
            b = np.concatenate([[0.0], coef[H + 1 :]])
            out[name] = c @ a + s @ b
            if name != "f":
                out[name + "dot"] = omega * (c @ (k * b) - s @ (k * a))
        return out

    # t = 0 and t = T/2 are both symmetry axes of a cosine series; take the one at max x
    if shift is None:
        ends = at(np.array([0.0, np.pi]))["x"]
        shift = 0.5 if ends[1] > ends[0] else 0.0
    return at(2.0 * np.pi * (np.asarray(phase) + shift)), shift


def orbit_differences(matched: MatchedOrbits, system: HarmonicBalanceSystem, phase_samples: int = 4096) -> dict:
    """Frequency and largest orbit differences of a matched pair (see the module docstring).

    Parameters
    ----------
    matched : MatchedOrbits
    system : HarmonicBalanceSystem
        The system of the regularized orbit (``EnergyMatcher.system``).
    phase_samples : int
        Equally spaced phases ``t/T`` per period (>= 64).

    Returns
    -------
    dict
        Scalars: frequencies, differences, amplitudes, origin shift and checks.
    """
    if int(phase_samples) != phase_samples or phase_samples < 64:
        raise ValueError(f"phase_samples must be an integer >= 64, got {phase_samples!r}")
    params = system.params
    y = matched.exact
    n = int(phase_samples)
    period_exact = 4.0 * y[3]

    def exact_on(phase):  # origin at the turning point T1
        h = time_history(y, params, y[3] + phase * period_exact)
        return {"x": h.x, "u": h.u, "xdot": h.xdot, "udot": h.udot, "force": h.force}

    phase = np.arange(n) / n
    ex = exact_on(phase)
    reg, shift = _regularized_on_phase(system, matched.regularized, phase)
    reg["force"] = reg.pop("f")
    frequency_exact = 1.0 / period_exact
    frequency_reg = float(system.frequency_hz(matched.regularized))
    # the origin must be the global maximum of x on both orbits
    for name, xs in (("exact", ex["x"]), ("regularized", reg["x"])):
        excess = float(xs.max() - xs[0])
        if excess > 1e-9 * max(1.0, abs(float(xs[0]))):
            raise ValueError(
                f"the {name} orbit at energy {matched.energy!r} does not have its maximum of x on a symmetry "
                f"axis (max x exceeds x at the origin by {excess:.3e}); the phase alignment does not apply"
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
    # largest difference on the grid, refined on a grid 256 times finer around the grid's maximum
    # (the force difference peaks sharply where the exact orbit enters the stop)
    for key in ("x", "u", "xdot", "udot", "force"):
        diff = np.abs(reg[key] - ex[key])
        j = int(np.argmax(diff))
        local = phase[j] + np.linspace(-1.0, 1.0, 513) / n
        reg_local = _regularized_on_phase(system, matched.regularized, local, shift)[0]
        fine = np.abs(reg_local["f" if key == "force" else key] - exact_on(local)[key])
        out[f"max_{key}_difference"] = float(max(diff[j], fine.max()))
    return out


# --------------------------------------------------------------------------- dataset


def comparison_energies(matcher: EnergyMatcher, count: int, marked: dict | None = None) -> tuple[np.ndarray, dict]:
    """Log-spaced energies over the common range, with the ``marked`` energies added.

    Parameters
    ----------
    matcher : EnergyMatcher
    count : int
        Number of log-spaced energies spanning :attr:`EnergyMatcher.energy_range` (>= 2).
    marked : dict, optional
        Label -> energy (for example ``{"a": 0.72, "b": 20.0}``), each inside the range.

    Returns
    -------
    energies : ndarray
        Sorted, unique.
    marks : dict
        Label -> index into ``energies``.
    """
    if int(count) != count or count < 2:
        raise ValueError(f"the number of compared energies must be an integer >= 2, got {count!r}")
    marked = dict(marked or {})
    values = {label: matcher.check_energy(e) for label, e in marked.items()}
    grid = np.geomspace(*matcher.energy_range, int(count))
    energies = np.unique(np.concatenate([grid, list(values.values())]))
    marks = {label: int(np.flatnonzero(energies == e)[0]) for label, e in values.items()}
    return energies, marks


def comparison_dataset(
    exact: xr.Dataset,
    branch: xr.Dataset,
    count: int = 48,
    marked: dict | None = None,
    phase_samples: int = 4096,
    end_margin: float = 0.01,
) -> xr.Dataset:
    """Compare the exact and regularized NNM1 at matched energies; labelled dataset.

    Parameters
    ----------
    exact : xarray.Dataset
        Exact two-impact family.
    branch : xarray.Dataset
        Regularized NNM1 (stage 1 or more) dataset.
    count : int
        Number of log-spaced energies over the common range.
    marked : dict, optional
        Labelled energies (``{"a": E_a, "b": E_b}``), added to the grid and flagged in the
        variable ``marked`` (1 for the first label, 2 for the second, ...).
    phase_samples : int
        Phases per period on which the orbit differences are maximized.
    end_margin : float
        Relative margin from the ends of the common energy range.

    Returns
    -------
    xarray.Dataset
        Dimensions ``point`` (compared energies, increasing) and ``harmonic``.
    """
    matcher = EnergyMatcher(exact, branch, end_margin)
    energies, marks = comparison_energies(matcher, count, marked)
    system = matcher.system
    rows, orbits = [], []
    for energy in energies:
        pair = matcher.match(energy)
        diff = orbit_differences(pair, system, phase_samples)
        rows.append((pair, diff))
        orbits.append(pair.regularized)
        logger.info(
            "E = %.6g: frequency exact %.8f Hz, regularized %.8f Hz (relative difference %+.3e); max |dx| %.3e, "
            "|du| %.3e, |df| %.3e", energy, diff["frequency_exact"], diff["frequency_regularized"],
            diff["relative_frequency_difference"], diff["max_x_difference"], diff["max_u_difference"],
            diff["max_force_difference"],
        )
    n = len(energies)
    one = "1"
    hz = "Hz"

    def col(values, long_name, units=one, dtype=float, **extra):
        return ("point", np.asarray(values, dtype=dtype), {"long_name": long_name, "units": units, **extra})

    def pairs(attr):
        return [getattr(p, attr) for p, _ in rows]

    def diffs(key):
        return [d[key] for _, d in rows]

    y = np.array(pairs("exact"))
    aligned = "over the period, on the phase t/T aligned at the maximum of x"
    not_used = "(error that interpolation alone would add; not present in this comparison)"
    from_diffs = (
        ("frequency_exact", "frequency 1/T of the exact (non-smooth) orbit", hz),
        ("frequency_regularized", "frequency omega/(2 pi) of the regularized HBM orbit", hz),
        ("frequency_difference", "frequency of the regularized orbit minus frequency of the exact orbit", hz),
        ("relative_frequency_difference", "frequency difference (regularized minus exact) over the exact one", one),
        ("max_x_difference", f"largest |x_regularized - x_exact| {aligned}", one),
        ("max_u_difference", f"largest |u_regularized - u_exact| {aligned}", one),
        ("max_xdot_difference", f"largest |xdot_regularized - xdot_exact| {aligned}", one),
        ("max_udot_difference", f"largest |udot_regularized - udot_exact| {aligned}", one),
        (
            "max_force_difference",
            "largest |f_HBM - f_piecewise(x_exact)|: regularized contact force from its Fourier coefficients vs the "
            f"piecewise-linear law (Eq. 4) evaluated on the exact orbit, {aligned}",
            one,
        ),
        ("x_max_exact", "maximum of x over the exact orbit", one),
        ("u_max_exact", "maximum of |u| over the exact orbit", one),
        ("force_max_exact", "maximum of the piecewise-linear contact force over the exact orbit", one),
        (
            "regularized_origin_shift",
            "shift of the time origin of the HBM cosine series, in periods, that puts the maximum of x at t = 0 "
            "(0: x is maximum at t = 0; 0.5: x is minimum at t = 0)",
            one,
        ),
    )
    from_pairs = (
        ("exact_energy", "total energy of the exact orbit (piecewise model), computed from its unknowns", one),
        ("regularized_energy", "total energy of the regularized HBM orbit (regularized model), period mean", one),
        ("exact_residual", "norm of the quarter-period equations of the exact orbit", one),
        ("regularized_residual", "norm of the HBM residual relative to the norm of the unknowns", one),
        (
            "interpolation_coefficient_shift",
            "largest difference between the matched HBM unknowns and their linear interpolation in energy between "
            f"the neighbouring branch points {not_used}",
            one,
        ),
        (
            "interpolation_frequency_shift",
            "frequency of the linear interpolation between neighbouring branch points minus frequency of the matched "
            f"HBM orbit {not_used}",
            hz,
        ),
    )
    data = {name: col(diffs(name), long_name, units) for name, long_name, units in from_diffs}
    data.update({name: col(pairs(name), long_name, units) for name, long_name, units in from_pairs})
    data["regularized_energy_spread"] = col(
        [system.diagnostics(p.regularized)["energy_spread"] for p, _ in rows],
        "relative variation over the period of the energy of the regularized HBM orbit (HBM truncation)",
    )
    exact_names = (
        ("exact_xdot0", "exact orbit: velocity of x at x = u = 0"),
        ("exact_udot0", "exact orbit: velocity of u at x = u = 0"),
        ("exact_tau1", "exact orbit: free-flight duration tau1 of the quarter period"),
        ("exact_T1", "exact orbit: quarter period T1 (the turning point, t = 0 of the aligned phase)"),
    )
    data.update({name: col(y[:, j], long_name) for j, (name, long_name) in enumerate(exact_names)})
    flags = np.zeros(n, dtype=np.int8)
    labels = list(marks)
    for j, label in enumerate(labels, start=1):
        flags[marks[label]] = j
    data["marked"] = (
        "point",
        flags,
        {
            "long_name": "labelled point of the paper's Figs 2-4 (0: not labelled)",
            "units": one,
            "flag_values": np.arange(len(labels) + 1, dtype=np.int8),
            "flag_meanings": " ".join(["none"] + [f"point_{label}" for label in labels]),
        },
    )
    # the regularized orbits, in the layout of the branch datasets (for nnmstop.figures.common.orbit)
    H = system.H
    U = np.array(orbits)
    x, u, f, z, lam, _ = system.split(U)
    fields = ((x, "x", "x"), (u, "u", "u"), (f, "regularized contact force f", "f"), (z, "internal variable z", "z"))
    for c, name, symbol in fields:
        full = system.to_full(c)
        parts = {"cos": full[:, : H + 1], "sin": np.concatenate([np.zeros((n, 1)), full[:, H + 1 :]], axis=1)}
        for kind, values in parts.items():
            word = {"cos": "cosine", "sin": "sine"}[kind]
            attrs = {"long_name": f"regularized orbit: {word} Fourier coefficients of {name}", "units": one}
            data[f"{symbol}_{kind}"] = (("point", "harmonic"), values, attrs)
    data["omega_squared"] = col(lam, "regularized orbit: squared angular frequency")
    coords = {
        "point": ("point", np.arange(n), {"long_name": "index of the compared energy", "units": one}),
        "harmonic": ("harmonic", np.arange(H + 1), {"long_name": "harmonic number k (0 is the mean)", "units": one}),
        "energy": col(energies, "matched total energy of the exact and regularized orbits"),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs = {
        **system.params.as_attrs(),
        "harmonics": H,
        "time_samples": system.M,
        "basis": system.basis,
        "phase_samples": int(phase_samples),
        "end_margin": float(end_margin),
        "energy_range_min": matcher.energy_range[0],
        "energy_range_max": matcher.energy_range[1],
        "exact_arm_first_point": int(matcher.exact_arm.start),
        "regularized_last_point": int(matcher.regularized_part.stop - 1),
        "matching": (
            "Newton's method at fixed energy on both sides: exact closed-form quarter-period equations plus energy; "
            "HBM equations plus mean energy over the period. Exact family: increasing arm from its energy minimum; "
            "regularized branch: leading points with increasing energy and at most two impacts per period."
        ),
        "alignment": (
            "phase t/T of each orbit, origin on the symmetry axis where both velocities vanish and x is maximum "
            "(exact: t = T1; HBM cosine series: t = 0 or T/2)"
        ),
        **{f"point_{label}_energy": float(energies[i]) for label, i in marks.items()},
    }
    return ds


def _load(path) -> xr.Dataset:
    with xr.open_dataset(path) as ds:
        return ds.load()


def build_comparison_dataset(config: dict, inputs: dict, output_path) -> Path:
    """Pipeline task: compare the exact family and regularized NNM1 stage 1; write NetCDF.

    Parameters
    ----------
    config : dict
        Validated configuration with the ``model`` and ``compare`` sections.
    inputs : dict
        ``exact`` (the exact family) and ``nnm1`` (regularized NNM1 stage 1) paths.
    output_path : str or Path

    Raises
    ------
    ValueError
        If a section or input is missing, or the datasets do not match the configuration.
    """
    for key in ("model", "compare"):
        if key not in config:
            raise ValueError(f"config lacks the section {key!r}")
    for key in ("exact", "nnm1"):
        if key not in inputs:
            raise ValueError(f"the comparison needs the input {key!r}, got {sorted(inputs)}")
    spec = config["compare"]
    exact, branch = _load(inputs["exact"]), _load(inputs["nnm1"])
    for key in PARAMETER_KEYS:
        ds = branch if key == "eta" else exact
        if not np.isclose(float(ds.attrs[key]), float(config["model"][key]), rtol=1e-12, atol=0):
            raise ValueError(
                f"model.{key} = {config['model'][key]!r} in the configuration but {ds.attrs[key]!r} in "
                f"{inputs['nnm1'] if ds is branch else inputs['exact']} (stale dataset?)"
            )
    if int(branch.attrs["harmonics"]) != int(config["hbm"]["harmonics"]):
        raise ValueError(
            f"hbm.harmonics = {config['hbm']['harmonics']!r} in the configuration but {branch.attrs['harmonics']!r} in "
            f"{inputs['nnm1']} (stale dataset?)"
        )
    marked = {label: spec["points"][label] for label in ("a", "b")}
    ds = comparison_dataset(
        exact, branch, count=spec["energy_count"], marked=marked, phase_samples=spec["phase_samples"],
        end_margin=spec["end_margin"],
    )
    p = ds.attrs
    summary = (
        "Exact (non-smooth) versus regularized (HBM, "
        f"H = {p['harmonics']}, eta = {p['eta']:g}) NNM1 at matched energies over the range with one impact per "
        "stop per period: frequencies and their difference, largest differences of x, u, velocities and contact "
        "force over the period on the phase t/T aligned at the maximum of x, and both orbits."
    )
    path = write_dataset(
        ds, output_path, title="NNM1: exact non-smooth vs regularized orbits at matched energies",
        summary=summary, keywords="exact solution, regularization, comparison",
        metadata=config.get("metadata"),
    )
    for label in ("a", "b"):
        i = int(np.flatnonzero(ds["marked"].values == ("ab".index(label) + 1))[0])
        logger.info(
            "point %s) E = %.6g: frequency %.8f (exact) vs %.8f Hz (regularized), relative difference %+.3e; "
            "max |dx| = %.3e, |du| = %.3e, |df| = %.3e", label, float(ds["energy"][i]),
            float(ds["frequency_exact"][i]), float(ds["frequency_regularized"][i]),
            float(ds["relative_frequency_difference"][i]), float(ds["max_x_difference"][i]),
            float(ds["max_u_difference"][i]), float(ds["max_force_difference"][i]),
        )
    return path
