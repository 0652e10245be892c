#!/usr/bin/env python
"""Full sparse path against the reduced one on the tube on three plates, N = 1e2 .. 1e5 DOFs, H = 100.

Usage::

    python benchmarks/reduction_scaling.py [--dofs 100 1000 10000 100000] [--full-step-max 10000]
        [--full-branch-max 1000] [--modes 24] [--harmonics 100] [--output benchmarks/reduction_scaling.md]
    python benchmarks/reduction_scaling.py --tiny --output /tmp/scaling.md     # seconds (the tests)

The model is ``nnmstop.models.beam.tube_plates_parameters`` (clamped-pinned tube, three plates) with
``N / 2`` elements (rounded to a multiple of 4). Every case runs in its own interpreter with one BLAS thread
(peak resident memory ``ru_maxrss`` of that process, interpreter included):

* ``reduced``: the full model assembled (sparse), reduced onto the plates' DOFs and ``--modes`` fixed-interface
  modes (one-time cost: sparse LU of ``K_ii``, ``modes + 1`` eigenpairs by shift-invert Lanczos, projection),
  then NNM1 continued by the engine (HBM, cosine basis, ANM with config/config.yaml's ``anm`` settings) up to
  energy 100, and its dataset assembled with the Floquet stability of every stored point (monodromy);
* ``files`` (from ``--files-min`` DOFs on): the same, its matrices written as Matrix Market files in a
  shuffled DOF numbering (an FE code's own) and read back by ``structure: kind: matrices``'s reader with its
  checks (symmetry, definiteness by a sparse LDL^T, held by the stops), time of reading and checking apart;
* ``full``: the same model without reduction (the engine's sparse path): one ANM step from NNM1 at half the
  gap (up to ``--full-step-max`` DOFs) and the same continuation (up to ``--full-branch-max`` DOFs; its
  stability is not computed: a monodromy matrix of order 2N per orbit is what the reduction avoids).

Ends with the exponents of the one-time cost and of the reduced continuation's cost per step in N.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from timing import emit_report

ROOT = Path(__file__).resolve().parents[1]
ENERGY = 62.0  # the tube's NNM1 backbone below its energy fold (config/config.yaml's tube_plates)


def _settings(newton_threshold: float | None = None, max_steps: int = 400):
    from nnmstop.config import load_config
    from nnmstop.continuation.anm import ANMSettings
    from nnmstop.hbm.stages import BranchSettings, BranchSpec, StageSpec

    anm = {**load_config(ROOT / "config" / "config.yaml")["anm"], "max_steps": max_steps}
    if newton_threshold is not None:
        anm["newton_threshold"] = newton_threshold
    settings = BranchSettings(ANMSettings.from_config(anm, points_per_step=2), 1e-3, start_tolerance=1e-7)
    spec = BranchSpec("nnm1", 1, 0.05, (StageSpec("backbone", {"energy_above": ENERGY}),))
    return settings, spec


def membrane_structure(dofs: int):
    """A square membrane (5-point Laplacian on an ``n x n`` grid of interior nodes, edges fixed, ``n**2`` close to
    ``dofs``) with three stops on its middle line at n/4, n/2, 3n/4; nondimensional: lumped mass, the first
    frequency 1, the stops' gap 1, stiffness 3 times the static stiffness at the middle stop, eta 1/300 of it.
    Its stiffness's condition grows as ``N`` (second order), not as ``N**2`` (a beam's ``N**4`` in its elements)."""
    import scipy.sparse
    import scipy.sparse.linalg

    from nnmstop.models.structure import Stop, Structure

    n = max(4, int(round(np.sqrt(dofs))))
    line = scipy.sparse.diags([2.0 * np.ones(n), -np.ones(n - 1), -np.ones(n - 1)], [0, -1, 1])
    laplacian = scipy.sparse.kronsum(line, line, format="csc")
    laplacian = laplacian / (2 * 4 * np.sin(np.pi / (2 * (n + 1))) ** 2)  # first eigenvalue 1 with M = I
    area = 1.0 / (n + 1) ** 2  # lumped mass of a node (unit square): energies do not grow with the mesh
    nodes = [(n // 2) * n + n // 2, (n // 2) * n + n // 4, (n // 2) * n + (3 * n) // 4]
    unit = np.zeros(n * n)
    unit[nodes[0]] = 1.0
    static = area / scipy.sparse.linalg.splu(laplacian).solve(unit)[nodes[0]]
    stops = tuple(Stop(dof=d, gap=1.0, stiffness=3.0 * static, eta=3.0 * static / 300.0) for d in nodes)
    return Structure(area * scipy.sparse.identity(n * n, format="csr"), area * laplacian.tocsr(), stops)


def _elements(dofs: int) -> int:
    return max(4, int(round(dofs / 2 / 4)) * 4)


def run_case(path: str, dofs: int, modes: int, harmonics: int, branch: bool, full_threshold: float) -> dict:
    from nnmstop.hbm.stages import follow_stage, stage_dataset
    from nnmstop.hbm.system import HarmonicBalanceSystem
    from nnmstop.models.beam import Beam, beam_structure, tube_plates_parameters
    from nnmstop.models.reduction import craig_bampton

    out = {"path": path}
    started = time.perf_counter()
    if path == "files":
        structure = membrane_structure(dofs)
    else:
        out["elements"] = _elements(dofs)
        structure = beam_structure(Beam.from_parameters(tube_plates_parameters(out["elements"])))
    out["assembly"] = time.perf_counter() - started
    out["dofs"] = structure.n_dofs
    if path == "files":
        structure, out["read_and_check"] = _through_files(structure)
    if path in ("reduced", "files"):
        started = time.perf_counter()
        try:
            structure = craig_bampton(structure, modes)
        except ValueError as err:  # measured: the model cannot be reduced in double precision
            out["failed"] = f"reduction refused: {err}"
            out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            return out
        out["reduction"] = time.perf_counter() - started
        out.update({f"reduction_{k}": v for k, v in structure.reduction.costs.items()})
        out["reduced_dofs"] = structure.n_dofs
        out["first_neglected_over_first"] = float(structure.reduction.next_frequency)  # omega_1 = 1
    system = HarmonicBalanceSystem(structure, harmonics)
    out["unknowns"] = system.n_unknowns
    settings, spec = _settings(full_threshold if path == "full" else None)
    out["newton_threshold"] = settings.continuation.newton_threshold
    if path == "full":
        out.update(_one_step(system, settings))
    if branch:
        from nnmstop.continuation.core import ContinuationError

        started = time.perf_counter()
        try:
            continued = follow_stage(system, settings, spec)
        except ContinuationError as err:  # measured: the full path's continuation fails at this size
            out["failed"] = str(err)
            out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            return out
        out["branch"] = time.perf_counter() - started
        out["steps"] = continued.stats.steps
        out["per_step"] = out["branch"] / max(continued.stats.steps, 1)
        out["end"] = continued.end_reason
        out["final_frequency"] = float(system.frequency_hz(continued.points[-1]))
        if path in ("reduced", "files"):
            started = time.perf_counter()
            ds = stage_dataset(system, continued, 1, settings, {"branch": "nnm1"})
            out["stability"] = time.perf_counter() - started
            resolved = ds.stability_resolved.values == 1
            out["points"] = int(ds.sizes["point"])
            out["resolved"] = int(resolved.sum())
            out["stable"] = int(((ds.stable.values == 1) & resolved).sum())
    out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def _through_files(structure):
    """``structure`` written as Matrix Market files in a shuffled DOF numbering (an FE code's own), then read
    back by ``matrix_structure`` with its checks (symmetry, definiteness by a sparse LDL^T, held by the stops);
    returns the structure read and the seconds of reading and checking."""
    import tempfile

    import scipy.io

    from nnmstop.models.matrices import matrix_structure

    order = np.random.default_rng(0).permutation(structure.n_dofs)
    position = np.argsort(order)  # new index of each old DOF
    stops = [
        {"dof": int(position[s.dof]), "gap": s.gap, "stiffness": s.stiffness, "eta": s.eta} for s in structure.stops
    ]
    with tempfile.TemporaryDirectory() as folder:
        paths = {}
        for name in ("mass", "stiffness"):
            paths[name] = Path(folder) / f"{name}.mtx"
            scipy.io.mmwrite(paths[name], getattr(structure, name)[order][:, order].tocoo(), symmetry="symmetric")
        started = time.perf_counter()
        read = matrix_structure(paths["mass"], paths["stiffness"], stops)
        return read, time.perf_counter() - started


def _one_step(system, settings) -> dict:
    """Time of one ANM step of the full model from NNM1 at half the gap (corrected to round-off, true tangent,
    untimed); a step that fails is reported with its reason."""
    from nnmstop.continuation.core import ContinuationError, ContinuationStats, unit_tangent
    from nnmstop.hbm.reduced import orbit_at_amplitude

    direction = np.zeros(system.n_unknowns)
    direction[system.phase_dof * system.nc + 1] = 1.0
    try:
        U = orbit_at_amplitude(system, system.linear_mode_guess(1, 0.5), 0.5, max_iter=12)  # the engine's count
    except ContinuationError as err:
        return {"one_step_failed": f"no start point: {err}"}
    tangent, _ = unit_tangent(system, U, direction)
    started = time.perf_counter()
    try:
        settings.continuation.stepper().step(system, U, tangent, ContinuationStats())
    except ContinuationError as err:
        return {"one_step_failed": str(err)}
    return {"one_step": time.perf_counter() - started}


def run_in_child(path, dofs, args, branch) -> dict:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    command = [sys.executable, __file__, "--case", path, str(dofs), "--modes", str(args.modes)]
    command += ["--harmonics", str(args.harmonics), "--full-threshold", str(args.full_threshold)]
    command += ["--branch"] if branch else []
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    if done.returncode != 0:  # measured too: the case and the end of its error
        last = done.stderr.strip().splitlines()[-1:] or [f"exit status {done.returncode}"]
        return {"path": path, "dofs": dofs, "assembly": 0.0, "peak_mb": 0.0, "failed": f"process: {last[0]}"}
    return json.loads(done.stdout.strip().splitlines()[-1])


def _exponent(rows, key):
    points = [(r["dofs"], r[key]) for r in rows if key in r and r[key] > 0]
    if len(points) < 2:
        return None
    x, y = np.log([p[0] for p in points]), np.log([p[1] for p in points])
    return float(np.polyfit(x, y, 1)[0])


def _cell(row, key, fmt="{:.3g}"):
    return fmt.format(row[key]) if key in row else "-"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dofs", type=int, nargs="+", default=[100, 1000, 10000, 100000])
    parser.add_argument("--full-step-max", type=int, default=10000)
    parser.add_argument("--full-branch-max", type=int, default=1000)
    parser.add_argument("--modes", type=int, default=24)
    parser.add_argument("--files-min", type=int, default=1000, help="the membrane from .mtx files from this N on")
    parser.add_argument("--harmonics", type=int, default=100)
    parser.add_argument(
        "--full-threshold",
        type=float,
        default=1e-5,
        help="newton_threshold of the full path (its residual has a floor of ~1e-7 relative on a fine mesh)",
    )
    parser.add_argument("--tiny", action="store_true", help="N = 40, 80; H = 10; 8 modes (seconds)")
    parser.add_argument("--case", nargs=2, metavar=("PATH", "DOFS"), help=argparse.SUPPRESS)
    parser.add_argument("--branch", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--output", type=Path)
    args = parser.parse_args(argv)
    if args.case:
        case = run_case(args.case[0], int(args.case[1]), args.modes, args.harmonics, args.branch, args.full_threshold)
        print(json.dumps(case))
        return 0
    if args.tiny:
        args.dofs, args.modes, args.harmonics = [40, 80], 8, 10
        args.full_step_max = args.full_branch_max = args.files_min = 80
    started = time.perf_counter()
    reduced, full = [], []
    for dofs in args.dofs:
        reduced.append(run_in_child("reduced", dofs, args, True))
        if dofs >= args.files_min:
            reduced.append(run_in_child("files", dofs, args, True))
        if dofs <= args.full_step_max:
            full.append(run_in_child("full", dofs, args, dofs <= args.full_branch_max))
    lines = [
        "# Full sparse path against the reduced one (`python benchmarks/reduction_scaling.py`)",
        "",
        f"Tube on three plates (`tube_plates_parameters`), N DOFs; H = {args.harmonics}, cosine basis, NNM1 up to "
        f"energy {ENERGY:g} (config/config.yaml's anm settings, 2 points per step); reduced: {args.modes} "
        "fixed-interface modes and the 3 plate DOFs. The full path's Newton threshold is "
        f"{args.full_threshold:g} (the reduced path's: config/config.yaml's), its residual having a floor of about "
        "1e-7 relative on a fine mesh (a stiffness spanning N^4). Each case in its own process, one BLAS thread; "
        "peak = max RSS of that process (interpreter included). Times in seconds.",
        "",
        "| N | path | unknowns | assembly (+ files read, checked) | reduction (LU + eigen + projection) | ANM steps "
        "| per step | branch "
        "| stability of the points | points (stable / resolved) | one full step | peak (MB) |",
        "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in sorted(reduced + full, key=lambda r: (r["dofs"], r["path"])):
        reduction = (
            f"{row['reduction']:.3g} ({row['reduction_factorization']:.2g} + {row['reduction_eigensolve']:.2g} + "
            f"{row['reduction_projection']:.2g})"
            if "reduction" in row
            else "-"
        )
        points = f"{row['points']} ({row['stable']} / {row['resolved']})" if "points" in row else "-"
        assembly = f"{row['assembly']:.3g}" + (f" + {row['read_and_check']:.3g}" if "read_and_check" in row else "")
        lines.append(
            f"| {row['dofs']} | {row['path']} | {row.get('unknowns', '-')} | {assembly} | {reduction} | "
            f"{row.get('steps', '-')} | {_cell(row, 'per_step')} | {_cell(row, 'branch')} | "
            f"{_cell(row, 'stability')} | {points} | {_cell(row, 'one_step')} | {row['peak_mb']:.0f} |"
        )
    for row in reduced + full:
        for key in ("failed", "one_step_failed"):
            if key in row:
                what = "one ANM step" if key == "one_step_failed" else "run"
                lines.append(f"\n{row['path']} N = {row['dofs']}: the {what} failed: {row[key]}")
        if "end" in row:
            ending = f"ends at {row['end']}, last point's frequency {row['final_frequency']:.8g} Hz"
            lines.append(f"\n{row['path']} N = {row['dofs']}: {ending}")
    tube = [r for r in reduced if r["path"] == "reduced" and "branch" in r]
    files = [r for r in reduced if r["path"] == "files" and "branch" in r]

    def one_time(rows):
        return [
            {"dofs": r["dofs"], "cost": r["assembly"] + r.get("read_and_check", 0.0) + r["reduction"]} for r in rows
        ]

    exponents = {
        "tube, one-time cost (assembly + reduction)": _exponent(one_time(tube), "cost"),
        "tube, reduced continuation per ANM step": _exponent(tube, "per_step"),
        "membrane from files, one-time cost (assembly + files + reduction)": _exponent(one_time(files), "cost"),
        "membrane from files, reduced continuation per ANM step": _exponent(files, "per_step"),
        "tube, full sparse path, one ANM step": _exponent(full, "one_step"),
    }
    lines += [
        "",
        "The last point is the first stored one past the energy bound, where the steps happen to fall: its frequency "
        "says which branch each run followed, not how accurate it is (benchmarks/reduction_convergence.md compares "
        "reduced and full orbits at matched amplitudes).",
        "",
        "Fitted exponents in N over the sizes run:",
        "",
    ]
    lines += [f"- {name}: {value:.2f}" if value is not None else f"- {name}: -" for name, value in exponents.items()]
    lines.append("")
    for rows, what in ((tube, "tube on three plates"), (files, "membrane read from files")):
        if not rows:
            continue
        largest = max(rows, key=lambda r: r["dofs"])
        total = sum(largest.get(k, 0.0) for k in ("assembly", "read_and_check", "reduction", "branch", "stability"))
        lines.append(
            f"Largest {what}, N = {largest['dofs']}: NNM1 with stability by the reduced path in {total:.0f} s "
            f"(assembly {largest['assembly']:.0f}, files {largest.get('read_and_check', 0.0):.0f}, reduction "
            f"{largest['reduction']:.0f}, continuation {largest['branch']:.0f}, stability {largest['stability']:.0f}), "
            f"peak {largest['peak_mb']:.0f} MB; first neglected mode at {largest['first_neglected_over_first']:.3g} "
            "times the first linear frequency."
        )
    lines.append(f"whole run {time.perf_counter() - started:.0f} s")
    return emit_report("\n".join(lines), args.output)


if __name__ == "__main__":
    sys.exit(main())
