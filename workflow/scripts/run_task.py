"""The script of every rule: runs the task named like the rule (:mod:`nnmstop.pipeline.run`).

The task, the function ``snakemake.rule`` of the task module of the rule's file, receives the
configuration sections of the rule's ``params.config``, the rule's named inputs and outputs,
its log file and its wildcards. It runs in a fork of the warm worker (:mod:`nnmstop.pipeline.worker`,
``execution`` in the configuration) when one can be reached, else in this process. To run a task
standalone for debugging, use ``python -m nnmstop.pipeline.run TASK ...`` (see
``python -m nnmstop.pipeline.run --help``).
"""

import sys

from nnmstop.pipeline.worker import plain_request, run_in_worker, worker_enabled

smk = globals()["snakemake"]
request = plain_request(smk.rule, smk.params.config, smk.input, smk.output, smk.log, smk.wildcards)
if worker_enabled(smk.config):
    status = run_in_worker(request, idle=smk.config.get("execution", {}).get("worker_idle_seconds", 20.0))
    if status is not None:
        sys.exit(status)

from nnmstop.pipeline.run import run_request  # noqa: E402  (only when no worker ran the task)

run_request(request)
