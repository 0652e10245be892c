# The offline explorer (issue 24, docs/explorer.md): one self-contained HTML page of every branch of the
# build, with each branch's dataset path and SHA-256 from the manifest. Task: nnmstop.tasks.explorer.
#
#   snakemake --cores 2 explorer


rule explorer:
    """dist/explorer.html: frequency-energy plot of every branch, orbits synthesized in the browser."""
    input:
        **explorer_branches(),
        **structure_files(),
        manifest=rules.dataset_manifest.output.manifest,
    output:
        page="dist/explorer.html",
    log:
        logs("explorer.log"),
    benchmark:
        benchmarks("explorer.tsv")
    params:
        config=task_config("explorer", "model", "structure"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
