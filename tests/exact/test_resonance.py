"""The exact one-stop family of a beam leaves its backbone into an internal resonance (issue 21.9).

On the tube the family's frequency stays locked while its energy grows sixfold with no change of the
contact: the energy goes into a higher linear mode vibrating at an odd harmonic of the orbit. Checked on
the coarse tube of the tests (5 elements) against computations that share nothing with the closed-form
orbits: DOP853 time integration of the non-smooth finite-element equations with event location, and
the modes of (K, M) from scipy.
"""

import numpy as np
import pytest
import scipy.linalg
import yaml

from nnmstop.checks.time_integration import integrate_structure_nonsmooth
from nnmstop.exact.dataset import one_stop_backbone, one_stop_dataset
from nnmstop.exact.ndof import follow_one_stop_family
from nnmstop.exact.resonance import classify_resonances
from nnmstop.models.beam import Beam, beam_structure
from nnmstop.models.structure import two_dof_structure


@pytest.fixture(scope="module")
def coarse_tube(repo_root):
    config = yaml.safe_load((repo_root / "tests" / "data" / "small_tube_config.yaml").read_text())["tube"]
    structure = beam_structure(Beam.from_parameters(config["structure"]))
    family = follow_one_stop_family(structure, step=config["exact"]["step"], max_points=36)
    return structure, family, classify_resonances(family)


def _integrated_half_period(structure, family, i, samples):
    """The orbit ``i`` integrated over half a period from its state at q = 0, at ``samples + 1`` times."""
    z0 = np.concatenate([np.zeros(structure.n_dofs), family.initial_velocity[i]])
    t = 0.5 * family.period[i] * np.arange(samples + 1) / samples
    return integrate_structure_nonsmooth(structure, z0, t, rtol=1e-10, atol=1e-10), z0


def test_the_family_leaves_its_backbone_into_an_odd_internal_resonance(coarse_tube):
    structure, family, resonances = coarse_tube
    first = resonances.first()
    assert first is not None and first > 2  # a backbone from the grazing orbit, then the resonance
    assert np.all(resonances.mode[:first] == 0)
    mode, order = int(resonances.mode[first]), int(resonances.order[first])
    assert np.all(resonances.mode[first:] == mode) and np.all(resonances.order[first:] == order)
    assert order % 2 == 1 and order >= 3  # the symmetric orbits hold odd harmonics only
    # locked: along the resonance the energy grows by 5 % while the frequency moves by 1e-5 of itself
    energy, frequency = family.energy[first:], family.frequency[first:]
    assert energy[-1] / energy[0] > 1.05
    assert np.ptp(frequency) < 1e-5 * frequency[0]


def test_time_integration_sees_the_resonant_mode_in_the_difference_of_two_orbits(coarse_tube):
    """Two orbits of the resonance integrated by DOP853: each comes back to minus its start after half a period
    (the half-period symmetry of a periodic orbit of this class) with one impact; their difference lies in the
    classified mode, at the classified harmonic (modes from scipy)."""
    structure, family, resonances = coarse_tube
    first = resonances.first()
    mode, order = int(resonances.mode[first]), int(resonances.order[first])
    samples = 4 * order
    runs = []
    for i in (first + 4, len(family) - 1):
        trajectory, z0 = _integrated_half_period(structure, family, i, samples)
        np.testing.assert_allclose(trajectory.states[-1], -z0, rtol=0, atol=1e-6 * np.abs(z0).max())
        assert list(trajectory.switch_sides[trajectory.switch_sides != 0]) == [1]
        half = trajectory.states[:-1, : structure.n_dofs]
        runs.append(np.concatenate([half, -half]))  # the whole period: q(t + T/2) = -q(t)
    mass, stiffness = structure.dense_matrices()
    _, shapes = scipy.linalg.eigh(stiffness, mass)  # mass-normalized, increasing frequencies
    modal = (runs[1] - runs[0]) @ mass @ shapes  # the difference's modal coordinates over the period
    power = np.abs(np.fft.rfft(modal, axis=0)) ** 2
    per_mode = power.sum(axis=0)
    assert per_mode[mode - 1] > 0.99 * per_mode.sum()
    assert power[order, mode - 1] > 0.99 * per_mode[mode - 1]


def test_the_two_dof_family_has_no_internal_resonance(paper_params):
    """Near grazing and at high energy the second mode takes most of the energy growth, off resonance."""
    family = follow_one_stop_family(two_dof_structure(paper_params), step=0.05)
    resonances = classify_resonances(family)
    assert resonances.first() is None
    assert np.any(resonances.growth_mode == 2)  # the condition on the harmonic is what tells them apart


def test_the_dataset_names_the_resonance_and_the_backbone_leaves_it_out(coarse_tube):
    _, family, resonances = coarse_tube
    ds = one_stop_dataset(family)
    first = resonances.first()
    assert (
        f"{resonances.order[first]}:1 internal resonance with linear mode {resonances.mode[first]}"
        in (ds.attrs["internal_resonance"])
    )
    np.testing.assert_allclose(ds["modal_energy"].sum("mode").values, ds["energy"].values, rtol=1e-12)
    backbone = one_stop_backbone(ds)
    assert backbone.sizes["orbit"] == first and int(backbone["resonant_mode"].max()) == 0
