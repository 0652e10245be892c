# The offline explorer (issue 24, docs/explorer.md): one self-contained HTML page of every branch of the
# build, with each branch's dataset path and SHA-256 from the manifest. Task: nnmstop.tasks.explorer.
#
#   snakemake --cores 2 explorer


def explorer_branches():
    """Datasets drawn by the explorer, by kind of branch (nnmstop.explorer.extract.KINDS)."""
    exact = rules.exact_nnm1.output.dataset if "exact_multi" in config else rules.exact_two_impacts.output.dataset
    regularized = [branch_file("nnm1"), branch_file("nnm2"), *[bifurcated_file(name) for name in config.get("bifurcations", {})]]
    if config.get("explorer", {}).get("tube", False) and "tube" in config:  # the tube's branches, built for it
        regularized += [tube_file(name) for name in config["tube"]["branches"]]
    return {"regularized": regularized, "exact": [exact]}


rule explorer:
    """dist/explorer.html: frequency-energy plot of every branch, orbits synthesized in the browser."""
    input:
        **explorer_branches(),
        manifest=rules.dataset_manifest.output.manifest,
    output:
        page="dist/explorer.html",
    log:
        logs("explorer.log"),
    benchmark:
        benchmarks("explorer.tsv")
    params:
        config=task_config("explorer"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
