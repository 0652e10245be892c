# SHA-256 manifest of the datasets behind the paper's figures (for sharing and checking copies).


rule dataset_manifest:
    """results/MANIFEST.sha256 over every dataset of the paper's figures."""
    input:
        datasets=PAPER_DATASETS,
    output:
        manifest="results/MANIFEST.sha256",
    log:
        "logs/dataset_manifest.log",
    params:
        task="dataset_manifest",
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
