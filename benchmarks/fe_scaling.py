#!/usr/bin/env python
"""Cost of one ANM step against the number of degrees of freedom: sparse ordered LU vs dense LU.

Usage::

    python benchmarks/fe_scaling.py [--dofs 50 100 200 400] [--harmonics 50 100] [--repeat 2]
        [--dense-max-unknowns 21000] [--output benchmarks/fe_scaling.md]

Structures: the paper's 2-DOF oscillator, then fixed-free spring-mass chains of N unit masses
and springs with one stop (gap 1, alpha = 30, eta = 0.1) on the mass at 70 % of the chain, the
discrete analogue of the tube guided by a support plate. Cosine basis, the engine's default
for NNM branches (``N (H + 1) + 2 (H + 1) + 1`` unknowns).

One ANM step, as ``nnmstop.anm.anm_series`` does it: assemble the Jacobian, factor the bordered
matrix ``[J; t^T]`` once (``HarmonicBalanceSystem.factorize_bordered``), then for the orders
2..20 the series products and a back-substitution. The point is the first linear mode at the
grazing amplitude, the tangent a dense unit vector; the cost does not depend on where on the
branch the step is. Methods, each case in its own subprocess (peak resident memory
``ru_maxrss`` of that case alone, interpreter included), one BLAS thread:

* ``sparse``: the engine's sparse path (SuperLU in the harmonic-by-harmonic order);
* ``sparse-colamd``: the same matrix with SuperLU's COLAMD column ordering instead;
* ``dense``: LAPACK LU of the same bordered matrix assembled dense in place (the engine's dense
  path without its extra copy), measured up to ``--dense-max-unknowns`` unknowns.

Ends with one line: the exponent of the sparse cost per step fitted between 50 and 400 DOF at
the largest H, and the dense/sparse ratio at 400 DOF for that H (measured, or extrapolated
from the largest dense case by the n**3 law if that one was not measured, and said so).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ORDER = 20
ALPHA, ETA, GAP = 30.0, 0.1, 1.0


def structure_of(dofs: int):
    """The paper's oscillator (``dofs == 2``) or a fixed-free chain with one stop at 70 % of it."""
    import numpy as np
    import scipy.sparse as sp

    from nnmstop.models.structure import Stop, Structure, two_dof_structure
    from nnmstop.models.two_dof import ModelParameters

    if dofs == 2:
        return two_dof_structure(ModelParameters())
    springs = np.ones(dofs)
    main = springs + np.append(springs[1:], 0.0)  # spring i links mass i-1 (or the ground) to mass i
    stiffness = sp.diags([main, -springs[1:], -springs[1:]], [0, -1, 1], format="csr")
    stop = Stop(dof=int(0.7 * dofs), gap=GAP, stiffness=ALPHA, eta=ETA)
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


def run_case(method: str, dofs: int, harmonics: int, repeat: int) -> dict:
    """Best-of-``repeat`` times of the parts of one ANM step, and the peak memory of this process."""
    import resource

    import numpy as np

    from nnmstop.continuation.linear import BorderedFactorization
    from nnmstop.hbm.factorization import SparseBorderedLU
    from nnmstop.hbm.system import HarmonicBalanceSystem

    algebra = "dense" if method == "dense" else "sparse"
    system = HarmonicBalanceSystem(structure_of(dofs), harmonics, linear_algebra=algebra)
    U = system.linear_mode_guess(1, 1.0)
    tangent = np.random.default_rng(0).standard_normal(system.n_unknowns)
    tangent /= np.linalg.norm(tangent)
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    best = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        if method == "dense":
            lu = BorderedFactorization.of_matrix(dense_bordered(system, U, tangent), overwrite=True)
        elif method == "sparse":
            lu = system.factorize_bordered(U, tangent)
        else:
            identity = np.arange(system.n_unknowns)
            lu = SparseBorderedLU(system.jacobian(U, sparse=True), tangent, identity, column_ordering="COLAMD")
        t1 = time.perf_counter()
        series = np.empty((ORDER + 1, system.n_unknowns))
        series[0] = U
        rhs = np.zeros(system.n_unknowns)
        rhs[-1] = 1.0
        series[1] = lu.solve(rhs)
        rhs[-1] = 0.0
        cache = system.series_cache(ORDER)
        products = solves = 0.0
        for p in range(2, ORDER + 1):
            s0 = time.perf_counter()
            np.negative(system.series_products(series, p, cache), out=rhs[:-1])
            s1 = time.perf_counter()
            series[p] = lu.solve(rhs)
            products, solves = products + s1 - s0, solves + time.perf_counter() - s1
        total = time.perf_counter() - t0
        sample = {"factor": t1 - t0, "products": products, "solves": solves, "step": total}
        if best is None or sample["step"] < best["step"]:
            best = sample
        del lu
    return {
        "method": method,
        "dofs": dofs,
        "harmonics": harmonics,
        "unknowns": system.n_unknowns,
        **best,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "base_mb": rss_before / 1024,
    }


def in_subprocess(method, dofs, harmonics, repeat, threads) -> dict:
    env = dict(
        os.environ, OPENBLAS_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads), MKL_NUM_THREADS=str(threads)
    )
    command = [sys.executable, __file__, "--case", method, str(dofs), str(harmonics), "--repeat", str(repeat)]
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"case {method} {dofs} {harmonics} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def fitted_exponent(rows, harmonics, lo=50, hi=400) -> float:
    import numpy as np

    points = sorted(
        (r["dofs"], r["step"])
        for r in rows
        if r["method"] == "sparse" and r["harmonics"] == harmonics and lo <= r["dofs"] <= hi
    )
    n, cost = np.log(np.array(points)).T
    return float(np.polyfit(n, cost, 1)[0])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dofs", type=int, nargs="+", default=[50, 100, 200, 400])
    parser.add_argument("--harmonics", type=int, nargs="+", default=[50, 100])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument(
        "--dense-max-unknowns",
        type=int,
        default=21000,
        help="largest dense case measured (41k unknowns, 400 DOF at H = 100, need 13 GB and ~25 min)",
    )
    parser.add_argument("--colamd-max-dofs", type=int, default=400)
    parser.add_argument("--blas-threads", type=int, default=1)
    parser.add_argument("--output", type=Path, default=Path(__file__).with_name("fe_scaling.md"))
    parser.add_argument("--case", nargs=3, metavar=("METHOD", "DOFS", "H"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.case:
        method, dofs, harmonics = args.case[0], int(args.case[1]), int(args.case[2])
        print(json.dumps(run_case(method, dofs, harmonics, args.repeat)))
        return
    rows = []
    load_start = os.getloadavg()[0]
    for harmonics in args.harmonics:
        for dofs in [2] + args.dofs:
            unknowns = (dofs + 2) * (harmonics + 1) + 1
            methods = ["sparse"] + (["sparse-colamd"] if dofs <= args.colamd_max_dofs and dofs > 2 else [])
            methods += ["dense"] if unknowns <= args.dense_max_unknowns else []
            for method in methods:
                # one repeat of a dense case above 5000 unknowns: minutes each, and its time is not noise-bound
                repeat = 1 if method == "dense" and unknowns > 5000 else args.repeat
                row = in_subprocess(method, dofs, harmonics, repeat, args.blas_threads)
                rows.append(row)
                print(
                    f"{method:14s} N={dofs:4d} H={harmonics:3d} n={row['unknowns']:6d} step {row['step']:9.3f} s "
                    f"factor {row['factor']:9.3f} s peak {row['peak_mb']:8.0f} MB",
                    flush=True,
                )
    top = max(args.harmonics)
    exponent = fitted_exponent(rows, top)
    largest = max(args.dofs)

    def find(method, dofs, harmonics):
        return next((r for r in rows if (r["method"], r["dofs"], r["harmonics"]) == (method, dofs, harmonics)), None)

    sparse_top, dense_top = find("sparse", largest, top), find("dense", largest, top)
    if dense_top is not None:
        speedup, how = dense_top["step"] / sparse_top["step"], "measured"
    else:
        measured = [r for r in rows if r["method"] == "dense" and r["dofs"] > 2]
        base = max(measured, key=lambda r: r["unknowns"])
        dense_step = base["factor"] * (sparse_top["unknowns"] / base["unknowns"]) ** 3
        speedup = dense_step / sparse_top["step"]
        how = (
            f"dense factorization alone, extrapolated by n**3 from {base['dofs']} DOF, H = {base['harmonics']}; "
            "not measured"
        )
    lines = [
        "# Cost of one ANM step against the number of DOF (`python benchmarks/fe_scaling.py`)",
        "",
        f"Spring-mass chains with one stop, cosine basis, order {ORDER}: assembly + one factorization of "
        f"`[J; t^T]` + {ORDER - 1} series products and back-substitutions; best of {args.repeat} (dense cases "
        f"above 5000 unknowns: one run), "
        f"{args.blas_threads} BLAS thread(s), each case in its own process (peak RSS includes the interpreter).",
        "",
        "| method | DOF | H | unknowns | step (s) | factorization (s) | products (s) | solves (s) | peak RSS (MB) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['method']} | {r['dofs']} | {r['harmonics']} | {r['unknowns']} | {r['step']:.4g} | "
            f"{r['factor']:.4g} | {r['products']:.3g} | {r['solves']:.3g} | {r['peak_mb']:.0f} |"
        )
    exponents = ", ".join(f"H = {h}: {fitted_exponent(rows, h):.2f}" for h in args.harmonics)
    lines += [
        "",
        f"Fitted exponent of the sparse cost per step, 50-{largest} DOF: {exponents}.",
        f"Load average (1 min) at the start and end of the run: {load_start:.1f}, {os.getloadavg()[0]:.1f} "
        f"on {os.cpu_count()} CPUs: on a shared machine absolute times stretch, the side-by-side ratios hold.",
        "",
    ]
    summary = (
        f"exponent of sparse cost per step (50-{largest} DOF, H = {top}): {exponent:.2f}; "
        f"speed-up over dense LU at {largest} DOF, H = {top}: {speedup:.0f}x ({how})"
    )
    lines.append(summary)
    args.output.write_text("\n".join(lines) + "\n")
    print(summary)


if __name__ == "__main__":
    main()
