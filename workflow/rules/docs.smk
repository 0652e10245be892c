# The documentation pages generated from the datasets (nnmstop.docpages): docs/results.md and the
# front-page figure, both committed; tests/docs/test_generated_pages.py fails when the committed
# page was not generated from the reference build. Task: nnmstop.tasks.docs.
#
#   snakemake --cores 2 docs
#
# The site itself: sphinx-build -W --keep-going -b html docs docs/_build/html

localrules:
    docs,


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
