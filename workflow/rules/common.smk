# Input functions shared by the rules.


def previous_stage(wildcards):
    """Stage k > 1 of a branch starts from the dataset of stage k - 1."""
    stage = int(wildcards.stage)
    if stage == 1:
        return {}
    return {"previous": f"results/hbm/stages/{wildcards.branch}_stage{stage - 1}.nc"}


def branch_stages(wildcards):
    """All stage datasets of a branch, in order."""
    n = len(config["branches"][wildcards.branch]["stages"])
    return {"stages": [f"results/hbm/stages/{wildcards.branch}_stage{k}.nc" for k in range(1, n + 1)]}
