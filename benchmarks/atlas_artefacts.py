"""Measure the atlas' regularization artefacts (nnmstop.bifurcation_atlas.artefacts) and write them as a report.

* the jump-down fold of NNM1 of the oscillator (the default forced scene's damping, force on u), exact and
  regularized (H = 100) at a few forces, for decreasing eta: relative distance and its order in eta
  (expected 1);
* along the exact one-contact family from each grazing orbit of the response at F = 0.1, the departure of the
  half-period map's multipliers from the non-impacting ones against the penetration, and its exponent
  (expected 1/2) over the decades the contact durations span.

Usage::

    python benchmarks/atlas_artefacts.py --output benchmarks/atlas_artefacts.md
    python benchmarks/atlas_artefacts.py --exponent-only        # seconds: the square-root law alone

docs/atlas.md includes the committed report; tests/atlas/test_artefacts.py recomputes the exponent and
checks the report's number.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from timing import emit_report  # noqa: E402

#: Contact durations (phase, radians) of the square-root law: the penetration goes as their square, so they
#: span four decades of penetration; beyond 1e-3 the next terms of the expansion show (0.52 at 3e-3).
DURATIONS = np.geomspace(1e-5, 1e-3, 9)
ETAS = (0.1, 0.05, 0.025)
FORCES = (0.1, 0.15, 0.2)
WINDOW = (0.08, 0.17)
HARMONICS = 100


def oscillator(force: float):
    """The paper's oscillator with the default forced scene's damping (ratio 0.01 on both modes), force on u."""
    from nnmstop.models.excitation import Damping, Excitation, HarmonicForce
    from nnmstop.models.structure import two_dof_structure

    structure = two_dof_structure()
    return Excitation(structure, Damping.from_modal_ratios(structure, [0.01, 0.01]), HarmonicForce(force, [1]))


def exponent_rows():
    """Per grazing orbit of the response at F = 0.1: frequency, penetration range, decades, exponent."""
    from nnmstop.bifurcation_atlas.artefacts import multiplier_departure, power_law_exponent
    from nnmstop.exact.forced import grazing_frequencies

    excitation = oscillator(0.1)
    rows = []
    for omega in grazing_frequencies(excitation, 2 * np.pi * 0.05, 2 * np.pi * 0.35):
        penetration, departure = multiplier_departure(excitation, omega, DURATIONS)
        rows.append(
            (
                omega / (2 * np.pi),
                penetration.min(),
                penetration.max(),
                np.log10(penetration.max() / penetration.min()),
                power_law_exponent(penetration, departure),
            )
        )
    return rows


def fold_rows():
    """Per eta: the fold distances at each force and the order against the previous eta."""
    from nnmstop.bifurcation_atlas.artefacts import fold_distances
    from nnmstop.continuation.anm import ANMSettings

    anm = ANMSettings(order=20, tolerance=1e-8, newton_threshold=1e-7, max_steps=3000, points_per_step=2)
    exact, regularized, distance = fold_distances(oscillator(0.1), ETAS, FORCES, HARMONICS, anm, 1e-2, WINDOW)
    worst = distance.max(axis=1)
    orders = [np.nan] + [np.log(worst[i - 1] / worst[i]) / np.log(ETAS[i - 1] / ETAS[i]) for i in range(1, len(ETAS))]
    return exact, regularized, distance, worst, orders


def report(exponent_only: bool) -> str:
    lines = ["## Square-root law of the exact multipliers near grazing", ""]
    lines += [
        "F = 0.1, the default forced scene's damping; contact durations "
        f"{DURATIONS[0]:g} to {DURATIONS[-1]:g} (phase) from each grazing orbit; exponent of "
        "max_k |nu_k - nu0_k| against the penetration max|x| - gap (least squares in log-log; expected 1/2).",
        "",
        "| grazing frequency [Hz] | penetration range | decades | exponent |",
        "| ---: | ---: | ---: | ---: |",
    ]
    for f, low, high, decades, slope in exponent_rows():
        lines.append(f"| {f:.6f} | {low:.3g} - {high:.3g} | {decades:.2f} | {slope:.4f} |")
    if not exponent_only:
        exact, regularized, distance, worst, orders = fold_rows()
        lines += ["", "## Exact against regularized jump-down fold of NNM1", ""]
        lines += [
            f"Harmonic balance with H = {HARMONICS}; the fold located on each response (Omega extremal on the ANM "
            "steps) nearest the exact one; relative distance in frequency; order in eta between successive rows "
            "of the largest distance (expected 1).",
            "",
            "| eta | " + " | ".join(f"F = {F:g}" for F in FORCES) + " | largest | order |",
            "| ---: | " + " | ".join("---:" for _ in FORCES) + " | ---: | ---: |",
            "| exact [Hz] | " + " | ".join(f"{f:.6f}" for f in exact) + " | | |",
        ]
        for eta, row, big, order in zip(ETAS, distance, worst, orders):
            shown = "" if np.isnan(order) else f"{order:.3f}"
            lines.append(f"| {eta:g} | " + " | ".join(f"{d:.3e}" for d in row) + f" | {big:.3e} | {shown} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=None, help="also write the report here")
    parser.add_argument("--exponent-only", action="store_true", help="only the square-root law (seconds)")
    args = parser.parse_args(argv)
    return emit_report(report(args.exponent_only), args.output)


if __name__ == "__main__":
    sys.exit(main())
