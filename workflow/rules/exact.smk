# Exact (non-smooth, piecewise-linear) NNM1, Section 3.1 of the paper: the family with one
# impact per stop per period, then its continuation through the grazing transitions to any
# number of impacts per period. Thin rules: the tasks are in nnmstop.tasks.exact.


rule exact_two_impacts:
    """Closed-form quarter-period orbits followed by pseudo-arclength continuation."""
    output:
        dataset=results("exact/nnm1_two_impacts.nc"),
    log:
        logs("exact_two_impacts.log"),
    benchmark:
        benchmarks("exact_two_impacts.tsv")
    params:
        config=task_config("model", "exact", "metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule exact_nnm1:
    """Phase-sequence orbits in closed form, continued from the end of the two-impact family."""
    input:
        two_impacts=rules.exact_two_impacts.output.dataset,
    output:
        dataset=results("exact/nnm1.nc"),
    priority: CRITICAL_PATH
    log:
        logs("exact_nnm1.log"),
    benchmark:
        benchmarks("exact_nnm1.tsv")
    params:
        config=task_config("model", "exact_multi", "metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
