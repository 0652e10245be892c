# Nonlinear normal modes of a 2-DOF oscillator with a bilateral elastic stop.
# Data flow: model -> exact orbits -> HBM/ANM continuation -> datasets -> comparisons -> figures.
import glob
import os
import sys

from snakemake.utils import min_version

from nnmstop.config import validate_config
from nnmstop.pipeline.numerics import numerics_env

min_version("9.0")


configfile: "config/config.yaml"


validate_config(config)

# Pinned numerics for every job (nnmstop.pipeline.numerics.numerics_env, docs/reproducibility.md):
# one BLAS thread (jobs run side by side; threads oversubscribe the cores) and one
# OpenBLAS kernel family and numpy SIMD level per CPU family, overriding the user's
# shell, so that machines of one family build byte-identical datasets. Jobs are
# subprocesses and inherit os.environ.
os.environ.update(numerics_env(pin_kernels=config.get("numerics", {}).get("pin_kernels", True)))


# Rule files in the order of the data flow; a rule refers to the outputs of the rules it reads
# (rules.<rule>.output), so a file comes after those it reads from. Each rule runs the task of
# its name in nnmstop.tasks.<rule file> (nnmstop.pipeline.run).
include: "workflow/rules/common.smk"
include: "workflow/rules/exact.smk"
include: "workflow/rules/hbm.smk"
include: "workflow/rules/compare.smk"
include: "workflow/rules/structure.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/study.smk"


PAPER_DATASETS = paper_datasets()
PAPER_FIGURES = paper_figure_files()


include: "workflow/rules/manifest.smk"
include: "workflow/rules/explorer.smk"


if "tube" in config:  # the finite-element tube (issue 14); a configuration may leave it out

    include: "workflow/rules/tube.smk"


if "tube_plates" in config:  # a tube on several support plates, reduced (issue 32)

    include: "workflow/rules/tube_plates.smk"


if "forced" in config:  # forced responses (issue 23); a configuration may leave them out

    include: "workflow/rules/forced.smk"


if "atlas" in config:  # the bifurcation atlas (issue 31); a configuration may leave it out

    include: "workflow/rules/atlas.smk"


include: "workflow/rules/verify.smk"  # after the forced and atlas rules: it checks their datasets too
include: "workflow/rules/bundle.smk"
include: "workflow/rules/docs.smk"


rule all:
    """Every figure of the paper, the datasets behind them and their SHA-256 manifest."""
    default_target: True
    input:
        PAPER_FIGURES,
        PAPER_DATASETS,
        rules.dataset_manifest.output.manifest,


onstart:
    # A job killed with SIGKILL (or the OOM killer) leaves the temporary file of its atomic writer; the next
    # build removes those no live writer holds (nnmstop.atomic), and says so.
    from nnmstop.atomic import remove_stale_temporaries

    for stale in remove_stale_temporaries(["results", "paper_figures", "dist", "docs"]):
        print(f"nnmstop: removed {stale}, a partial file left by an interrupted job", file=sys.stderr)


rule report_figures:
    """Every figure the build made (`built_figures`): the target of `snakemake --report report.html report_figures`."""
    input:
        built_figures(),
