# Issue 11: check a build against the committed reference (reference/), or regenerate it.
# Both rules have no output (and so no benchmark: it would be one), so they run whenever they
# are asked for; the tasks (nnmstop.tasks.verify) print the verifier's table and fail on a
# discrepant file (docs/reproducibility.md).


rule verify:
    """Compare results/ with reference/: identical, within tolerance or discrepant (the job fails)."""
    input:
        datasets=PAPER_DATASETS,
        manifest=rules.dataset_manifest.output.manifest,
    log:
        logs("verify.log"),
    params:
        config=task_config(),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule update_reference:
    """Regenerate reference/ from results/ (only when the physics is meant to change)."""
    input:
        datasets=PAPER_DATASETS,
        manifest=rules.dataset_manifest.output.manifest,
    log:
        logs("update_reference.log"),
    params:
        config=task_config(),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
