# Input functions shared by the rules.


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
