# A structure other than the paper's oscillator (config `structure.kind`: beam or matrices): beyond its
# branches (workflow/rules/hbm.smk), the exact family with one impact per stop side, its comparison with
# the regularized NNM1, and the frequency-energy figures of nnmstop.figures.structure. The paper's Figs 2-4
# (the exact multi-impact family of the 2-DOF oscillator) take their place for the oscillator.
# Tasks: nnmstop.tasks.structure.

STRUCTURE_DATASETS = {
    "nnm1": branch_file("nnm1"),
    "nnm2": branch_file("nnm2"),
    "exact": results("exact/nnm1_one_impact.nc"),
    "comparison": results("compare/nnm1_one_impact.nc"),
}


rule structure_exact:
    """Exact NNM1 of the non-smooth structure (one impact per stop side per period)."""
    input:
        unpack(structure_files),
    output:
        dataset=STRUCTURE_DATASETS["exact"],
    log:
        logs("exact/nnm1_one_impact.log"),
    benchmark:
        benchmarks("structure_exact.tsv")
    params:
        config=task_config("model", "structure", "exact", "metadata"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule structure_compare:
    """Exact against regularized NNM1 of the structure at matched energies."""
    input:
        exact=rules.structure_exact.output.dataset,
        nnm1=STRUCTURE_DATASETS["nnm1"],
    output:
        dataset=STRUCTURE_DATASETS["comparison"],
    log:
        logs("compare/nnm1_one_impact.log"),
    benchmark:
        benchmarks("structure_compare.tsv")
    params:
        config=lambda wildcards: {**task_config("model", "structure", "metadata")(wildcards), "compare_count": config.get("compare", {}).get("energy_count", 24)},
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule structure_figure:
    """paper_figures/structure_<figure>.{pdf,png}; reads only the datasets its figure draws."""
    input:
        unpack(lambda wildcards: {key: STRUCTURE_DATASETS[key] for key in structure_figure_inputs()[wildcards.figure]}),
    output:
        pdf=paper_figures("structure_{figure}.pdf"),
        png=report(paper_figures("structure_{figure}.png"), category="Structure", subcategory="{figure}"),
    wildcard_constraints:
        figure="|".join(TUBE_FIGURE_INPUTS),
    log:
        logs("figures/structure_{figure}.log"),
    benchmark:
        benchmarks("structure_figure_{figure}.tsv")
    params:
        config=lambda wildcards: {"figures": {"png_dpi": config["figures"]["png_dpi"]}},
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
