# Input functions and file patterns shared by the rules.

from nnmstop.study.error_runtime import sweep_cases
from nnmstop.study.runs import format_number
from nnmstop.study.stiff_cases import stiff_case_parameters
from nnmstop.tasks.figures import figure_nnm1_stages


def stage_file(branch, stage):
    """The dataset of stage ``stage`` (1-based) of ``branch``."""
    return f"results/hbm/stages/{branch}_stage{stage}.nc"


def previous_stage(wildcards):
    """Stage k > 1 of a branch starts from the dataset of stage k - 1."""
    stage = int(wildcards.stage)
    if stage == 1:
        return {}
    return {"previous": stage_file(wildcards.branch, stage - 1)}


def branch_stages(wildcards):
    """All stage datasets of a branch, in order."""
    return {"stages": stage_files(wildcards.branch)}


def stage_files(branch):
    """Stage datasets of a branch, in order."""
    n = len(config["branches"][branch]["stages"])
    return [stage_file(branch, k) for k in range(1, n + 1)]


def bifurcation_parent(wildcards):
    """The stage dataset of the parent branch that holds the branch point."""
    spec = config["bifurcations"][wildcards.bifurcation]
    return {"parent": f"results/hbm/stages/{spec['parent']}_stage{spec['stage']}.nc"}


def bifurcated_files(figure):
    """Bifurcated-branch datasets drawn on a figure (``figures.<figure>.bifurcated``)."""
    return [f"results/hbm/bifurcated/{name}.nc" for name in config["figures"][figure].get("bifurcated", [])]


# Every dataset behind the paper's figures (the study's measurements are kept apart).
PAPER_DATASETS = [
    "results/exact/nnm1_two_impacts.nc",
    "results/hbm/nnm1.nc",
    "results/hbm/nnm2.nc",
    "results/compare/nnm1_exact_vs_regularized.nc",
    *stage_files("nnm1"),
    *stage_files("nnm2"),
    *[f"results/hbm/bifurcated/{name}.nc" for name in config.get("bifurcations", {})],
]
# The error per impact regime needs the exact multi-impact NNM1, whose settings section
# (exact_multi) a configuration may leave out: then there is no such branch to compare.
if "exact_multi" in config:
    PAPER_DATASETS += ["results/exact/nnm1.nc", "results/compare/nnm1_regimes.nc"]


def exact_overlay(wildcards):
    """The exact multi-impact NNM1, for Figs 7-11 when figures.overlay_exact is true."""
    if config.get("figures", {}).get("overlay_exact", False):
        return {"exact": "results/exact/nnm1.nc"}
    return {}


def nnm1_stage_files(figure):
    """The NNM1 stage datasets paper figure ``figure`` reads (``figures.<figure>.nnm1_stages``)."""
    return [stage_file("nnm1", k) for k in figure_nnm1_stages(config, figure)]


# The files of the sweep jobs: one pattern each, used by the job rules and by the gathers
# (which receive the files in the order of sweep_cases / stiff_case_parameters).
STUDY_CASE = "results/study/cases/H{harmonics}_eta{eta}.nc"
STUDY_ANM_CASE = "results/study/cases/anm_N{order}_tol{tolerance}.nc"
STUDY_REFERENCE = "results/study/cases/reference_eta{eta}.nc"
STUDY_EXACT_COST = "results/study/cases/exact_cost.nc"
STIFF_EXACT = "results/study/stiff/exact_a{alpha}_b{beta}_d{delta}.nc"
STIFF_BRANCH = "results/study/stiff/nnm1_a{alpha}_b{beta}_d{delta}_e{eta}.nc"
STIFF_ENERGY = "results/study/stiff/energy_a{alpha}.nc"


def study_case_files(config):
    """Files of the error-against-run-time jobs, by kind, in the order the gather expects."""
    cases, n = sweep_cases(config), format_number
    return {
        "cases": [STUDY_CASE.format(harmonics=H, eta=n(eta)) for H, eta in cases["cases"]],
        "anm_cases": [STUDY_ANM_CASE.format(order=order, tolerance=n(tol)) for order, tol in cases["anm_cases"]],
        "references": [STUDY_REFERENCE.format(eta=n(eta)) for eta in cases["references"]],
        "exact_cost": STUDY_EXACT_COST,
    }


def stiff_case_files(config):
    """Files of the stiff-case jobs, by kind, in the order the gather expects."""
    cases, n = stiff_case_parameters(config), format_number
    return {
        "exact": [STIFF_EXACT.format(alpha=n(a), beta=n(b), delta=n(d)) for a, b, d in cases["exact"]],
        "branches": [STIFF_BRANCH.format(alpha=n(a), beta=n(b), delta=n(d), eta=n(e)) for a, b, d, e in cases["branches"]],
        "energy": [STIFF_ENERGY.format(alpha=n(a)) for a in cases["energy"]],
    }
