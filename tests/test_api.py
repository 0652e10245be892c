"""The Python API (``import nnmstop``): the objects a user composes, their docstring examples, and physics."""

from __future__ import annotations

import doctest
import subprocess
import sys

import numpy as np
import pytest

import nnmstop
from nnmstop import api
from nnmstop.models import contact, matrices, structure


def test_import_is_light_and_names_the_objects():
    """``import nnmstop`` loads no numerics until an object is used (workflow jobs import light modules)."""
    code = "import sys, nnmstop; print(sorted(m for m in ('numpy', 'xarray', 'scipy') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    for name in ("Structure", "Stop", "two_dof_structure", "matrix_structure", "continue_nnm", "stability"):
        assert name in dir(nnmstop) and getattr(nnmstop, name).__doc__
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        nnmstop.nothing  # noqa: B018


@pytest.mark.parametrize("module", [nnmstop, api, structure, matrices, contact], ids=lambda m: m.__name__)
def test_docstring_examples_run(module):
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0


def test_normal_modes_without_a_mode_count_give_every_mode():
    chain = nnmstop.Structure(np.eye(3), [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]],
                              [nnmstop.Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)])  # fmt: skip
    omega, shapes = nnmstop.normal_modes(chain)
    # the grounded chain of N unit masses and springs: omega_k = 2 sin((2k - 1) pi / (2 (2N + 1)))
    np.testing.assert_allclose(omega, 2 * np.sin((2 * np.arange(1, 4) - 1) * np.pi / 14), rtol=1e-12)
    np.testing.assert_allclose(shapes.T @ shapes, np.eye(3), atol=1e-12)  # mass-normalized, M = I


def test_a_continued_nnm_is_a_labelled_branch_of_its_structure():
    """NNM2 of the paper's oscillator from the API: the pipeline's schema, starting at the regularized linear
    mode (closed form) and hardening towards the gap-0 mode without reaching it."""
    params = nnmstop.ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
    nnm2 = nnmstop.continue_nnm(nnmstop.two_dof_structure(params), mode=2, harmonics=12, energy_max=3.0)
    from nnmstop.models.two_dof import linear_modes
    from nnmstop.netcdf import check_labelled

    check_labelled(nnm2)
    assert list(nnm2.dof_label.values) == ["x", "u"] and nnm2.attrs["branch"] == "nnm2"
    start = linear_modes(params, "regularized")[0][1] / (2 * np.pi)
    gap_zero = linear_modes(params, "gap_zero")[0][1] / (2 * np.pi)
    assert float(nnm2.frequency[0]) == pytest.approx(start, rel=1e-4)
    assert float(nnm2.energy[-1]) > 3.0 and start < float(nnm2.frequency[-1]) < gap_zero
