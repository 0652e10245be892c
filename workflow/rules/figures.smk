# The figures, drawn from datasets only (a figure never continues a branch), and each rule
# declares only the datasets its figure reads. Figs 2-4 read the exact two-impact family, NNM1
# stage 1 and their comparison; Fig 6 reads NNM2 alone; Figs 7-11 only the NNM1 stages listed
# under `figures.figNN.nnm1_stages` in config/config.yaml. Extra figures (not in the default
# target) show the regime errors and the stability verdicts. Tasks: nnmstop.tasks.figures.


rule paper_fig02:
    """Fig 2: FEP of NNM1, non-smooth (red) vs regularized (blue), points a) and b)."""
    input:
        exact=rules.exact_two_impacts.output.dataset,
        nnm1=stage_file("nnm1", 1),
        comparison=rules.compare_nnm1.output.dataset,
    output:
        pdf=paper_figures("fig02.pdf"),
        png=report(paper_figures("fig02.png"), category="Paper figures"),
    log:
        logs("figures/fig02.log"),
    benchmark:
        benchmarks("paper_fig02.tsv")
    params:
        config=task_config("compare"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig03:
    """Fig 3: orbits at a) and b): x-phase plane, u-phase plane, modal line."""
    input:
        comparison=rules.compare_nnm1.output.dataset,
    output:
        pdf=paper_figures("fig03.pdf"),
        png=report(paper_figures("fig03.png"), category="Paper figures"),
    log:
        logs("figures/fig03.log"),
    benchmark:
        benchmarks("paper_fig03.tsv")
    params:
        config=task_config("compare"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig04:
    """Fig 4: contact force at a) and b): over one period, and (x, f) vs the piecewise law."""
    input:
        comparison=rules.compare_nnm1.output.dataset,
    output:
        pdf=paper_figures("fig04.pdf"),
        png=report(paper_figures("fig04.png"), category="Paper figures"),
    log:
        logs("figures/fig04.log"),
    benchmark:
        benchmarks("paper_fig04.tsv")
    params:
        config=task_config("compare"),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_figs_02_04:
    """Figs 2-4 (PDF and PNG)."""
    input:
        [path for n in ("02", "03", "04") for path in getattr(rules, f"paper_fig{n}").output],


rule paper_fig05:
    """Fig 5: FEP of NNM1 (blue) and NNM2 (green) over the whole energy range."""
    input:
        nnm1=branch_file("nnm1"),
        nnm2=branch_file("nnm2"),
    output:
        pdf=paper_figures("fig05.pdf"),
        png=report(paper_figures("fig05.png"), category="Paper figures"),
    log:
        logs("figures/fig05.log"),
    benchmark:
        benchmarks("paper_fig05.tsv")
    params:
        config=task_config(figures=["png_dpi", "fig05"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig06:
    """Fig 6: FEP of NNM2 with modal lines a)-f); reads NNM2 only."""
    input:
        nnm2=branch_file("nnm2"),
    output:
        pdf=paper_figures("fig06.pdf"),
        png=report(paper_figures("fig06.png"), category="Paper figures"),
    log:
        logs("figures/fig06.log"),
    benchmark:
        benchmarks("paper_fig06.tsv")
    params:
        config=task_config(figures=["png_dpi", "fig06"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig07:
    """Fig 7: NNM1 at low energy, modal lines a)-c)."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: figure_stages("fig07"),
    output:
        pdf=paper_figures("fig07.pdf"),
        png=report(paper_figures("fig07.png"), category="Paper figures"),
    log:
        logs("figures/fig07.log"),
    benchmark:
        benchmarks("paper_fig07.tsv")
    params:
        config=task_config(figures=["png_dpi", "fig07"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig08:
    """Fig 8: NNM1 with the NNM2 curve at f2/3, the 3:1 internal resonance, d)-i)."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: figure_stages("fig08"),
        nnm2=branch_file("nnm2"),
        bifurcated=lambda wildcards: bifurcated_files("fig08"),
    output:
        pdf=paper_figures("fig08.pdf"),
        png=report(paper_figures("fig08.png"), category="Paper figures"),
    log:
        logs("figures/fig08.log"),
    benchmark:
        benchmarks("paper_fig08.tsv")
    params:
        config=task_config(figures=["png_dpi", "fig08"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig09:
    """Fig 9: NNM1 with the NNM2 curve at f2/5, the 5:1 internal resonance, j)-m)."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: figure_stages("fig09"),
        nnm2=branch_file("nnm2"),
        bifurcated=lambda wildcards: bifurcated_files("fig09"),
    output:
        pdf=paper_figures("fig09.pdf"),
        png=report(paper_figures("fig09.png"), category="Paper figures"),
    log:
        logs("figures/fig09.log"),
    benchmark:
        benchmarks("paper_fig09.tsv")
    params:
        config=task_config(figures=["png_dpi", "fig09"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig10:
    """Fig 10: NNM1 with the NNM2 curve at f2/5 after the 5:1 resonance, o)-q)."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: figure_stages("fig10"),
        nnm2=branch_file("nnm2"),
        bifurcated=lambda wildcards: bifurcated_files("fig10"),
    output:
        pdf=paper_figures("fig10.pdf"),
        png=report(paper_figures("fig10.png"), category="Paper figures"),
    log:
        logs("figures/fig10.log"),
    benchmark:
        benchmarks("paper_fig10.tsv")
    params:
        config=task_config(figures=["png_dpi", "fig10"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig11:
    """Fig 11: NNM1 at high energy, tending to the gap-0 first linear mode."""
    input:
        unpack(exact_overlay),
        nnm1_stages=lambda wildcards: figure_stages("fig11"),
    output:
        pdf=paper_figures("fig11.pdf"),
        png=report(paper_figures("fig11.png"), category="Paper figures"),
    log:
        logs("figures/fig11.log"),
    benchmark:
        benchmarks("paper_fig11.tsv")
    params:
        config=task_config(figures=["png_dpi", "fig11"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_figs_05_11:
    """All of Figs 5-11 (PDF and PNG)."""
    input:
        [path for n in ("05", "06", "07", "08", "09", "10", "11") for path in getattr(rules, f"paper_fig{n}").output],


rule regime_error_figure:
    """Extra figure: |df|/f against energy, one colour per impact regime (not in the default target)."""
    input:
        dataset=rules.compare_regimes.output.dataset,
    output:
        pdf=paper_figures("extra_regime_error.pdf"),
        png=report(paper_figures("extra_regime_error.png"), category="Beyond the paper"),
    log:
        logs("figures/extra_regime_error.log"),
    benchmark:
        benchmarks("regime_error_figure.tsv")
    params:
        config=task_config(figures=["png_dpi"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule stability_figure:
    """Extra figure: FEP of NNM1, exact (red) and regularized (blue), stable solid, unstable dashed, changes marked."""
    input:
        exact=rules.exact_nnm1.output.dataset,
        nnm1=branch_file("nnm1"),
        dataset=rules.compare_stability.output.dataset,
    output:
        pdf=paper_figures("extra_stability.pdf"),
        png=report(paper_figures("extra_stability.png"), category="Beyond the paper"),
    log:
        logs("figures/extra_stability.log"),
    benchmark:
        benchmarks("stability_figure.tsv")
    params:
        config=task_config(figures=["png_dpi", "extra_stability"]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
