#!/usr/bin/env python
"""Cost of one ANM step against the number of degrees of freedom: sparse ordered LU vs dense LU.

Usage::

    python benchmarks/fe_scaling.py [--dofs 50 100 200 400] [--harmonics 50 100] [--repeat 2]
        [--structure tube|chain] [--methods sparse dense] [--output benchmarks/fe_scaling.md]
    python benchmarks/fe_scaling.py --methods sparse --repeat 7     # the sparse cases alone
    python benchmarks/fe_scaling.py --tiny --output /tmp/fe.md      # seconds: 10 DOF, H = 5 (the tests)

Structures: the paper's 2-DOF oscillator (``two_dof_structure``), then the default tube of
``nnmstop.models.beam`` (``default_tube_parameters``: clamped-free Euler-Bernoulli beam, one
stop at 0.6 L) meshed with ``N / 2`` elements for ``N`` DOF (a multiple of 5 elements keeps the
stop on a node); ``--structure chain`` uses fixed-free spring-mass chains instead. Cosine basis,
the engine's default for NNM branches (``N (H + 1) + 2 (H + 1) + 1`` unknowns).

One ANM step is the engine's own (``nnmstop.continuation.anm.ANMStepper.step`` with the settings
of config/config.yaml: anm section, the tube's points per step): one factorization of the
bordered Jacobian ``[J; t^T]``, the series products and back-substitutions of orders 1..order,
step length, Padé approximant, end (and interior) points with their residual checks. The point
is NNM1 at half the gap, corrected by Newton to the continuation's threshold, with its true
tangent (both prepared with the sparse solver, untimed); the cost hardly depends on where on
the branch the step is.
Methods, each case in its own subprocess with one BLAS thread (peak resident memory
``ru_maxrss`` of that child, interpreter included):

* ``sparse``: the engine's sparse path (``linear_algebra="sparse"``: SuperLU in the
  harmonic-by-harmonic order);
* ``dense``: LAPACK LU of the same bordered matrix assembled dense in place (the engine's dense
  path without its extra ``vstack`` copy, which would double the memory at 40k unknowns).

The largest dense case (400 DOF, H = 100: 13 GB, tens of minutes) starts first, in the
background, while the others run one after the other. Ends with one line: the exponent of the
sparse cost per step fitted between the smallest and largest ``--dofs`` at the largest H, and the
measured dense/sparse ratio at the largest DOF for that H (when both methods ran).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from timing import emit_report

ROOT = Path(__file__).resolve().parents[1]
START_AMPLITUDE = 0.5  # of the gap: NNM1 before contact, reached by Newton from the linear mode
BACKGROUND_UNKNOWNS = 30000  # dense cases above this start first, in the background


def structure_of(dofs: int, kind: str):
    """The paper's oscillator (``dofs == 2``), the default tube with ``dofs`` DOF, or a chain."""
    import numpy as np
    import scipy.sparse as sp

    from nnmstop.models.beam import Beam, beam_structure, default_tube_parameters
    from nnmstop.models.structure import Stop, Structure, two_dof_structure
    from nnmstop.models.two_dof import ModelParameters

    if dofs == 2:
        return two_dof_structure(ModelParameters())
    if kind == "tube":
        if dofs % 10:
            raise ValueError(
                f"tube DOF count must be a multiple of 10 (2 per element, elements a multiple of 5 "
                f"so that the stop at 0.6 L is on a node), got {dofs}"
            )
        return beam_structure(Beam.from_parameters({**default_tube_parameters(), "n_elements": dofs // 2}))
    springs = np.ones(dofs)
    main = springs + np.append(springs[1:], 0.0)  # spring i links mass i-1 (or the ground) to mass i
    stiffness = sp.diags([main, -springs[1:], -springs[1:]], [0, -1, 1], format="csr")
    stop = Stop(dof=int(0.7 * dofs), gap=1.0, stiffness=30.0, eta=0.1)
    return Structure(sp.identity(dofs, format="csr"), stiffness, (stop,))


def dense_bordered(system, U, tangent):
    """``[J(U); t^T]`` as one Fortran-ordered array filled in place (no second n x n copy)."""
    import numpy as np

    n = system.n_unknowns
    coo = system.jacobian(U, sparse=True).tocoo()
    A = np.zeros((n, n), order="F")
    A[coo.row, coo.col] = coo.data
    A[-1] = tangent
    return A


def anm_settings():
    """The engine's ANM settings from config/config.yaml (anm section, the tube's points per step)."""
    from nnmstop.config import load_config
    from nnmstop.continuation.anm import ANMSettings

    config = load_config(ROOT / "config" / "config.yaml")
    return ANMSettings.from_config(config["anm"], points_per_step=config["tube"]["points_per_step"])


def run_case(method: str, dofs: int, harmonics: int, repeat: int, kind: str) -> dict:
    """Best-of-``repeat`` time of one ANM step (and of its factorization), and the peak memory of this process."""
    import resource

    import numpy as np

    from nnmstop.continuation.core import ContinuationStats, newton_correct, unit_tangent
    from nnmstop.continuation.linear import BorderedFactorization
    from nnmstop.hbm.system import HarmonicBalanceSystem

    system = HarmonicBalanceSystem(structure_of(dofs, kind), harmonics, linear_algebra="sparse")
    settings = anm_settings()
    U = system.linear_mode_guess(1, START_AMPLITUDE)
    direction = np.zeros(system.n_unknowns)
    direction[system.phase_dof * system.nc + 1] = 1.0  # the first stop's cos(theta) amplitude, as in the engine
    # corrected to the continuation's own accuracy: structure_start_point's 1e-12 is out of reach of round-off
    # on the finer meshes (the stiffness spans ~N**4)
    U, _ = newton_correct(system, U, direction, ContinuationStats(), tol=settings.newton_threshold)
    tangent, _ = unit_tangent(system, U, direction)
    stepper = settings.stepper()
    factor_time = []
    sparse_factorize = system.factorize_bordered

    def timed_factorize(U0, t):
        t0 = time.perf_counter()
        lu = (
            BorderedFactorization.of_matrix(dense_bordered(system, U0, t), overwrite=True)
            if method == "dense"
            else sparse_factorize(U0, t)
        )
        factor_time.append(time.perf_counter() - t0)
        return lu

    system.factorize_bordered = timed_factorize  # the step's factorize_bordered delegates to it
    best = None
    for _ in range(repeat):
        factor_time.clear()
        stats = ContinuationStats()
        t0 = time.perf_counter()
        result = stepper.step(system, U, tangent, stats)
        points = list(result.points)
        step = time.perf_counter() - t0
        if best is None or step < best["step"]:
            best = {
                "step": step,
                "factor": sum(factor_time),
                "factorizations": stats.factorizations,
                "newton_iterations": stats.newton_iterations,
                "points": len(points),
                "step_length": float(result.length),
            }
        del result, points
    return {
        "method": method,
        "dofs": dofs,
        "harmonics": harmonics,
        "unknowns": system.n_unknowns,
        "repeat": repeat,
        **best,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def case_command(method, dofs, harmonics, repeat, kind, threads):
    """Command and environment of one case in its own interpreter, ``threads`` BLAS threads."""
    env = dict(
        os.environ, OPENBLAS_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads), MKL_NUM_THREADS=str(threads)
    )
    command = [
        sys.executable,
        __file__,
        "--case",
        method,
        str(dofs),
        str(harmonics),
        "--repeat",
        str(repeat),
        "--structure",
        kind,
    ]
    return command, env


def case_result(name, returncode, stdout, stderr) -> dict:
    if returncode != 0:
        raise RuntimeError(f"case {name} failed:\n{stderr[-2000:]}")
    return json.loads(stdout.strip().splitlines()[-1])


def fitted_exponent(rows, harmonics, lo, hi) -> float | None:
    """Slope of log(sparse step time) against log(DOF) between ``lo`` and ``hi`` DOF (None below two sizes)."""
    import numpy as np

    points = sorted(
        (r["dofs"], r["step"])
        for r in rows
        if r["method"] == "sparse" and r["harmonics"] == harmonics and lo <= r["dofs"] <= hi
    )
    if len({dofs for dofs, _ in points}) < 2:
        return None
    n, cost = np.log(np.array(points)).T
    return float(np.polyfit(n, cost, 1)[0])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dofs", type=int, nargs="+", default=[50, 100, 200, 400])
    parser.add_argument("--harmonics", type=int, nargs="+", default=[50, 100])
    parser.add_argument("--structure", choices=("tube", "chain"), default="tube")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument(
        "--dense-repeat-max-unknowns",
        type=int,
        default=5000,
        help="dense cases above this many unknowns run once (minutes each, not noise-bound)",
    )
    parser.add_argument("--blas-threads", type=int, default=1)
    parser.add_argument("--output", type=Path, default=Path(__file__).with_name("fe_scaling.md"))
    parser.add_argument("--methods", nargs="+", choices=("sparse", "dense"), default=["sparse", "dense"])
    parser.add_argument("--tiny", action="store_true", help="10 DOF, H = 5, one run: checks that the script works")
    parser.add_argument("--case", nargs=3, metavar=("METHOD", "DOFS", "H"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.tiny:
        args.dofs, args.harmonics, args.repeat = [10], [5], 1
    if args.case:
        method, dofs, harmonics = args.case[0], int(args.case[1]), int(args.case[2])
        print(json.dumps(run_case(method, dofs, harmonics, args.repeat, args.structure)))
        return
    cases = []
    for harmonics in args.harmonics:
        for dofs in [2] + args.dofs:
            unknowns = (dofs + 2) * (harmonics + 1) + 1
            for method in args.methods:
                repeat = 1 if method == "dense" and unknowns > args.dense_repeat_max_unknowns else args.repeat
                cases.append((method, dofs, harmonics, repeat, unknowns))
    started = time.time()
    background = {}  # the largest dense cases first, while the others run one after the other
    for case in cases:
        if case[0] == "dense" and case[4] > BACKGROUND_UNKNOWNS:
            command, env = case_command(*case[:4], args.structure, args.blas_threads)
            background[case] = subprocess.Popen(
                command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
            print(f"started in the background: {case[0]} N={case[1]} H={case[2]} n={case[4]}", flush=True)
    rows = []

    def record(row):
        rows.append(row)
        print(
            f"{row['method']:6s} N={row['dofs']:4d} H={row['harmonics']:3d} n={row['unknowns']:6d} "
            f"step {row['step']:9.3f} s factor {row['factor']:9.3f} s peak {row['peak_mb']:8.0f} MB "
            f"(x{row['repeat']}, {row['factorizations']} factorization(s))",
            flush=True,
        )

    for case in cases:
        if case not in background:
            command, env = case_command(*case[:4], args.structure, args.blas_threads)
            done = subprocess.run(command, env=env, capture_output=True, text=True)
            record(case_result(case[:3], done.returncode, done.stdout, done.stderr))
    for case, process in background.items():
        stdout, stderr = process.communicate()
        record(case_result(case[:3], process.returncode, stdout, stderr))
    elapsed = time.time() - started
    top, largest = max(args.harmonics), max(args.dofs)

    def find(method, dofs, harmonics):
        return next((r for r in rows if (r["method"], r["dofs"], r["harmonics"]) == (method, dofs, harmonics)), None)

    def cells(row, keys):
        return [f"{row[k]:.4g}" if row else "-" for k in keys]

    structure = (
        "the default tube (clamped-free Euler-Bernoulli beam, one stop at 0.6 L), N / 2 elements"
        if args.structure == "tube"
        else "fixed-free spring-mass chains with one stop at 70 %"
    )
    lines = [
        "# Cost of one ANM step against the number of DOF (`python benchmarks/fe_scaling.py`)",
        "",
        f"2 DOF: the paper's oscillator; above: {structure}. Cosine basis. One step = the engine's ANM step "
        "(`ANMStepper.step`, config/config.yaml settings): one factorization of `[J; t^T]`, the series "
        "products and back-substitutions, Padé, end and interior points with their residual checks. "
        f"Sparse: SuperLU in the engine's order; dense: LAPACK LU of the same matrix. Best of {args.repeat} runs, "
        f"dense cases above {args.dense_repeat_max_unknowns} unknowns one run (column 'dense runs'); "
        f"{args.blas_threads} BLAS thread(s), each case in its own process; peak memory = max RSS of that process "
        "(interpreter included). The dense cases above "
        f"{BACKGROUND_UNKNOWNS} unknowns ran in the background, on the second core, while the others ran. "
        f"Whole run {elapsed / 60:.1f} min; on a shared machine absolute times stretch, the side-by-side ratios hold.",
        "",
        "| DOF | H | unknowns | sparse step (s) | sparse factorization (s) | dense step (s) | dense factorization (s) "
        "| speed-up | sparse peak (MB) | dense peak (MB) | dense runs |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for harmonics in args.harmonics:
        for dofs in [2] + args.dofs:
            sparse, dense = find("sparse", dofs, harmonics), find("dense", dofs, harmonics)
            unknowns = (sparse or dense)["unknowns"]
            speedup = f"{dense['step'] / sparse['step']:.0f}" if sparse and dense else "-"
            lines.append(
                "| "
                + " | ".join(
                    [
                        str(dofs),
                        str(harmonics),
                        str(unknowns),
                        *cells(sparse, ["step", "factor"]),
                        *cells(dense, ["step", "factor"]),
                        speedup,
                        *[f"{r['peak_mb']:.0f}" if r else "-" for r in (sparse, dense)],
                        str(dense["repeat"]) if dense else "-",
                    ]
                )
                + " |"
            )
    lo = min(args.dofs)
    exponents = {h: fitted_exponent(rows, h, lo, largest) for h in args.harmonics}
    factorizations = sorted({r["factorizations"] for r in rows})
    summary = (
        f"Fitted exponent of the sparse cost per step, {lo}-{largest} DOF: "
        + ", ".join(f"H = {h}: " + (f"{e:.2f}" if e is not None else "n/a (one size)") for h, e in exponents.items())
        + f". Factorizations per step in all cases: {factorizations}."
    )
    if "sparse" in args.methods and "dense" in args.methods:
        speedup = find("dense", largest, top)["step"] / find("sparse", largest, top)["step"]
        summary += f" Measured speed-up over dense LU at {largest} DOF, H = {top}: {speedup:.0f}x."
    lines += ["", summary]
    emit_report("\n".join(lines), args.output)


if __name__ == "__main__":
    main()
