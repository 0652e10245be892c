# The documentation pages generated from the datasets (nnmstop.docpages): docs/results.md and the
# front-page figure, both committed; tests/docs/test_generated_pages.py fails when the committed
# page was not generated from the reference build. Task: nnmstop.tasks.docs.
#
#   snakemake --cores 2 docs
#
# The site itself: sphinx-build -W --keep-going -b html docs docs/_build/html

from nnmstop.docpages.paper_table import PAPER_TABLE_DATASETS
from nnmstop.docpages.results import OPTIONAL_DATASETS, RESULT_DATASETS
from nnmstop.docpages.results import STRUCTURE_DATASETS as STRUCTURE_PAGE_DATASETS


localrules:
    docs,


def docs_inputs(wildcards):
    """The datasets of the pages: the paper's oscillator's (the switched branches only where `bifurcations` has
    them; the small test configuration has none), or a structure of one's own's; and the front-page figure."""
    if STRUCTURE_KIND != "two_dof":
        return {
            **{name: results(path) for name, path in STRUCTURE_PAGE_DATASETS.items()},
            "figure": paper_figures("structure_frequency_energy.png"),
        }
    inputs = {
        name: results(path)
        for name, path in {**RESULT_DATASETS, **PAPER_TABLE_DATASETS}.items()
        if name not in OPTIONAL_DATASETS or name in config.get("bifurcations", {})
    }
    return {**inputs, "figure": rules.paper_fig02.output.png}


rule docs:
    """docs/results.md and docs/paper_vs_build.md from the datasets of the default build, and the front-page figure
    (Fig 2, or the structure's frequency-energy plot)."""
    input:
        unpack(docs_inputs),
    output:
        results="docs/results.md",
        paper_table="docs/paper_vs_build.md",
        figure="docs/nnm1_frequency_energy.png",
    log:
        logs("docs.log"),
    params:
        config=task_config("model", "structure", "compare", figures=["fig06", "fig07", "fig08", "fig09", "fig10", "fig11"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
