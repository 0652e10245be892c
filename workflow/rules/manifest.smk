# SHA-256 manifest of the datasets behind the paper's figures (for sharing and checking
# copies). Task: nnmstop.tasks.manifest.


rule dataset_manifest:
    """results/MANIFEST.sha256 over every dataset of the paper's figures."""
    input:
        datasets=PAPER_DATASETS,
    output:
        manifest=results("MANIFEST.sha256"),
    log:
        logs("dataset_manifest.log"),
    benchmark:
        benchmarks("dataset_manifest.tsv")
    params:
        config=task_config(),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
