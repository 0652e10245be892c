"""The script of every rule: runs the task named like the rule (:mod:`nnmstop.pipeline.run`).

The task, the function ``snakemake.rule`` of the task module of the rule's file, receives the
configuration sections of the rule's ``params.config``, the rule's named inputs and outputs,
its log file and its wildcards. It runs in a fork of the warm worker (:mod:`nnmstop.pipeline.worker`,
``execution`` in the configuration) when one can be used, else in this process. Either way the
task ends with its job and puts no output in place after it (docs/methods/warm_worker.md). To run
a task standalone for debugging, use ``python -m nnmstop.pipeline.run TASK ...`` (see
``python -m nnmstop.pipeline.run --help``).
"""

import sys

from nnmstop.pipeline.run import Interrupted, run_request, watch_parent
from nnmstop.pipeline.worker import WorkerUnavailable, plain_request, run_in_worker, worker_enabled

smk = globals()["snakemake"]
request = plain_request(smk.rule, smk.params.config, smk.input, smk.output, smk.log, smk.wildcards)
execution = smk.config.get("execution", {})
note = None
try:
    watch_parent()  # this job ends when Snakemake does
    if worker_enabled(smk.config):
        try:
            sys.exit(
                run_in_worker(
                    request,
                    idle=execution.get("worker_idle_seconds", 20.0),
                    answer_timeout=execution.get("worker_answer_seconds", 30.0),
                )
            )
        except WorkerUnavailable as reason:
            note = f"the task runs in the job's own process: {reason}"
            print(f"nnmstop: {note}", file=sys.stderr)
    run_request(request, note=note)
except Interrupted as interruption:
    sys.exit(128 + interruption.signum)
