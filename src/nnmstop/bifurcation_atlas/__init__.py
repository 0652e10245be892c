"""The bifurcation atlas (issue 31): where a forced structure impacts, jumps and stops being periodic.

The user-facing function is :func:`nnmstop.atlas` (:mod:`nnmstop.api`); the workflow's tasks are in
:mod:`nnmstop.tasks.atlas`. Method note: ``docs/methods/atlas.md``.
"""
