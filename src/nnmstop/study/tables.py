"""The study's tables, printed from its datasets: the numbers a page about the study may quote.

:func:`study_tables` (Markdown) reads ``results/study/error_vs_runtime.nc`` and
``results/study/stiff_cases.nc`` only: the error split and its cost per ``(eta, H)``, the
smallest ``H`` whose truncation part stays below the regularization part of each ``eta``, the
ANM sweep, the harmonics the stiff cases need, and the exactness of the exact solver; every
setting or case not computed appears with its reason. Run times are measurements of the machine
that built the datasets (``times=False`` leaves them out, for a page compared across machines).

Command line::

    python -m nnmstop.study.tables [results/study] [--no-times]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import xarray as xr

from nnmstop.netcdf import read_dataset
from nnmstop.study.status import status_words

__all__ = ["markdown_table", "error_split_rows", "harmonics_advice_rows", "stiff_rows", "study_tables", "main"]


def _number(value, digits: int = 2) -> str:
    """A number as the tables print it (``-`` where it was not computed)."""
    value = float(value)
    return "-" if not np.isfinite(value) else f"{value:.{digits}g}"


def markdown_table(header: list[str], rows: list[list]) -> str:
    """A Markdown table (no external formatter)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def _largest(values, computed) -> float:
    """Largest ``|value|`` over the computed entries (NaN when none is)."""
    values = np.abs(np.asarray(values, dtype=float))[np.asarray(computed)]
    return float(values.max()) if values.size else np.nan


def error_split_rows(ds: xr.Dataset, times: bool = True) -> tuple[list[str], list[list]]:
    """One row per ``(eta, H)``: the largest errors over the study energies and their two parts.

    A setting (or reference) compared at some energies only gets its largest errors over those,
    marked ``*``, and the energies left out in its reason.
    """
    header = (
        ["eta", "H"]
        + (["CPU time (s)"] if times else [])
        + [
            "frequency error",
            "truncation part",
            "regularization part",
            "max x error",
            "max force error / max force",
            "not computed because",
        ]
    )
    words, energies = status_words(ds["status"]), ds["energy"].values
    rows = []
    for j, eta in enumerate(ds["eta"].values):
        reference = ds.isel(eta=j)
        ref_ok = reference["reference_energy_status"].values == 0
        for i, H in enumerate(ds["harmonics"].values):
            case = reference.isel(harmonics=i)
            ok = case["energy_status"].values == 0
            star = "" if ok.all() else "*"
            force = case["max_force_difference_at_energy"].values / case["force_max_exact_at_energy"].values
            cells = [
                _largest(case["relative_frequency_difference_at_energy"], ok),
                _largest(case["relative_frequency_difference_truncation_at_energy"], ok & ref_ok),
                _largest(reference["relative_frequency_difference_regularization_at_energy"], ref_ok),
                _largest(case["max_x_difference_at_energy"], ok),
                _largest(force, ok),
            ]
            shown = [_number(c) + (star if np.isfinite(c) else "") for c in cells]
            shown[2] = _number(cells[2]) + ("" if ref_ok.all() or not np.isfinite(cells[2]) else "*")
            reason = words[i, j] or ""
            if reason and ok.any():
                left_out = ", ".join(f"{e:g}" for e in energies[~ok])
                reason += f" at E = {left_out} (* over the other energies)"
            rows.append([f"{eta:g}", int(H)] + ([_number(case["cpu_time"])] if times else []) + shown + [reason])
    return header, rows


def harmonics_advice_rows(ds: xr.Dataset, times: bool = True) -> tuple[list[str], list[list]]:
    """Per ``eta``: the smallest ``H`` compared at every energy whose frequency truncation part is below
    the regularization part (more harmonics would not make the frequency closer to the exact one)."""
    header = (
        ["eta", "regularization part (frequency)", "smallest H with truncation part below it"]
        + (["CPU time (s)"] if times else [])
        + ["frequency error", "max x error"]
    )
    rows = []
    for j, eta in enumerate(ds["eta"].values):
        floor = float(ds["frequency_error_regularization"].values[j])
        truncation = ds["frequency_error_truncation"].values[:, j]
        enough = np.flatnonzero(np.isfinite(truncation) & (truncation < floor))
        if not np.isfinite(floor) or not enough.size:
            reason = status_words(ds["reference_status"])[j] or "no setting of the sweep is that accurate"
            rows.append([f"{eta:g}", _number(floor), f"none ({reason})"] + (["-"] if times else []) + ["-", "-"])
            continue
        case = ds.isel(eta=j, harmonics=int(enough[0]))
        rows.append(
            [f"{eta:g}", _number(floor), int(case["harmonics"])]
            + ([_number(case["cpu_time"])] if times else [])
            + [_number(case["frequency_error"]), _number(case["x_error"])]
        )
    return header, rows


def anm_rows(ds: xr.Dataset, times: bool = True) -> tuple[list[str], list[list]]:
    """One row per ANM ``(order, tolerance)``: steps, the accuracy of the stored path, the frequency error."""
    header = (
        ["order", "tolerance", "steps"]
        + (["CPU time (s)"] if times else [])
        + ["path frequency error", "frequency error", "not compared because"]
    )
    words = status_words(ds["anm_status"])
    rows = []
    for i, order in enumerate(ds["order"].values):
        for j, tol in enumerate(ds["tolerance"].values):
            case = ds.isel(order=i, tolerance=j)
            steps = int(case["anm_steps"])
            rows.append(
                [int(order), f"{tol:g}", steps if steps >= 0 else "-"]
                + ([_number(case["anm_cpu_time"])] if times else [])
                + [_number(case["anm_path_frequency_error"]), _number(case["anm_frequency_error"]), words[i, j] or ""]
            )
    return header, rows


def stiff_rows(ds: xr.Dataset) -> tuple[list[str], list[list]]:
    """Per ``alpha``: the harmonics NNM1 stage 1 needs at each ``eta`` (or why none), the frequency error
    with them, and the two-impact range of the exact family."""
    etas = ds["eta"].values
    header = (
        ["alpha"]
        + [f"H needed, eta = {e:g}" for e in etas]
        + [f"frequency error, eta = {e:g}" for e in etas]
        + ["exact two-impact range"]
    )
    words = status_words(ds["status"])
    rows = []
    for i, alpha in enumerate(ds["alpha"].values):
        needed = []
        for j in range(etas.size):
            H = int(ds["harmonics"].values[i, j])
            needed.append(str(H) if H > 0 else f"none ({words[i, j]})")
        errors = [_number(ds["frequency_error"].values[i, j]) for j in range(etas.size)]
        span = f"{_number(ds['exact_energy_min'].values[i], 3)} .. {_number(ds['exact_energy_max'].values[i], 3)}"
        rows.append([f"{alpha:g}"] + needed + errors + [span])
    return header, rows


def _exactness(ds: xr.Dataset) -> str:
    residual = max(float(ds["exact_relative_residual"].max()), float(ds["ratio_exact_relative_residual"].max()))
    periodic = max(float(ds["exact_periodicity_error"].max()), float(ds["ratio_exact_periodicity_error"].max()))
    confirmed = bool(ds["exact_end_confirmed"].all()) and bool(ds["ratio_exact_end_confirmed"].all())
    return (
        f"Exact solver over every stiff case: largest relative residual {residual:.2g}, largest periodicity error "
        f"by event-located integration {periodic:.2g}; every family end confirmed with a 100 times smaller step: "
        f"{'yes' if confirmed else 'no (see exact_end_note)'}."
    )


def study_tables(error_ds: xr.Dataset, stiff_ds: xr.Dataset, times: bool = True) -> str:
    """Every table of the study in Markdown, from the two gathered datasets."""
    note = (
        f"Errors are the largest over the study energies; parts: H_ref = {error_ds.attrs['reference_harmonics']} "
        "against exact (regularization), H against H_ref (truncation)."
    )
    parts = [
        "## Error against run time",
        note,
        markdown_table(*error_split_rows(error_ds, times)),
        "## Harmonics enough for each eta",
        markdown_table(*harmonics_advice_rows(error_ds, times)),
        f"## ANM order and tolerance (H = {error_ds.attrs['anm_sweep_harmonics']}, "
        f"eta = {error_ds.attrs['anm_sweep_eta']:g})",
        markdown_table(*anm_rows(error_ds, times)),
        f"## Stiff cases (harmonics tried: {stiff_ds.attrs['harmonics_tried']})",
        markdown_table(*stiff_rows(stiff_ds)),
        _exactness(stiff_ds),
    ]
    return "\n\n".join(parts) + "\n"


def main(argv=None) -> None:
    """Command line: print :func:`study_tables` of ``results/study`` (or the folder given)."""
    parser = argparse.ArgumentParser(prog="python -m nnmstop.study.tables", description=__doc__.splitlines()[0])
    parser.add_argument(
        "folder", nargs="?", default="results/study", help="where error_vs_runtime.nc and stiff_cases.nc are"
    )
    parser.add_argument("--no-times", action="store_true", help="leave out the run times (machine measurements)")
    args = parser.parse_args(argv)
    folder = Path(args.folder)
    print(
        study_tables(
            read_dataset(folder / "error_vs_runtime.nc"),
            read_dataset(folder / "stiff_cases.nc"),
            times=not args.no_times,
        ),
        end="",
    )


if __name__ == "__main__":
    main()
