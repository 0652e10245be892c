"""What each periodic orbit of a branch is, computed from its harmonic content rather than configured.

A continued branch starts as one nonlinear normal mode, but along the way it can enter an internal
resonance *tongue* (the orbit locks its frequency while another mode grows at the ``n``-th harmonic) or
cross over for good onto another family read over ``n`` periods: an NNM2 orbit of frequency ``f2`` is
also an orbit of period ``n / f2``, whose fundamental ``f2 / n`` carries nothing (notes on the paper,
Figs 8-10). The stage of the continuation that holds a point says neither; its Fourier coefficients do.

For an orbit with the displacement coefficients ``a_k = q_cos[:, k] - i q_sin[:, k]`` (``k >= 1``; the mean is
left out: a shift, not an oscillation), harmonic ``k`` carries the mass-weighted mean square
``w_k = a_k^H M a_k / 2`` of the motion, a share ``s_k = w_k / sum_j w_j``:

* the **dominant harmonic** ``n`` is the one of largest share;
* its **mode** is the linear mode of the structure *as the orbit loads it* that carries most of ``a_n``
  (``|Phi_m^T M a_n|^2`` over ``a_n^H M a_n``): each stop replaced by its equivalent stiffness over the orbit,
  ``k_s = <f_s x_s> / <x_s^2>`` (least squares of the stop force in time, by Parseval's identity over the
  coefficients), which goes from ``eta`` near rest to ``alpha`` as the gap closes, so that the mode is the
  regularized structure's near rest and the gap-0 structure's at high energy, continuously in between
  (:func:`effective_stop_stiffness`);
* the orbit is **NNM m** (``kind`` 0) when ``n = 1`` and no other harmonic holds more than
  :data:`TONGUE_SHARE` of the motion; in the **n:1 tongue of NNM m** (``kind`` 1) when ``n = 1`` and
  harmonic ``k >= 2`` holds more than that (the one of largest share is the tongue's order); **NNM m seen at
  1/n of its frequency** (``kind`` 2) when ``n > 1``: it is an orbit of mode ``m`` at ``n`` times the
  stored frequency.

The threshold: impacts drive secondary oscillations between the stops at odd harmonics, which on the
impacting NNM1 orbits of the paper's oscillator hold up to a tenth of the motion (the 3rd, 5th and 7th
harmonics of ``x`` at alpha = 10, 30, 100; measured on the branches of ``config/config.yaml``), while in a
tongue the resonant harmonic's share rises from there to 1 at the branch point where the fundamental
vanishes; a tenth is where an internal resonance starts to be more than the impacts' ripple. Also per
degree of freedom, the harmonic of its largest amplitude (``dof_dominant_harmonic``: ``x`` at 7 while
``u`` stays at 1 on the alpha = 100 NNM1 before its 7:1 crossing).

:func:`orbit_identity` computes the per-orbit variables of the branch datasets
(:mod:`nnmstop.hbm.dataset`, catalogue :mod:`nnmstop.catalogue.branch`); :func:`identity_label` names an
orbit in words; :func:`identity_runs` cuts a branch into runs of one identity (where a branch crosses onto
another family, and what it becomes). Method notes: ``docs/methods/identity.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse

from nnmstop.models.structure import Structure, generalized_modes

__all__ = [
    "TONGUE_SHARE",
    "KINDS",
    "effective_stop_stiffness",
    "harmonic_shares",
    "sampled_shares",
    "content_kind",
    "orbit_identity",
    "identity_label",
    "IdentityRun",
    "identity_runs",
    "branch_identity_text",
]

#: A harmonic other than the dominant one holding more than this share of the motion's mean square
#: puts a dominant-fundamental orbit in that harmonic's tongue (module docstring).
TONGUE_SHARE = 0.1
#: Codes of ``orbit_kind`` (their flag meanings in the catalogue).
KINDS = ("own_frequency", "tongue", "seen_at_fraction")
#: Largest number of linear modes computed per orbit for the projection (all of them below 400 DOF).
MAX_MODES = 6


def harmonic_shares(mass, q_cos, q_sin) -> np.ndarray:
    """Share ``s_k`` of the mass-weighted mean square of the motion carried by each harmonic ``k >= 1``.

    ``q_cos``, ``q_sin``: (point, dof, harmonic), the mean at index 0 (left out). Returns (point, H), column
    ``k - 1`` for harmonic ``k``; rows of an orbit at rest are zero.
    """
    mass = mass if scipy.sparse.issparse(mass) else np.asarray(mass, float)
    c, s = np.asarray(q_cos, float)[..., 1:], np.asarray(q_sin, float)[..., 1:]
    weight = np.einsum("pdk,pdk->pk", c, _apply(mass, c)) + np.einsum("pdk,pdk->pk", s, _apply(mass, s))
    total = weight.sum(axis=1, keepdims=True)
    return np.divide(weight, total, out=np.zeros_like(weight), where=total > 0)


def sampled_shares(mass, samples) -> np.ndarray:
    """:func:`harmonic_shares` of an orbit given by ``samples`` (time, dof) equally spaced over one period.

    The coefficients come from the discrete Fourier transform (exact for a band-limited orbit with more than
    twice its highest harmonic in samples; an exact non-smooth orbit's aliasing is below the sampling's
    resolution of its shares). Returns (H,) shares of the harmonics 1 .. samples // 2 - 1.
    """
    samples = np.asarray(samples, float)
    spectrum = np.fft.rfft(samples, axis=0)[1 : samples.shape[0] // 2] * (2.0 / samples.shape[0])  # (H, dof)
    q = spectrum.T[None]  # (1, dof, H): cos - i sin coefficients
    q_cos = np.concatenate([np.zeros((1, q.shape[1], 1)), q.real], axis=2)
    q_sin = np.concatenate([np.zeros((1, q.shape[1], 1)), -q.imag], axis=2)
    return harmonic_shares(mass, q_cos, q_sin)[0]


#: The orbit variables :func:`orbit_identity` reads, in its argument order (``f2_*`` only with a circular clearance).
ORBIT_FORCE_NAMES = ("q_cos", "q_sin", "f_cos", "f_sin", "f2_cos", "f2_sin")


def content_kind(shares) -> tuple[int, int, int]:
    """``(dominant harmonic, tongue harmonic, orbit_kind)`` of one orbit's harmonic ``shares`` (module docstring):
    the part of its identity that needs no linear mode (to compare an exact orbit with a regularized one)."""
    shares = np.asarray(shares, float)
    dominant = int(np.argmax(shares)) + 1
    others = shares.copy()
    others[dominant - 1] = 0.0
    tongue = int(np.argmax(others)) + 1 if dominant == 1 and others.max(initial=0.0) > TONGUE_SHARE else 0
    return dominant, tongue, 2 if dominant > 1 else (1 if tongue else 0)


def _apply(mass, vectors):
    """``M v`` for (point, dof, harmonic) vectors."""
    p, n, k = vectors.shape
    flat = np.moveaxis(vectors, 1, 0).reshape(n, p * k)
    return np.moveaxis((mass @ flat).reshape(n, p, k), 0, 1)


def effective_stop_stiffness(structure: Structure, q_cos, q_sin, f_cos, f_sin, f2_cos=None, f2_sin=None):
    """Equivalent linear stiffness ``<f . x> / <|x|^2>`` of each stop over each orbit (point, stop).

    ``x = A q / gap`` (the stop's scaled coordinates, :meth:`~nnmstop.models.contact.Stop.coordinates`) and ``f``
    (force over gap, and ``f2`` its second component for a circular clearance) over the period, by Parseval's
    identity on the harmonics ``k >= 1``: the least-squares slope of the stop force against its displacement, in
    ``[eta, alpha)`` for the regularized law (its ``f(x) / x`` grows with ``|x|``). ``eta`` where the stop's
    coordinates are at rest.
    """
    q_cos, q_sin = np.asarray(q_cos, float), np.asarray(q_sin, float)
    out = np.empty((q_cos.shape[0], len(structure.stops)))
    for j, stop in enumerate(structure.stops):
        xc, xs = stop.coordinates(q_cos[..., 1:], axis=1), stop.coordinates(q_sin[..., 1:], axis=1)
        fc, fs = [np.asarray(f_cos)[:, j, 1:]], [np.asarray(f_sin)[:, j, 1:]]
        if stop.n_components == 2:
            if f2_cos is None or f2_sin is None:
                raise ValueError(f"stop {j} ({stop.label}) has two force components: give f2_cos and f2_sin")
            fc.append(np.asarray(f2_cos)[:, j, 1:])
            fs.append(np.asarray(f2_sin)[:, j, 1:])
        power = sum((xc[k] ** 2 + xs[k] ** 2).sum(axis=1) for k in range(stop.n_components))
        cross = sum((fc[k] * xc[k] + fs[k] * xs[k]).sum(axis=1) for k in range(stop.n_components))
        out[:, j] = np.divide(cross, power, out=np.full(power.shape, stop.eta), where=power > 0)
    return out


def _stiffness_added(structure: Structure, stiffness_added) -> scipy.sparse.csr_matrix:
    """``sum_j k_j A_j^T A_j``: each stop replaced by a linear spring of stiffness ``k_j`` on its coordinates."""
    n = structure.n_dofs
    added = scipy.sparse.csr_matrix((n, n))
    for stop, k in zip(structure.stops, stiffness_added):
        A = scipy.sparse.csr_matrix(stop.coordinate_matrix(n))
        added = added + k * (A.T @ A)
    return added.tocsr()


def _mode_shares(structure: Structure, mass, stiffness, stiffness_added, cos, sin) -> np.ndarray:
    """Share of ``cos - i sin`` (dof,) carried by each mode of ``K`` with each stop a spring (lowest first)."""
    added = _stiffness_added(structure, stiffness_added)
    loaded = (stiffness + added).tocsr() if scipy.sparse.issparse(stiffness) else stiffness + added.toarray()
    n_modes = structure.n_dofs if structure.n_dofs <= 400 else min(MAX_MODES, structure.n_dofs)
    omega, shapes = generalized_modes(mass, loaded, n_modes)
    projected = shapes.T @ (mass @ np.column_stack([cos, sin]))
    norm = float(cos @ (mass @ cos) + sin @ (mass @ sin))
    shares = (projected**2).sum(axis=1) / norm if norm > 0 else np.zeros(n_modes)
    return _rotated_pairs_merged(structure, omega, shares)


#: Relative gap of two frequencies below which, for a structure invariant under rotations, two modes are one mode
#: and its copy turned by 90 degrees (the tolerance of nnmstop.hbm.system's rotated pairs).
ROTATED_PAIR_TOLERANCE = 1e-8


def _rotated_pairs_merged(structure: Structure, omega, shares) -> np.ndarray:
    """For a structure invariant under rotations, each mode and its copy turned by 90 degrees (one frequency) are one
    mode: their shares summed on the first (any basis of the pair is as good as another, so the split between them
    is round-off, their sum is not), the second's zero. Other structures' shares unchanged."""
    if structure.rotation_pairs is None:
        return shares
    shares = np.array(shares, dtype=float)
    scale = max(float(np.max(np.abs(omega))), 1e-300)
    j = 0
    while j < len(omega) - 1:
        if abs(omega[j + 1] - omega[j]) <= ROTATED_PAIR_TOLERANCE * scale:
            shares[j], shares[j + 1] = shares[j] + shares[j + 1], 0.0
            j += 2
        else:
            j += 1
    return shares


def orbit_identity(structure: Structure, q_cos, q_sin, f_cos, f_sin, f2_cos=None, f2_sin=None) -> dict:
    """The identity of each orbit (module docstring) as arrays, the variables of the branch datasets.

    Parameters
    ----------
    structure : Structure
    q_cos, q_sin : array_like, shape (point, dof, harmonic)
        Fourier coefficients of the degrees of freedom (mean first).
    f_cos, f_sin : array_like, shape (point, stop, harmonic)
        Of the stop forces (force over gap).
    f2_cos, f2_sin : array_like, shape (point, stop, harmonic), optional
        Of the second force component of each stop (needed with a circular clearance).

    Returns
    -------
    dict
        ``dominant_harmonic``, ``dominant_harmonic_share``, ``fundamental_share``, ``dominant_mode`` (1-based),
        ``dominant_mode_share``, ``tongue_harmonic`` (0 outside a tongue), ``orbit_kind`` (:data:`KINDS`),
        per point; ``dof_dominant_harmonic`` (point, dof); ``effective_stop_stiffness`` (point, stop).

    Examples
    --------
    An orbit of the paper's oscillator moving at its third harmonic only (an NNM2 orbit read over three
    periods) is NNM2 seen at a third of its frequency:

    >>> import numpy as np
    >>> from nnmstop.models.structure import two_dof_structure
    >>> q = np.zeros((1, 2, 4)); q[0, :, 3] = [0.5, -0.3]   # x and u out of phase, harmonic 3
    >>> f = np.zeros((1, 1, 4)); f[0, 0, 3] = 0.05           # the stop near rest: f = eta x
    >>> ident = orbit_identity(two_dof_structure(), q, 0 * q, f, 0 * f)
    >>> identity_label(*(int(ident[k][0]) for k in ("orbit_kind", "dominant_mode", "dominant_harmonic",
    ...                                             "tongue_harmonic")))
    'NNM2 seen at 1/3 of its frequency'
    """
    q_cos, q_sin = np.asarray(q_cos, float), np.asarray(q_sin, float)
    mass, stiffness = structure.mass, structure.stiffness
    shares = harmonic_shares(mass, q_cos, q_sin)
    n_points = shares.shape[0]
    dominant = np.argmax(shares, axis=1) + 1 if shares.size else np.zeros(0, dtype=int)
    rows = np.arange(n_points)
    stiffness_eff = effective_stop_stiffness(structure, q_cos, q_sin, f_cos, f_sin, f2_cos, f2_sin)
    mode, mode_share = np.zeros(n_points, dtype=np.int32), np.zeros(n_points)
    for i in range(n_points):
        k = int(dominant[i])
        m_shares = _mode_shares(structure, mass, stiffness, stiffness_eff[i], q_cos[i, :, k], q_sin[i, :, k])
        mode[i], mode_share[i] = int(np.argmax(m_shares)) + 1, float(np.max(m_shares))
    others = shares.copy()
    if shares.size:
        others[rows, dominant - 1] = 0.0
    tongue = np.where(others.max(axis=1, initial=0.0) > TONGUE_SHARE, np.argmax(others, axis=1) + 1, 0)
    tongue = np.where(dominant == 1, tongue, 0)
    kind = np.where(dominant > 1, 2, np.where(tongue > 0, 1, 0))
    amplitude = q_cos[..., 1:] ** 2 + q_sin[..., 1:] ** 2
    moving = amplitude.max(axis=2, initial=0.0) > 0
    return {
        "dominant_harmonic": dominant.astype(np.int32),
        "dominant_harmonic_share": shares[rows, dominant - 1] if shares.size else np.zeros(0),
        "fundamental_share": shares[:, 0] if shares.size else np.zeros(0),
        "dominant_mode": mode,
        "dominant_mode_share": mode_share,
        "tongue_harmonic": tongue.astype(np.int32),
        "orbit_kind": kind.astype(np.int8),
        "dof_dominant_harmonic": np.where(moving, np.argmax(amplitude, axis=2) + 1, 0).astype(np.int32),
        "effective_stop_stiffness": stiffness_eff,
    }


def identity_label(kind: int, mode: int, harmonic: int, tongue: int = 0) -> str:
    """An orbit's identity in words: ``"NNM1"``, ``"3:1 tongue of NNM1"``, ``"NNM2 seen at 1/7 of its frequency"``.

    ``kind``: code of ``orbit_kind`` (:data:`KINDS`); ``mode``: ``dominant_mode``; ``harmonic``:
    ``dominant_harmonic``; ``tongue``: ``tongue_harmonic``.
    """
    if kind == 2:
        return f"NNM{mode} seen at 1/{harmonic} of its frequency"
    if kind == 1:
        return f"{tongue}:1 tongue of NNM{mode}"
    return f"NNM{mode}"


def _point_labels(ds) -> list[str]:
    return [
        identity_label(int(k), int(m), int(n), int(t))
        for k, m, n, t in zip(
            ds["orbit_kind"].values, ds["dominant_mode"].values, ds["dominant_harmonic"].values,
            ds["tongue_harmonic"].values,
        )
    ]  # fmt: skip


@dataclass(frozen=True)
class IdentityRun:
    """Consecutive points of a branch with one identity: ``[start, stop)``, its ``label`` and codes."""

    start: int
    stop: int
    label: str
    kind: int
    mode: int
    harmonic: int
    tongue: int = 0

    @property
    def family(self) -> str:
        """The family the orbits belong to (a tongue belongs to its fundamental's NNM): ``"NNM1"``, ``"NNM2/7"``."""
        return f"NNM{self.mode}" if self.kind != 2 else f"NNM{self.mode}/{self.harmonic}"


def identity_runs(ds) -> list[IdentityRun]:
    """The runs of constant identity along a branch dataset (a dataset with ``orbit_kind`` ..., in branch order).

    Each change between two runs is where the branch crosses onto another family (a tongue, another NNM
    seen at 1/n of its frequency) and the next run says what it becomes.
    """
    if "orbit_kind" not in ds or ds.sizes.get("point", 0) == 0:
        return []
    labels = _point_labels(ds)
    codes = [ds[v].values for v in ("orbit_kind", "dominant_mode", "dominant_harmonic", "tongue_harmonic")]
    starts = [0] + [i for i in range(1, len(labels)) if labels[i] != labels[i - 1]]
    stops = starts[1:] + [len(labels)]
    return [IdentityRun(a, b, labels[a], *(int(c[a]) for c in codes)) for a, b in zip(starts, stops)]


def branch_identity_text(ds, limit: int = 12) -> str:
    """The runs of :func:`identity_runs` in words, with their energies (at most ``limit``, then how many more)."""
    runs = identity_runs(ds)
    energy = ds["energy"].values if runs else np.zeros(0)
    parts = [
        f"{run.label} (points {run.start}-{run.stop - 1}, E {energy[run.start]:.4g} -> {energy[run.stop - 1]:.4g})"
        for run in runs[:limit]
    ]
    if len(runs) > limit:
        parts.append(f"... {len(runs) - limit} more runs")
    return "; ".join(parts) if parts else "no orbit"
