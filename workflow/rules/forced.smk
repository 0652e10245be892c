# Forced, damped responses around the NNMs (issue 23): exact responses of the non-smooth system and
# regularized ones by harmonic balance + ANM, their stability, the backbones' prediction of the peaks, the
# figures paper_figures/forced_*. `snakemake --cores 2 forced` builds all of it; a figure asked for alone
# builds only the datasets it draws. Thin rules: the tasks are in nnmstop.tasks.forced.




# `structure` and `model`: the structure forced (nnmstop.forced.scenes); its matrix files, if any, are inputs
FORCED_CONFIG = task_config("model", "structure", "anm", "forced", "metadata", tube=["structure"], hbm=["start_tolerance"])


rule forced_exact:
    """Exact response of the non-smooth structure at one force level."""
    input:
        unpack(structure_files),
    output:
        dataset=results("forced/exact_{scene}.nc"),
    log:
        logs("forced/exact_{scene}.log"),
    benchmark:
        benchmarks("forced_exact_{scene}.tsv")
    params:
        config=FORCED_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule forced_regularized:
    """Regularized response (harmonic balance + ANM) at one force level, or the tube's."""
    input:
        unpack(structure_files),
    output:
        dataset=results("forced/regularized_{scene}.nc"),
    log:
        logs("forced/regularized_{scene}.log"),
    benchmark:
        benchmarks("forced_regularized_{scene}.tsv")
    params:
        config=FORCED_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule forced_backbone:
    """Regularized NNM backbones over the forced frequency range and the peaks they predict at each force level."""
    input:
        unpack(structure_files),
    output:
        dataset=results("forced/backbone.nc"),
    log:
        logs("forced/backbone.log"),
    benchmark:
        benchmarks("forced_backbone.tsv")
    params:
        config=FORCED_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule forced_prediction:
    """The backbone's prediction of the NNM1 peak against the located peak as the damping goes to zero."""
    input:
        unpack(structure_files),
    output:
        dataset=results("forced/prediction_error.nc"),
    log:
        logs("forced/prediction_error.log"),
    benchmark:
        benchmarks("forced_prediction.tsv")
    params:
        config=FORCED_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


# Datasets each forced figure draws (the keys are the figure task's named inputs).
FORCED_FIGURE_INPUTS = {
    "frequency_response": lambda: {
        "exact": [forced_file("exact", s) for s in forced_scene_names("structure", exact=True)],
        "regularized": [forced_file("regularized", s) for s in forced_scene_names("structure")],
        "backbone": rules.forced_backbone.output.dataset,
    },
    "phase_lag": lambda: {
        "exact": [forced_file("exact", s) for s in forced_scene_names("structure", exact=True)],
        "regularized": [forced_file("regularized", s) for s in forced_scene_names("structure")],
    },
    "orbits": lambda: {
        "exact": [forced_file("exact", s) for s in forced_scene_names("structure", exact=True)[-1:]],
        "regularized": [forced_file("regularized", forced_scene_names("structure")[-1])],
    },
    "prediction_error": lambda: {"prediction": rules.forced_prediction.output.dataset},
    "tube": lambda: {"regularized": [forced_file("regularized", s) for s in forced_scene_names("tube")]},
}


rule forced_figure:
    """paper_figures/forced_<figure>.{pdf,png}; reads only the datasets its figure draws."""
    input:
        unpack(lambda wildcards: FORCED_FIGURE_INPUTS[wildcards.figure]()),
    output:
        pdf=paper_figures("forced_{figure}.pdf"),
        png=report(paper_figures("forced_{figure}.png"), category="Forced responses"),
    wildcard_constraints:
        figure="|".join(FORCED_FIGURE_INPUTS),
    log:
        logs("forced/figure_{figure}.log"),
    benchmark:
        benchmarks("forced_figure_{figure}.tsv")
    params:
        config=FORCED_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"




rule forced_manifest:
    """results/forced/MANIFEST.sha256 over every forced dataset (recorded by update_reference, checked by verify)."""
    input:
        datasets=forced_datasets(),
    output:
        manifest=results("forced/MANIFEST.sha256"),
    log:
        logs("forced/manifest.log"),
    benchmark:
        benchmarks("forced_manifest.tsv")
    params:
        config=FORCED_CONFIG,
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule forced:
    """Everything of the forced responses: datasets, their manifest and figures (not in the default target)."""
    input:
        forced_datasets(),
        rules.forced_manifest.output.manifest,
        forced_figures(),
