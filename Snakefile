# Nonlinear normal modes of a 2-DOF oscillator with a bilateral elastic stop.
# Data flow: model -> exact orbits -> HBM/ANM continuation -> datasets -> comparisons -> figures.
import glob
import os

from snakemake.utils import min_version

from nnmstop.config import validate_config

min_version("9.0")


configfile: "config/config.yaml"


validate_config(config)

# Jobs run side by side (--cores N): one BLAS thread each avoids oversubscribing the
# cores, which slows dense factorizations by an order of magnitude on a busy machine.
for _threads_variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_threads_variable, "1")


include: "workflow/rules/common.smk"
include: "workflow/rules/exact.smk"
include: "workflow/rules/exact_multi.smk"
include: "workflow/rules/hbm.smk"
include: "workflow/rules/compare.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/manifest.smk"
include: "workflow/rules/study.smk"


PAPER_FIGURES = [f"paper_figures/fig{n:02d}.{ext}" for n in range(2, 12) for ext in ("pdf", "png")]


rule all:
    """Every figure of the paper, the datasets behind them and their SHA-256 manifest."""
    default_target: True
    input:
        PAPER_FIGURES,
        PAPER_DATASETS,
        "results/MANIFEST.sha256",


# After PAPER_FIGURES: the bundle packs the figures.
include: "workflow/rules/bundle.smk"
