"""Generic stability on the 3-DOF example: a reference commit's code against this tree's, side by side in one run.

NNM1 of the 3-DOF example (issue 21, docs: a grounded chain ``M = I``, ``K = [[2, -1, 0], [-1, 2, -1], [0, -1, 1]]``,
one stop on DOF 0 with gap 1, ``alpha = 30``, ``eta = 0.1``) at ``H = 50``, continued by this tree's code from the
linear mode up to ``--energy-max`` (25: about 160 points). Then, each in a fresh interpreter on the same points:

* the reference commit's generic stability (``--reference``, default ``fc5e57b``, the commit before issue 21's
  stability work): ``nnmstop.hbm.structure_stability.structure_stability`` with its defaults (256 and 512 Magnus
  steps per period, one ``scipy.linalg.expm`` per step; stable when ``max |mu| <= 1 + 1e-4``);
* this tree's one interface ``nnmstop.hbm.stability.orbit_stability`` with the ``stability`` section of
  ``config/config.yaml`` (shooting refinement included).

With ``--tube results/tube/nnm1.nc`` the orbits of a built tube branch instead (the reference with the
tube's former settings, 128 and 256 steps a period). The two run alternately, best of ``--repeat`` (CPU time,
``time.process_time``; wall time beside it). The report (``--output``) gives the commits, machine and load
(:func:`timing.run_header`), the points, seconds, the ratio, and the points whose verdicts differ.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/structure_stability.py [--reference fc5e57b] [--energy-max 25] \\
        [--repeat 1] [--output benchmarks/structure_stability.md]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from cold_build import REPO, tracked_copy
from timing import check_repeat, emit_report, git_commit

HARMONICS = 50  # of the example (--harmonics changes it, for tiny runs)

# The 3-DOF example, built in every interpreter from the same numbers.
_STRUCTURE = """
import numpy as np
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.structure import Stop, Structure
structure = Structure(np.eye(3), np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]),
                      [Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)])
system = HarmonicBalanceSystem(structure, {harmonics})
"""

# The tube of config/config.yaml (read without validation: the commits' schemas differ), with --tube.
_TUBE = """
import numpy as np, yaml
from nnmstop.hbm.system import HarmonicBalanceSystem
from nnmstop.models.beam import Beam, beam_structure
structure = beam_structure(Beam.from_parameters(yaml.safe_load(open({config!r}))["tube"]["structure"]))
system = HarmonicBalanceSystem(structure, {harmonics})
"""

_CONTINUE = (
    _STRUCTURE
    + """
from nnmstop.config import load_config
from nnmstop.continuation.anm import ANMSettings
from nnmstop.hbm.stages import BranchSettings, BranchSpec, StageSpec, follow_stage
config = load_config({config!r})
settings = ANMSettings.from_config(config["anm"], points_per_step=config["hbm"].get("points_per_step", 1))
up = StageSpec("up", {{"energy_above": {energy_max!r}}})
branch = follow_stage(system, BranchSettings(settings, config["hbm"]["max_truncation"],
                                             start_tolerance=settings.newton_threshold),
                      BranchSpec("nnm1", 1, 0.05, (up,), energy_max={energy_max!r}))
U = np.array(branch.points)
diagnostics = [system.diagnostics(u) for u in U]
np.savez({points!r}, U=U, time_residual=[d["time_residual"] for d in diagnostics],
         energy=[d["energy"] for d in diagnostics])
"""
)

_REFERENCE = """
import json, time
from nnmstop.hbm.structure_stability import structure_stability
data = np.load({points!r})
cpu, wall = time.process_time(), time.perf_counter()
r = structure_stability(system, data["U"], **{reference_settings!r})
cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
print(json.dumps(dict(cpu=cpu, wall=wall, stable=r.stable.tolist(), resolved=r.resolved.tolist(),
                      max_multiplier=r.max_multiplier.tolist(), error=r.error.tolist())))
"""

_THIS = """
import json, time
import yaml
from nnmstop.hbm.monodromy import MonodromySettings
from nnmstop.hbm.stability import StabilitySettings, orbit_stability
config = yaml.safe_load(open({config!r}))
settings = StabilitySettings(monodromy=MonodromySettings.from_config(config["stability"]))
data = np.load({points!r})
cpu, wall = time.process_time(), time.perf_counter()
r = orbit_stability(system, data["U"], settings, time_residual=data["time_residual"])
cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
print(json.dumps(dict(cpu=cpu, wall=wall, stable=r.stable.tolist(), resolved=r.resolved.tolist(),
                      max_multiplier=r.max_multiplier.tolist(), reason=r.reason.tolist(), margin=r.margin.tolist(),
                      error=r.integration_error.tolist(), refined=int(r.refined.sum()))))
"""


def run(code: str, source: Path) -> dict:
    """Run ``code`` in a fresh interpreter with the package of ``source`` (its ``src``); its last JSON line."""
    env = dict(os.environ, PYTHONPATH=str(source / "src"), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    if out.returncode:
        raise RuntimeError(f"the run with {source} failed:\n{out.stderr}")
    lines = out.stdout.strip().splitlines()
    return json.loads(lines[-1]) if lines else {}


def differences(reference: dict, this: dict, energy) -> list[str]:
    """Table rows of the points whose verdicts differ."""
    rows = []
    for i, (a, b) in enumerate(zip(reference["stable"], this["stable"])):
        if a != b:
            rows.append(
                f"| {i} | {energy[i]:.4g} | {'stable' if a else 'unstable'} ({reference['max_multiplier'][i]:.6f}, "
                f"error {reference['error'][i]:.1e}, {'resolved' if reference['resolved'][i] else 'unresolved'}) | "
                f"{'stable' if b else 'unstable'} (reason {this['reason'][i]}, margin {this['margin'][i]:.2e}, "
                f"error {this['error'][i]:.1e}) |"
            )
    return rows


def report(args, commits, points, best, last, energy) -> str:
    ref, this = best["reference"], best["this"]
    same = sum(a == b for a, b in zip(last["reference"]["stable"], last["this"]["stable"]))
    what = (
        f"the tube's orbits of `{args.tube}` (H = {args.harmonics}, {points} points)"
        if args.tube
        else f"NNM1 of the 3-DOF example (H = {args.harmonics}, {points} points up to energy {args.energy_max:g})"
    )
    settings = "steps 128, tolerance 1e-4: the tube's" if args.tube else "its defaults"
    lines = [
        f"Generic stability of {what}, side by side in one run, best of {args.repeat}, CPU seconds (wall in "
        "parentheses).",
        "",
        f"- reference: `{commits['reference']}` (`structure_stability`, {settings}); this: `{commits['this']}` "
        f"(`orbit_stability`, config/config.yaml's `stability`; {last['this']['refined']} orbits refined by shooting)",
        "",
        "| code | points | seconds | points per second |",
        "|---|---:|---:|---:|",
        f"| reference `{commits['reference']}` | {points} | {ref[0]:.2f} ({ref[1]:.2f}) | {points / ref[0]:.1f} |",
        f"| this `{commits['this']}` | {points} | {this[0]:.2f} ({this[1]:.2f}) | {points / this[0]:.1f} |",
        "",
        f"Ratio reference / this: **{ref[0] / this[0]:.0f}x** CPU ({ref[1] / this[1]:.0f}x wall).",
        "",
        f"Same `stable` on {same} of {points} points; resolved: reference {sum(last['reference']['resolved'])}, "
        f"this {sum(last['this']['resolved'])}.",
    ]
    rows = differences(last["reference"], last["this"], energy)
    if rows:
        lines += [
            "",
            "Points whose verdicts differ (reference: max |mu| from the eigenvalues of the monodromy, "
            "its step-doubling error; this: reason, margin of the invariants, integration error):",
            "",
            "| point | energy | reference | this |",
            "|---:|---:|---|---|",
            *rows,
        ]
    return "\n".join(lines)


def tube_points(dataset: Path, points_file: str) -> int:
    """The orbits of a built tube branch dataset as unknown vectors (DOF blocks and omega**2: all either code
    reads) with their time residuals and energies, into ``points_file``; returns H."""
    import xarray as xr

    from nnmstop.config import load_config
    from nnmstop.hbm.system import HarmonicBalanceSystem
    from nnmstop.models.beam import Beam, beam_structure

    with xr.open_dataset(dataset) as ds:
        harmonics = int(ds.attrs["harmonics"])
        structure = beam_structure(Beam.from_parameters(load_config(REPO / "config/config.yaml")["tube"]["structure"]))
        system = HarmonicBalanceSystem(structure, harmonics)
        U = np.zeros((ds.sizes["point"], system.n_unknowns))
        for j in range(system.n_dofs):
            U[:, system.slices[f"q{j}"]] = ds["q_cos"].values[:, j, : system.nc]
        U[:, system.i_lam] = ds["omega_squared"].values
        np.savez(points_file, U=U, time_residual=ds["time_residual"].values, energy=ds["energy"].values)
    return harmonics


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", default="fc5e57b", help="git ref of the code before the change")
    parser.add_argument("--energy-max", type=float, default=25.0)
    parser.add_argument("--harmonics", type=int, default=HARMONICS)
    parser.add_argument(
        "--tube",
        type=Path,
        help="a built tube branch dataset (results/tube/nnm1.nc): its orbits instead of the 3-DOF's",
    )
    parser.add_argument("--config", type=Path, default=REPO / "config/config.yaml")
    parser.add_argument("--repeat", type=int, default=1, help="best of this many runs of each")
    parser.add_argument("--output", type=Path, help="also write the Markdown report here")
    args = parser.parse_args(argv)
    check_repeat(args.repeat)
    config = str(args.config.resolve())
    with tempfile.TemporaryDirectory(prefix="nnmstop-structure-stability-") as tmp:
        reference = Path(tmp) / "reference"
        reference.mkdir()
        tracked_copy(reference, args.reference)
        points_file = str(Path(tmp) / "points.npz")
        if args.tube:
            args.harmonics = tube_points(args.tube, points_file)
            structure = _TUBE.format(config=config, harmonics=args.harmonics)
            reference_settings = {"steps": 128, "tolerance": 1e-4}  # the reference's tube.stability
        else:
            structure = _STRUCTURE.format(harmonics=args.harmonics)
            reference_settings = {}  # structure_stability's defaults
            continuation = _CONTINUE.format(
                harmonics=args.harmonics, config=config, energy_max=args.energy_max, points=points_file
            )
            run(continuation, REPO)
        data = np.load(points_file)
        codes = {
            "reference": (
                structure + _REFERENCE.format(points=points_file, reference_settings=reference_settings),
                reference,
            ),
            "this": (structure + _THIS.format(config=config, points=points_file), REPO),
        }
        best, last = {}, {}
        for _ in range(args.repeat):
            for name, (code, source) in codes.items():
                last[name] = run(code, source)
                old = best.get(name, (float("inf"), float("inf")))
                best[name] = (min(old[0], last[name]["cpu"]), min(old[1], last[name]["wall"]))
    commits = {"reference": git_commit(args.reference), "this": git_commit()}
    text = report(args, commits, len(data["U"]), best, last, data["energy"])
    return emit_report(text, args.output)


if __name__ == "__main__":
    sys.exit(main())
