# Section 4.1, Figs 2-4: the exact (non-smooth) NNM1 two-impact family against the
# regularized NNM1 (HBM), stage 1 only (from the linear mode to the first orbit with
# more than one impact per stop). Figs 2-4 read only the exact family, NNM1 stage 1 and
# the comparison dataset: building them computes no NNM2 and no later NNM1 stage.
# Energies of the labelled points a) and b): `compare.points` in config/config.yaml.


rule compare_nnm1:
    """Exact vs regularized NNM1 at matched energies: frequency and orbit differences."""
    input:
        exact="results/exact/nnm1_two_impacts.nc",
        nnm1="results/hbm/stages/nnm1_stage1.nc",
    output:
        dataset="results/compare/nnm1_exact_vs_regularized.nc",
    log:
        "logs/compare/nnm1_exact_vs_regularized.log",
    benchmark:
        "benchmarks/runs/compare_nnm1.tsv"
    params:
        task="compare_nnm1",
        settings=lambda wildcards: repr(config["compare"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig02:
    """Fig 2: FEP of NNM1, non-smooth (red) vs regularized (blue), points a) and b)."""
    input:
        exact="results/exact/nnm1_two_impacts.nc",
        nnm1="results/hbm/stages/nnm1_stage1.nc",
        comparison="results/compare/nnm1_exact_vs_regularized.nc",
    output:
        pdf="paper_figures/fig02.pdf",
        png=report("paper_figures/fig02.png", category="Paper figures"),
    log:
        "logs/figures/fig02.log",
    benchmark:
        "benchmarks/runs/paper_fig02.tsv"
    params:
        task="paper_fig02",
        settings=lambda wildcards: repr(config["compare"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig03:
    """Fig 3: orbits at a) and b): x-phase plane, u-phase plane, modal line."""
    input:
        comparison="results/compare/nnm1_exact_vs_regularized.nc",
    output:
        pdf="paper_figures/fig03.pdf",
        png=report("paper_figures/fig03.png", category="Paper figures"),
    log:
        "logs/figures/fig03.log",
    benchmark:
        "benchmarks/runs/paper_fig03.tsv"
    params:
        task="paper_fig03",
        settings=lambda wildcards: repr(config["compare"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_fig04:
    """Fig 4: contact force at a) and b): over one period, and (x, f) vs the piecewise law."""
    input:
        comparison="results/compare/nnm1_exact_vs_regularized.nc",
    output:
        pdf="paper_figures/fig04.pdf",
        png=report("paper_figures/fig04.png", category="Paper figures"),
    log:
        "logs/figures/fig04.log",
    benchmark:
        "benchmarks/runs/paper_fig04.tsv"
    params:
        task="paper_fig04",
        settings=lambda wildcards: repr(config["compare"]),  # rerun when they change
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule paper_figs_02_04:
    """Figs 2-4 (PDF and PNG)."""
    input:
        expand("paper_figures/fig{number}.{ext}", number=["02", "03", "04"], ext=["pdf", "png"]),


# Issue 6: the regularization error over the whole NNM1 branch, per impact regime
# (nnmstop.compare.regimes): the exact multi-impact NNM1 against the regularized NNM1.


rule compare_regimes:
    """Frequency error of the regularized NNM1 in each impact regime: dataset and CSV table."""
    input:
        exact="results/exact/nnm1.nc",
        nnm1="results/hbm/nnm1.nc",
    output:
        dataset="results/compare/nnm1_regimes.nc",
        table="results/compare/nnm1_regimes.csv",
    log:
        "logs/compare/nnm1_regimes.log",
    benchmark:
        "benchmarks/runs/compare_regimes.tsv"
    params:
        task="compare_regimes",
        settings=lambda wildcards: repr(config["model"]),  # checked against the inputs
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule regime_error_figure:
    """Extra figure: |df|/f against energy, one colour per impact regime (not in the default target)."""
    input:
        dataset="results/compare/nnm1_regimes.nc",
    output:
        pdf="paper_figures/extra_regime_error.pdf",
        png="paper_figures/extra_regime_error.png",
    log:
        "logs/figures/extra_regime_error.log",
    benchmark:
        "benchmarks/runs/regime_error_figure.tsv"
    params:
        task="regime_error_figure",
        settings=lambda wildcards: repr(config.get("figures", {}).get("png_dpi")),  # rerun when it changes
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


# Issue 13, part 3: Floquet stability of the exact NNM1 against the regularized one, per
# impact regime (nnmstop.compare.stability), and its figure (nnmstop.figures.stability).
# The regularized verdict is the `stable` flag of results/hbm/nnm1.nc, whatever method set it.


rule compare_stability:
    """Agreement of the exact and regularized stability verdicts per impact regime: dataset and CSV table."""
    input:
        exact="results/exact/nnm1.nc",
        nnm1="results/hbm/nnm1.nc",
    output:
        dataset="results/compare/nnm1_stability.nc",
        table="results/compare/nnm1_stability.csv",
    log:
        "logs/compare/nnm1_stability.log",
    benchmark:
        "benchmarks/runs/compare_stability.tsv"
    params:
        task="compare_stability",
        settings=lambda wildcards: repr(config["model"]),  # checked against the inputs
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"


rule stability_figure:
    """Extra figure: FEP of NNM1, exact (red) and regularized (blue), stable solid, unstable dashed, changes marked."""
    input:
        exact="results/exact/nnm1.nc",
        nnm1="results/hbm/nnm1.nc",
        dataset="results/compare/nnm1_stability.nc",
    output:
        pdf="paper_figures/extra_stability.pdf",
        png="paper_figures/extra_stability.png",
    log:
        "logs/figures/extra_stability.log",
    benchmark:
        "benchmarks/runs/stability_figure.tsv"
    params:
        task="stability_figure",
        settings=lambda wildcards: repr([config.get("figures", {}).get(k) for k in ("png_dpi", "extra_stability")]),
    conda:
        "../envs/nnmstop.yaml"
    script:
        "../scripts/run_task.py"
