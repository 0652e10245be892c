#!/usr/bin/env python
"""Convergence of the Craig-Bampton reduced NNM1 to the full model's, against the number of kept modes.

Usage::

    python benchmarks/reduction_convergence.py [--elements 500] [--harmonics 10 20 50 100]
        [--amplitudes 0.9 1.04] [--modes 1 2 4 8 12 16 24 32 48 64] [--tolerance 1e-6]
        [--output benchmarks/reduction_convergence.md]
    python benchmarks/reduction_convergence.py --tiny --output /tmp/conv.md   # seconds (the tests)

The model is the tube on three plates (``nnmstop.models.beam.tube_plates_parameters``: clamped-pinned,
plates at L/2, L/4, 3L/4) with ``--elements`` elements (500: 999 DOFs). For each ``H``, NNM1 of the
structure reduced with the largest ``--modes`` is continued (ANM, cosine basis) up to energy 62 (the
backbone below its energy fold, as ``tube_plates`` in config/config.yaml). At each ``--amplitudes``
(fundamental cosine amplitude of the middle plate's DOF over its gap: 0.9 before contact, 1.04 with one
impact on each side of the middle plate) its orbit is solved by Newton with that amplitude held; then
the same orbit of the **full** model (sparse path, Newton from the recovered orbit) and of the structure
reduced with each smaller number of modes (Newton from the orbit with the next larger count, truncated).
Errors against the full orbit: relative frequency, and largest contact-DOF harmonic over the largest.
``modes needed``: the fewest kept modes whose errors are below ``--tolerance`` at every amplitude (and at
every larger count tried); the first neglected fixed-interface mode's frequency against ``H f``, the
highest frequency in the balance. Ends with the fitted exponent of the frequency error against
``f_next / f`` and of the modes needed against ``H``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from timing import emit_report

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))


def convergence(elements: int, harmonics: int, amplitudes, modes) -> list[dict]:
    """Rows ``{amplitude, modes, next_over_highest, frequency, harmonics, energy}`` of one ``H``."""
    from nnmstop.continuation.anm import ANMSettings
    from nnmstop.hbm.reduced import fewer_modes, full_unknowns, orbit_at_amplitude, orbit_difference
    from nnmstop.hbm.stages import BranchSettings, BranchSpec, StageSpec, follow_stage
    from nnmstop.hbm.system import HarmonicBalanceSystem
    from nnmstop.models.beam import Beam, beam_structure, tube_plates_parameters
    from nnmstop.models.reduction import craig_bampton

    full = beam_structure(Beam.from_parameters(tube_plates_parameters(elements)))
    modes = sorted(m for m in modes if m <= full.n_dofs - len(full.stops))
    largest = craig_bampton(full, modes[-1])
    system = HarmonicBalanceSystem(largest, harmonics)
    anm = ANMSettings.from_config(
        {"order": 20, "tolerance": 1e-8, "newton_threshold": 1e-7, "max_steps": 400, "pade": True}
    )
    spec = BranchSpec("nnm1", 1, 0.05, (StageSpec("backbone", {"energy_above": 62.0}),))
    # the same HBM problem, reduced and full, is compared at each H: the truncation guard is no matter here
    branch = follow_stage(system, BranchSettings(anm, 0.5), spec)
    points = np.array(branch.points)
    along = points[:, system.slices["x"].start + 1] / system.gaps[0]
    full_system = HarmonicBalanceSystem(full, harmonics)
    rows = []
    for amplitude in amplitudes:
        if not along.min() <= amplitude <= along.max():
            span = f"{along.min():.3g}..{along.max():.3g}"
            raise ValueError(f"amplitude {amplitude} is off the continued branch ({span})")
        reference = orbit_at_amplitude(system, points[np.argmin(abs(along - amplitude))], amplitude)
        U_full = orbit_at_amplitude(full_system, full_unknowns(system, full_system, reference), amplitude)
        energy_full = full_system.diagnostics(U_full)["energy"]
        highest = harmonics * np.sqrt(U_full[full_system.i_lam])
        guess, previous_system = reference, system
        for m in reversed(modes):  # each from the orbit with more modes, truncated
            reduced = largest if m == modes[-1] else craig_bampton(full, m)
            reduced_system = HarmonicBalanceSystem(reduced, harmonics)
            guess = orbit_at_amplitude(reduced_system, fewer_modes(previous_system, guess, m), amplitude)
            previous_system = reduced_system
            error = orbit_difference(reduced_system, guess, full_system, U_full)
            rows.append(
                {
                    "amplitude": amplitude,
                    "energy": energy_full,
                    "modes": m,
                    "next_over_highest": reduced.reduction.next_frequency / highest,
                    "next_over_fundamental": reduced.reduction.next_frequency / np.sqrt(U_full[full_system.i_lam]),
                    **error,
                }
            )
    return rows


def modes_needed(rows, tolerance: float) -> int | None:
    """Fewest modes whose errors, and those of every larger count, are below ``tolerance`` at every amplitude."""
    counts = sorted({r["modes"] for r in rows})
    ok = {m: all(max(r["frequency"], r["harmonics"]) < tolerance for r in rows if r["modes"] == m) for m in counts}
    needed = None
    for m in reversed(counts):
        if not ok[m]:
            break
        needed = m
    return needed


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, default=500)
    parser.add_argument("--harmonics", type=int, nargs="+", default=[10, 20, 50, 100])
    parser.add_argument("--amplitudes", type=float, nargs="+", default=[0.9, 1.04])
    parser.add_argument("--modes", type=int, nargs="+", default=[1, 2, 4, 8, 12, 16, 24, 32, 48, 64])
    parser.add_argument("--tolerance", type=float, default=1e-6)
    parser.add_argument("--tiny", action="store_true", help="20 elements, H = 5 and 10, modes 1..16 (seconds)")
    parser.add_argument("--output", type=Path)
    args = parser.parse_args(argv)
    if args.tiny:
        args.elements, args.harmonics, args.modes = 20, [5, 10], [1, 2, 4, 8, 16]
    from nnmstop.models.beam import Beam, beam_structure, tube_plates_parameters

    dofs = beam_structure(Beam.from_parameters(tube_plates_parameters(args.elements))).n_dofs
    started = time.perf_counter()
    lines = [
        "# Craig-Bampton reduced NNM1 against the full model (`python benchmarks/reduction_convergence.py`)",
        "",
        f"Tube on three plates (`tube_plates_parameters`), {args.elements} elements: {dofs} DOFs, 3 stops. "
        "Errors of the reduced orbit against the full model's (sparse path, Newton) at the same amplitude of the "
        "middle plate: relative frequency, and largest contact-DOF harmonic over the largest. "
        "`f_next / (H f)`: the first neglected fixed-interface mode's frequency over the highest frequency in "
        "the balance.",
        "",
        "| H | amplitude | energy | kept modes | f_next / (H f) | frequency error | contact harmonics error |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    needed, all_rows = {}, {}
    for H in args.harmonics:
        rows = all_rows[H] = convergence(args.elements, H, args.amplitudes, args.modes)
        for r in sorted(rows, key=lambda r: (r["amplitude"], r["modes"])):
            lines.append(
                f"| {H} | {r['amplitude']:g} | {r['energy']:.4g} | {r['modes']} | {r['next_over_highest']:.3g} | "
                f"{r['frequency']:.2e} | {r['harmonics']:.2e} |"
            )
        needed[H] = modes_needed(rows, args.tolerance)
    lines += ["", f"Modes needed for both errors below {args.tolerance:g} at every amplitude:", ""]
    lines += ["| H | modes needed |", "|---:|---:|"]
    lines += [f"| {H} | {m if m is not None else 'more than ' + str(max(args.modes))} |" for H, m in needed.items()]
    every = [r for H in args.harmonics for r in all_rows[H] if r["frequency"] > 1e-12]
    ratio = np.log([r["next_over_fundamental"] for r in every])
    slope, intercept = np.polyfit(ratio, np.log([r["frequency"] for r in every]), 1)
    worst = max(r["frequency"] * r["next_over_fundamental"] ** 2 for r in every)
    lines += [
        "",
        f"frequency error against f_next / f (every row): fitted exponent {slope:.2f}, "
        f"error = {np.exp(intercept):.3g} (f / f_next)^{-slope:.2f}; largest error x (f_next / f)^2: {worst:.3g}",
    ]
    fitted = {H: m for H, m in needed.items() if m}
    if len(fitted) >= 2:
        slope = np.polyfit(np.log(list(fitted)), np.log(list(fitted.values())), 1)[0]
        lines += ["", f"fitted exponent of the modes needed against H: {slope:.2f}"]
    lines += ["", f"whole run {time.perf_counter() - started:.0f} s"]
    return emit_report("\n".join(lines), args.output)


if __name__ == "__main__":
    sys.exit(main())
