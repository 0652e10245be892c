"""Damping and force objects: Rayleigh damping from modal ratios, clear errors."""

import numpy as np
import pytest

from nnmstop.models.excitation import Damping, Excitation, HarmonicForce, linear_response, modal_damping_ratios
from nnmstop.models.structure import Stop, Structure, two_dof_structure
from nnmstop.models.two_dof import ModelParameters


def test_rayleigh_damping_gives_the_ratios_on_both_modes():
    structure = two_dof_structure(ModelParameters())
    excitation = Excitation(structure, Damping.from_modal_ratios(structure, [0.02, 0.03]), HarmonicForce(1.0, [1]))
    np.testing.assert_allclose(modal_damping_ratios(excitation, 2), [0.02, 0.03], rtol=1e-12)


def test_linear_response_of_one_mass_is_the_textbook_one():
    structure = Structure(np.eye(1) * 2.0, np.eye(1) * 8.0, (Stop(0, 1.0, 10.0, 0.1),))
    excitation = Excitation(structure, Damping(0.0, 0.05), HarmonicForce(0.3, [0]))
    omega = np.array([0.5, 2.0, 3.0])
    expected = 0.3 / (8.0 - 2.0 * omega**2 + 1j * omega * 0.05 * 8.0)
    np.testing.assert_allclose(linear_response(excitation, omega)[:, 0], expected, rtol=1e-14)


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda s: Damping(-0.1, 0.0), "negative damping"),
        (lambda s: Damping.from_modal_ratios(s, [-0.01, 0.01]), "negative damping"),
        (
            lambda s: Excitation(s, Damping(0.1, 0.0), HarmonicForce(1.0, [2])),
            r"forcing dof\(s\) \[2\] are off the model",
        ),
        (lambda s: HarmonicForce(0.0, [1]), "forcing amplitude must be > 0"),
    ],
)
def test_bad_input_is_named(make, message):
    structure = two_dof_structure(ModelParameters())
    with pytest.raises(ValueError, match=message):
        make(structure)
