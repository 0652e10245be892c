"""Structures: the paper's 2-DOF oscillator and the structure passed to the engines."""

# --- BRANCH-ONLY BRIDGE (branch fe, before the issue-12 restructure reaches it) -------------------
# On main the 2-DOF model lives in nnmstop/models/two_dof.py; on this branch it is still the flat
# nnmstop/model.py. Alias it under its future name so the new modules import it from where it will
# be. AT MERGE: take main's version of this file (the docstring line alone).
import importlib as _importlib
import sys as _sys

two_dof = _sys.modules.setdefault("nnmstop.models.two_dof", _importlib.import_module("nnmstop.model"))
