"""The periodic-orbit problem of a phase sequence: residual and exact Jacobian.

Unknowns ``y = (xdot0, udot0, d_1, ..., d_n)``: the velocities at the origin crossing and
the durations of the ``n`` phases of the quarter period; equations: x on the stop at
every switching, both velocities zero at the turning point (:class:`SequenceProblem`).
The two-impact orbits of Section 3.1 are the sequence ``"FR"``; :class:`TwoImpactProblem`
is that problem with the switching times ``(tau1, T1)`` as unknowns instead of the
durations, the unknowns of the paper and of ``results/exact/nnm1_two_impacts.nc``.
Starting orbits (:func:`first_grazing_orbit`, :func:`high_energy_orbit`) and the one
Newton iteration of this package's exact solvers (:func:`newton`) are here too.
Method notes: ``docs/methods/exact.md``.
"""

from __future__ import annotations

import numpy as np

from nnmstop.continuation.newton import newton_solve
from nnmstop.exact.phases import OrbitTimeHistory, check_sequence_model, phase_of, stop_stiffness, unfold_quarter
from nnmstop.exact.sequences import check_sequence, sequence_impacts, switch_levels
from nnmstop.models.two_dof import ModelParameters, linear_modes, mass_matrix

__all__ = [
    "SequenceProblem",
    "TwoImpactProblem",
    "newton",
    "first_grazing_orbit",
    "high_energy_orbit",
    "from_two_impact_unknowns",
]


def newton(fun, jac, y, tol=1e-14, max_iter=40):
    """Newton iteration to round-off: once a step is below ``tol (1 + |y|)``, one more step.

    :func:`nnmstop.continuation.newton.newton_solve` with its step criterion; the polishing update counts
    among the ``max_iter`` updates (none when the criterion holds only at the last one).

    Returns
    -------
    y : ndarray
    converged : bool
        False on a singular Jacobian, a non-finite iterate or ``max_iter`` iterations.
    """
    try:
        result = newton_solve(fun, jac, y, tol=tol, max_iter=max_iter)
        if result.converged and result.iterations < max_iter:
            result = newton_solve(fun, jac, result.y, tol=tol, max_iter=1, criterion=lambda y, r, dy: dy is not None)
    except np.linalg.LinAlgError:
        return np.asarray(y, dtype=float), False
    return result.y, result.converged


class SequenceProblem:
    """Residual and analytic Jacobian of the quarter-period equations of a phase sequence.

    Parameters
    ----------
    model : ModelParameters or Structure
        The paper's oscillator (only ``alpha``, ``beta`` and ``delta`` matter) or a 2-DOF structure with one
        stop on its first degree of freedom and gap 1 (:func:`nnmstop.exact.phases.check_sequence_model`;
        anything else is refused with a ValueError naming what is not supported).
    sequence : str
        Phase sequence, see :func:`nnmstop.exact.sequences.check_sequence`.

    Notes
    -----
    ``z_0 = (0, 0, xdot0, udot0)`` and ``z_k = flow_k(d_k) z_{k-1}``. The flows are affine in
    the state, so ``dz_k/dy = E_k(d_k) dz_{k-1}/dy + f_k(z_k) e_{d_k}`` with ``E_k`` the exact
    transition matrix and ``f_k`` the vector field of phase k.
    """

    #: The unknowns after the velocities are the phase durations (``False``) or the switching times.
    switch_times = False
    #: At a switching time, :meth:`quarter_state` takes the state from the phase starting there
    #: (``"next"``) or ending there (``"previous"``); both agree to round-off.
    state_at_switch = "next"

    def __init__(self, model, sequence: str):
        self.model = check_sequence_model(model)
        #: The paper's parameters when the model is given by them (None for a structure).
        self.params = model if isinstance(model, ModelParameters) else None
        self.mass = mass_matrix(model) if self.params is not None else np.asarray(model.dense_matrices()[0], float)
        self.sequence = check_sequence(sequence)
        self.n_phases = len(sequence)
        self.n_unknowns = self.n_phases + 2
        self.phases = tuple(phase_of(model, kind) for kind in sequence)
        self.levels = switch_levels(sequence)
        self._last_states = (None, None)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.sequence!r})"

    @property
    def impacts_per_period(self) -> int:
        """Excursions beyond the stops per period (:func:`nnmstop.exact.sequences.sequence_impacts`)."""
        return sequence_impacts(self.sequence)

    def check(self, y) -> np.ndarray:
        """``y`` as a float array, after checking its shape and finiteness."""
        y = np.asarray(y, dtype=float)
        if y.shape != (self.n_unknowns,):
            raise ValueError(
                f"unknowns of {self.sequence!r} are (xdot0, udot0, {self._time_names()}), "
                f"expected shape ({self.n_unknowns},), got {y.shape}"
            )
        if not np.isfinite(y).all():
            raise ValueError(f"unknowns must be finite, got {y}")
        return y

    def _time_names(self) -> str:
        return f"t_1..t_{self.n_phases}" if self.switch_times else f"d_1..d_{self.n_phases}"

    def durations(self, y) -> np.ndarray:
        """Phase durations ``d_1..d_n`` of the orbit ``y``."""
        return self._durations(self.check(y))

    def _durations(self, y) -> np.ndarray:
        times = y[2:]
        if not self.switch_times:
            return times
        return np.concatenate([times[:1], times[1:] - times[:-1]])

    def switch_states(self, y) -> np.ndarray:
        """States ``z_0`` (origin) ... ``z_n`` (turning point), shape ``(n + 1, 4)``."""
        return self._switch_states(self.check(y)).copy()

    def _switch_states(self, y) -> np.ndarray:
        # A continuation step asks for the states of one orbit several times (residual, validity,
        # Jacobian): the last ones are kept, keyed by the exact unknowns.
        key = y.tobytes()
        if self._last_states[0] == key:
            return self._last_states[1]
        d = self._durations(y)
        z = np.empty((self.n_phases + 1, 4))
        z[0] = (0.0, 0.0, y[0], y[1])
        for k, phase in enumerate(self.phases):
            z[k + 1] = phase.state(z[k], d[k])
        z.flags.writeable = False
        self._last_states = (key, z)
        return z

    def residual_from_states(self, z) -> np.ndarray:
        """Residual from the switch states of :meth:`switch_states`."""
        switches = [z[k + 1, 0] - level for k, level in enumerate(self.levels)]
        return np.array([*switches, z[-1, 2], z[-1, 3]])

    def residual(self, y) -> np.ndarray:
        """Switching conditions ``x(end of phase k) - level_k`` then ``xdot(T1)``, ``udot(T1)``."""
        return self.residual_from_states(self._switch_states(self.check(y)))

    def state_derivatives(self, y, z=None) -> list:
        """Exact ``dz_k / dy`` for ``k = 0..n``, each of shape ``(4, n + 2)``.

        ``z``: the switch states of ``y`` when the caller has them.
        """
        y = self.check(y)
        d_k = self._durations(y)
        z = self._switch_states(y) if z is None else z
        d = np.zeros((4, self.n_unknowns))
        d[2, 0] = d[3, 1] = 1.0
        out = [d]
        for k, phase in enumerate(self.phases):
            d = phase.transition(d_k[k]) @ d
            d[:, 2 + k] = phase.field(z[k + 1])
            out.append(d)
        if self.switch_times:  # d_k = t_k - t_{k-1}: chain rule column by column
            out = [self._to_switch_times(d) for d in out]
        return out

    def _to_switch_times(self, d):
        d = d.copy()
        d[:, 2:-1] -= d[:, 3:]
        return d

    def _jacobian_from(self, dz) -> np.ndarray:
        rows = [dz[k + 1][0] for k in range(self.n_phases - 1)]
        return np.vstack([*rows, dz[-1][2], dz[-1][3]])

    def jacobian(self, y) -> np.ndarray:
        """Analytic ``(n + 1) x (n + 2)`` Jacobian of :meth:`residual`."""
        return self._jacobian_from(self.state_derivatives(y))

    def energy(self, y) -> float:
        """Total energy: the kinetic energy at the origin ``x = u = 0``."""
        y = self.check(y)
        xdot, udot = float(y[0]), float(y[1])
        (m00, m01), (m10, m11) = self.mass.tolist()
        return 0.5 * (xdot * (m00 * xdot + m01 * udot) + udot * (m10 * xdot + m11 * udot))

    def quarter(self, y) -> float:
        """Quarter period ``T1``."""
        y = self.check(y)
        return float(y[-1]) if self.switch_times else float(np.sum(y[2:]))

    def frequency(self, y) -> float:
        """``1 / (4 T1)``, in Hz of the nondimensional time."""
        return 1.0 / (4.0 * self.quarter(y))

    def diagnostics(self, y) -> dict:
        """Energy, frequency and impacts per period, for the continuation."""
        return {"energy": self.energy(y), "frequency": self.frequency(y), "impacts_per_period": self.impacts_per_period}

    def quarter_state(self, y, t) -> np.ndarray:
        """State at times ``0 <= t <= T1`` of the quarter period, shape ``np.shape(t) + (4,)``."""
        y = self.check(y)
        z = self._switch_states(y)
        t = np.asarray(t, dtype=float)
        ends = y[2:] if self.switch_times else np.cumsum(y[2:])
        starts = np.concatenate([[0.0], ends])
        side = "right" if self.state_at_switch == "next" else "left"
        k = np.clip(np.searchsorted(starts, t, side=side) - 1, 0, self.n_phases - 1)
        if t.shape == (1,):  # one time (the validity check asks for one): the phase without masks
            j = int(k[0])
            return self.phases[j].state(z[j], t - starts[j])
        out = np.empty(t.shape + (4,))
        for j in np.unique(k):
            sel = k == j
            out[sel] = self.phases[j].state(z[j], t[sel] - starts[j])
        return out

    def time_history(self, y, t) -> OrbitTimeHistory:
        """Exact time history of the orbit ``y`` at any times ``t`` (:func:`nnmstop.exact.phases.unfold_quarter`)."""
        y = self.check(y)
        return unfold_quarter(lambda r: self.quarter_state(y, r), self.quarter(y), t, stop_stiffness(self.model))


class TwoImpactProblem(SequenceProblem):
    """The two-impact problem of Section 3.1: ``"FR"`` with unknowns ``(xdot0, udot0, tau1, T1)``.

    ``tau1`` is the end of the free flight (entry into the stop), ``T1`` the quarter period.
    Equations ``x(tau1) = 1``, ``xdot(T1) = 0``, ``udot(T1) = 0``.
    """

    switch_times = True
    state_at_switch = "previous"
    names = ("xdot0", "udot0", "tau1", "T1")

    def __init__(self, model):
        super().__init__(model, "FR")
        self.free, self.contact = self.phases


def first_grazing_orbit(params: ModelParameters) -> np.ndarray:
    """The grazing orbit where the two-impact family starts: first linear mode with x amplitude 1.

    ``q(t) = phi_1 sin(omega_1 t)`` with ``phi_1 = (1, u/x)``, so ``xdot0 = omega_1``,
    ``udot0 = omega_1 phi_1[1]`` and ``tau1 = T1 = pi / (2 omega_1)`` (contact duration 0).

    Returns
    -------
    ndarray, shape (4,)
        ``(xdot0, udot0, tau1, T1)``, the unknowns of :class:`TwoImpactProblem`.
    """
    omega, shapes = linear_modes(params, "no_contact")
    w = omega[0]
    quarter = 0.5 * np.pi / w
    return np.array([w, w * shapes[1, 0], quarter, quarter])


def high_energy_orbit(params: ModelParameters, x_max: float) -> np.ndarray:
    """Two-impact orbit with turning point ``x(T1) = x_max``, for large ``x_max``.

    Seeded from the gap-0 first linear mode (stop always engaged) of x amplitude
    ``x_max``, then solved by Newton on the three quarter-period equations plus
    ``x(T1) = x_max``. Meant for ``x_max`` of at least about 10 (the seed is poor below);
    the result is **not** checked here, use :func:`nnmstop.exact.grazing.assess_orbit`.

    Returns
    -------
    ndarray, shape (4,)
        ``(xdot0, udot0, tau1, T1)``.

    Raises
    ------
    ValueError
        If ``x_max <= 1`` or Newton does not converge.
    """
    if not np.isfinite(x_max) or x_max <= 1.0:
        raise ValueError(f"x_max must be a finite number > 1, got {x_max!r}")
    problem = TwoImpactProblem(params)
    omega, shapes = linear_modes(params, "gap_zero")
    w = omega[0]
    y0 = np.array([w * x_max, w * x_max * shapes[1, 0], np.arcsin(1.0 / x_max) / w, 0.5 * np.pi / w])

    def fun(y):
        z = problem.switch_states(y)
        return np.append(problem.residual_from_states(z), z[-1, 0] - x_max)

    def jac(y):
        dz = problem.state_derivatives(y)
        return np.vstack([problem._jacobian_from(dz), dz[-1][0]])

    y, ok = newton(fun, jac, y0)
    if not ok:
        raise ValueError(f"Newton did not converge for the high-energy orbit with x_max={x_max!r}")
    return y


def from_two_impact_unknowns(y) -> np.ndarray:
    """Unknowns of ``"FR"`` from those of :class:`TwoImpactProblem`.

    ``(xdot0, udot0, tau1, T1)`` -> ``(xdot0, udot0, tau1, T1 - tau1)``; works on the last axis.
    """
    y = np.asarray(y, dtype=float)
    if y.shape[-1] != 4:
        raise ValueError(f"two-impact unknowns are (xdot0, udot0, tau1, T1), got shape {y.shape}")
    out = y.copy()
    out[..., 3] = y[..., 3] - y[..., 2]
    return out
