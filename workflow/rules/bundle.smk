# Result bundle to share and cite (nnmstop.pipeline.bundle): one deterministic zip under dist/ with the
# datasets, figures, manifest, configuration, environment.lock, CITATION.cff and an RO-Crate.
# Task: nnmstop.tasks.bundle.
#
#   snakemake --cores 2 bundle


localrules:
    bundle,


rule bundle:
    """dist/nnmstop-results.zip, described by its ro-crate-metadata.json (Workflow Run Crate)."""
    input:
        datasets=PAPER_DATASETS + (forced_datasets() if "forced" in config else []),
        # the explorer page is a result of the run too
        figures=[*PAPER_FIGURES, rules.explorer.output.page, *(forced_figures() if "forced" in config else [])],
        # the build's manifests: the bundle's datasets are checked against them (verify_bundle)
        manifest=[
            rules.dataset_manifest.output.manifest,
            *([rules.forced_manifest.output.manifest] if "forced" in config else []),
        ],
        environment_lock=os.path.join(workflow.basedir, "environment.lock"),
        citation=os.path.join(workflow.basedir, "CITATION.cff"),
        workflow_files=[
            os.path.join(workflow.basedir, "Snakefile"),
            *sorted(glob.glob(os.path.join(workflow.basedir, "workflow", "rules", "*.smk"))),
        ],
    output:
        bundle="dist/nnmstop-results.zip",
    log:
        logs("bundle.log"),
    benchmark:
        benchmarks("bundle.tsv")
    params:
        config=config,  # stored in the bundle as config/config.yaml
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
