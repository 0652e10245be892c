"""Floquet multipliers of the exact (non-smooth) NNM1 orbits, from their linear phases.

The monodromy matrix of an exact orbit is the ordered product of the transition matrices
of its linear phases (the stop force is continuous, so every saltation matrix is the
identity); the non-trivial multiplier pair follows from its trace. The derivation, the
verdict and its tolerance are in ``docs/methods/exact_stability.md``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from nnmstop.exact.phases import phase_of
from nnmstop.floquet import multipliers_from_invariant

__all__ = [
    "ExactMultipliers",
    "quarter_transitions",
    "monodromy",
    "multipliers_from_monodromy",
    "exact_multipliers",
    "stability_variables",
    "summarize",
]

#: Safety factor on the round-off bound of the trace (see :func:`multipliers_from_monodromy`).
TRACE_SAFETY = 16.0


class ExactMultipliers(NamedTuple):
    """Floquet multipliers of one exact orbit.

    Attributes
    ----------
    multiplier : complex
        The non-trivial multiplier of largest modulus (on the unit circle, the one with
        non-negative imaginary part); the other one is its reciprocal.
    trace_invariant : float
        ``s = lambda + 1/lambda = tr M - 2``.
    stability_margin : float
        ``2 - |s|``: > 0 for an elliptic pair (on the unit circle), < 0 for a real pair off it.
    tolerance : float
        Round-off bound on ``s``; ``stable`` is ``stability_margin >= -tolerance``.
    stable : bool
    trivial_distance : float
        Largest distance to +1 of the two eigenvalues of ``M`` nearest to +1 (the trivial
        Jordan pair; about ``sqrt(eps |M|)`` from round-off alone).
    invariant_mismatch : float
        ``|s - s2|`` with ``s2`` from the second characteristic-polynomial invariant: a
        round-off check of the structure ``{1, 1, lambda, 1/lambda}``.
    """

    multiplier: complex
    trace_invariant: float
    stability_margin: float
    tolerance: float
    stable: bool
    trivial_distance: float
    invariant_mismatch: float


def _phases(model) -> dict:
    # Left and right contacts differ only in their constant force, which the transition
    # matrix (the linear part of the affine flow) does not see.
    contact = phase_of(model, "R")
    return {"F": phase_of(model, "F"), "R": contact, "L": contact}


def quarter_transitions(model, sequence: str, durations, phases: dict | None = None) -> list:
    """Transition matrices ``E_k(d_k)`` of the phases of the quarter period, in time order.

    Parameters
    ----------
    model : ModelParameters or Structure
        The paper's oscillator or a 2-DOF structure (:func:`nnmstop.exact.phases.check_sequence_model`).
    sequence : str
        Quarter-period phase sequence (``"FR"``, ``"FLFR"``...; see :mod:`nnmstop.exact.sequences`).
    durations : array_like
        Duration of each phase (>= 0), same length as ``sequence``.
    phases : dict, optional
        The phases of ``model`` (``{"F", "R", "L"}`` -> LinearPhase) when the caller has them.

    Returns
    -------
    list of ndarray, shape (4, 4)
    """
    durations = _checked_durations(sequence, durations, (len(sequence),))
    phases = phases or _phases(model)
    return [phases[kind].transition(d) for kind, d in zip(sequence, durations)]


def _checked_durations(sequence, durations, shape) -> np.ndarray:
    """``durations`` as a float array of ``shape`` (last axis: the phases of ``sequence``), finite and >= 0."""
    durations = np.asarray(durations, dtype=float)
    if not isinstance(sequence, str) or not sequence or set(sequence) - set("FRL"):
        raise ValueError(f"sequence must be a non-empty string of F, R, L; got {sequence!r}")
    if durations.shape != shape:
        raise ValueError(f"need one duration per phase of {sequence!r}, got shape {durations.shape}")
    if not np.all(np.isfinite(durations)) or np.any(durations < 0):
        raise ValueError(f"phase durations must be finite and >= 0, got {durations}")
    return durations


def monodromy(model, sequence: str, durations, start: str = "origin", phases: dict | None = None) -> np.ndarray:
    """Monodromy matrix of the symmetric orbit with this quarter-period phase sequence.

    With ``A = E_n ... E_1`` (quarter period, origin to turning point) and
    ``B = E_1 ... E_n`` (turning point back to the origin, phases in reverse order),
    the half period is ``B A`` and the second half repeats the same linear parts with
    the stops swapped, so ``M = (B A)^2`` from the origin crossing at ``t = 0``, and
    ``(A B)^2`` (similar to it) from the turning point at ``t = T1`` (``start="turning_point"``).

    Returns
    -------
    ndarray, shape (4, 4)
    """
    if start not in ("origin", "turning_point"):
        raise ValueError(f"start must be 'origin' or 'turning_point', got {start!r}")
    return _monodromy_from(quarter_transitions(model, sequence, durations, phases), start)


def _monodromy_from(mats: list, start: str) -> np.ndarray:
    """``(B A)^2`` (``start="origin"``) or ``(A B)^2`` from the quarter-period transitions.

    ``mats`` may hold stacks of transition matrices (one per orbit, ``(..., 4, 4)``).
    """
    order = mats + mats[::-1] if start == "origin" else mats[::-1] + mats
    half = np.eye(4)
    for e in order:
        half = e @ half
    return half @ half


def multipliers_from_monodromy(m, m_similar=None) -> ExactMultipliers:
    """Non-trivial multiplier pair of a 4 x 4 symplectic monodromy with a trivial pair at +1.

    For multipliers ``{1, 1, lambda, 1/lambda}`` the characteristic polynomial is
    ``(l - 1)^2 (l^2 - s l + 1)``, so ``tr M = 2 + s`` and the sum of the principal 2 x 2
    minors is ``2 + 2 s``; ``s = tr M - 2`` is a well-conditioned function of ``M``
    (the eigenvalues of the Jordan block are not). The pair is elliptic when ``|s| <= 2``.

    The tolerance on ``s`` is ``TRACE_SAFETY`` times the round-off measured on ``s``:
    the spread of ``s`` between ``M`` and ``m_similar`` (the same monodromy computed from
    another point of the orbit, equal in exact arithmetic), plus the mismatch of the two
    invariants, plus ``4 eps ||M||_2`` (the error of one trace). ``stable`` is
    ``|s| <= 2 + tolerance``.

    Parameters
    ----------
    m : array_like, shape (4, 4)
    m_similar : array_like, shape (4, 4), optional
        A matrix similar to ``m`` in exact arithmetic.
    """
    s, margin, tol, mismatch = _trace_analysis(m, m_similar)
    lam = complex(multipliers_from_invariant(s)[2])
    return ExactMultipliers(lam, s, margin, tol, bool(margin >= -tol), float(_trivial_distance(m)), mismatch)


def _trace_analysis(m, m_similar=None):
    """``(s, 2 - |s|, tolerance on s, invariant mismatch)`` of :func:`multipliers_from_monodromy`.

    ``m`` (and ``m_similar``) may be stacks ``(n, 4, 4)``; the four results are then arrays.
    """
    m = np.asarray(m, dtype=float)
    if m.shape[-2:] != (4, 4) or m.ndim > 3 or not np.all(np.isfinite(m)):
        raise ValueError(f"the monodromy must be a finite 4 x 4 matrix, got shape {m.shape}")
    eps = np.finfo(float).eps
    trace = np.trace(m, axis1=-2, axis2=-1)
    s = trace - 2.0
    # squares by the scalar power (libm pow), as for one matrix: numpy's array square can differ by an ulp
    trace_squared = np.reshape([value**2 for value in np.ravel(trace).tolist()], np.shape(trace))
    minors = 0.5 * (trace_squared - np.trace(m @ m, axis1=-2, axis2=-1))
    mismatch = np.abs(s - 0.5 * (minors - 2.0))
    spread = 0.0 if m_similar is None else np.abs(np.trace(m_similar, axis1=-2, axis2=-1) - 2.0 - s)
    norm_2 = np.linalg.svd(m, compute_uv=False).max(axis=-1)  # the spectral norm of each matrix
    tol = TRACE_SAFETY * (spread + mismatch + 4.0 * eps * norm_2)
    if m.ndim == 2:
        return float(s), float(2.0 - abs(s)), float(tol), float(mismatch)
    return s, 2.0 - np.abs(s), tol, mismatch


def _trivial_distance(m):
    """Largest distance to +1 of the two eigenvalues of ``m`` (or of each of a stack) nearest to +1."""
    trivial = np.sort(np.abs(np.linalg.eigvals(m) - 1.0), axis=-1)[..., :2]
    return trivial.max(axis=-1)


def exact_multipliers(model, sequence: str, durations, phases: dict | None = None) -> ExactMultipliers:
    """Monodromy (:func:`monodromy`) and multipliers (:func:`multipliers_from_monodromy`) of one orbit."""
    mats = quarter_transitions(model, sequence, durations, phases)
    return multipliers_from_monodromy(_monodromy_from(mats, "origin"), _monodromy_from(mats, "turning_point"))


def stability_variables(model, sequences, durations) -> dict:
    """Floquet variables of exact orbits, as ``{name: (dims, values)}`` along ``point``.

    Parameters
    ----------
    model : ModelParameters or Structure
        The paper's oscillator or a 2-DOF structure (:func:`nnmstop.exact.phases.check_sequence_model`).
    sequences : sequence of str
        Quarter-period phase sequence of each orbit.
    durations : sequence of array_like
        Phase durations of each orbit.

    Returns
    -------
    dict
        ``multiplier_real``, ``multiplier_imag``, ``multiplier_modulus``, ``trace_invariant``,
        ``stability_margin``, ``stability_tolerance``, ``trivial_multiplier_distance`` and
        the flag ``stable`` (int8, 1 stable); their metadata are in :mod:`nnmstop.catalogue.exact`.
    """
    phases = _phases(model)
    sequences = list(sequences)
    if not sequences:
        raise ValueError("no orbit to compute the multipliers of")
    if len(durations) != len(sequences):
        raise ValueError(f"need the durations of each of the {len(sequences)} orbits, got {len(durations)}")
    # The orbits of one phase sequence in stacked products: the numbers of exact_multipliers, orbit by orbit.
    origin = np.empty((len(sequences), 4, 4))
    s, margin, tol = (np.empty(len(sequences)) for _ in range(3))
    by_sequence = {}
    for index, seq in enumerate(sequences):
        by_sequence.setdefault(seq, []).append(index)
    for seq, rows in by_sequence.items():
        d = _checked_durations(seq, [durations[i] for i in rows], (len(rows), len(seq)))
        mats = [phases[kind].transitions(d[:, k]) for k, kind in enumerate(seq)]
        origin[rows] = _monodromy_from(mats, "origin")
        s[rows], margin[rows], tol[rows], _ = _trace_analysis(origin[rows], _monodromy_from(mats, "turning_point"))
    lam = multipliers_from_invariant(s)[:, 2]
    trivial = _trivial_distance(origin)
    stable = margin >= -tol

    def var(values):
        return ("point", np.asarray(values, dtype=float))

    return {
        "multiplier_real": var(lam.real),
        "multiplier_imag": var(lam.imag),
        "multiplier_modulus": var(np.abs(lam)),
        "trace_invariant": var(s),
        "stability_margin": var(margin),
        "stability_tolerance": var(tol),
        "trivial_multiplier_distance": var(trivial),
        "stable": ("point", stable.astype(np.int8)),
    }


def summarize(ds) -> str:
    """Plain-text summary of the Floquet variables of an exact branch dataset."""
    from nnmstop.compare.stability import stability_changes, verdicts

    lines = [
        f"{ds.sizes['point']} orbits, {int(ds['stable'].sum())} stable",
        f"largest stability_tolerance {float(ds['stability_tolerance'].max()):.2e}, "
        f"largest trivial_multiplier_distance {float(ds['trivial_multiplier_distance'].max()):.2e}, "
        f"largest |multiplier| {float(ds['multiplier_modulus'].max()):.4g}",
        f"smallest |stability_margin| {float(np.abs(ds['stability_margin']).min()):.2e}",
    ]
    band = np.abs(ds["stability_margin"].values) <= ds["stability_tolerance"].values
    if band.any():
        e = ds["energy"].values[band]
        lines.append(
            f"{int(band.sum())} orbits with |stability_margin| <= stability_tolerance "
            "(verdict by convention), "
            f"energy {e.min():.6g} to {e.max():.6g}"
        )
    seq = ds["phase_sequence"].values if "phase_sequence" in ds else np.array(["FR"] * ds.sizes["point"])
    for c in stability_changes(ds["energy"].values, ds["frequency"].values, verdicts(ds)):
        a, b = c["before"], c["after"]
        lines.append(
            f"change between points {a} and {b} ({seq[a]}): energy {c['energy_before']:.6g} -> "
            f"{c['energy_after']:.6g}, s {float(ds['trace_invariant'][a]):.6f} -> "
            f"{float(ds['trace_invariant'][b]):.6f}, "
            f"becomes {c['becomes']}"
        )
    return "\n".join(lines)


def main(argv=None) -> None:
    """Command line: ``python -m nnmstop.exact.stability results/exact/nnm1.nc`` prints :func:`summarize`."""
    import argparse

    import xarray as xr

    parser = argparse.ArgumentParser(prog="python -m nnmstop.exact.stability", description=__doc__.splitlines()[0])
    parser.add_argument("dataset", help="exact branch dataset, e.g. results/exact/nnm1.nc")
    args = parser.parse_args(argv)
    with xr.open_dataset(args.dataset) as ds:
        print(summarize(ds.load()))


if __name__ == "__main__":
    main()
