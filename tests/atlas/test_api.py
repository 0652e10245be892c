"""nnmstop.atlas: the atlas of any structure from Python, the workflow's builders in one call."""

import numpy as np
import pytest

import nnmstop
from nnmstop.bifurcation_atlas.build import CheckFailed
from nnmstop.bifurcation_atlas.curves import CurveSettings
from nnmstop.bifurcation_atlas.flags import CURVE_KINDS, REGIONS

#: Coarser steps in the plane than the workflow's: the tests check the curves where they cross values, not
#: their drawing.
FAST = CurveSettings(step=0.05, max_frequency_step=0.002)


@pytest.mark.numerics
def test_atlas_of_the_oscillator_holds_regions_curves_and_checks():
    """Three slices across NNM1's first contact; grazing and fold curves; every check on its curve; the
    dataset is of the catalogue's kind atlas."""
    ds = nnmstop.atlas(
        nnmstop.two_dof_structure(), (0.085, 0.16), ["u"], (0.08, 0.12), slices=3, kinds=("grazing", "fold"),
        frequency_samples=60, seeds=[0.1], checks=[0.08, 0.12], curve=FAST,
    )  # fmt: skip
    assert ds.attrs["dataset_kind"] == "atlas"
    assert ds.sizes["slice"] == 3 and ds.sizes["grid"] == 60
    kinds = {CURVE_KINDS[k] for k in ds["curve_kind"].values}
    assert kinds == {"grazing", "fold"}
    assert ds.sizes["check"] >= 4 and float(ds["check_deviation"].max()) < ds.attrs["check_tolerance"]
    regions = {REGIONS[k] for k in np.unique(ds["region"].values)}
    assert {"no_contact", "coexisting"} <= regions


@pytest.mark.numerics
def test_atlas_of_a_three_dof_chain():
    """Any structure the engine takes: a grounded 3-DOF chain with a stop on its first mass, forced at its end."""
    chain = nnmstop.Structure(
        np.eye(3), [[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]], [nnmstop.Stop(0, 1.0, 20.0, 0.1)]
    )
    omega = nnmstop.normal_modes(chain)[0][0] / (2 * np.pi)
    ds = nnmstop.atlas(chain, (0.8 * omega, 1.5 * omega), [2], (0.02, 0.06), slices=2, kinds=("grazing",),
                       frequency_samples=30, seeds=[0.06], checks=[0.02])  # fmt: skip
    assert ds.sizes["curve"] >= 1 and ds.sizes["check"] >= 1
    assert float(ds["check_deviation"].max()) < 1e-7


def test_a_located_point_off_every_curve_fails_the_build():
    """With a tolerance below round-off no curve can hold the located points: CheckFailed names them."""
    with pytest.raises(CheckFailed, match="lie on no grazing curve"):
        nnmstop.atlas(nnmstop.two_dof_structure(), (0.085, 0.12), ["u"], (0.05, 0.1), slices=2,
                      kinds=("grazing",), frequency_samples=20, check_tolerance=1e-30)  # fmt: skip


def test_bad_parameters_are_refused_with_their_name():
    with pytest.raises(ValueError, match="plane"):
        nnmstop.atlas(nnmstop.two_dof_structure(), (0.085, 0.12), ["u"], (0.05, 0.1), plane="mass")
    with pytest.raises(ValueError, match="force dof"):
        nnmstop.atlas(nnmstop.two_dof_structure(), (0.085, 0.12), ["w"], (0.05, 0.1))
    with pytest.raises(ValueError, match="unknown curve kinds"):
        nnmstop.atlas(nnmstop.two_dof_structure(), (0.085, 0.12), ["u"], (0.05, 0.1), kinds=("cusp",))
