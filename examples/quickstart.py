"""Quick start: the NNMs of a structure of one's own, from Python (docs/structures.md).

A grounded chain of three unit masses and springs with a bilateral elastic stop on the first mass
(nondimensional: lengths over the gap, time over sqrt(m/k)). Run: ``python examples/quickstart.py``.
"""

import numpy as np

import nnmstop

chain = nnmstop.Structure(
    mass=np.eye(3),
    stiffness=[[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]],
    stops=[nnmstop.Stop(dof=0, gap=1.0, stiffness=30.0, eta=0.1)],
)
omega, shapes = nnmstop.normal_modes(chain)  # linear modes, no contact
print("linear frequencies (Hz of the nondimensional time):", np.round(omega / (2 * np.pi), 4))

nnm1 = nnmstop.continue_nnm(chain, mode=1, harmonics=40, energy_max=3.0)  # a labelled xarray.Dataset
print("NNM1:", nnm1.sizes["point"], "orbits,", nnm1.attrs["end_reason"])
print("  frequency from", round(float(nnm1.frequency[0]), 4), "to", round(float(nnm1.frequency[-1]), 4), "Hz")
print("  impacts per period at the end:", int(nnm1.impacts_per_period[-1]), "; stable:", bool(nnm1.stable[-1]))

exact = nnmstop.exact_family(chain, step=0.05)  # the non-smooth chain, one impact per stop side, closed form
print("exact NNM1 from E =", round(float(exact.energy[0]), 4), "to", round(float(exact.energy[-1]), 4))
print("  it ends because", exact.attrs["end_reason"])
