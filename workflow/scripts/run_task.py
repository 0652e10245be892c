"""Generic Snakemake script: runs the nnmstop pipeline task named in the rule's params.

Each rule sets ``params: task="<name>"``; the task receives the validated config, the
rule's named inputs and outputs, its log file and its wildcards. To run a task
standalone for debugging, use ``python -m nnmstop.tasks.run TASK ...`` (see
``python -m nnmstop.tasks.run --help``).
"""

from nnmstop.tasks.run import run_task

smk = globals()["snakemake"]
run_task(smk.params.task, smk.config, smk.input, smk.output, smk.log[0] if smk.log else None, **dict(smk.wildcards.items()))
