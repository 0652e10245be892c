"""nnmstop: nonlinear normal modes of structures with elastic stops (regularized and exact).

The objects a user composes (numpydoc docstrings with examples; ``examples/quickstart.py``):

* :class:`Structure`, :class:`Stop` — mass, stiffness and stops, nondimensional (``docs/structures.md``); a stop
  is bilateral (the paper's), one-sided, relative (between two DOFs) or a circular clearance
  (:mod:`nnmstop.models.contact`);
  :func:`two_dof_structure` — the paper's oscillator; :func:`matrix_structure`, :func:`load_matrix` —
  a structure of one's own from ``.mtx``/``.npz`` files; :func:`normal_modes` — its linear modes.
* :func:`continue_nnm` — an NNM by harmonic balance and the asymptotic numerical method, as a labelled
  :class:`xarray.Dataset`; :func:`stability` — Floquet multipliers of its orbits;
  :func:`exact_family` — the exact NNM1 of the non-smooth structure with one impact per stop side;
  :func:`forced_response` — its damped response to a harmonic force, exact or regularized, with stability.
  :func:`atlas` — the bifurcation atlas of the structure forced and damped (regions and curves over the
  frequency and the force, or a structural parameter).

Data flow of the package: :mod:`nnmstop.models` -> :mod:`nnmstop.exact` (closed-form orbits of the
non-smooth system) -> :mod:`nnmstop.hbm` / :mod:`nnmstop.continuation` (regularized NNMs) ->
:mod:`nnmstop.netcdf` -> :mod:`nnmstop.compare` -> :mod:`nnmstop.figures`; :mod:`nnmstop.tasks` reads the
configuration for the workflow.

Examples
--------
>>> import numpy as np
>>> import nnmstop
>>> chain = nnmstop.Structure(np.eye(3), [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]],
...                           [nnmstop.Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)])
>>> omega, shapes = nnmstop.normal_modes(chain)
>>> [round(float(w), 4) for w in omega]
[0.445, 1.247, 1.8019]
"""

__version__ = "0.1.0"

# The objects are imported when first used (PEP 562): ``import nnmstop.config`` or a workflow job that needs
# only a light module does not pay for the numerics' imports.
_EXPORTS = {
    "Structure": "nnmstop.models.structure",
    "Stop": "nnmstop.models.structure",
    "two_dof_structure": "nnmstop.models.structure",
    "normal_modes": "nnmstop.models.structure",
    "ModelParameters": "nnmstop.models.two_dof",
    "matrix_structure": "nnmstop.models.matrices",
    "load_matrix": "nnmstop.models.matrices",
    "continue_nnm": "nnmstop.api",
    "stability": "nnmstop.api",
    "exact_family": "nnmstop.api",
    "forced_response": "nnmstop.api",
    "atlas": "nnmstop.api",
}

__all__ = [*_EXPORTS, "__version__"]


def __getattr__(name):
    if name in _EXPORTS:
        import importlib

        value = getattr(importlib.import_module(_EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'nnmstop' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
