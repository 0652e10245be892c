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


# --------------------------------------------------------------------------- forced responses (issue 30)


def _readme_block(section: str) -> str:
    """The Python block of a README section."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    part = text[text.index(f"## {section}\n") :]
    return part[part.index("```python\n") + len("```python\n") : part.index("```\n", part.index("```python"))]


def test_the_readme_forced_example_gives_exact_and_regularized_responses_with_stability(capsys):
    """README's forced section as written: a 2-DOF chain with a one-sided stop, both responses labelled as the
    pipeline's datasets; the regularized law (eta = alpha / 400) folds where the exact one does, within 1 %."""
    from nnmstop.netcdf import check_labelled

    namespace = {}
    exec(_readme_block("Forced responses"), namespace)  # noqa: S102 (the README's own code)
    exact, regularized = namespace["exact"], namespace["regularized"]
    assert "frequency" in capsys.readouterr().out
    for ds, kind in ((exact, "forced_exact"), (regularized, "forced_regularized")):
        check_labelled(ds)
        assert ds.attrs["dataset_kind"] == kind and ds.attrs["stop_kinds"] == "one_sided"
        assert (ds.stable == 0).any() and (ds.stable == 1).any()
    folds = [
        np.sort(ds.change_frequency.values[ds.change_kind.values == 0]) for ds in (exact, regularized)
    ]  # fold: flag 0
    assert len(folds[0]) == len(folds[1]) == 2
    np.testing.assert_allclose(folds[1][1], folds[0][1], rtol=0.01)  # the upper fold: the jump down


def test_the_forced_page_shows_the_readme_example():
    """docs/forced.md's example is README's (run above), line for line."""
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs" / "forced.md").read_text()
    block = page[page.index("```python\n") + len("```python\n") : page.index("```\n", page.index("```python"))]
    assert set(block.splitlines()) <= set(_readme_block("Forced responses").splitlines())


def test_forced_response_takes_the_configurations_forms_and_refuses_what_it_cannot_do():
    paper = nnmstop.two_dof_structure()
    ds = nnmstop.forced_response(paper, {"ratios": [0.01, 0.01], "modes": [1, 2]}, (0.01, ["u"]), (0.05, 0.35))
    assert ds.attrs["segment_kinds"] == "non_impacting" and list(ds.attrs["forcing_dofs"]) == [1]
    from nnmstop.models.excitation import linear_response

    amplitude = np.abs(linear_response(_paper_excitation(0.01), 2 * np.pi * ds.frequency.values))
    np.testing.assert_allclose(ds.amplitude.values, amplitude, rtol=1e-12)
    with pytest.raises(ValueError, match="method must be one of"):
        nnmstop.forced_response(paper, [0.01], (0.01, [1]), (0.05, 0.35), method="shooting")
    hole = nnmstop.Structure(np.eye(2), np.eye(2), [nnmstop.Stop(kind="circular", dofs=[0, 1], gap=1.0,
                                                                 stiffness=10.0, eta=0.1)])  # fmt: skip
    with pytest.raises(ValueError, match="method='regularized'"):
        nnmstop.forced_response(hole, [0.01], (0.1, [0]), (0.1, 0.3))
    with pytest.raises(ValueError, match="force dof 'w' is not a degree of freedom"):
        nnmstop.forced_response(paper, [0.01], (0.1, ["w"]), (0.1, 0.3))
    with pytest.raises(ValueError, match="frequency range"):
        nnmstop.forced_response(paper, [0.01], (0.1, [0]), (0.3, 0.1))


def _paper_excitation(force):
    from nnmstop.models.excitation import Damping, Excitation, HarmonicForce

    paper = nnmstop.two_dof_structure()
    return Excitation(paper, Damping.from_modal_ratios(paper, [0.01, 0.01]), HarmonicForce(force, [1]))
