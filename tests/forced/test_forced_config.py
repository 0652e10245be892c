"""The forced section of the configuration: bad values are refused with the key and the value named."""

import copy

import pytest

from nnmstop.config import ConfigError, load_config, validate_config
from nnmstop.forced.scenes import forced_scenes


@pytest.fixture(scope="module")
def config(repo_root):
    return load_config(repo_root / "config" / "config.yaml")


def test_default_scene_is_the_paper_oscillator_and_the_tube(config):
    names = [scene.name for scene in forced_scenes(config)]
    assert names == ["F0.01", "F0.02", "F0.05", "F0.1", "tube_F0.5"]
    scene = forced_scenes(config, "structure")[0]
    assert scene.excitation.force.dofs == (1,)  # u
    assert scene.excitation.damping.ratios == (0.01, 0.01)


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda f: f["damping"].update(ratios=[-0.01, 0.01]), r"forced\.damping\.ratios\.0"),
        (
            lambda f: f.update(damping={"mass_coefficient": -1.0, "stiffness_coefficient": 0.0}),
            r"forced\.damping\.mass_coefficient",
        ),
        (lambda f: f["force"].update(dofs=["v"]), r"force dof 'v' is not a degree of freedom of the model"),
        (lambda f: f["force"].update(dofs=[7]), r"force dof 7 is off the model"),
        (lambda f: f.update(frequency_range=[0.3, 0.1]), r"frequency range \[0\.3, 0\.1\] Hz is empty"),
        (lambda f: f["tube"].update(force_dofs=["w99"]), r"forced\.tube\.force_dofs: force dof 'w99'"),
    ],
)
def test_bad_forced_settings_are_named(config, change, message):
    bad = copy.deepcopy(config)
    change(bad["forced"])
    with pytest.raises(ConfigError, match=message):
        validate_config(bad)


@pytest.mark.parametrize(
    "change, message",
    [
        # issue 33, reproduction 7: each of these was ignored, overwritten or failed later without naming the key
        (lambda c: c["forced"]["force"].update(amplitudes=[0.1, 0.1000001]),
         r"forced\.force\.amplitudes: \[0\.1, 0\.1000001\] give the same scene name 'F0\.1'"),
        (lambda c: c["forced"]["force"].update(amplitudes=[0.05, 100.0]),
         r"forced\.force\.amplitudes: at F = 100 the linear response reaches the stop over the whole range"),
        (lambda c: c.pop("tube"), r"forced\.tube: the tube's forced response needs the 'tube' section"),
        (lambda c: c["forced"]["figures"].update(orbit_frequencies=[0.12, 0.5]),
         r"forced\.figures\.orbit_frequencies: \[0\.5\] Hz lie outside forced\.frequency_range"),
    ],
)  # fmt: skip
def test_scenes_that_cannot_be_computed_or_drawn_are_refused_naming_the_key(config, change, message):
    bad = copy.deepcopy(config)
    change(bad)
    with pytest.raises(ConfigError, match=message):
        validate_config(bad)


def test_an_exact_response_without_any_piece_is_named_by_its_task(config, monkeypatch):
    """Past validation (a configuration built by hand), the task names the scene and the keys."""
    from nnmstop.forced import assemble
    from nnmstop.tasks import forced

    monkeypatch.setattr(assemble, "exact_response", lambda *args: [])
    with pytest.raises(
        ValueError, match=r"forced scene F0\.05 \(forced\.force\.amplitudes.*\): the exact response has no piece"
    ):
        forced.exact_response_dataset(config, forced_scenes(config)[2])


def test_the_forced_section_applies_to_the_structure_of_the_configuration(config, repo_root):
    """A 3-DOF chain from matrix files with a one-sided stop (``structure: kind: matrices``): the scenes are
    built on it (force DOF by its label), its exact response is stored by its switches, and every stored orbit
    is rebuilt from the dataset (periodic, through the stored switch states)."""
    import numpy as np

    from nnmstop.catalogue import describe
    from nnmstop.forced.dataset import exact_time_history
    from nnmstop.tasks.forced import exact_response_dataset

    example = repo_root / "examples" / "three_dof_chain"
    chain = copy.deepcopy(config)
    chain["structure"] = {
        "kind": "matrices",
        "matrices": {
            "mass": str(example / "mass.mtx"),
            "stiffness": str(example / "stiffness.mtx"),
            "dof_labels": ["x1", "x2", "x3"],
            "stops": [{"kind": "one_sided", "dof": 0, "side": "positive", "gap": 1.0, "stiffness": 30.0, "eta": 0.1}],
        },
    }
    chain["forced"]["force"].update(dofs=["x3"], amplitudes=[0.1])
    (scene,) = forced_scenes(chain, "structure")
    assert scene.excitation.structure.n_dofs == 3 and scene.excitation.force.dofs == (2,)
    assert scene.excitation.structure.stops[0].kind == "one_sided"
    ds = describe(exact_response_dataset(chain, scene), "forced_exact")
    assert "contact_unknowns" not in ds and ds.attrs["stop_kinds"] == "one_sided"
    assert ds.attrs["segment_sequences"].startswith("1: q0 >= 1 in, q0 >= 1 out")
    for point in (1, ds.sizes["contact_point"] // 2):
        history = exact_time_history(ds, scene.excitation, point, samples=256)
        start = ds["switch_state"].values[point]
        np.testing.assert_allclose(np.concatenate([history["q"][:, 0], history["qdot"][:, 0]]), start, atol=1e-12)
        i = ds["contact_point_index"].values[point]
        np.testing.assert_allclose(np.abs(history["q"]).max(axis=1), ds["amplitude"].values[i], rtol=1e-3)
