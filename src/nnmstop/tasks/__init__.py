"""The workflow's tasks: the only code that reads the configuration and files, checks and writes results.

One module per rule file: the rules of ``workflow/rules/<name>.smk`` run the functions of
:mod:`nnmstop.tasks.<name>` named like the rules; :mod:`nnmstop.pipeline.run` dispatches them.
"""
