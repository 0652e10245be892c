# Exact (non-smooth) against regularized NNM1. Section 4.1 (Figs 2-4): the two-impact family
# against NNM1 stage 1 only (from the linear mode to the first orbit with more than one impact
# per stop), so Figs 2-4 compute no NNM2 and no later NNM1 stage; energies of the labelled
# points a) and b): `compare.points`. Issue 6: the frequency error over the whole NNM1 branch
# per impact regime. Issue 13: the Floquet verdicts per impact regime (the regularized verdict
# is the `stable` flag of the whole NNM1 dataset). Tasks: nnmstop.tasks.compare.


rule compare_nnm1:
    """Exact vs regularized NNM1 at matched energies: frequency and orbit differences."""
    input:
        exact=rules.exact_two_impacts.output.dataset,
        nnm1=stage_file("nnm1", 1),
    output:
        dataset=results("compare/nnm1_exact_vs_regularized.nc"),
    priority: CRITICAL_PATH
    log:
        logs("compare/nnm1_exact_vs_regularized.log"),
    benchmark:
        benchmarks("compare_nnm1.tsv")
    params:
        config=task_config("model", "hbm", "compare", "metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule compare_regimes:
    """Frequency error of the regularized NNM1 in each impact regime: dataset and CSV table."""
    input:
        exact=rules.exact_nnm1.output.dataset,
        nnm1=branch_file("nnm1"),
    output:
        dataset=results("compare/nnm1_regimes.nc"),
        table=results("compare/nnm1_regimes.csv"),
    log:
        logs("compare/nnm1_regimes.log"),
    benchmark:
        benchmarks("compare_regimes.tsv")
    params:
        config=task_config("model", "metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule compare_stability:
    """Agreement of the exact and regularized stability verdicts per impact regime: dataset and CSV table."""
    input:
        exact=rules.exact_nnm1.output.dataset,
        nnm1=branch_file("nnm1"),
    output:
        dataset=results("compare/nnm1_stability.nc"),
        table=results("compare/nnm1_stability.csv"),
    log:
        logs("compare/nnm1_stability.log"),
    benchmark:
        benchmarks("compare_stability.tsv")
    params:
        config=task_config("model", "metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
