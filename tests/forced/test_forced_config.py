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
