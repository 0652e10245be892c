"""Paper Figs 5-11: built from datasets, byte-reproducible, and loud on bad input.

The datasets are real small-H branches (H = 15, well under a second each): NNM2 up
to a moderate energy, and the first NNM1 stage cut into four consecutive pieces that
stand in for the four continuation stages (each piece starts at the last point of
the previous one, as real stages do), so that every figure function, including the
multi-stage ones, runs on genuine HBM orbits.
"""

import copy

import numpy as np
import pytest

from nnmstop.config import ConfigError, load_config, validate_config
from nnmstop.figures import frequency_energy as fe
from nnmstop.figures.modal_lines import LabelSpec, energy_crossings, label_specs, locate_label, select_point
from nnmstop.hbm.stages import combine_stages
from nnmstop.models.two_dof import ModelParameters, linear_modes
from nnmstop.pipeline.run import run_task
from nnmstop.tasks.figures import combine_nnm1_stages
from nnmstop.tasks.hbm import build_stage

PNG_DPI = 60  # small PNGs keep the tests fast; the pipeline uses figures.png_dpi


@pytest.fixture(scope="module")
def small_config(repo_root):
    """Paper physics at H = 15: NNM1 up to its first orbit with > 2 impacts, NNM2 to E > 50."""
    config = copy.deepcopy(load_config(repo_root / "config" / "config.yaml"))
    config["hbm"]["harmonics"] = 15
    config["hbm"]["points_per_step"] = 2
    config["hbm"]["max_truncation"] = 5e-2  # coarse on purpose: these tests are about drawing
    config["branches"]["nnm1"]["stages"] = [{"name": "one_impact_per_stop", "until": {"impacts_above": 2}}]
    config["branches"]["nnm2"]["stages"] = [{"name": "moderate_energy", "until": {"energy_above": 50.0}}]
    # no branch switching here: its parent stage is cut away (tests/hbm/test_bifurcation.py covers it)
    config.pop("bifurcations", None)
    for spec in config["figures"].values():
        if isinstance(spec, dict):
            spec.pop("bifurcated", None)
    return config


@pytest.fixture(scope="module")
def nnm2(small_config):
    return build_stage(small_config, "nnm2", 1)


@pytest.fixture(scope="module")
def nnm1_stages(small_config):
    """NNM1 stage 1 cut into four consecutive 'stages' sharing their junction points."""
    whole = build_stage(small_config, "nnm1", 1)
    n = whole.sizes["point"]
    cuts = np.linspace(0, n - 1, 5).round().astype(int)
    stages = []
    for k in range(4):
        part = whole.isel(point=slice(cuts[k], cuts[k + 1] + 1)).copy(deep=True)
        part = part.assign_coords(point=np.arange(part.sizes["point"]))
        part["stage"].values[:] = k + 1
        part.attrs["stages"] = 4
        stages.append(part)
    return stages


def _mid_energy(ds):
    return float(ds["energy"].values[ds.sizes["point"] // 2])


def _label(letter, ds, stage=None, **extra):
    entry = {"label": letter, "energy": _mid_energy(ds), **extra}
    if stage is not None:
        entry["stage"] = stage
    return entry


@pytest.fixture(scope="module")
def specs(nnm1_stages, nnm2):
    """A figure configuration per paper figure, with labels inside the fixture data."""
    s = nnm1_stages
    return {
        "fig05": {},
        "fig06": {"labels": [{"label": "a", "energy": float(nnm2["energy"].values[3])}, _label("b", nnm2)]},
        "fig07": {
            "nnm1_stages": [1],
            "labels": [_label("a", s[0], 1), {"label": "b", "energy": float(s[0]["energy"].values[-2]), "stage": 1}],
        },
        "fig08": {"nnm1_stages": [1, 2], "labels": [_label("d", s[1], 2), _label("e", s[0], 1)]},
        "fig09": {"nnm1_stages": [2, 3], "labels": [_label("j", s[2], 3)]},
        "fig10": {"nnm1_stages": [3, 4], "labels": [_label("o", s[2], 3), _label("p", s[3], 4)]},
        "fig11": {"nnm1_stages": [4], "labels": [_label("r", s[3], 4)]},
    }


def _draw(name, nnm1_stages, nnm2, spec, pdf):
    """Call the figure function of ``name`` with the datasets it reads."""
    if name == "fig05":
        return fe.figure_05(combine_stages(nnm1_stages), nnm2, spec, pdf, PNG_DPI)
    if name == "fig06":
        return fe.figure_06(nnm2, spec, pdf, PNG_DPI)
    nnm1 = combine_nnm1_stages([nnm1_stages[k - 1] for k in spec["nnm1_stages"]], name, spec["nnm1_stages"])
    if name in ("fig07", "fig11"):
        return getattr(fe, f"figure_{name[3:]}")(nnm1, spec, pdf, PNG_DPI)
    return getattr(fe, f"figure_{name[3:]}")(nnm1, nnm2, spec, pdf, PNG_DPI)


@pytest.mark.parametrize("name", sorted(fe.PAPER_FIGURES))
def test_figure_writes_pdf_and_png_byte_reproducibly(name, nnm1_stages, nnm2, specs, tmp_path):
    first = _draw(name, nnm1_stages, nnm2, specs[name], tmp_path / "a" / f"{name}.pdf")
    second = _draw(name, nnm1_stages, nnm2, specs[name], tmp_path / "b" / f"{name}.pdf")
    pdf, png = first
    assert pdf.read_bytes().startswith(b"%PDF") and png.read_bytes().startswith(b"\x89PNG")
    assert pdf.with_suffix(".png") == png
    for a, b in zip(first, second):
        assert a.read_bytes() == b.read_bytes(), f"{a.name} differs between two builds"


def test_nan_in_a_dataset_is_refused_with_its_name(nnm1_stages, nnm2, specs, tmp_path):
    bad = nnm2.copy(deep=True)
    bad["energy"].values[4] = np.nan
    with pytest.raises(ValueError, match=r"fig06.*NNM2.*'energy'.*NaN.*point 4"):
        fe.figure_06(bad, specs["fig06"], tmp_path / "fig06.pdf", PNG_DPI)
    stage = nnm1_stages[0].copy(deep=True)
    stage["q_cos"].values[2, 0, 3] = np.inf
    with pytest.raises(ValueError, match=r"fig07.*NNM1 stage 1.*'q_cos'"):
        fe.figure_07(stage, specs["fig07"], tmp_path / "fig07.pdf", PNG_DPI)
    with pytest.raises(ValueError, match=r"fig07.*NNM1 stage 1.*'q_cos'"):
        combine_nnm1_stages([stage], "fig07", [1])
    assert not (tmp_path / "fig06.pdf").exists() and not (tmp_path / "fig07.pdf").exists()


def _description(pdf_path) -> str:
    """What a figure says it shows and could not (its PNG's Description text)."""
    from PIL import Image

    return Image.open(pdf_path.with_suffix(".png")).info["Description"]


def test_a_label_whose_feature_is_missing_is_named_not_drawn(nnm1_stages, nnm2, specs, tmp_path):
    spec = copy.deepcopy(specs["fig06"])
    spec["labels"].append({"label": "f", "energy": 1.0e9})
    pdf, _ = fe.figure_06(nnm2, spec, tmp_path / "fig06.pdf", PNG_DPI)
    text = _description(pdf)
    assert "not on this branch: f) at energy 1e+09" in text and "outside the energy range" in text
    spec = copy.deepcopy(specs["fig08"])
    spec["labels"][0]["energy"] = float(nnm1_stages[0]["energy"].values[1])  # a stage-1 energy asked of stage 2
    spec["labels"].append({"label": "g", "branch_point": 7})
    pdf, _ = fe.figure_08(combine_stages(nnm1_stages[:2]), nnm2, spec, tmp_path / "fig08.pdf", PNG_DPI)
    text = _description(pdf)
    assert "d) at energy" in text and "of stage 2" in text
    assert "g) at the 7:1 branch point (no 7:1 branch point located on this branch)" in text
    assert "e) at energy" not in text  # the label that exists is drawn, not named


def test_a_label_of_a_stage_not_read_is_named(nnm1_stages, nnm2, specs, tmp_path):
    spec = copy.deepcopy(specs["fig11"])
    spec["labels"][0]["stage"] = 2
    pdf, _ = fe.figure_11(nnm1_stages[3], spec, tmp_path / "fig11.pdf", PNG_DPI)
    assert "no orbit of stage 2 (stages with orbits: 4)" in _description(pdf)


def test_skipped_stages_and_missing_switched_branches_are_named(small_config, nnm1_stages, nnm2, specs, tmp_path):
    """A figure whose stages were not continued is still drawn, and says why; so is a switch without branch point."""
    from nnmstop.hbm.dataset import skipped_stage_dataset
    from nnmstop.tasks.hbm import system_from_config

    system = system_from_config(small_config)
    labels = {"branch": "nnm1", "stage_name": "high_energy"}
    skipped = skipped_stage_dataset(system, 4, labels, "skipped: stage 3 (x) ended without its condition (y): z")
    none = skipped_stage_dataset(system, 0, {"branch": "nnm1_5to1", "parent_branch": "nnm1", "resonance": 5}, "none")
    spec = dict(specs["fig11"], nnm1_stages=[4])
    pdf, _ = fe.figure_11(skipped, spec, tmp_path / "fig11.pdf", PNG_DPI, stages=[skipped])
    text = _description(pdf)
    assert "stage 4 (high_energy) not continued" in text
    pdf, _ = fe.figure_09(nnm1_stages[2], nnm2, specs["fig09"], tmp_path / "fig09.pdf", PNG_DPI, bifurcated=[none])
    assert "no branch switched at a 5:1 branch point (none located)" in _description(pdf)


def test_stages_other_than_configured_or_not_consecutive_are_refused(nnm1_stages, nnm2, specs, tmp_path):
    with pytest.raises(ValueError, match=r"hold stages \[1\], the configuration asks for \[4\]"):
        combine_nnm1_stages([nnm1_stages[0]], "fig11", specs["fig11"]["nnm1_stages"])
    spec = dict(specs["fig08"], nnm1_stages=[1, 3])
    with pytest.raises(ValueError, match="consecutive"):
        combine_nnm1_stages([nnm1_stages[0], nnm1_stages[2]], "fig08", spec["nnm1_stages"])


def test_swapped_branches_and_mixed_models_are_refused(nnm1_stages, nnm2, specs, tmp_path):
    with pytest.raises(ValueError, match="expected a dataset of branch 'nnm2'"):
        fe.figure_06(nnm1_stages[0], specs["fig06"], tmp_path / "fig06.pdf", PNG_DPI)
    other = nnm2.copy()
    other.attrs = {**nnm2.attrs, "alpha": 50.0}
    with pytest.raises(ValueError, match="different structures: alpha"):
        fe.figure_08(combine_stages(nnm1_stages[:2]), other, specs["fig08"], tmp_path / "fig08.pdf", PNG_DPI)


def test_a_label_outside_the_configured_window_is_named(nnm2, specs, tmp_path):
    spec = dict(specs["fig06"], energy_range=[float(nnm2["energy"].values[10]), 1.0e3])
    pdf, _ = fe.figure_06(nnm2, spec, tmp_path / "fig06.pdf", PNG_DPI)
    assert "a) at energy" in _description(pdf) and "outside the configured energy_range" in _description(pdf)


def test_energy_crossings_follow_the_branch_and_its_turning_points():
    energy = np.array([1.0, 2.0, 4.0, 8.0, 4.0, 2.0, 3.0, 6.0])
    everywhere = np.ones(energy.size, dtype=bool)
    assert energy_crossings(energy, everywhere, 3.0) == [2, 4, 6]  # nearest end in log(E) on each crossing
    assert energy_crossings(energy, everywhere, 4.0) == [2, 4, 6]  # exact hits count once
    assert energy_crossings(energy, everywhere, 7.9) == [3]  # both sides of the fold pick the same point
    allowed = everywhere.copy()
    allowed[4] = False  # a run broken by a filtered point: no crossing across the gap
    assert energy_crossings(energy, allowed, 3.0) == [2, 6]


def _constructed_branch():
    """A branch whose features are known: stage 1 rises to a fold at E = 16, stage 2 turns back down to
    E = 3 (its energy minimum) and rises again; impact regimes 0, 2, 4; a located 3:1 branch point at E = 7."""
    import xarray as xr

    energy = np.array([1.0, 2.0, 4.0, 8.0, 16.0, 8.0, 4.0, 3.0, 6.0, 12.0, 24.0])
    frequency = 0.1 + 0.01 * np.arange(energy.size)
    return xr.Dataset(
        {
            "energy": ("point", energy),
            "frequency": ("point", frequency),
            "stage": ("point", np.array([1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2])),
            "impacts_per_period": ("point", np.array([0, 0, 2, 2, 2, 2, 2, 4, 4, 4, 4])),
            "branch_point_energy": ("located_branch_point", [7.0]),
            "branch_point_frequency": ("located_branch_point", [float(frequency[5])]),
            "branch_point_resonance": ("located_branch_point", [3]),
        },
        coords={"point": np.arange(energy.size)},
    )


def test_select_point_honours_stage_impacts_and_occurrence():
    # A constructed branch, so that how often an energy is met does not hang on where a
    # continuation happened to store its points.
    branch = _constructed_branch()
    # E = 5 is met on the way up (nearest point E = 4), down (E = 4) and up again (E = 6)
    assert select_point(branch, LabelSpec("c", "energy", 5.0), "test") == 2
    assert select_point(branch, LabelSpec("c", "energy", 5.0, occurrence=2), "test") == 6
    assert select_point(branch, LabelSpec("c", "energy", 5.0, occurrence=3), "test") == 8
    assert select_point(branch, LabelSpec("c", "energy", 5.0, occurrence=-1), "test") == 8
    assert select_point(branch, LabelSpec("c", "energy", 5.0, stage=2), "test") == 6
    assert select_point(branch, LabelSpec("c", "energy", 5.0, stage=2, impacts=4), "test") == 8
    with pytest.raises(ValueError, match="no orbit of stage 1 with 4 impacts/period"):
        select_point(branch, LabelSpec("c", "energy", 5.0, stage=1, impacts=4), "test")
    with pytest.raises(ValueError, match=r"met 1 time\(s\).*point 8 \(E = 6\).*fewer than 2"):
        select_point(branch, LabelSpec("c", "energy", 5.0, stage=2, impacts=4, occurrence=2), "test")
    with pytest.raises(ValueError, match=r"energy 30 outside the energy range \[3, 24\] of stage 2 with 4 impacts"):
        select_point(branch, LabelSpec("c", "energy", 30.0, stage=2, impacts=4), "test")


def test_labels_follow_the_features_of_the_branch():
    """Each anchor lands on the feature it names, whatever the energies of the branch."""
    branch = _constructed_branch()
    at = {"x": lambda anchor, value, **scope: locate_label(branch, LabelSpec("x", anchor, value, **scope)).point}
    assert at["x"]("branch_point", 3) == 5  # the stored point nearest to the located branch point
    assert at["x"]("regime_start", 2) == 2 and at["x"]("regime_start", 4) == 7
    assert at["x"]("energy_minimum", 1, stage=2) == 7 and at["x"]("energy_minimum", 1, impacts=2) == 2
    # the fraction of the scope's range in log energy: 0.25 of stage 2's [3, 24] is 3 * 8**0.25 = 5.05, first met
    # between E = 8 and 4 (nearest: 4), then between 3 and 6 (nearest: 6)
    assert at["x"]("energy_fraction", 0.25, stage=2) == 6
    assert at["x"]("energy_fraction", 0.25, stage=2, occurrence=-1) == 8
    assert at["x"]("energy_fraction", 1.0) == 10
    missing = locate_label(branch, LabelSpec("x", "branch_point", 5.0))
    assert missing.point is None and missing.missing == "no 5:1 branch point located on this branch"
    assert locate_label(branch, LabelSpec("x", "regime_start", 6.0)).missing == "no orbit with 6 impacts per period"


def test_label_specs_refuse_duplicates_and_bad_values():
    with pytest.raises(ValueError, match=r"used twice.*\['a'\]"):
        label_specs([{"label": "a", "energy": 1.0}, {"label": "a", "energy": 2.0}])
    with pytest.raises(ValueError, match="energy must be finite"):
        label_specs([{"label": "a", "energy": float("nan")}])
    with pytest.raises(ValueError, match="exactly one of"):
        label_specs([{"label": "a", "energy": 1.0, "branch_point": 3}])
    with pytest.raises(ValueError, match="energy_fraction must lie in"):
        label_specs([{"label": "a", "energy_fraction": 1.5}])


def test_gap_zero_lines_come_from_the_dataset(nnm2):
    """The gap-0 frequencies stored with the branch are those of the paper's closed form, alpha added on x."""
    params = ModelParameters(**{k: float(nnm2.attrs[k]) for k in ("alpha", "beta", "delta", "eta")})
    expected = linear_modes(params, "gap_zero")[0] / (2 * np.pi)
    np.testing.assert_allclose(fe.gap_zero_frequencies(nnm2), expected, rtol=1e-12)


def test_pipeline_task_draws_fig06_from_the_nnm2_file_alone(small_config, nnm2, specs, tmp_path):
    config = copy.deepcopy(small_config)
    config["figures"] = {**config["figures"], "png_dpi": PNG_DPI, "fig06": specs["fig06"]}
    validate_config(config)
    path = tmp_path / "nnm2.nc"
    nnm2.to_netcdf(path)
    outputs = {"pdf": str(tmp_path / "out" / "fig06.pdf"), "png": str(tmp_path / "out" / "fig06.png")}
    run_task("paper_fig06", config, {"nnm2": str(path)}, outputs, log=str(tmp_path / "fig06.log"))
    assert all((tmp_path / "out" / name).stat().st_size > 0 for name in ("fig06.pdf", "fig06.png"))
    assert "label b)" in (tmp_path / "fig06.log").read_text()
    with pytest.raises(ValueError, match="missing input 'nnm2'"):
        run_task("paper_fig06", config, {}, outputs, log=str(tmp_path / "fig06.log"))


def test_figures_section_of_the_configuration_is_validated(repo_root):
    config = load_config(repo_root / "config" / "config.yaml")
    assert set(fe.PAPER_FIGURES) <= set(config["figures"])
    for bad in (
        {"label": "ab", "energy": 1.0},
        {"label": "a", "energy": -1.0},
        {"label": "a", "energy": 1.0, "colour": "red"},
    ):
        broken = copy.deepcopy(config)
        broken["figures"]["fig07"]["labels"][0] = bad
        with pytest.raises(ConfigError, match=r"figures\.fig07\.labels\.0"):
            validate_config(broken)
    broken = copy.deepcopy(config)
    del broken["figures"]["fig08"]["nnm1_stages"]
    with pytest.raises(ConfigError, match=r"figures\.fig08\.nnm1_stages"):
        validate_config(broken)


def test_exact_overlay_is_drawn_and_changes_the_figure(nnm1_stages, specs, tmp_path):
    """figures.overlay_exact: the exact NNM1 curve is drawn (a non-smooth dataset with its
    own energy/frequency, no alpha-eta mismatch check against the regularized model)."""
    import matplotlib.pyplot as plt
    import xarray as xr

    stage = nnm1_stages[0]
    energy = stage["energy"].values
    exact = xr.Dataset(
        {
            "energy": ("point", energy, {"long_name": "energy", "units": "1"}),
            "frequency": ("point", 0.99 * stage["frequency"].values, {"long_name": "frequency", "units": "Hz"}),
        },
        attrs={k: stage.attrs[k] for k in ("alpha", "beta", "delta")},
    )
    drawn = []
    original = plt.Axes.plot

    def recording_plot(self, *args, **kwargs):
        drawn.append((kwargs.get("color"), kwargs.get("ls")))
        return original(self, *args, **kwargs)

    plain = fe.figure_07(stage, specs["fig07"], tmp_path / "plain" / "fig07.pdf", PNG_DPI)
    plt.Axes.plot = recording_plot
    try:
        overlaid = fe.figure_07(stage, specs["fig07"], tmp_path / "overlay" / "fig07.pdf", PNG_DPI, exact=exact)
    finally:
        plt.Axes.plot = original
    assert (fe.EXACT_OVERLAY_COLOR, ":") in drawn
    assert plain[1].read_bytes() != overlaid[1].read_bytes()


def test_branch_line_styles_follow_stability_and_resolution():
    """Solid where stable, dashed where unstable, dotted where unresolved; runs join."""
    import matplotlib.pyplot as plt
    import xarray as xr

    from nnmstop.figures.common import plot_branch

    ds = xr.Dataset(
        {
            "energy": ("point", np.arange(1.0, 7.0)),
            "frequency": ("point", np.linspace(0.1, 0.2, 6)),
            "stable": ("point", np.array([1, 1, 0, 0, 1, 1], dtype=np.int8)),
            "stability_resolved": ("point", np.array([1, 1, 1, 0, 1, 1], dtype=np.int8)),
        }
    )
    fig, ax = plt.subplots()
    drawn = plot_branch(ax, ds, "tab:blue")
    styles = [line.get_linestyle() for line in ax.get_lines()]
    starts = [line.get_xdata()[0] for line in ax.get_lines()]
    plt.close(fig)
    assert drawn == {"stable", "unstable", "unresolved"}
    assert styles == ["-", "--", ":", "-"]
    assert starts == [1.0, 3.0, 4.0, 5.0]  # each run starts where the previous one ended


@pytest.fixture
def drawn_figures(monkeypatch):
    """The figures the figure functions save, caught after their labels are placed (to inspect the artists)."""
    from nnmstop.figures.labels import label_overlaps

    caught = []
    real = fe.save_figure

    def spy(fig, pdf_path, png_dpi=150, description=None, after_layout=None):
        def inspect(figure):
            if after_layout is not None:
                after_layout(figure)
            caught.append((figure, label_overlaps(figure)))

        return real(fig, pdf_path, png_dpi, description=description, after_layout=inspect)

    monkeypatch.setattr(fe, "save_figure", spy)
    return caught


def test_letters_of_crowded_points_cover_no_mark_and_no_other_letter(nnm1_stages, nnm2, drawn_figures, tmp_path):
    """Letters asked at neighbouring points, all at one offset, land apart and off the marks."""
    stage = nnm1_stages[1]
    middle = stage.sizes["point"] // 2
    labels = [
        {"label": letter, "energy": float(stage["energy"].values[middle + k]), "stage": 2, "offset": [0, 0]}
        for k, letter in enumerate("defg")
    ]
    spec = {"nnm1_stages": [1, 2], "labels": labels, "legend": "best"}
    fe.figure_08(combine_stages(nnm1_stages[:2]), nnm2, spec, tmp_path / "fig08.pdf", PNG_DPI)
    fig, overlaps = drawn_figures[-1]
    assert overlaps == []
    top = fig.axes[0]
    assert sorted(t.get_text() for t in top.texts if t.get_gid() == "point-label") == list("defg")


def test_fig05_enlarges_nnm1_in_its_own_panel(nnm1_stages, nnm2, drawn_figures, tmp_path):
    """Panel (b) holds the NNM1 curve alone on a frequency scale finer than panel (a)'s."""
    nnm1 = combine_stages(nnm1_stages)
    fe.figure_05(nnm1, nnm2, {}, tmp_path / "fig05.pdf", PNG_DPI)
    fig, _ = drawn_figures[-1]
    whole, zoom = fig.axes[:2]
    assert zoom.get_title(loc="left").startswith("(b)")
    curves = [line for line in zoom.get_lines() if np.size(line.get_xdata()) > 1]
    drawn = np.concatenate([line.get_ydata() for line in curves if line.get_color() == fe.NNM1_COLOR])
    assert np.isin(drawn, nnm1["frequency"].values).all() and drawn.size >= nnm1.sizes["point"]
    assert not any(np.isin(line.get_ydata(), nnm2["frequency"].values).any() for line in curves)
    assert np.ptp(zoom.get_ylim()) < 0.5 * np.ptp(whole.get_ylim())
    low, high = zoom.get_ylim()
    assert low <= nnm1["frequency"].values.max() <= high


def test_the_nnm2_curve_at_f2_over_n_is_a_pale_band_under_the_branch(nnm1_stages, nnm2, specs, drawn_figures, tmp_path):
    fe.figure_08(combine_stages(nnm1_stages[:2]), nnm2, specs["fig08"], tmp_path / "fig08.pdf", PNG_DPI)
    fig, _ = drawn_figures[-1]
    lines = fig.axes[0].get_lines()
    target = nnm2["frequency"].values / 3
    band = [
        line for line in lines if np.shape(line.get_ydata()) == target.shape and np.allclose(line.get_ydata(), target)
    ]
    branch = [line for line in lines if line.get_color() == fe.NNM1_COLOR and np.size(line.get_xdata()) > 1]
    assert len(band) == 1 and branch
    assert band[0].get_linewidth() >= 4 * max(line.get_linewidth() for line in branch)
    assert band[0].get_alpha() < 0.5
    assert band[0].get_zorder() < min(line.get_zorder() for line in branch)
    legend = [text.get_text() for text in fig.legends[0].get_texts()] if fig.legends else []
    legend += [text.get_text() for ax in fig.axes if ax.get_legend() for text in ax.get_legend().get_texts()]
    assert any("NNM2 frequency / 3" in text and "band" in text for text in legend)


# --------------------------------------------------------------------------- issue 29: scenes and names by physics


def test_a_figure_whose_stages_were_not_continued_draws_its_scene_by_physics(nnm1_stages, small_config, tmp_path):
    """Fig 11 asks for stage 4; here that stage was skipped (the continuation ended before it), but NNM1 reached
    high energy earlier: the figure draws the branch's high-energy end (its last run of one identity and one
    impact count) with its letters placed there, instead of an empty panel, and says so."""
    from nnmstop.hbm.dataset import skipped_stage_dataset
    from nnmstop.settings import system_from_config

    whole = combine_stages(list(nnm1_stages[:3]))
    skipped = skipped_stage_dataset(system_from_config(small_config), 4, {"branch": "nnm1"}, "skipped: test")
    spec = {"nnm1_stages": [4], "labels": [{"label": "r", "energy_fraction": 0.5, "stage": 4}]}
    pdf, _ = fe.figure_11(skipped, spec, tmp_path / "fig11.pdf", PNG_DPI, stages=[skipped], whole=whole)
    text = _description(pdf)
    assert "drawn instead the high-energy end of the continuation" in text
    assert "no orbit of" not in text and "not on this branch" not in text  # r) placed on the part drawn
    part, _ = fe.scene_part(whole, "fig11")
    impacts = whole["impacts_per_period"].values
    last = np.flatnonzero(part)
    assert last[-1] == whole.sizes["point"] - 1 and np.all(impacts[last] == impacts[-1])


def test_a_scene_that_does_not_exist_draws_the_branch_without_letters(nnm1_stages, tmp_path):
    """No 5:1 resonance on this short branch: Fig 9's scene by physics does not exist; the whole branch is drawn,
    the letters are named as not on it."""
    whole = combine_stages(list(nnm1_stages))
    assert fe.scene_part(whole, "fig09")[0] is None
    empty = whole.isel(point=slice(0, 0))
    spec = {"nnm1_stages": [2, 3], "labels": [{"label": "j", "energy_fraction": 0.5, "stage": 2}]}
    nnm2 = whole.copy()
    nnm2.attrs["branch"] = "nnm2"
    pdf, _ = fe.figure_09(empty, nnm2, spec, tmp_path / "fig09.pdf", PNG_DPI, stages=[], whole=whole)
    text = _description(pdf)
    assert "no 5:1 internal resonance on this branch" in text and "j)" in text


def test_titles_are_wrapped_to_the_figure_width():
    """A title line never runs past the figure: rendered at its font size, each wrapped line fits the width."""
    import matplotlib.pyplot as plt

    title = "NNM1 skipped: stage 3 (resonance_5to1) ended without its condition (at most 2 impacts per period): " * 3
    for size in (8.5, 9.0):
        fig = plt.figure(figsize=(fe.FIGURE_WIDTH, 2.0))
        renderer = fig.canvas.get_renderer()
        for line in fe.wrapped_title(title, size).split("\n"):
            text = fig.text(0.5, 0.5, line, fontsize=size, ha="center")
            assert text.get_window_extent(renderer).width <= fe.FIGURE_WIDTH * fig.dpi
        plt.close(fig)


def test_the_branch_is_drawn_and_named_by_identity(tmp_path, small_config):
    """A branch whose orbits include another family seen at 1/n: that part gets its own colour and legend
    entry named by its identity (here an NNM2 orbit read over three periods appended to NNM1)."""
    import matplotlib.pyplot as plt

    from nnmstop.figures.common import identity_legend_handles, plot_identities

    whole = build_stage(small_config, "nnm1", 1)
    ds = whole.copy(deep=True)
    n = ds.sizes["point"]
    ds["orbit_kind"].values[n // 2 :] = 2
    ds["dominant_mode"].values[n // 2 :] = 2
    ds["dominant_harmonic"].values[n // 2 :] = 3
    fig, ax = plt.subplots()
    _, others = plot_identities(ax, ds, "tab:blue")
    labels = [h.get_label() for h in identity_legend_handles(others)]
    plt.close(fig)
    assert labels == [f"NNM2 seen at 1/3 of its frequency (from E = {float(ds['energy'].values[n // 2]):.4g})"]
