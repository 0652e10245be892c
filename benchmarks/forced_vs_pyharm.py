"""The regularized frequency response with this project and with pyHarm, side by side in one run.

Same equations: the paper's oscillator with the damping of the default forced scene (``forced`` in
config/config.yaml), the force on ``u`` at one level (``--force``), the regularized stop law (Eq. 5 corrected:
``benchmarks/pyharm_side.py`` gives pyHarm an element for it, as it has none), ``H`` harmonics (100), the
scene's frequency range. This project: harmonic balance of the quadratic recast + ANM (Padé), the
configuration's ``anm`` settings; pyHarm (PyPI ``pyharm-os``, installed by this script into a venv of its
own, ``--venv``): alternating frequency-time with ``--time-samples`` instants, tangent predictor,
arc-length corrector, Newton-Raphson to ``--newton-tol``, its accepted-step size rule.

Reported, over ``--repeat`` pairs of runs (one of each side back to back, so that both meet the same load):
wall and CPU time, the speed-up of each pair (its median decides the target), points, factorizations (here: LU
of the bordered Jacobian; pyHarm: its Newton solves, each an LU of the dense Jacobian, and its Jacobian
evaluations); the largest distance between the two curves, in ``max |x|`` and ``max |u|`` over the period
(both from the harmonics, extremes located to round-off) at pyHarm's points, against this project's curve at
the same frequency (located on the ANM steps, no interpolation; the nearest branch where the curve folds); and
what this project adds: the multipliers, the verdicts and the located folds, period doublings and
Neimark-Sacker points, timed apart.

Usage::

    python benchmarks/forced_vs_pyharm.py [--force 0.1] [--repeat 3] [--profile] \\
        [--output benchmarks/forced_vs_pyharm.md]

Skipped, with the reason in the report, where pyHarm cannot be installed.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import venv
from pathlib import Path

# One BLAS thread on both sides, as the pipeline's jobs run (config `numerics`): on 2 shared cores a second
# OpenBLAS thread costs more than it gives (this project's response: 3x the CPU time). Set before numpy loads;
# the pyHarm process inherits it. Override with OPENBLAS_NUM_THREADS.
BLAS_THREADS = os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
for _name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, BLAS_THREADS)

import numpy as np  # noqa: E402

from timing import REPO, check_repeat, emit_report, timed  # noqa: E402

PYHARM = "pyharm-os==1.2.2"
# what pyHarm imports (its declared requirements also pull Jupyter, which it does not need to compute)
PYHARM_IMPORTS = ("numpy", "scipy", "pandas", "numba", "jax", "tomli_w", "psutil")
DEFAULT_VENV = Path.home() / ".cache" / "nnmstop" / "pyharm-venv"


def pyharm_python(venv_dir: Path) -> Path:
    """The venv's interpreter with pyHarm importable; the venv is made and pyHarm installed on first use."""
    python = venv_dir / "bin" / "python"
    if python.exists() and subprocess.run([python, "-c", "import pyHarm"], capture_output=True).returncode == 0:
        return python
    venv.create(venv_dir, with_pip=True, clear=True)
    for args in (["--no-deps", PYHARM], list(PYHARM_IMPORTS)):
        run = subprocess.run([python, "-m", "pip", "install", "-q", *args], capture_output=True, text=True)
        if run.returncode:
            raise RuntimeError(f"pip install {' '.join(args)} failed: {run.stderr.strip()[-500:]}")
    check = subprocess.run([python, "-c", "import pyHarm"], capture_output=True, text=True)
    if check.returncode:
        raise RuntimeError(f"pyHarm does not import: {check.stderr.strip()[-500:]}")
    return python


def scene_problem(force: float):
    """The default scene's excitation at ``force``, its frequency range and ``H`` (config/config.yaml)."""
    from nnmstop.config import load_config
    from nnmstop.forced.scenes import forced_scenes

    config = load_config(REPO / "config" / "config.yaml")
    scene = forced_scenes(config, "oscillator")[0]
    return config, scene, scene.excitation.with_amplitude(force)


def our_response(config, scene, excitation) -> dict:
    """The response by harmonic balance + ANM, timed."""
    from nnmstop.continuation.anm import ANMSettings
    from nnmstop.forced.responses import RegularizedSettings, regularized_response

    anm = ANMSettings.from_config(config["anm"], points_per_step=scene.points_per_step)
    settings = RegularizedSettings(scene.harmonics, anm, float(config["forced"]["max_truncation"]))
    (system, branch), cpu, wall = timed(lambda: regularized_response(excitation, scene.frequency_range, settings))
    return dict(
        system=system,
        branch=branch,
        cpu=cpu,
        wall=wall,
        points=len(branch.points),
        factorizations=branch.stats.factorizations,
        steps=branch.stats.steps,
        branch_settings=anm,
    )


def our_stability(config, scene, mine: dict) -> dict:
    """What pyHarm does not give, timed apart: the multipliers of every point and the located changes."""
    from nnmstop.forced.regularized import ForcedStabilitySettings, regularized_stability
    from nnmstop.forced.stability_changes import KINDS

    stability_settings = ForcedStabilitySettings.from_config(scene.stability)
    (stability, changes), cpu, wall = timed(
        lambda: regularized_stability(mine["system"], mine["branch"], mine["branch_settings"], stability_settings)
    )
    kinds = {kind: sum(c.kind == kind for c in changes) for kind in KINDS}
    return dict(stability_cpu=cpu, stability_wall=wall, unresolved=int(np.sum(~stability.resolved)), changes=kinds)


#: Where this project's time goes (``--profile``): part -> (module path suffix, function) whose cumulative time it is.
PROFILE_PARTS = {
    "Jacobian assembly and LU factorization (bordered, z condensed)": ("continuation/linear.py", "factorize_bordered"),
    "solves (one per series order)": ("hbm/factorization.py", "solve"),
    "series products of the quadratic recast": ("hbm/forced.py", "series_products"),
    "Pade approximants and step lengths": ("continuation/anm.py", "_pade_path"),
    "per-point diagnostics (truncation, time residual)": ("hbm/system.py", "diagnostics_many"),
    "whole response": ("forced/responses.py", "regularized_response"),
}


def profile_ours(config, scene, excitation) -> dict:
    """Cumulative CPU seconds of the parts of :data:`PROFILE_PARTS` in one more run of the response, under cProfile
    (its own overhead included: shares, not timings)."""
    import cProfile
    import pstats

    from nnmstop.continuation.anm import ANMSettings
    from nnmstop.forced.responses import RegularizedSettings, regularized_response

    anm = ANMSettings.from_config(config["anm"], points_per_step=scene.points_per_step)
    settings = RegularizedSettings(scene.harmonics, anm, float(config["forced"]["max_truncation"]))
    profiler = cProfile.Profile(time.process_time)
    profiler.runcall(regularized_response, excitation, scene.frequency_range, settings)
    stats = pstats.Stats(profiler).stats
    parts = {}
    for part, (path, function) in PROFILE_PARTS.items():
        parts[part] = sum(v[3] for (file, _, name), v in stats.items() if file.endswith(path) and name == function)
    return parts


def pyharm(python: Path, scene, excitation, args) -> dict:
    """pyHarm's response (``pyharm_side.py`` in the venv) for the same equations."""
    structure = excitation.structure
    M, K = structure.dense_matrices()
    C = excitation.damping_matrix
    C = C.toarray() if hasattr(C, "toarray") else np.asarray(C)
    stop = structure.stops[0]
    low, high = scene.frequency_range
    problem = dict(
        law_file=str(REPO / "src" / "nnmstop" / "models" / "two_dof.py"),
        stop=dict(alpha=stop.stiffness, eta=stop.eta, gap=stop.gap, dof=stop.dof),
        M=M.tolist(),
        C=C.tolist(),
        K=K.tolist(),
        harmonics=scene.harmonics,
        time_samples=args.time_samples,
        force_dof=int(excitation.force.dofs[0]),
        force=excitation.force.amplitude,
        continuation=dict(
            puls_inf=2 * np.pi * low,
            puls_sup=2 * np.pi * high,
            ds0=args.ds0,
            ds_max=args.ds_max,
            ds_min=1e-8,
            solver="NewtonRaphson",
            solver_options=dict(tol_residual=args.newton_tol, tol_delta_x=args.newton_tol),
        ),
    )
    with tempfile.TemporaryDirectory() as scratch:  # pyHarm writes a .pyHarm/ context where it runs
        run = subprocess.run(
            [python, str(Path(__file__).with_name("pyharm_side.py"))],
            input=json.dumps(problem),
            capture_output=True,
            text=True,
            cwd=scratch,
        )
    if run.returncode:
        raise RuntimeError(f"pyHarm run failed: {run.stderr.strip()[-2000:]}")
    return json.loads(run.stdout)


def curve_distance(mine: dict, theirs: dict) -> dict:
    """Largest distance in ``max |x|`` and ``max |u|`` between pyHarm's points and this project's curve at their
    frequencies (every crossing of the frequency on the ANM steps located by bisection; the nearest one)."""
    from nnmstop.continuation.anm import ANMStepper
    from nnmstop.continuation.newton import bisect_sign_change
    from nnmstop.forced.responses import path_between
    from nnmstop.hbm.forced import response_amplitudes, series_extremes

    system, U = mine["system"], np.asarray(mine["branch"].points)
    stepper, paths = ANMStepper(mine["branch_settings"]), {}
    omega = U[:, system.i_omega]
    H = system.H
    amplitudes = []
    for coefficients in theirs["coefficients"]:  # pyHarm's [c_0, c_1, s_1, ...] -> [c_0, c_1..c_H, s_1..s_H]
        c = np.asarray(coefficients)
        low, high = series_extremes(np.concatenate([c[:, :1], c[:, 1::2], c[:, 2::2]], axis=1), H)
        amplitudes.append(np.maximum(-low, high))
    theirs_amplitude = np.stack(amplitudes, axis=1)  # (points, N)
    distance = np.zeros_like(theirs_amplitude)
    outside = 0
    for k, w in enumerate(theirs["omega"]):
        crossings = np.flatnonzero(np.sign(omega[:-1] - w) != np.sign(omega[1:] - w))
        if not crossings.size:
            outside += 1
            continue
        found = []
        for i in crossings:
            if i not in paths:
                paths[i] = path_between(system, stepper, U, int(i))
            path, length = paths[i]
            at = bisect_sign_change(lambda a, p=path, w=w: p(a)[system.i_omega] - w, 0.0, length, tol=1e-13 * length)
            found.append(response_amplitudes(system, path(at.midpoint)[None])[0])
        distance[k] = np.min(np.abs(np.array(found) - theirs_amplitude[k]), axis=0)
    return dict(
        largest=distance.max(axis=0),
        compared=len(theirs["omega"]) - outside,
        outside=outside,
        largest_amplitude=theirs_amplitude.max(axis=0),
    )


def _spread(values) -> str:
    """Median and range of ``values``: ``m [lo-hi]``."""
    values = np.asarray(values, dtype=float)
    return f"{np.median(values):.2f} [{values.min():.2f}-{values.max():.2f}]"


def report(args, runs, stability, distance, profile=None) -> str:
    """The report of ``runs``, pairs ``(mine, theirs)`` of back-to-back runs (the last pair's curves compared)."""
    mine, theirs = runs[-1]
    ratios = {kind: [t[f"{kind}_seconds"] / m[kind] for m, t in runs] for kind in ("cpu", "wall")}
    median = {kind: float(np.median(values)) for kind, values in ratios.items()}
    labels = [str(label) for label in mine["system"].structure.dof_labels]
    lines = [
        "# Regularized frequency response: this project against pyHarm",
        "",
        f"The paper's oscillator (regularized law, alpha, eta of `model`), the default forced scene's damping, "
        f"F = {args.force:g} on u, H = {mine['system'].H}, {mine['range'][0]:g}..{mine['range'][1]:g} Hz. "
        f"pyHarm {PYHARM.split('==')[1]}: AFT with {args.time_samples} instants, Newton-Raphson to "
        f"{args.newton_tol:g}, ds0 = {args.ds0:g}, ds_max = {args.ds_max:g}. Both sides with "
        f"OPENBLAS_NUM_THREADS = {BLAS_THREADS} (the pipeline's jobs use one BLAS thread). {len(runs)} pairs of "
        "runs, each pair one run of each side back to back (times: median [smallest-largest]).",
        "",
        "| | wall (s) | CPU (s) | points | factorizations | other counts |",
        "|---|---|---|---|---|---|",
        f"| this project (HBM + ANM) | {_spread([m['wall'] for m, _ in runs])} | "
        f"{_spread([m['cpu'] for m, _ in runs])} | {mine['points']} | {mine['factorizations']} | "
        f"{mine['steps']} ANM steps |",
        f"| pyHarm | {_spread([t['wall_seconds'] for _, t in runs])} | {_spread([t['cpu_seconds'] for _, t in runs])} "
        f"| {theirs['points']} | {theirs['linear_solves']} | {theirs['jacobian_evaluations']} Jacobian, "
        f"{theirs['residual_evaluations']} residual evaluations |",
        "",
        f"Speed-up (pyHarm / this project, per pair of runs): **{_spread(ratios['cpu'])}x** in CPU time, "
        f"{_spread(ratios['wall'])}x in wall time (target: 20x on the medians) -> "
        f"{'met' if min(median.values()) >= 20 else 'NOT met'}.",
        "",
        f"Largest distance between the curves at pyHarm's {distance['compared']} points "
        f"({distance['outside']} outside this project's range): "
        + ", ".join(
            f"max |{label}| {d:.2e} (largest value {a:.3g})"
            for label, d, a in zip(labels, distance["largest"], distance["largest_amplitude"])
        )
        + ".",
        "",
        f"What pyHarm does not give, computed here in {stability['stability_cpu']:.2f} s CPU "
        f"({stability['stability_wall']:.2f} s wall) more: Floquet multipliers of every point with their error "
        f"estimates ({stability['unresolved']} of {mine['points']} verdicts unresolved), and the located stability "
        "changes: " + ", ".join(f"{n} {kind.replace('_', ' ')}" for kind, n in stability["changes"].items()) + ".",
    ]
    if profile:
        total = profile["whole response"]
        lines += [
            "",
            f"Where this project's time goes (`--profile`: one more run under cProfile, {total:.2f} s CPU with its "
            "overhead):",
            "",
            "| part | CPU (s) | share |",
            "|---|---:|---:|",
        ]
        lines += [
            f"| {part} | {seconds:.2f} | {100 * seconds / total:.0f} % |"
            for part, seconds in profile.items()
            if part != "whole response"
        ]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", type=float, default=0.1)
    parser.add_argument("--time-samples", type=int, default=1024)
    parser.add_argument("--newton-tol", type=float, default=1e-9)
    parser.add_argument("--ds0", type=float, default=0.01)
    parser.add_argument("--ds-max", type=float, default=0.1)
    parser.add_argument("--repeat", type=int, default=3, help="pairs of runs (one of each side, back to back)")
    parser.add_argument("--venv", type=Path, default=DEFAULT_VENV)
    parser.add_argument("--profile", action="store_true", help="also report where this project's time goes")
    parser.add_argument("--output", type=Path)
    args = parser.parse_args(argv)
    check_repeat(args.repeat)
    try:
        python = pyharm_python(args.venv)
    except (RuntimeError, OSError) as error:
        return emit_report(f"# Regularized frequency response against pyHarm\n\nSkipped: {error}", args.output)
    config, scene, excitation = scene_problem(args.force)
    runs = []
    for _ in range(args.repeat):
        mine = our_response(config, scene, excitation)
        mine["range"] = scene.frequency_range
        runs.append((mine, pyharm(python, scene, excitation, args)))
    mine, theirs = runs[-1]
    stability = our_stability(config, scene, mine)
    profile = profile_ours(config, scene, excitation) if args.profile else None
    return emit_report(report(args, runs, stability, curve_distance(mine, theirs), profile), args.output)


if __name__ == "__main__":
    sys.exit(main())
