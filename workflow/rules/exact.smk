# Exact (non-smooth, piecewise-linear) NNM1 family with one impact per stop per period,
# Section 3.1 of the paper. Thin rule: everything happens in nnmstop.tasks.exact (numerics: nnmstop.exact).


rule exact_two_impacts:
    """Closed-form quarter-period orbits followed by pseudo-arclength continuation."""
    output:
        dataset="results/exact/nnm1_two_impacts.nc",
    log:
        "logs/exact_two_impacts.log",
    benchmark:
        "benchmarks/runs/exact_two_impacts.tsv"
    params:
        task="exact_two_impacts",
        settings=lambda wildcards: repr([config["model"], config["exact"]]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
