"""Task of ``workflow/rules/docs.smk``: the documentation pages generated from the datasets.

``docs/results.md`` (:func:`nnmstop.docpages.results.results_page`; for a structure of one's own
:func:`~nnmstop.docpages.results.structure_results_page`), ``docs/paper_vs_build.md``
(:func:`nnmstop.docpages.paper_table.paper_table_page`) and the front-page figure
``docs/nnm1_frequency_energy.png`` (a copy of ``paper_figures/fig02.png``), all committed for the paper's build.
"""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

from nnmstop.atomic import atomic_output

__all__ = ["docs"]

logger = logging.getLogger("nnmstop.tasks.docs")


def write_page(path, text: str) -> None:
    """A generated page, written atomically (a failed write names its path and leaves nothing behind)."""
    with atomic_output(path) as partial:
        partial.write_text(text)


def docs(config: dict, inputs: dict, outputs: dict) -> None:
    """Write the pages ``outputs["results"]`` and ``outputs["paper_table"]`` from the datasets and copy
    ``inputs["figure"]`` to ``outputs["figure"]``.

    Parameters
    ----------
    config : dict
        Sections ``model`` and ``structure`` (which structure the build is of), ``compare`` and ``figures`` (the
        labelled points the paper table lists).
    inputs : dict
        One entry per dataset of :data:`nnmstop.docpages.results.RESULT_DATASETS` and
        :data:`nnmstop.docpages.paper_table.PAPER_TABLE_DATASETS` (same names; the switched branches only where the
        build has them), or of :data:`nnmstop.docpages.results.STRUCTURE_DATASETS` for a structure of one's own;
        and ``figure``: the PNG shown on the front page and in README.
    outputs : dict
        ``results``, ``paper_table``: the pages; ``figure``: the copy of the figure.
    """
    from nnmstop.docpages.paper_table import PAPER_TABLE_DATASETS, paper_table_page
    from nnmstop.docpages.results import RESULT_DATASETS, STRUCTURE_DATASETS, results_page, structure_results_page
    from nnmstop.models.two_dof import ModelParameters
    from nnmstop.pipeline.verify import data_digest

    own = config.get("structure", {}).get("kind", "two_dof") != "two_dof"
    known = STRUCTURE_DATASETS if own else {**RESULT_DATASETS, **PAPER_TABLE_DATASETS}
    paths = {name: Path(inputs[name]) for name in known if name in inputs}
    results_dir = paths["nnm1"].parents[len(Path(known["nnm1"]).parts) - 1]
    for name, path in paths.items():
        if path != results_dir / known[name]:
            raise ValueError(f"input {name!r} must be {results_dir / known[name]}, got {path}")
    digests = {known[name]: data_digest(path) for name, path in paths.items()}
    if own:
        write_page(outputs["results"], structure_results_page(results_dir, digests))
        write_page(
            outputs["paper_table"],
            "# The paper against this build\n\nThis build is of a structure of one's own "
            f"({config['structure']['kind']}); the paper's numbers concern its 2-DOF oscillator "
            "(`structure.kind: two_dof`): there is nothing of the paper to set against it. Its results are in "
            "[the results page](results.md).\n",
        )
    else:
        pages = {"results": (RESULT_DATASETS, results_page), "paper_table": (PAPER_TABLE_DATASETS, paper_table_page)}
        for key, (names, build) in pages.items():
            read = {known[n]: digests[known[n]] for n in names if n in paths}
            extra = ModelParameters(**config["model"]) if key == "results" else config
            write_page(outputs[key], build(results_dir, extra, read))
    with atomic_output(outputs["figure"]) as partial:
        shutil.copyfile(inputs["figure"], partial)
    logger.info("wrote %s, %s from %d datasets and %s", outputs["results"], outputs["paper_table"], len(paths),
                outputs["figure"])  # fmt: skip


#: The tasks of this module's rule file, by rule name (nnmstop.pipeline.run).
TASKS = {f.__name__: f for f in (docs,)}
