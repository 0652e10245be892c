# The paper's next step (issue 14): NNMs of a finite-element tube with bilateral elastic stops,
# computed by the same harmonic-balance + ANM engine. `snakemake --cores 2 tube` builds all of it.


def tube_path(name):
    """Path of a tube dataset under results/tube/."""
    return f"results/tube/{name}.nc"


TUBE_FIGURE_INPUTS = {
    "frequency_energy": ["nnm1", "nnm2", "exact"],
    "shapes": ["nnm1"],
    "contact_force": ["nnm1"],
    "exact_vs_regularized": ["nnm1", "exact", "comparison"],
}
TUBE_DATASETS = {"nnm1": tube_path("nnm1"), "nnm2": tube_path("nnm2"), "exact": tube_path("exact_nnm1"),
                 "comparison": tube_path("nnm1_exact_vs_regularized")}


def tube_study_cases():
    study = config["tube"]["study"]
    return [f"results/tube/study/gap{g:g}_k{k:g}.nc" for g in study["gaps"] for k in study["stiffness_factors"]]


rule tube_exact:
    """Exact NNM1 of the non-smooth tube (one impact per stop side per period)."""
    output:
        dataset=TUBE_DATASETS["exact"],
    log:
        "logs/tube/exact_nnm1.log",
    benchmark:
        "benchmarks/runs/tube_exact_nnm1.tsv"
    params:
        task="tube_exact",
        settings=lambda wildcards: repr([config["tube"][k] for k in ("structure", "exact")]),
    script:
        "../scripts/run_task.py"


rule tube_branch:
    """A regularized NNM of the tube by HBM + ANM (tube.branches.<branch>)."""
    output:
        dataset="results/tube/{branch}.nc",
    wildcard_constraints:
        branch="nnm[0-9]+",
    log:
        "logs/tube/{branch}.log",
    benchmark:
        "benchmarks/runs/tube_{branch}.tsv"
    params:
        task="tube_branch",
        settings=lambda wildcards: repr([config["anm"]] + [config["tube"][k] for k in ("structure", "harmonics", "points_per_step", "max_truncation", "max_steps", "stability")] + [config["tube"]["branches"][wildcards.branch]]),
    script:
        "../scripts/run_task.py"


rule tube_compare:
    """Exact against regularized NNM1 of the tube at matched energies."""
    input:
        exact=TUBE_DATASETS["exact"],
        nnm1=TUBE_DATASETS["nnm1"],
    output:
        dataset=TUBE_DATASETS["comparison"],
    log:
        "logs/tube/compare.log",
    params:
        task="tube_compare",
        settings=lambda wildcards: repr(config["tube"]["compare_count"]),
    script:
        "../scripts/run_task.py"


rule tube_figure:
    """paper_figures/tube_<name>.{pdf,png}; reads only the datasets its figure draws."""
    input:
        unpack(lambda wildcards: {key: TUBE_DATASETS[key] for key in TUBE_FIGURE_INPUTS[wildcards.figure]}),
    output:
        pdf="paper_figures/tube_{figure}.pdf",
        png="paper_figures/tube_{figure}.png",
    wildcard_constraints:
        figure="|".join(TUBE_FIGURE_INPUTS),
    log:
        "logs/tube/figure_{figure}.log",
    params:
        task="tube_figure",
        settings=lambda wildcards: repr(config["tube"]["figures"]),
    script:
        "../scripts/run_task.py"


rule tube_study_case:
    """NNM1 of the tube for one gap (m) and stop stiffness factor: one job per case."""
    output:
        dataset="results/tube/study/gap{gap}_k{factor}.nc",
    log:
        "logs/tube/study_gap{gap}_k{factor}.log",
    benchmark:
        "benchmarks/runs/tube_study_gap{gap}_k{factor}.tsv"
    params:
        task="tube_study_case",
        settings=lambda wildcards: repr([config["anm"], config["tube"]]),
    script:
        "../scripts/run_task.py"


rule tube_study:
    """paper_figures/tube_study.{pdf,png}: the study's NNM1 backbones in physical units."""
    input:
        cases=tube_study_cases(),
    output:
        pdf="paper_figures/tube_study.pdf",
        png="paper_figures/tube_study.png",
    log:
        "logs/tube/study.log",
    params:
        task="tube_study",
    script:
        "../scripts/run_task.py"


rule tube:
    """Everything of the tube: datasets and figures (not in the default target)."""
    input:
        list(TUBE_DATASETS.values()),
        expand("paper_figures/tube_{figure}.{ext}", figure=TUBE_FIGURE_INPUTS, ext=("pdf", "png")),
        "paper_figures/tube_study.pdf",
