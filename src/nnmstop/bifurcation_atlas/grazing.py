r"""The grazing curve of the non-impacting response in closed form, for any stop (a circular clearance included).

Below grazing the response is linear: each stop's physical coordinates are ``c(theta) = Re(C e^{i theta})``
with ``C = A Q`` (``A`` the stop's coordinate matrix, ``Q`` the complex amplitudes of the linear response at
unit force, :func:`nnmstop.exact.forced.non_impacting_response`). For a stop with two components (a circular
clearance: a tube in a circular hole) ``c`` runs over an ellipse whose largest radius is its semi-major axis

    a = sqrt((|C|^2 + |C^T C|) / 2)

(``|c(theta)|^2 = (|C|^2 + Re(C^T C e^{2 i theta})) / 2``); for a stop with one component the same formula gives
``|C|``, the sinusoid's amplitude. The stop is reached at the force ``g / a``: the grazing force of the map is
``F_g(Omega) = 1 / max_s (a_s / g_s)`` and, on the gap plane (one stop), the grazing gap is ``F a(Omega)``. This
is the atlas' ``grazing`` curve of a structure whose stop is not piecewise linear (no exact formulation to
continue it on), drawn on a fine frequency grid; it is checked at the check values against grazing frequencies
located independently, by Brent's method on the orbit's largest radius maximized over the phase
(:func:`sampled_reach`). Method note: ``docs/methods/atlas.md``.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize

from nnmstop.exact.forced import free_phase, non_impacting_response

__all__ = [
    "semi_major_axis",
    "stop_reaches",
    "grazing_second",
    "sampled_reach",
    "closed_form_grazing_curves",
    "grazing_checks",
    "CURVE_SAMPLES",
]

#: Frequencies of the closed-form grazing curve over the map's frequency range.
CURVE_SAMPLES = 2001
#: Planes on which the grazing curve has a closed form here.
GRAZING_PLANES = ("force", "gap")


def semi_major_axis(C) -> np.ndarray:
    """Largest ``|Re(C e^{i theta})|`` over ``theta`` of complex amplitudes ``C`` (last axis: the components):
    ``sqrt((|C|^2 + |C^T C|) / 2)``, the ellipse's semi-major axis (``|C|`` for one component)."""
    C = np.asarray(C, dtype=complex)
    norm2 = np.sum(np.abs(C) ** 2, axis=-1)
    return np.sqrt(0.5 * (norm2 + np.abs(np.sum(C * C, axis=-1))))


def stop_reaches(excitation, omega) -> np.ndarray:
    """``a_s / g_s`` of every stop at unit force (shape ``np.shape(omega) + (stops,)``): the non-impacting
    response reaches the stop ``s`` at the force ``g_s / a_s``."""
    unit = excitation.with_amplitude(1.0)
    Q = non_impacting_response(unit, omega)
    n = excitation.structure.n_dofs
    return np.stack(
        [semi_major_axis(Q @ s.coordinate_matrix(n).T) / s.gap for s in excitation.structure.stops], axis=-1
    )


def _check_plane(atlas) -> None:
    if atlas.plane not in GRAZING_PLANES:
        raise ValueError(
            f"atlas map {atlas.name!r}: the closed-form grazing curve of the "
            f"{', '.join(s.label for s in atlas.excitation.structure.stops)} is computed on the planes "
            f"{list(GRAZING_PLANES)}, not {atlas.plane!r}"
        )
    if atlas.plane == "gap" and len(atlas.excitation.structure.stops) > 1:
        raise ValueError(
            f"atlas map {atlas.name!r}: the closed-form grazing curve on the gap plane takes one stop (the gap is "
            f"the first stop's); this structure has {len(atlas.excitation.structure.stops)}"
        )


def grazing_second(atlas, omega) -> np.ndarray:
    """The second parameter at which the non-impacting response grazes at ``omega``: the force ``1 / max_s
    (a_s / g_s)`` on the force plane, the gap ``F a`` on the gap plane (``F`` the map's force)."""
    _check_plane(atlas)
    reach = stop_reaches(atlas.excitation, omega)
    if atlas.plane == "force":
        return 1.0 / reach.max(axis=-1)
    return atlas.excitation.force.amplitude * reach[..., 0] * atlas.excitation.structure.stops[0].gap


def sampled_reach(C, samples: int = 64) -> float:
    """``max_theta |Re(C e^{i theta})|`` by sampling and Brent's method on the best sample's neighbourhood (an
    independent evaluation of :func:`semi_major_axis`, to round-off)."""
    C = np.asarray(C, dtype=complex)

    def radius(theta):
        return float(np.linalg.norm(np.real(C * np.exp(1j * theta))))

    theta = 2 * np.pi * np.arange(samples) / samples
    best = theta[int(np.argmax([radius(t) for t in theta]))]
    step = 2 * np.pi / samples
    found = scipy.optimize.minimize_scalar(
        lambda t: -radius(t), bounds=(best - step, best + step), method="bounded", options={"xatol": 1e-12}
    )
    return max(radius(found.x), radius(best))


def closed_form_grazing_curves(atlas) -> list:
    """``[(omega, second), ...]``: the grazing curve on :data:`CURVE_SAMPLES` frequencies of the map's range,
    split where it leaves the window of the second parameter (one array pair per piece inside it)."""
    low, high = (2 * np.pi * f for f in atlas.frequency_range)
    omega = np.linspace(low, high, CURVE_SAMPLES)
    second = grazing_second(atlas, omega)
    inside = (second >= atlas.second_range[0]) & (second <= atlas.second_range[1])
    pieces, start = [], None
    for i, keep in enumerate(np.append(inside, False)):
        if keep and start is None:
            start = i
        elif not keep and start is not None:
            if i - start >= 2:
                pieces.append((omega[start:i], second[start:i]))
            start = None
    return pieces


def _orbit_grazing_frequencies(atlas, value: float, samples: int = 400) -> list:
    """Frequencies (rad) where the non-impacting response at ``value`` of the second parameter reaches a stop,
    from the orbit's largest radius maximized over the phase (:func:`sampled_reach`), bracketed on a grid and
    located by Brent's method: independent of the closed form."""
    _check_plane(atlas)
    excitation = atlas.excitation_at(value)
    n = excitation.structure.n_dofs
    matrices = [s.coordinate_matrix(n) for s in excitation.structure.stops]
    gaps = [s.gap for s in excitation.structure.stops]

    def excess(w):
        Q = non_impacting_response(excitation, [w])[0]
        return max(sampled_reach(A @ Q) - g for A, g in zip(matrices, gaps))

    low, high = (2 * np.pi * f for f in atlas.frequency_range)
    grid = np.linspace(low, high, samples)
    values = np.array([excess(w) for w in grid])
    crossings = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
    return [scipy.optimize.brentq(excess, grid[i], grid[i + 1], xtol=1e-14, rtol=1e-14) for i in crossings]


def grazing_checks(atlas, curves: list, values) -> tuple:
    """Rows ``(curve index, value, curve frequency Hz, located frequency Hz, relative distance)`` (the layout of
    :func:`nnmstop.bifurcation_atlas.build.check_curves`) and the located points on no curve (``(value,
    frequency Hz, nearest distance or None)``): every grazing frequency :func:`_orbit_grazing_frequencies` finds
    at a check value, against the closed form solved at that value on the curve that brackets it."""
    rows, missed = [], []
    for value in values:
        crossings = []
        for j, (omega, second) in enumerate(curves):
            for i in np.flatnonzero((second[:-1] - value) * (second[1:] - value) <= 0):
                root = scipy.optimize.brentq(
                    lambda w, value=value: float(grazing_second(atlas, [w])[0]) - value,
                    omega[i],
                    omega[i + 1],
                    xtol=1e-15,
                    rtol=1e-15,
                )
                crossings.append((j, root))
        for located in _orbit_grazing_frequencies(atlas, float(value)):
            best = min(crossings, key=lambda c: abs(c[1] - located), default=None)
            if best is None:
                missed.append((float(value), located / (2 * np.pi), None))
                continue
            distance = abs(best[1] - located) / located
            rows.append((best[0], float(value), best[1] / (2 * np.pi), located / (2 * np.pi), distance))
    return rows, missed


def linear_multipliers(excitation, omega: float) -> np.ndarray:
    """Floquet multipliers of the linear (non-impacting) response at ``omega``: ``exp(lambda 2 pi / Omega)`` of
    the free flight's eigenvalues, by decreasing modulus."""
    mu = np.exp(free_phase(excitation).eigenvalues * 2 * np.pi / omega)
    return mu[np.argsort(-np.abs(mu), kind="stable")]
