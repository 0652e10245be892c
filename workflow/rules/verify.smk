# Issue 11: check a build against the committed reference (reference/), or regenerate it.
# Both rules have no output, so they run whenever they are asked for; nnmstop.verify
# does the work (docs/reproducibility.md).


rule verify:
    """Compare results/ with reference/: identical, within tolerance or discrepant (non-zero exit)."""
    input:
        PAPER_DATASETS,
        "results/MANIFEST.sha256",
    log:
        "logs/verify.log",
    conda:
        "../envs/nnmstop.yaml"
    shell:
        "python -m nnmstop.verify results --reference reference 2>&1 | tee {log}"


rule update_reference:
    """Regenerate reference/ from results/ (only when the physics is meant to change)."""
    input:
        PAPER_DATASETS,
        "results/MANIFEST.sha256",
    log:
        "logs/update_reference.log",
    conda:
        "../envs/nnmstop.yaml"
    shell:
        "python -m nnmstop.verify --update-reference results --reference reference 2>&1 | tee {log}"
