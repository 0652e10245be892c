"""Exact periodic orbits of the non-smooth (piecewise-linear) system, in closed form."""

# --- BRANCH-ONLY BRIDGE (branch fe, before the issue-12 restructure reaches it) -------------------
# This package shadows the flat module nnmstop/exact.py of this branch. Load that module under its
# future name nnmstop.exact.two_impact and re-export its names, so both the old imports
# (``from nnmstop.exact import follow_family``) and the new ones (``nnmstop.exact.two_impact``) work.
# AT MERGE: take main's version of this file (the docstring line alone).
import importlib.util as _util
import sys as _sys
from pathlib import Path as _Path

if "nnmstop.exact.two_impact" not in _sys.modules:
    _spec = _util.spec_from_file_location("nnmstop._flat_exact", _Path(__file__).parent.parent / "exact.py")
    _module = _util.module_from_spec(_spec)
    _sys.modules["nnmstop._flat_exact"] = _module
    _sys.modules["nnmstop.exact.two_impact"] = _module
    _spec.loader.exec_module(_module)
two_impact = _sys.modules["nnmstop.exact.two_impact"]
globals().update({_k: _v for _k, _v in vars(two_impact).items() if not _k.startswith("__")})
