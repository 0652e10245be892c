# Issue 11: check a build against the committed reference (reference/), or regenerate it.
# Both rules have no output (and so no benchmark: it would be one), so they run whenever they
# are asked for; the tasks (nnmstop.tasks.verify) print the verifier's table and fail on a
# discrepant file (docs/reproducibility.md). Both cover the paper's datasets (results/MANIFEST.sha256) and,
# where the configuration has them, the forced responses (results/forced/MANIFEST.sha256): verified_inputs in
# common.smk.


rule verify:
    """Compare results/ with reference/: identical, within tolerance or discrepant (the job fails)."""
    input:
        unpack(verified_inputs),
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
        unpack(verified_inputs),
    log:
        logs("update_reference.log"),
    params:
        config=task_config(),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
