# Nonlinear normal modes of a 2-DOF oscillator with a bilateral elastic stop.
# Data flow: model -> exact orbits -> HBM/ANM continuation -> datasets -> comparisons -> figures.
from snakemake.utils import min_version

from nnmstop.config import validate_config

min_version("9.0")


configfile: "config/config.yaml"


validate_config(config)


include: "workflow/rules/common.smk"
include: "workflow/rules/exact.smk"
include: "workflow/rules/hbm.smk"
include: "workflow/rules/figures.smk"


rule all:
    default_target: True
    input:
        "results/exact/nnm1_two_impacts.nc",
        "results/hbm/nnm1.nc",
        "results/hbm/nnm2.nc",
