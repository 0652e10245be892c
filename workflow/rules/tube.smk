# The paper's next step (issue 14): NNMs of a finite-element tube with bilateral elastic stops. The tube
# is a structure like any other: its rules run the tasks of the default structure (nnmstop.tasks.hbm and
# nnmstop.tasks.structure) on the `tube` section, passed in the shape of the top-level configuration
# (tube_task_config). `snakemake --cores 2 tube` builds all of it; a figure asked for alone builds only
# the datasets it draws. Tasks: nnmstop.tasks.tube.

rule tube_stage:
    """One continuation stage of a regularized NNM of the tube (`tube.branches.<branch>.stages`)."""
    input:
        unpack(tube_previous_stage),
    output:
        dataset=results("tube/stages/{branch}_stage{stage}.nc"),
    wildcard_constraints:
        branch="nnm[0-9]+",
        stage=r"\d+",
    log:
        logs("tube/{branch}_stage{stage}.log"),
    benchmark:
        benchmarks("tube_{branch}_stage{stage}.tsv")
    params:
        config=tube_task_config("structure", "hbm", "anm", "stability", "metadata", branches=True),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_branch:
    """A regularized NNM of the tube: its stages joined."""
    input:
        stages=lambda wildcards: tube_stage_files(wildcards.branch),
    output:
        dataset=results("tube/{branch}.nc"),
    wildcard_constraints:
        branch="nnm[0-9]+",
    log:
        logs("tube/{branch}.log"),
    benchmark:
        benchmarks("tube_{branch}.tsv")
    params:
        config=tube_task_config("metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_exact:
    """Exact NNM1 of the non-smooth tube (one impact per stop side per period)."""
    output:
        dataset=TUBE_DATASETS["exact"],
    log:
        logs("tube/exact_nnm1.log"),
    benchmark:
        benchmarks("tube_exact_nnm1.tsv")
    params:
        config=tube_task_config("structure", "exact", "metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_compare:
    """Exact against regularized NNM1 of the tube at matched energies."""
    input:
        exact=rules.tube_exact.output.dataset,
        nnm1=TUBE_DATASETS["nnm1"],
    output:
        dataset=TUBE_DATASETS["comparison"],
    log:
        logs("tube/compare.log"),
    benchmark:
        benchmarks("tube_compare.tsv")
    params:
        config=tube_task_config("structure", "compare_count", "metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_figure:
    """paper_figures/tube_<figure>.{pdf,png}; reads only the datasets its figure draws."""
    input:
        unpack(lambda wildcards: {key: TUBE_DATASETS[key] for key in TUBE_FIGURE_INPUTS[wildcards.figure]}),
    output:
        pdf=paper_figures("tube_{figure}.pdf"),
        png=report(paper_figures("tube_{figure}.png"), category="Tube", subcategory="{figure}"),
    wildcard_constraints:
        figure="|".join(TUBE_FIGURE_INPUTS),
    log:
        logs("tube/figure_{figure}.log"),
    benchmark:
        benchmarks("tube_figure_{figure}.tsv")
    params:
        config=tube_task_config("figures"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_study_case:
    """NNM1 of the tube for one gap (m) and stop stiffness factor: one job per case (spreads over a cluster)."""
    output:
        dataset=results("tube/study/gap{gap}_k{factor}.nc"),
    log:
        logs("tube/study_gap{gap}_k{factor}.log"),
    benchmark:
        benchmarks("tube_study_gap{gap}_k{factor}.tsv")
    params:
        config=task_config("anm", "stability", "metadata", tube=["structure", "hbm", "anm", "stability", "branches", "exact", "compare_count", "figures", "study"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_study:
    """paper_figures/tube_study.{pdf,png}: the study's NNM1 backbones in physical units."""
    input:
        cases=tube_study_files(),
    output:
        pdf=paper_figures("tube_study.pdf"),
        png=report(paper_figures("tube_study.png"), category="Tube"),
    log:
        logs("tube/study.log"),
    benchmark:
        benchmarks("tube_study.tsv")
    params:
        config=task_config(tube=["figures"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_manifest:
    """results/tube/MANIFEST.sha256 over the tube's branches (and their stages), exact family, comparison and study
    cases (recorded by update_reference, checked by verify)."""
    input:
        datasets=tube_manifest_datasets(),
    output:
        manifest=results("tube/MANIFEST.sha256"),
    log:
        logs("tube/manifest.log"),
    benchmark:
        benchmarks("tube_manifest.tsv")
    params:
        config=task_config(),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_circular_stage:
    """One continuation stage of a branch of the tube in a circular hole (`tube.circular_hole.branches`)."""
    input:
        unpack(tube_circular_previous_stage),
    output:
        dataset=results("tube/circular/stages/{branch}_stage{stage}.nc"),
    wildcard_constraints:
        branch="(nnm|whirl)[0-9]+",
        stage=r"\d+",
    log:
        logs("tube/circular_{branch}_stage{stage}.log"),
    benchmark:
        benchmarks("tube_circular_{branch}_stage{stage}.tsv")
    params:
        config=tube_circular_task_config("structure", "hbm", "anm", "stability", "metadata", branches=True),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_circular_branch:
    """A branch of the tube in a circular hole (planar or whirling): its stages joined."""
    input:
        stages=lambda wildcards: tube_circular_stage_files(wildcards.branch),
    output:
        dataset=results("tube/circular/{branch}.nc"),
    wildcard_constraints:
        branch="(nnm|whirl)[0-9]+",
    log:
        logs("tube/circular_{branch}.log"),
    benchmark:
        benchmarks("tube_circular_{branch}.tsv")
    params:
        config=tube_circular_task_config("metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_circular_figure:
    """paper_figures/tube_circular_<figure>.{pdf,png}: the branches of the tube in a circular hole, their frequency
    and wear power along them."""
    input:
        unpack(lambda wildcards: tube_circular_datasets()),
    output:
        pdf=paper_figures("tube_circular_{figure}.pdf"),
        png=report(paper_figures("tube_circular_{figure}.png"), category="Tube", subcategory="circular hole"),
    wildcard_constraints:
        figure="|".join(TUBE_CIRCULAR_FIGURES),
    log:
        logs("tube/circular_figure_{figure}.log"),
    benchmark:
        benchmarks("tube_circular_figure_{figure}.tsv")
    params:
        config=tube_circular_task_config("figures"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule tube_circular:
    """The tube in a circular hole alone (`tube.circular_hole`; part of the tube target when configured)."""
    input:
        tube_circular_outputs(),


rule tube:
    """Everything of the tube: datasets, their manifest and figures (not in the default target); the tube in a
    circular hole too when `tube.circular_hole` is configured."""
    input:
        list(TUBE_DATASETS.values()),
        rules.tube_manifest.output.manifest,
        expand(paper_figures("tube_{figure}.{ext}"), figure=TUBE_FIGURE_INPUTS, ext=("pdf", "png")),
        rules.tube_study.output,
        tube_circular_outputs(),
