"""The script of every rule: runs the task named like the rule (:mod:`nnmstop.tasks.run`).

The task, the function ``snakemake.rule`` of the task module of the rule's file, receives the
configuration sections of the rule's ``params.config``, the rule's named inputs and outputs,
its log file and its wildcards. To run a task standalone for debugging, use
``python -m nnmstop.tasks.run TASK ...`` (see ``python -m nnmstop.tasks.run --help``).
"""

from nnmstop.tasks.run import run_task

smk = globals()["snakemake"]
log = smk.log[0] if smk.log else None
run_task(smk.rule, smk.params.config, smk.input, smk.output, log, **dict(smk.wildcards.items()))
