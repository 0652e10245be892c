# Regularized NNMs by harmonic balance (H harmonics) and ANM continuation, in stages:
# stage k starts from the last point of stage k-1, so a figure that needs only the
# low-energy part of a branch builds only the first stages. Tasks: nnmstop.tasks.hbm.

HBM_SECTIONS = ("model", "structure", "hbm", "anm", "stability", "metadata")


rule hbm_stage:
    """One continuation stage of a regularized NNM branch."""
    input:
        unpack(previous_stage),
    output:
        dataset=results("hbm/stages/{branch}_stage{stage}.nc"),
    wildcard_constraints:
        branch="nnm[12]",
        stage=r"\d+",
    priority: CRITICAL_PATH
    log:
        logs("hbm/{branch}_stage{stage}.log"),
    benchmark:
        benchmarks("hbm_{branch}_stage{stage}.tsv")
    params:
        config=task_config(*HBM_SECTIONS, branches=lambda wildcards: [wildcards.branch]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule hbm_bifurcated:
    """A branch switched at a branch point of a regularized branch (config: bifurcations.<name>)."""
    input:
        unpack(bifurcation_parent),
    output:
        dataset=results("hbm/bifurcated/{bifurcation}.nc"),
    wildcard_constraints:
        bifurcation="[a-z0-9_]+",
    priority: CRITICAL_PATH
    log:
        logs("hbm/bifurcated_{bifurcation}.log"),
    benchmark:
        benchmarks("hbm_bifurcated_{bifurcation}.tsv")
    params:
        config=task_config(*HBM_SECTIONS, bifurcations=lambda wildcards: [wildcards.bifurcation]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule hbm_branch:
    """A whole regularized NNM branch: its stages concatenated."""
    input:
        unpack(branch_stages),
    output:
        dataset=results("hbm/{branch}.nc"),
    wildcard_constraints:
        branch="nnm[12]",
    priority: CRITICAL_PATH
    log:
        logs("hbm/{branch}.log"),
    benchmark:
        benchmarks("hbm_{branch}.tsv")
    params:
        config=task_config("metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
