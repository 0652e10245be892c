# Regularized NNMs by harmonic balance (H harmonics) and ANM continuation, in stages:
# stage k starts from the last point of stage k-1, so a figure that needs only the
# low-energy part of a branch builds only the first stages.


rule hbm_stage:
    """One continuation stage of a regularized NNM branch."""
    input:
        unpack(previous_stage),
    output:
        dataset="results/hbm/stages/{branch}_stage{stage}.nc",
    wildcard_constraints:
        branch="nnm[12]",
        stage=r"\d+",
    log:
        "logs/hbm/{branch}_stage{stage}.log",
    benchmark:
        "benchmarks/runs/hbm_{branch}_stage{stage}.tsv"
    params:
        task="hbm_stage",
        settings=lambda wildcards: repr([config[k] for k in ("model", "hbm", "anm")] + [config["branches"][wildcards.branch], config.get("stability")]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule hbm_bifurcated:
    """A branch switched at a branch point of a regularized branch (config: bifurcations.<name>)."""
    input:
        unpack(bifurcation_parent),
    output:
        dataset="results/hbm/bifurcated/{bifurcation}.nc",
    wildcard_constraints:
        bifurcation="[a-z0-9_]+",
    log:
        "logs/hbm/bifurcated_{bifurcation}.log",
    benchmark:
        "benchmarks/runs/hbm_bifurcated_{bifurcation}.tsv"
    params:
        task="hbm_bifurcated",
        settings=lambda wildcards: repr([config[k] for k in ("model", "hbm", "anm")] + [config["bifurcations"][wildcards.bifurcation], config.get("stability")]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule hbm_branch:
    """A whole regularized NNM branch: its stages concatenated."""
    input:
        unpack(branch_stages),
    output:
        dataset="results/hbm/{branch}.nc",
    wildcard_constraints:
        branch="nnm[12]",
    log:
        "logs/hbm/{branch}.log",
    benchmark:
        "benchmarks/runs/hbm_{branch}.tsv"
    params:
        task="hbm_branch",
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
