"""Tasks of the regularized branches (``workflow/rules`` HBM rules): configuration in, datasets out.

The only place of the HBM side that reads the configuration dict and writes files. The
configuration becomes the settings of :mod:`nnmstop.hbm.stages` through :mod:`nnmstop.settings`
(``branch_settings``, ``branch_spec``, ``bifurcation_spec``, ``system_from_config``, imported here
for the callers that know them from this module); :func:`build_stage` and :func:`build_bifurcated`
return the datasets in memory (tests and studies use them); the tasks ``hbm_stage``,
``hbm_bifurcated`` and ``hbm_branch`` (dispatched by :mod:`nnmstop.pipeline.run`) read their inputs
and write their outputs; the configured paths come from the workflow's rules, never from the library.
Command line: ``python -m nnmstop.tasks.hbm summary BIFURCATED.nc [NNM2.nc]``
prints :func:`nnmstop.hbm.dataset.summarize_bifurcated`.
"""

from __future__ import annotations

import xarray as xr

from nnmstop.hbm.dataset import summarize_bifurcated
from nnmstop.hbm.stages import bifurcated_branch, combine_stages, continue_stage
from nnmstop.netcdf import write_dataset
from nnmstop.settings import (  # noqa: F401 - re-exported: the HBM tasks' settings live in nnmstop.settings
    bifurcation_spec,
    branch_settings,
    branch_spec,
    stability_settings,
    system_from_config,
)

__all__ = [
    "build_stage",
    "build_bifurcated",
    "hbm_stage",
    "hbm_bifurcated",
    "hbm_branch",
    "main",
]


def build_stage(config: dict, branch: str, stage: int, previous: xr.Dataset | None = None) -> xr.Dataset:
    """Dataset of stage ``stage`` of ``branches.<branch>`` (``previous``: the dataset of the stage before)."""
    return continue_stage(
        system_from_config(config), branch_settings(config), branch_spec(config, branch), stage, previous
    )


def build_bifurcated(config: dict, name: str, parent_stage: xr.Dataset) -> xr.Dataset:
    """Dataset of the switched branch ``bifurcations.<name>`` from the dataset of its parent stage."""
    return bifurcated_branch(
        system_from_config(config), branch_settings(config), bifurcation_spec(config, name), parent_stage
    )


def _load(path) -> xr.Dataset:
    with xr.open_dataset(path) as ds:
        return ds.load()


def hbm_stage(config, inputs, outputs, branch: str, stage: str | int):
    """One stage of a regularized NNM branch (HBM + ANM)."""
    stage = int(stage)
    previous = _load(inputs["previous"]) if stage > 1 else None
    ds = build_stage(config, branch, stage, previous)
    name = config["branches"][branch]["stages"][stage - 1]["name"]
    write_dataset(
        ds,
        outputs["dataset"],
        kind="nnm_branch",
        title=f"Regularized {branch.upper()}, stage {stage} ({name}): HBM-ANM continuation",
        summary=(
            f"Periodic orbits of the regularized 2-DOF oscillator with a bilateral elastic stop along "
            f"{branch.upper()}, stage {stage} ({name}), computed by harmonic balance with "
            f"{ds.attrs['harmonics']} harmonics and the asymptotic numerical method."
        ),
        metadata=config.get("metadata"),
    )


def hbm_bifurcated(config, inputs, outputs, bifurcation: str):
    """The branch switched at a branch point of a regularized branch (``bifurcations.<name>``)."""
    ds = build_bifurcated(config, bifurcation, _load(inputs["parent"]))
    n, parent_name = ds.attrs["resonance"], ds.attrs["parent_branch"].upper()
    write_dataset(
        ds,
        outputs["dataset"],
        kind="switched_branch",
        title=f"Branch bifurcating from regularized {parent_name} at the {n}:1 internal resonance ({bifurcation})",
        summary=(
            f"Periodic orbits of the regularized 2-DOF oscillator with a bilateral elastic stop on the curve "
            f"that crosses {parent_name} at its {n}:1 branch point (orbits of period T/{n}), reached by branch "
            f"switching and continued both ways by harmonic balance with {ds.attrs['harmonics']} harmonics "
            f"and the asymptotic numerical method."
        ),
        metadata=config.get("metadata"),
    )


def hbm_branch(config, inputs, outputs, branch: str):
    """Concatenate the stages of a branch into one dataset."""
    combined = combine_stages([_load(path) for path in inputs["stages"]])
    write_dataset(
        combined,
        outputs["dataset"],
        kind="nnm_branch",
        title=f"Regularized {branch.upper()}: HBM-ANM continuation, whole branch",
        summary=(
            f"Periodic orbits of the regularized 2-DOF oscillator with a bilateral elastic stop along "
            f"{branch.upper()}, from its linear mode to the end of the last continuation stage."
        ),
        metadata=config.get("metadata"),
    )


def main(argv=None) -> None:
    """Command line: ``python -m nnmstop.tasks.hbm summary BIFURCATED.nc [NNM2.nc]``."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m nnmstop.tasks.hbm", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    summary = sub.add_parser("summary", help="branch point and bifurcated branch, optionally against NNM2")
    summary.add_argument("bifurcated", help="e.g. results/hbm/bifurcated/nnm1_3to1.nc")
    summary.add_argument("nnm2", nargs="?", help="e.g. results/hbm/nnm2.nc")
    args = parser.parse_args(argv)
    print(summarize_bifurcated(_load(args.bifurcated), _load(args.nnm2) if args.nnm2 else None))


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (hbm_stage, hbm_bifurcated, hbm_branch)}


if __name__ == "__main__":
    main()
