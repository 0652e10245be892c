"""What an orbit is, from its harmonic content (nnmstop.hbm.identity), against independent references.

References: the linear modes of the structure (closed-form 2-DOF modes and the eigenvectors of a chain) for
orbits near rest continued from each mode; orbits built to be another orbit read over n periods (the same
HBM orbit with its harmonics k moved to n k and its frequency divided by n: a different orbit of period
n T of the same equations); the regularized law's slope eta at rest and its bound alpha; and along a
continued branch, the identity changes stored by the branch datasets against the runs recomputed from the
per-point identity.
"""

import numpy as np
import pytest

from nnmstop.continuation.core import relative_residual
from nnmstop.hbm.dataset import orbit_variables
from nnmstop.hbm.identity import TONGUE_SHARE, identity_label, identity_runs, orbit_identity
from nnmstop.hbm.stages import start_point
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import Stop, Structure, normal_modes, two_dof_structure
from nnmstop.models.two_dof import ModelParameters, regularized_contact_force

H = 24


def _identity(system, U):
    data = orbit_variables(system, np.atleast_2d(U))
    return orbit_identity(system.structure, *(data[name][1] for name in ("q_cos", "q_sin", "f_cos", "f_sin")))


def _label(ident, i=0):
    return identity_label(*(int(ident[k][i]) for k in ("orbit_kind", "dominant_mode", "dominant_harmonic",
                                                       "tongue_harmonic")))  # fmt: skip


def _law_slope(stop, amplitude: float) -> float:
    """``<f x> / <x^2>`` of the regularized law (its closed-form root) over ``x = amplitude cos(theta)``."""
    x = amplitude * np.cos(np.linspace(0.0, 2.0 * np.pi, 4096, endpoint=False))
    f = regularized_contact_force(x, ModelParameters(alpha=stop.stiffness, eta=stop.eta))
    return float(np.mean(f * x) / np.mean(x * x))


def _read_over(system, U, n: int):
    """The orbit ``U`` read over ``n`` of its periods: harmonic k becomes n k, omega^2 becomes omega^2 / n^2."""
    blocks = system.split(U)
    moved = []
    for block in blocks[:-2]:
        out = np.zeros_like(block)
        out[0::n] = block[: len(out[0::n])]
        moved.append(out)
    return np.concatenate(moved + [[blocks[-2] / n**2], [blocks[-1]]])


CHAIN = Structure(
    np.eye(3), [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]], [Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)]
)


@pytest.mark.parametrize("structure", [two_dof_structure(), two_dof_structure(ModelParameters(beta=2.0, delta=0.5)),
                                       CHAIN], ids=["paper", "beta2_delta0.5", "chain"])  # fmt: skip
def test_orbits_near_rest_are_the_linear_mode_they_start_from(structure):
    """Each mode's orbit at small amplitude: dominant harmonic 1 with nearly all of the motion, of that mode;
    its shape's mode checked against the eigenvectors of K + eta e e^T (the regularized structure near rest)."""
    system = HarmonicBalanceSystem(structure, H)
    for mode in range(1, structure.n_dofs + 1):
        U, _ = start_point(system, mode, 0.05)
        ident = _identity(system, U)
        assert _label(ident) == f"NNM{mode}"
        assert ident["fundamental_share"][0] > 1 - 1e-6
        assert ident["dominant_mode_share"][0] > 1 - 1e-6
        stop = structure.stops[0]
        # f = eta x (1 + O(x^2)) near rest: the law's own slope over the orbit's (nearly cosine) stop coordinate
        assert ident["effective_stop_stiffness"][0, 0] == pytest.approx(_law_slope(stop, 0.05), rel=1e-5)
        assert ident["effective_stop_stiffness"][0, 0] == pytest.approx(stop.eta, rel=3e-3)


def test_an_orbit_read_over_n_periods_is_seen_at_one_nth_of_its_frequency():
    """NNM2 of the oscillator at a moderate amplitude, read over 3, 5 and 7 of its periods: still a periodic orbit
    of the same equations (residual at round-off), named NNM2 seen at 1/n; every DOF moves at harmonic n."""
    system = HarmonicBalanceSystem(two_dof_structure(), 3 * H)
    U2, _ = start_point(system, 2, 0.3)
    for n in (3, 5, 7):
        U = _read_over(system, U2, n)
        assert relative_residual(system, U) < 1e-10
        ident = _identity(system, U)
        assert _label(ident) == f"NNM2 seen at 1/{n} of its frequency"
        assert ident["fundamental_share"][0] == 0.0
        assert ident["dof_dominant_harmonic"][0].tolist() == [n, n]


def test_a_resonant_harmonic_above_a_tenth_of_the_motion_makes_a_tongue():
    """NNM1's linear shape at the first harmonic plus NNM2's at the third, in chosen proportions: below the
    tongue share it stays NNM1, above it the 3:1 tongue of NNM1, and past the fundamental NNM2 seen at 1/3."""
    structure = two_dof_structure()
    _, shapes = normal_modes(structure)  # M = I: the mean square of a_k phi_k is a_k^2 / 2
    for share, expected in (
        (TONGUE_SHARE / 2, "NNM1"),
        (2 * TONGUE_SHARE, "3:1 tongue of NNM1"),
        (0.7, "NNM2 seen at 1/3 of its frequency"),
    ):
        q = np.zeros((1, 2, 6))
        q[0, :, 1] = np.sqrt(1 - share) * shapes[:, 0]
        q[0, :, 3] = np.sqrt(share) * shapes[:, 1]
        f = 0.1 * q[:, :1]  # the stop near rest: f = eta x
        ident = orbit_identity(structure, q, 0 * q, f, 0 * f)
        assert _label(ident) == expected
        assert ident["dominant_harmonic_share"][0] == pytest.approx(max(share, 1 - share), rel=1e-12)


def test_the_effective_stiffness_is_the_least_squares_slope_of_the_stop_force_in_time():
    """NNM1 of the oscillator continued past grazing to E = 30 (H = 24): <f x>/<x^2> from the coefficients
    (Parseval) equals the same means over the synthesized time history of the orbit; it starts at the law's
    slope at rest, grows as the stop engages, and stays in (eta, alpha); every orbit is NNM1 or its 3:1 tongue."""
    from nnmstop import fourier
    from nnmstop.continuation.anm import ANMSettings, continue_anm

    params = ModelParameters()
    system = HarmonicBalanceSystem(two_dof_structure(params), H)
    U0, direction = start_point(system, 1, 0.05)

    def stop(U, d):
        return "energy" if d["energy"] > 30.0 else ""

    U = np.array(continue_anm(system, U0, direction, stop, ANMSettings(points_per_step=1, max_steps=200)).points)
    ident = _identity(system, U)
    k = ident["effective_stop_stiffness"][:, 0]
    data = orbit_variables(system, U)
    samples = 8 * H
    x = fourier.to_time(fourier.from_cos_sin(data["q_cos"][1][:, 0], data["q_sin"][1][:, 0]), H, samples)
    f = fourier.to_time(fourier.from_cos_sin(data["f_cos"][1][:, 0], data["f_sin"][1][:, 0]), H, samples)
    x, f = x - x.mean(axis=1, keepdims=True), f - f.mean(axis=1, keepdims=True)
    np.testing.assert_allclose(k, (f * x).mean(axis=1) / (x * x).mean(axis=1), rtol=1e-10)
    assert k[0] == pytest.approx(_law_slope(system.structure.stops[0], 0.05), rel=1e-5)
    assert np.all((k > params.eta) & (k < params.alpha)) and k[-1] > 50 * params.eta
    assert {_label(ident, i) for i in range(len(k))} <= {"NNM1", "3:1 tongue of NNM1"}


def test_identity_runs_follow_the_per_point_identity(h40_nnm1_stages):
    """On a continued branch (NNM1 stages 1-2 at H = 40, through the 3:1 resonance): the stored identity
    changes are exactly where the recomputed per-point labels change, and the runs tile the branch."""
    from nnmstop.hbm.stages import combine_stages

    ds = combine_stages(list(h40_nnm1_stages))
    runs = identity_runs(ds)
    assert runs[0].label == "NNM1" and runs[0].start == 0 and runs[-1].stop == ds.sizes["point"]
    assert [r.start for r in runs[1:]] == ds["identity_change_point"].values.tolist()
    assert all(a.stop == b.start and a.label != b.label for a, b in zip(runs, runs[1:]))
    assert any(r.kind == 1 and r.tongue == 3 for r in runs)  # the 3:1 tongue the paper's Fig 8 shows
