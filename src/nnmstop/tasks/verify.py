"""Tasks of ``workflow/rules/verify.smk``: a build against the committed reference.

``verify`` compares the results folder of the build (the folder of its manifest) with
``reference/`` by :func:`nnmstop.pipeline.verify.verify` and fails when a file is discrepant;
``update_reference`` regenerates ``reference/`` from the build, for a change meant to move
the physics. Both rules have no output, so they run whenever they are asked for; the table
goes to the console and to the rule's log (docs/reproducibility.md).
"""

from __future__ import annotations

import logging
from pathlib import Path

__all__ = ["REFERENCE", "verify", "update_reference"]

logger = logging.getLogger("nnmstop.tasks.verify")

#: The committed reference build, relative to the working directory (as ``python -m nnmstop.pipeline.verify``).
REFERENCE = "reference"


def _results_folder(inputs: dict) -> Path:
    return Path(inputs["manifest"]).parent


def verify(config: dict, inputs: dict, outputs: dict) -> None:
    """Compare the build whose manifest is ``inputs["manifest"]`` with :data:`REFERENCE`.

    Raises
    ------
    RuntimeError
        If a file is discrepant (the table says which and by how much).
    """
    from nnmstop.pipeline.verify import file_verdicts, format_table
    from nnmstop.pipeline.verify import verify as compare_with_reference

    rows = compare_with_reference(_results_folder(inputs), REFERENCE)
    table = format_table(rows)
    print(table)
    logger.info("%s", table)
    discrepant = sorted(name for name, verdict in file_verdicts(rows).items() if verdict == "discrepant")
    if discrepant:
        raise RuntimeError(f"{len(discrepant)} file(s) differ from {REFERENCE}/ beyond tolerance: {discrepant}")


def update_reference(config: dict, inputs: dict, outputs: dict) -> None:
    """Regenerate :data:`REFERENCE` from the build whose manifest is ``inputs["manifest"]`` (and the forced
    responses', the tube's, the study's, the tube on plates' and the atlas' manifests where the configuration has them).

    Raises
    ------
    RuntimeError
        If a file of the build cannot be recorded (the table says which and why); the reference is untouched.
    """
    from nnmstop.pipeline.verify import (
        ATLAS_MANIFEST,
        FORCED_MANIFEST,
        MANIFEST,
        STUDY_MANIFEST,
        TUBE_MANIFEST,
        TUBE_PLATES_MANIFEST,
        ReferenceRefused,
        format_table,
    )
    from nnmstop.pipeline.verify import update_reference as regenerate

    optional = {
        "forced_manifest": FORCED_MANIFEST,
        "tube_manifest": TUBE_MANIFEST,
        "study_manifest": STUDY_MANIFEST,
        "atlas_manifest": ATLAS_MANIFEST,
        "tube_plates_manifest": TUBE_PLATES_MANIFEST,
    }
    manifests = [MANIFEST] + [name for key, name in optional.items() if inputs.get(key)]
    try:
        folder = regenerate(_results_folder(inputs), REFERENCE, manifests)
    except ReferenceRefused as refused:
        table = format_table(refused.rows)
        print(table)
        logger.error("%s", table)
        raise RuntimeError(str(refused)) from None
    print(f"reference regenerated in {folder}")
    logger.info("reference regenerated in %s", folder)


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (verify, update_reference)}
