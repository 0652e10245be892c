#!/usr/bin/env python
"""ANM against the Newton pseudo-arclength baseline, on the same branches, side by side.

Usage::

    python benchmarks/continuation_benchmark.py [--harmonics 100] \\
        [--output benchmarks/continuation_benchmark.md] [--repeat 1] [--blas-threads 1]

Branches (paper parameters alpha = 30, beta = 1, delta = 1, eta = 0.1, cosine basis):

* NNM2 from its regularized linear mode (``x_c^1 = 0.05``) to its asymptote: the run
  stops at the first point whose frequency is within 2 % of the gap-0 second mode;
* NNM1 from its regularized linear mode to energy 1.5e5, where it approaches the
  gap-0 first mode (through all the folds of the internal resonances).

Both methods start from the same Newton-corrected point, in the same direction, with
the same stop criterion, and are held to the same accuracy: the relative residual
``||S(U)|| / max(||U||, 1)`` of every returned point is at most ``--tolerance``
(1e-8) for the baseline corrector, and the ANM uses the same number as its series
tolerance (its step ends then sit at 1e-10 to a few 1e-9, and its Newton threshold of
1e-7 bounds them by construction). The largest residual of each run is printed, so
the claim can be checked. ANM order 20 ("about 20" in the paper) and tolerance 1e-8
are kept as defaults. At H = 100, order 15 costs 27-31 % more factorizations; order
30 costs 17-21 % fewer, with step ends still below 1e-8 (max 8e-9) and about the
same wall time as order 20 (its longer series cost what the factorizations save):
``--extra-order 30`` adds it as an extra row, never as the reference ANM run.

Each run happens in its own subprocess, so that its peak resident memory
(``ru_maxrss``, interpreter and libraries included; the resident size after the
imports is printed too) belongs to that run alone. BLAS is pinned to one thread by
default (``--blas-threads``): for 405 x 405 matrices a multithreaded BLAS gains
nothing and, on a shared machine, oversubscription made the same ANM run 6x slower.
Wall times are measured inside the continuation (``ContinuationStats.wall_time``,
start point excluded); with ``--repeat N`` the smallest of N runs is kept (the counts
are deterministic).

The ANM runs with the default settings, which step on the Padé approximant of the
series wherever that reaches further at the same tolerance (``ANMSettings.pade``, see
``nnmstop.continuation.pade``); ``--taylor-row`` adds the ANM on its plain Taylor series
(``pade=False``) as an extra row.

The timed ANM run stores the end point of each step only (like the baseline, whose
points are its step ends); an untimed second ANM run storing 8 points per series step
draws the reference frequency-energy curve, and the "curve gap" column is the largest
distance of a baseline point to it in (decades of energy, frequency / start
frequency): a check that both methods traced the same branch.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BRANCHES = ("NNM2", "NNM1")
METHODS = ("ANM", "pseudo-arclength")
BASELINE = "pseudo-arclength"
TAYLOR_ROW = "ANM Taylor series"  # the ANM on its plain power series (ANMSettings(pade=False))
NNM1_END_ENERGY = 1.5e5
NNM2_FREQUENCY_SHARE = 0.98
TARGETS = {"NNM2": 10.0, "NNM1": 60.0}  # ANM wall time targets, seconds
TARGET_FACTORIZATION_RATIO = 5.0
TARGET_WALL_RATIO = 3.0
TARGET_MEMORY_MB = 1024.0


# --------------------------------------------------------------------------- worker


def _rss_mb() -> float:
    import resource

    # ru_maxrss is in kilobytes on Linux, bytes on macOS.
    scale = 1.0 / 1024 if sys.platform != "darwin" else 1.0 / 1024**2
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale


def run_worker(spec: dict) -> dict:
    """One continuation run, in this (fresh) process; returns the measurements."""
    rss_imports_before = _rss_mb()
    import numpy as np

    from nnmstop.continuation.anm import ANMSettings, continue_anm
    from nnmstop.continuation.core import ContinuationError, ContinuationStats, newton_correct, relative_residual
    from nnmstop.continuation.pseudo_arclength import PseudoArclengthSettings, continue_pseudo_arclength
    from nnmstop.hbm.system import HarmonicBalanceSystem
    from nnmstop.models.structure import two_dof_structure
    from nnmstop.models.two_dof import ModelParameters, linear_modes

    rss_after_imports = _rss_mb()
    params = ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
    system = HarmonicBalanceSystem(two_dof_structure(params), spec["harmonics"])
    mode = 2 if spec["branch"] == "NNM2" else 1
    e = np.zeros(system.n_unknowns)
    e[system.slices["x"].start + 1] = 1.0
    U0, _ = newton_correct(system, system.linear_mode_guess(mode, 0.05), e, ContinuationStats(), 1e-12)
    if spec["branch"] == "NNM2":
        target = NNM2_FREQUENCY_SHARE * linear_modes(params, "gap_zero")[0][1] / (2 * np.pi)

        def stop(U, d):
            return "frequency within 2% of the gap-0 mode" if d["frequency"] >= target else ""

    else:

        def stop(U, d):
            return f"energy above {NNM1_END_ENERGY:g}" if d["energy"] >= NNM1_END_ENERGY else ""

    label = f"{spec['branch']} {spec['method']}"
    try:
        if spec["method"].startswith("ANM"):
            settings = ANMSettings(order=spec["order"], tolerance=spec["tolerance"], pade=spec["pade"])
            branch = continue_anm(system, U0, e, stop, settings, label=label, progress_seconds=1e9)
        else:
            settings = PseudoArclengthSettings(tolerance=spec["baseline_tolerance"])
            branch = continue_pseudo_arclength(system, U0, e, stop, settings, label=label, progress_seconds=1e9)
    except ContinuationError as err:
        return {"branch": spec["branch"], "method": spec["method"], "failed": str(err), "peak_rss_mb": _rss_mb()}
    stats = branch.stats
    peak_rss = _rss_mb()
    end = system.diagnostics(branch.points[-1])
    max_residual = max(relative_residual(system, U) for U in branch.points)
    if spec["method"].startswith("ANM"):
        # Untimed second run storing 8 points per series step (with their diagnostics),
        # only to draw the reference frequency-energy curve densely.
        settings = ANMSettings(order=spec["order"], tolerance=spec["tolerance"], points_per_step=8, pade=spec["pade"])
        branch = continue_anm(system, U0, e, stop, settings, label=label, progress_seconds=1e9)
    curve = np.array([[np.log10(d["energy"]), d["frequency"]] for d in branch.diagnostics])
    np.save(spec["curve_file"], curve)
    return {
        "branch": spec["branch"],
        "method": spec["method"],
        "wall_time": stats.wall_time,
        "steps": stats.steps,
        "factorizations": stats.factorizations,
        "newton_iterations": stats.newton_iterations,
        "rejected_steps": getattr(stats, "rejected_steps", 0),
        "corrected_steps": stats.corrected_steps if spec["method"].startswith("ANM") else 0,
        "geometric_tails": stats.geometric_tails,
        "pade_steps": stats.pade_steps,
        "peak_rss_mb": peak_rss,
        "rss_after_imports_mb": rss_after_imports,
        "rss_before_imports_mb": rss_imports_before,
        "max_residual": max_residual,
        "branch_points": len(branch.branch_points),
        "end_energy": end["energy"],
        "end_frequency": end["frequency"],
        "end_reason": branch.end_reason,
        "failed": "",
    }


def run_operations_worker(spec: dict) -> dict:
    """Cost of the building blocks at one NNM1 point with impacts (best of 5 x 10 calls)."""
    import timeit

    import numpy as np
    from scipy.linalg import lu_factor

    from nnmstop.continuation.anm import ANMSettings, anm_series, continue_anm, step_length
    from nnmstop.continuation.core import ContinuationStats, newton_correct
    from nnmstop.continuation.pade import pade_pair, pade_step_length
    from nnmstop.hbm.system import HarmonicBalanceSystem
    from nnmstop.models.structure import two_dof_structure
    from nnmstop.models.two_dof import ModelParameters

    params = ModelParameters(alpha=30.0, beta=1.0, delta=1.0, eta=0.1)
    system = HarmonicBalanceSystem(two_dof_structure(params), spec["harmonics"])
    e = np.zeros(system.n_unknowns)
    e[system.slices["x"].start + 1] = 1.0
    U0, _ = newton_correct(system, system.linear_mode_guess(1, 0.05), e, ContinuationStats(), 1e-12)
    branch = continue_anm(
        system, U0, e, lambda U, d: "impacts" if d["energy"] > 5.0 else "", ANMSettings(), progress_seconds=1e9
    )
    U, t = branch.points[-1], branch.end_tangent
    A = np.vstack([system.jacobian(U), t[None, :]])
    stats = ContinuationStats()
    series = anm_series(system, U, t, spec["order"], stats)
    a_series = step_length(series, 1e-8)

    def pade():
        high, low = pade_pair(series, a_series)
        return pade_step_length(high, low, 1e-8, a_series)

    operations = {
        "Jacobian assembly": lambda: system.jacobian(U),
        f"LU factorization ({A.shape[0]} x {A.shape[1]})": lambda: lu_factor(A),
        "residual": lambda: system.residual(U),
        "diagnostics of one point": lambda: system.diagnostics(U),
        f"ANM series of order {spec['order']} (one Jacobian and LU included)": lambda: anm_series(
            system, U, t, spec["order"], stats
        ),
    }
    if pade_pair(series, a_series) is not None:  # undefined where the series terms are dependent (small H)
        operations["Padé approximants of orders N and N-1 and their step length (from the series)"] = pade
    return {name: 1e3 * min(timeit.repeat(f, number=10, repeat=5)) / 10 for name, f in operations.items()}


# --------------------------------------------------------------------------- driver


def run_subprocess(spec: dict, blas_threads: int) -> dict:
    env = dict(os.environ)
    if blas_threads > 0:
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS"):
            env[var] = str(blas_threads)
    proc = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--worker", json.dumps(spec)],
        env=env,
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    if proc.returncode != 0:
        what = "operations" if spec.get("operations") else f"{spec['branch']} {spec['method']}"
        raise RuntimeError(f"{what} run failed:\n{proc.stderr[-4000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def curve_gap(anm_curve, baseline_curve) -> float:
    """Largest distance of a baseline point (the last excepted) to the ANM polyline."""
    import numpy as np

    scale = np.array([1.0, anm_curve[0, 1]])
    poly, points = anm_curve / scale, baseline_curve[:-1] / scale
    a, b = poly[:-1], poly[1:]
    d = b - a
    worst = 0.0
    for q in points:
        t = np.clip(np.sum((q - a) * d, axis=1) / np.maximum(np.sum(d * d, axis=1), 1e-300), 0.0, 1.0)
        worst = max(worst, float(np.min(np.linalg.norm(a + t[:, None] * d - q, axis=1))))
    return worst


def machine_description(blas_threads: int) -> list[str]:
    import numpy
    import scipy

    cpu = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        commit = subprocess.run(
            ["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
    except OSError:
        commit = "unknown"
    return [
        f"- date: {datetime.datetime.now().isoformat(timespec='seconds')}, commit {commit or 'unknown'}",
        f"- machine: {cpu}, {os.cpu_count()} logical CPUs, load average at start {os.getloadavg()[0]:.2f}",
        f"- Python {platform.python_version()}, numpy {numpy.__version__}, scipy {scipy.__version__}, "
        f"BLAS threads {blas_threads if blas_threads > 0 else 'library default'}",
    ]


def run_keys(args) -> list[tuple[str, float]]:
    """``(method, baseline tolerance)`` of every run of one branch, the reference pair first."""
    keys = [("ANM", args.tolerance), (BASELINE, args.tolerance)]
    if args.extra_baseline_tolerance > 0:
        keys.append((BASELINE, args.extra_baseline_tolerance))
    if args.extra_order > 0:
        keys.append((f"ANM order {args.extra_order}", args.tolerance))
    if args.taylor_row:
        keys.append((TAYLOR_ROW, args.tolerance))
    return keys


def run_order(args, method: str) -> int:
    """Series order of an ANM run: ``--order``, or ``--extra-order`` for the extra row."""
    return args.extra_order if method.startswith("ANM order") else args.order


def run_label(args, method: str, tolerance: float) -> str:
    if method == BASELINE and tolerance != args.tolerance:
        return f"{BASELINE} (tol {tolerance:g})"
    return method


def format_report(args, results, gaps, header, operations=None) -> str:
    keys = run_keys(args)
    lines = [
        f"# Continuation benchmark: ANM vs Newton pseudo-arclength (H = {args.harmonics})",
        "",
        f"Command: `python benchmarks/continuation_benchmark.py --harmonics {args.harmonics} "
        f"--repeat {args.repeat} --blas-threads {args.blas_threads}"
        + (f" --extra-order {args.extra_order}" if args.extra_order > 0 else "")
        + (" --taylor-row" if args.taylor_row else "")
        + "`",
        "",
        *header,
        f"- ANM: order {args.order}, series tolerance {args.tolerance:g}, Newton threshold 1e-7, steps on the Padé "
        "approximant of the series where it reaches further (the default, `ANMSettings.pade = True`); "
        f"baseline: full Newton, corrector tolerance {args.tolerance:g} on the relative residual, "
        "PseudoArclengthSettings defaults otherwise; both store one point per step, with its diagnostics "
        "(which the stop criterion needs)",
    ]
    if args.extra_order > 0:
        lines.append(
            f"- extra row: ANM order {args.extra_order} (not the default order {args.order}), same series "
            "tolerance and Newton threshold"
        )
    if args.taylor_row:
        lines.append(
            f"- extra row: {TAYLOR_ROW}: the ANM with `pade=False`: steps on the plain power series only, same "
            "order, tolerance and Newton threshold"
        )
    if args.extra_baseline_tolerance > 0:
        lines.append(
            f"- sensitivity row: the baseline at corrector tolerance {args.extra_baseline_tolerance:g} "
            "(the bound the ANM guarantees through its Newton threshold, looser than what it achieves)"
        )
    lines += [
        "",
        "| branch | method | wall time [s] | steps | factorizations | Newton iterations | rejected steps "
        "| peak RSS [MB] | max rel. residual | end energy | end frequency [Hz] |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for branch in args.branches:
        for key in keys:
            r = results[(branch, *key)]
            if r["failed"]:
                lines.append(f"| {branch} | {run_label(args, *key)} | failed: {r['failed']} |" + " |" * 8)
                continue
            lines.append(
                f"| {branch} | {run_label(args, *key)} | {r['wall_time']:.2f} | {r['steps']} | "
                f"{r['factorizations']} | {r['newton_iterations']} | {r['rejected_steps']} | "
                f"{r['peak_rss_mb']:.0f} | {r['max_residual']:.1e} | {r['end_energy']:.4g} | "
                f"{r['end_frequency']:.5f} |"
            )
    lines += [
        "",
        "Ratios baseline / ANM (curve gap: largest distance of a baseline point to the ANM "
        "frequency-energy curve, in decades of energy and frequency relative to the start):",
        "",
        "| branch | ANM | baseline | wall time | steps | factorizations | peak RSS | curve gap |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    anm_keys = [k for k in keys if k[0].startswith("ANM")]
    baseline_keys = [k for k in keys if k[0] == BASELINE]
    for branch in args.branches:
        for anm_key in anm_keys:
            a = results[(branch, *anm_key)]
            for key in baseline_keys:
                b = results[(branch, *key)]
                prefix = f"| {branch} | {run_label(args, *anm_key)} | {run_label(args, *key)} |"
                if a["failed"] or b["failed"]:
                    lines.append(f"{prefix} (a run failed) |" + " |" * 4)
                    continue
                lines.append(
                    f"{prefix} {b['wall_time'] / a['wall_time']:.2f} | "
                    f"{b['steps'] / a['steps']:.2f} | {b['factorizations'] / a['factorizations']:.2f} | "
                    f"{b['peak_rss_mb'] / a['peak_rss_mb']:.2f} | {gaps[(branch, *anm_key, *key)]:.1e} |"
                )
    rss_imports = max((r["rss_after_imports_mb"] for r in results.values() if not r["failed"]), default=float("nan"))
    if operations:
        lines += [
            "",
            "Cost of the building blocks at an NNM1 point with impacts (ms, best of 5 x 10 calls): "
            + "; ".join(f"{name} {ms:.2f}" for name, ms in operations.items())
            + ". An ANM step is one series; a baseline step is one Jacobian, one LU and one residual per "
            "Newton iteration; both evaluate the diagnostics of each new point for the stop criterion.",
        ]
    lines += [
        "",
        f"Resident size after the imports alone: {rss_imports:.0f} MB.",
        "",
        "Targets (ANM against the baseline at the same tolerance):",
        "",
    ]
    for branch in args.branches:
        a, b = results[(branch, *keys[0])], results[(branch, *keys[1])]
        if a["failed"] or b["failed"]:
            lines.append(f"- {branch}: NOT met (a run failed)")
            continue
        checks = [
            (f"ANM wall time <= {TARGETS[branch]:g} s", a["wall_time"] <= TARGETS[branch], f"{a['wall_time']:.2f} s"),
            (
                f"factorizations ratio >= {TARGET_FACTORIZATION_RATIO:g}",
                b["factorizations"] >= TARGET_FACTORIZATION_RATIO * a["factorizations"],
                f"{b['factorizations'] / a['factorizations']:.2f}",
            ),
            (
                f"wall time ratio >= {TARGET_WALL_RATIO:g}",
                b["wall_time"] >= TARGET_WALL_RATIO * a["wall_time"],
                f"{b['wall_time'] / a['wall_time']:.2f}",
            ),
            (
                f"peak memory <= {TARGET_MEMORY_MB:g} MB (every run)",
                max(r["peak_rss_mb"] for k, r in results.items() if k[0] == branch) <= TARGET_MEMORY_MB,
                f"{max(r['peak_rss_mb'] for k, r in results.items() if k[0] == branch):.0f} MB",
            ),
        ]
        for text, ok, value in checks:
            lines.append(f"- {branch}: {text}: {'met' if ok else 'NOT met'} ({value})")
        for anm_key in anm_keys[1:]:
            c = results[(branch, *anm_key)]
            if not c["failed"]:
                lines.append(
                    f"- {branch}, extra row {run_label(args, *anm_key)} (not the default, not a target check): "
                    f"factorizations ratio {b['factorizations'] / c['factorizations']:.2f}, "
                    f"wall time ratio {b['wall_time'] / c['wall_time']:.2f}"
                )
    return "\n".join(lines) + "\n"


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--harmonics", type=int, default=100, help="number of harmonics H (default 100)")
    parser.add_argument("--output", type=Path, default=None, help="markdown file for the report (default: stdout only)")
    parser.add_argument("--order", type=int, default=20, help="ANM series order (default 20)")
    parser.add_argument("--tolerance", type=float, default=1e-8, help="accuracy of both methods (default 1e-8)")
    parser.add_argument(
        "--extra-baseline-tolerance",
        type=float,
        default=1e-7,
        help="one more baseline run at this corrector tolerance (default 1e-7, the ANM Newton threshold; 0 = none)",
    )
    parser.add_argument(
        "--extra-order",
        type=int,
        default=0,
        help="one more ANM run at this series order, reported as an extra row (default 0 = none)",
    )
    parser.add_argument(
        "--taylor-row",
        action="store_true",
        help=f"one more ANM run on the plain Taylor series (pade=False), reported as an extra row ('{TAYLOR_ROW}')",
    )
    parser.add_argument("--repeat", type=int, default=1, help="runs per method, smallest wall time kept (default 1)")
    parser.add_argument("--blas-threads", type=int, default=1, help="BLAS threads per run, 0 = library default")
    parser.add_argument("--branches", nargs="+", choices=BRANCHES, default=list(BRANCHES))
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker is None:
        if args.harmonics < 1:
            parser.error(f"--harmonics must be >= 1, got {args.harmonics}")
        if args.order < 2:
            parser.error(f"--order must be >= 2, got {args.order}")
        if args.extra_order != 0 and (args.extra_order < 2 or args.extra_order == args.order):
            parser.error(f"--extra-order must be 0 or an order >= 2 other than --order, got {args.extra_order}")
        if not 0 < args.tolerance < 1e-2:
            parser.error(f"--tolerance must be in (0, 1e-2), got {args.tolerance}")
        if not 0 <= args.extra_baseline_tolerance < 1e-2:
            parser.error(f"--extra-baseline-tolerance must be in [0, 1e-2), got {args.extra_baseline_tolerance}")
        if args.repeat < 1:
            parser.error(f"--repeat must be >= 1, got {args.repeat}")
        if args.blas_threads < 0:
            parser.error(f"--blas-threads must be >= 0, got {args.blas_threads}")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    if args.worker is not None:
        spec = json.loads(args.worker)
        print(json.dumps(run_operations_worker(spec) if spec.get("operations") else run_worker(spec)))
        return 0
    import numpy as np

    header = machine_description(args.blas_threads)
    results, gaps = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for branch in args.branches:
            curves = {}
            for repeat in range(args.repeat):
                for i, (method, tolerance) in enumerate(run_keys(args)):  # interleaved: load changes hit all
                    curve_file = str(Path(tmp) / f"{branch}_{i}.npy")
                    spec = {
                        "branch": branch,
                        "method": method,
                        "harmonics": args.harmonics,
                        "order": run_order(args, method),
                        "tolerance": args.tolerance,
                        "baseline_tolerance": tolerance,
                        "curve_file": curve_file,
                        "pade": method != TAYLOR_ROW,
                    }
                    r = run_subprocess(spec, args.blas_threads)
                    if r["failed"]:
                        label = run_label(args, method, tolerance)
                        print(f"{branch:5s} {label:33s} FAILED: {r['failed']}", file=sys.stderr)
                        results.setdefault((branch, method, tolerance), r)
                        continue
                    print(
                        f"{branch:5s} {run_label(args, method, tolerance):33s} run {repeat + 1}: "
                        f"{r['wall_time']:7.2f} s, {r['steps']:4d} steps, {r['factorizations']:5d} factorizations, "
                        f"peak RSS {r['peak_rss_mb']:.0f} MB",
                        file=sys.stderr,
                        flush=True,
                    )
                    best = results.get((branch, method, tolerance))
                    if best is None or best["failed"] or r["wall_time"] < best["wall_time"]:
                        results[branch, method, tolerance] = r
                    curves[method, tolerance] = np.load(curve_file)
            for anm_key in [k for k in run_keys(args) if k[0].startswith("ANM")]:
                for key in [k for k in run_keys(args) if k[0] == BASELINE]:
                    if anm_key in curves and key in curves:
                        gaps[(branch, *anm_key, *key)] = curve_gap(curves[anm_key], curves[key])
    operations_spec = {"operations": True, "harmonics": args.harmonics, "order": args.order}
    operations = run_subprocess(operations_spec, args.blas_threads)
    report = format_report(args, results, gaps, header, operations)
    print(report)
    if args.output is not None:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text(report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
