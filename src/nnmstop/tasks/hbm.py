"""Tasks of the regularized branches (``workflow/rules`` HBM rules): configuration in, datasets out.

The only place of the HBM side that reads the configuration dict and writes files, for any structure:
the ``structure`` section (the paper's oscillator with the parameters of ``model``, a finite-element
beam, or matrices from files) and the sections ``hbm``, ``anm``, ``stability``, ``branches``,
``bifurcations`` become the inputs of :mod:`nnmstop.hbm.stages` through :mod:`nnmstop.settings`
(``structure_from_config``, ``system_from_config``, ``branch_settings``, ``branch_spec``,
``bifurcation_spec``, re-exported here for the callers that know them from this module).
The tube (:mod:`nnmstop.tasks.tube`) runs these same tasks on its own section. :func:`build_stage`
and :func:`build_bifurcated` return the datasets in memory (tests and studies use them); the tasks
``hbm_stage``, ``hbm_bifurcated`` and ``hbm_branch`` (dispatched by :mod:`nnmstop.pipeline.run`) read
their inputs and write their outputs; the paths come from the workflow's rules.
Command line: ``python -m nnmstop.tasks.hbm summary BIFURCATED.nc [NNM2.nc]``
prints :func:`nnmstop.hbm.dataset.summarize_bifurcated`.
"""

from __future__ import annotations

import xarray as xr

from nnmstop.hbm.dataset import branch_kind, is_skipped, summarize_bifurcated
from nnmstop.hbm.stages import bifurcated_branch, combine_stages, continue_stage
from nnmstop.netcdf import read_dataset, write_dataset
from nnmstop.settings import (  # noqa: F401 - re-exported: the HBM tasks' settings live in nnmstop.settings
    STRUCTURE_KINDS,
    bifurcation_spec,
    branch_settings,
    branch_spec,
    stability_settings,
    structure_from_config,
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


def build_bifurcated(config: dict, name: str, parent: xr.Dataset) -> xr.Dataset:
    """Dataset of the switched branch ``bifurcations.<name>`` from the whole branch of its parent."""
    return bifurcated_branch(
        system_from_config(config), branch_settings(config), bifurcation_spec(config, name), parent
    )


def _write(ds: xr.Dataset, path, title: str, summary: str, config: dict, keywords: str = "") -> None:
    write_dataset(
        ds, path, title=title, summary=summary, keywords=keywords, metadata=config.get("metadata"), kind=branch_kind(ds)
    )


def hbm_stage(config, inputs, outputs, branch: str, stage: str | int, keywords: str = ""):
    """One stage of a regularized NNM branch (HBM + ANM); a skipped stage's dataset says why it is empty."""
    stage = int(stage)
    previous = read_dataset(inputs["previous"]) if stage > 1 else None
    ds = build_stage(config, branch, stage, previous)
    name = config["branches"][branch]["stages"][stage - 1]["name"]
    what = _structure_words(ds)
    if is_skipped(ds):
        title = f"Regularized {branch.upper()}, stage {stage} ({name}): skipped"
        summary = f"No orbit: this stage of {branch.upper()} of {what} was not continued. {ds.attrs['end_reason']}."
    else:
        title = f"Regularized {branch.upper()}, stage {stage} ({name}): HBM-ANM continuation"
        summary = (
            f"Periodic orbits of {what} along {branch.upper()}, stage {stage} ({name}), computed by harmonic "
            f"balance with {ds.attrs['harmonics']} harmonics and the asymptotic numerical method. "
            f"End: {ds.attrs['end_reason']}."
        )
    _write(ds, outputs["dataset"], title, summary, config, keywords)


def _structure_words(ds: xr.Dataset) -> str:
    """Words for the structure of a branch dataset, in titles and summaries."""
    kind = ds.attrs.get("structure", "matrices")
    if kind == "two_dof":
        return "the regularized 2-DOF oscillator with a bilateral elastic stop"
    noun = "finite-element beam" if kind == "beam" else "structure"
    stops = "bilateral elastic stop(s)"
    if "stop_kind" in ds:  # not all the paper's bilateral stop: say which
        stops = f"stop(s): {', '.join(str(k).replace('_', ' ') for k in ds.stop_kind.values)}"
    return f"the regularized {int(ds.attrs['dofs'])}-DOF {noun} with {int(ds.attrs['stops'])} {stops}"


def hbm_bifurcated(config, inputs, outputs, bifurcation: str, keywords: str = ""):
    """The branch switched at a branch point of a regularized branch (``bifurcations.<name>``)."""
    ds = build_bifurcated(config, bifurcation, read_dataset(inputs["parent"]))
    n, parent_name = ds.attrs["resonance"], ds.attrs["parent_branch"].upper()
    title = f"Branch bifurcating from regularized {parent_name} at the {n}:1 internal resonance ({bifurcation})"
    if is_skipped(ds):
        summary = f"No orbit: {ds.attrs['end_reason']}."
    else:
        summary = (
            f"Periodic orbits of {_structure_words(ds)} on the curve that crosses {parent_name} at its {n}:1 branch "
            f"point (orbits of period T/{n}), reached by branch switching and continued both ways by harmonic "
            f"balance with {ds.attrs['harmonics']} harmonics and the asymptotic numerical method."
        )
    _write(ds, outputs["dataset"], title, summary, config, keywords)


def hbm_branch(config, inputs, outputs, branch: str, keywords: str = ""):
    """Concatenate the stages of a branch into one dataset (skipped stages left out, named in its attributes)."""
    combined = combine_stages([read_dataset(path) for path in inputs["stages"]])
    summary = (
        f"Periodic orbits of {_structure_words(combined)} along {branch.upper()}, from its linear mode to the end "
        f"of the last continued stage ({combined.attrs['end_reason']})."
    )
    if "skip_reason" in combined.attrs:
        summary += f" Stages not continued: {combined.attrs['skip_reason']}."
    _write(
        combined,
        outputs["dataset"],
        f"Regularized {branch.upper()}: HBM-ANM continuation, whole branch",
        summary,
        config,
        keywords,
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
    print(summarize_bifurcated(read_dataset(args.bifurcated), read_dataset(args.nnm2) if args.nnm2 else None))


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (hbm_stage, hbm_bifurcated, hbm_branch)}


if __name__ == "__main__":
    main()
