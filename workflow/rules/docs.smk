# The documentation pages generated from the datasets (nnmstop.docpages): docs/results.md and the
# front-page figure, both committed; tests/docs/test_generated_pages.py fails when the committed
# page was not generated from the reference build. Task: nnmstop.tasks.docs.
#
#   snakemake --cores 2 docs
#
# The site itself: sphinx-build -W --keep-going -b html docs docs/_build/html

from nnmstop.docpages.results import OPTIONAL_DATASETS, RESULT_DATASETS


localrules:
    docs,


rule docs:
    """docs/results.md from the datasets of the default build, and the front-page figure (Fig 2)."""
    input:
        # the switched branches only where `bifurcations` has them (the small test configuration has none)
        unpack(
            lambda wildcards: {
                name: results(path)
                for name, path in RESULT_DATASETS.items()
                if name not in OPTIONAL_DATASETS or name in config.get("bifurcations", {})
            }
        ),
        figure=rules.paper_fig02.output.png,
    output:
        results="docs/results.md",
        figure="docs/nnm1_frequency_energy.png",
    log:
        logs("docs.log"),
    params:
        config=task_config("model"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
