# Study (issue 5): error against run time, and stiff / extreme cases (nnmstop.study).
# Every sweep case is its own job (wildcards), so the sweep spreads over local cores
# (--cores N) or over a cluster (--profile profiles/slurm); gather rules assemble them.
# These outputs are measurements: they live under results/study/ and
# paper_figures/{error_vs_runtime,stiff_cases}.*, and nothing behind Figs 2-11 reads them.
#
#   snakemake --cores 2 study                 # both studies (datasets and figures)
#   snakemake --cores 2 study_error_vs_runtime_figure
#   snakemake --profile profiles/slurm study


STUDY_CASES = study_case_files() if "study" in config else {"cases": [], "anm_cases": [], "references": [], "exact_cost": []}
STIFF_CASES = stiff_case_files() if "study" in config else {"exact": [], "branches": [], "energy": []}
STUDY_NUMBER = r"[0-9][0-9.e-]*"
# The configuration each kind of job reads (nnmstop.settings.study_settings), and nothing else: a job
# reruns when its part changes, and only then (not for an edit of branches.nnm2, say).
STUDY_COMMON = dict(branches=["nnm1"])
STUDY_RUNS = ("model", "anm", "stability", "exact", "metadata")
ERROR_SWEEP_CONFIG = task_config(
    *STUDY_RUNS, **STUDY_COMMON,
    study=["energies", "end_margin", "phase_samples", "max_truncation", "points_per_step", "error_runtime"],
)
STIFF_CONFIG = task_config(
    *STUDY_RUNS, **STUDY_COMMON,
    study=["energies", "end_margin", "phase_samples", "max_truncation", "points_per_step", "stiff"],
)

# Gathers and figures are light: on a cluster they run on the submitting node.
localrules:
    study,
    study_error_vs_runtime,
    study_error_vs_runtime_figure,
    study_stiff_cases,
    study_stiff_cases_figure,


rule study_error_case:
    """One (H, eta) setting: timed, guarded continuation of NNM1 stage 1, errors at matched energies."""
    input:
        exact=rules.exact_two_impacts.output.dataset,
    output:
        dataset=results("study/cases/H{harmonics}_eta{eta}.nc"),
    wildcard_constraints:
        harmonics=r"\d+",
        eta=STUDY_NUMBER,
    log:
        logs("study/H{harmonics}_eta{eta}.log"),
    benchmark:
        benchmarks("study_H{harmonics}_eta{eta}.tsv")
    params:
        config=ERROR_SWEEP_CONFIG,
    resources:
        runtime=30,
        mem_mb=2000,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_anm_case:
    """One ANM (order, tolerance) setting at study.error_runtime.anm_harmonics and model.eta."""
    input:
        exact=rules.exact_two_impacts.output.dataset,
    output:
        dataset=results("study/cases/anm_N{order}_tol{tolerance}.nc"),
    wildcard_constraints:
        order=r"\d+",
        tolerance=STUDY_NUMBER,
    log:
        logs("study/anm_N{order}_tol{tolerance}.log"),
    benchmark:
        benchmarks("study_anm_N{order}_tol{tolerance}.tsv")
    params:
        config=ERROR_SWEEP_CONFIG,
    resources:
        runtime=30,
        mem_mb=2000,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_reference:
    """Reference orbits of one eta with study.error_runtime.reference_harmonics (truncation part)."""
    input:
        exact=rules.exact_two_impacts.output.dataset,
    output:
        dataset=results("study/cases/reference_eta{eta}.nc"),
    wildcard_constraints:
        eta=STUDY_NUMBER,
    log:
        logs("study/reference_eta{eta}.log"),
    benchmark:
        benchmarks("study_reference_eta{eta}.tsv")
    params:
        config=ERROR_SWEEP_CONFIG,
    resources:
        runtime=60,
        mem_mb=4000,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_exact_cost:
    """Cost per orbit of the exact (closed-form) solver."""
    output:
        dataset=results("study/cases/exact_cost.nc"),
    log:
        logs("study/exact_cost.log"),
    benchmark:
        benchmarks("study_exact_cost.tsv")
    params:
        config=task_config("model", "exact", "metadata", study=["phase_samples"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_error_vs_runtime:
    """Gather: results/study/error_vs_runtime.nc (coordinates harmonics, eta, energy, order, tolerance)."""
    input:
        cases=STUDY_CASES["cases"],
        anm_cases=STUDY_CASES["anm_cases"],
        references=STUDY_CASES["references"],
        exact_cost=STUDY_CASES["exact_cost"],
    output:
        dataset=results("study/error_vs_runtime.nc"),
    log:
        logs("study/error_vs_runtime.log"),
    benchmark:
        benchmarks("study_error_vs_runtime.tsv")
    params:
        config=ERROR_SWEEP_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_error_vs_runtime_figure:
    """Error against run time, log-log, Pareto front marked, labelled points."""
    input:
        dataset=rules.study_error_vs_runtime.output.dataset,
    output:
        pdf=paper_figures("error_vs_runtime.pdf"),
        png=report(paper_figures("error_vs_runtime.png"), category="Study"),
    log:
        logs("study/error_vs_runtime_figure.log"),
    benchmark:
        benchmarks("study_error_vs_runtime_figure.tsv")
    params:
        config=task_config(study=["png_dpi"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_stiff_exact:
    """Exact family of one (alpha, beta, delta): residuals, confirmed end, periodicity by integration."""
    output:
        dataset=results("study/stiff/exact_a{alpha}_b{beta}_d{delta}.nc"),
    wildcard_constraints:
        alpha=STUDY_NUMBER,
        beta=STUDY_NUMBER,
        delta=STUDY_NUMBER,
    log:
        logs("study/stiff/exact_a{alpha}_b{beta}_d{delta}.log"),
    benchmark:
        benchmarks("study_stiff_exact_a{alpha}_b{beta}_d{delta}.tsv")
    params:
        config=task_config("model", "exact", "metadata"),
    resources:
        runtime=30,
        mem_mb=2000,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_stiff_branch:
    """Harmonics ladder of NNM1 stage 1 for one stiff case, errors against its exact family."""
    input:
        exact=rules.study_stiff_exact.output.dataset,
    output:
        dataset=results("study/stiff/nnm1_a{alpha}_b{beta}_d{delta}_e{eta}.nc"),
    wildcard_constraints:
        alpha=STUDY_NUMBER,
        beta=STUDY_NUMBER,
        delta=STUDY_NUMBER,
        eta=STUDY_NUMBER,
    log:
        logs("study/stiff/nnm1_a{alpha}_b{beta}_d{delta}_e{eta}.log"),
    benchmark:
        benchmarks("study_stiff_nnm1_a{alpha}_b{beta}_d{delta}_e{eta}.tsv")
    params:
        config=STIFF_CONFIG,
    resources:
        runtime=60,
        mem_mb=2000,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_stiff_energy:
    """Exact solver and HBM at energies from 1e-6 to 1e6, for one alpha."""
    output:
        dataset=results("study/stiff/energy_a{alpha}.nc"),
    wildcard_constraints:
        alpha=STUDY_NUMBER,
    log:
        logs("study/stiff/energy_a{alpha}.log"),
    benchmark:
        benchmarks("study_stiff_energy_a{alpha}.tsv")
    params:
        config=STIFF_CONFIG,
    resources:
        runtime=30,
        mem_mb=2000,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_stiff_cases:
    """Gather: results/study/stiff_cases.nc (alpha x eta, beta x delta, energy x energy_alpha)."""
    input:
        exact=STIFF_CASES["exact"],
        branches=STIFF_CASES["branches"],
        energy=STIFF_CASES["energy"],
    output:
        dataset=results("study/stiff_cases.nc"),
    log:
        logs("study/stiff_cases.log"),
    benchmark:
        benchmarks("study_stiff_cases.tsv")
    params:
        config=STIFF_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_stiff_cases_figure:
    """Stiff cases: harmonics needed, exactness of the exact solver, errors, extreme energies."""
    input:
        dataset=rules.study_stiff_cases.output.dataset,
    output:
        pdf=paper_figures("stiff_cases.pdf"),
        png=report(paper_figures("stiff_cases.png"), category="Study"),
    log:
        logs("study/stiff_cases_figure.log"),
    benchmark:
        benchmarks("study_stiff_cases_figure.tsv")
    params:
        config=task_config(study=["png_dpi"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study_manifest:
    """results/study/MANIFEST.sha256 over the two gathered study datasets, which hold every case (recorded by
    update_reference, checked by verify: their run times are measurements of the machine, not compared)."""
    input:
        datasets=[rules.study_error_vs_runtime.output.dataset, rules.study_stiff_cases.output.dataset],
    output:
        manifest=results("study/MANIFEST.sha256"),
    log:
        logs("study/manifest.log"),
    benchmark:
        benchmarks("study_manifest.tsv")
    params:
        config=task_config(),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule study:
    """Both studies: datasets, their manifest and figures."""
    input:
        rules.study_manifest.output.manifest,
        rules.study_error_vs_runtime.output.dataset,
        rules.study_error_vs_runtime_figure.output,
        rules.study_stiff_cases.output.dataset,
        rules.study_stiff_cases_figure.output,
