"""Fixtures shared by the stability tests: one small H = 40 NNM1 branch, built once per session."""

import copy

import pytest

from nnmstop.config import load_config
from nnmstop.tasks.hbm import build_stage, system_from_config

H_BRANCH = 40  # the stability tests check Hill against the monodromy at this H


@pytest.fixture(scope="session")
def h40_config():
    """Paper physics, H = 40; NNM1 from no impact up to the first orbit with four impacts per period,
    NNM2 up to energy 20."""
    c = copy.deepcopy(load_config("config/config.yaml"))
    c["hbm"]["harmonics"] = H_BRANCH
    c["hbm"]["points_per_step"] = 1
    c["branches"]["nnm1"]["stages"] = [
        {"name": "one_impact_per_stop", "until": {"impacts_above": 2}},
        {"name": "three_impacts_per_stop", "until": {"impacts_at_most": 4}},
    ]
    c["branches"]["nnm2"]["stages"] = [{"name": "to_energy_20", "until": {"energy_above": 20.0}}]
    return c


@pytest.fixture(scope="session")
def h40_system(h40_config):
    return system_from_config(h40_config)


@pytest.fixture(scope="session")
def h40_nnm1_stages(h40_config):
    """NNM1 stage 1 (0 then 2 impacts per period) and stage 2 (6 impacts, down to the energy fold and back)."""
    first = build_stage(h40_config, "nnm1", 1)
    return first, build_stage(h40_config, "nnm1", 2, first)
