"""The pyHarm side of ``forced_vs_pyharm.py``: the regularized frequency response with pyHarm (run in its own venv).

Not imported by the project: ``forced_vs_pyharm.py`` runs this file with the interpreter of the venv where it
installed pyHarm (PyPI ``pyharm-os``), passing the problem as JSON on stdin, and reads the result (JSON) on
stdout. pyHarm has no element for the regularized contact law of the paper (only the piecewise penalty law),
so :class:`RegularizedStop` (written here, registered through pyHarm's plugin function) adds the force
``gap f(x / gap)`` of the stop DOF, ``f`` the admissible root of the corrected cubic of Eq. (5)
(``nnmstop.models.two_dof.regularized_contact_force``, loaded from its file: it needs numpy only), by the
alternating frequency-time scheme on pyHarm's time grid, with its analytic Jacobian ``f'(x)``.

Counts: residual and Jacobian evaluations of the solver, and the linear solves of its Newton iterations (each
one an LU factorization of the dense Jacobian).
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import sys
import time

import numpy as np


def _load_law(path: str):
    spec = importlib.util.spec_from_file_location("two_dof_law", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def make_element(law, alpha: float, eta: float, gap: float):
    """The regularized stop as a pyHarm node-to-ground element (its keyword: ``RegularizedStop``)."""
    from pyHarm.Elements.NodeToNodeElements.NodeToNodeElement import NodeToNodeElement

    params = law.ModelParameters(alpha=alpha, eta=eta)

    class RegularizedStop(NodeToNodeElement):
        factory_keyword = "RegularizedStop"

        def __flag_update__(self):
            self.flag_nonlinear = True
            self.flag_AFT = True

        def adim(self, lc, wc):
            raise ValueError("RegularizedStop is used with adim status False (nondimensional model already)")

        def _relative(self):
            return (self.Pdir[0] @ (self.Pslave - self.Pmaster)).astype(float)  # (n_coefficients, element dofs)

        def evalResidual(self, xg, om):
            P = self._relative()
            x_t = (P @ xg[self.indices]) @ self.D["ft"]  # stop DOF over pyHarm's time grid
            f_t = gap * law.regularized_contact_force(x_t / gap, params)
            self.R = P.T @ (f_t @ self.D["tf"])
            return self.R

        def evalJacobian(self, xg, om):
            P = self._relative()
            x_t = (P @ xg[self.indices]) @ self.D["ft"]
            k_t = law.regularized_contact_stiffness(x_t / gap, params)
            block = (self.D["ft"] * k_t) @ self.D["tf"]  # d(coefficients of f)/d(coefficients of x), transposed
            self.J = P.T @ block.T @ P
            self.dJdom = np.zeros((len(self.indices), 1))
            return self.J, self.dJdom

    return RegularizedStop


def _counted(owner, name: str, counts: dict):
    original = getattr(owner, name)

    def wrapper(*args, **kwargs):
        counts[name] = counts.get(name, 0) + 1
        return original(*args, **kwargs)

    setattr(owner, name, wrapper)


def run(problem: dict) -> dict:
    from pyHarm.BaseUtilFuncs import pyHarm_plugin
    from pyHarm.Maestro import Maestro

    law = _load_law(problem["law_file"])
    stop = problem["stop"]
    pyHarm_plugin(make_element(law, stop["alpha"], stop["eta"], stop["gap"]))
    matrices = {key: np.asarray(problem[key], dtype=float) for key in ("M", "C", "K")}
    matrices["G"] = 0.0 * matrices["M"]
    n = len(matrices["M"])
    data = {
        "analysis": {"frf": {"study": "frf", **problem["continuation"], "verbose": False}},
        "system": {
            "type": "Base",
            "nh": problem["harmonics"],
            "nti": problem["time_samples"],
            "adim": {"status": False},
        },
        "substructures": {"oscillator": {"matrix": matrices, "ndofs": 1}},
        "connectors": {
            "force": {
                "type": "CosinusForcing",
                "connect": {"oscillator": [problem["force_dof"]]},
                "dirs": [0],
                "amp": problem["force"],
            },
            "stop": {"type": "RegularizedStop", "connect": {"oscillator": [stop["dof"]]}, "dirs": [0]},
        },
    }
    with contextlib.redirect_stdout(io.StringIO()):
        maestro = Maestro(data)
    analysis = maestro.nls["frf"]
    counts: dict = {}
    for name in ("residual", "jacobian"):
        _counted(analysis.solver, name, counts)
    if hasattr(analysis.solver, "_linSysdeltak"):
        _counted(analysis.solver, "_linSysdeltak", counts)
    rows = [maestro.getIndex("oscillator", j, 0) for j in range(n)]
    started, cpu = time.perf_counter(), time.process_time()
    with contextlib.redirect_stdout(io.StringIO()):
        maestro.operate()
    wall, cpu = time.perf_counter() - started, time.process_time() - cpu
    accepted = [s for s in analysis.SolList if s.flag_accepted]
    x = np.array([s.x for s in accepted])
    return {
        "wall_seconds": wall,
        "cpu_seconds": cpu,
        "points": len(accepted),
        "attempts": len(analysis.SolList),
        "omega": x[:, -1].tolist(),
        # per DOF: pyHarm's layout [c_0, c_1, s_1, c_2, s_2, ...]
        "coefficients": [x[:, np.asarray(r)].tolist() for r in rows],
        "residual_evaluations": counts.get("residual", 0),
        "jacobian_evaluations": counts.get("jacobian", 0),
        "linear_solves": counts.get("_linSysdeltak", 0),
    }


if __name__ == "__main__":
    json.dump(run(json.load(sys.stdin)), sys.stdout)
