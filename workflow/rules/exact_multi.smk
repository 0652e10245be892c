# Exact (non-smooth, piecewise-linear) NNM1 with any number of impacts per period: the
# two-impact family continued through its grazing transitions. Thin rule: everything
# happens in nnmstop.tasks.exact (numerics: nnmstop.exact).


rule exact_nnm1:
    """Phase-sequence orbits in closed form, continued from the end of the two-impact family."""
    input:
        two_impacts="results/exact/nnm1_two_impacts.nc",
    output:
        dataset="results/exact/nnm1.nc",
    log:
        "logs/exact_nnm1.log",
    benchmark:
        "benchmarks/runs/exact_nnm1.tsv"
    params:
        task="exact_nnm1",
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
