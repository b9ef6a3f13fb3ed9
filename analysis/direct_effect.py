# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # The direct effect: simulated steady friction vs the mean-field theory
#
# Mean-field nanoblock joint (k2 = 0, reset; 001/Fig. 14) with the reference parameters
# of physics.md section 4 (u = 50), rigid drive, no ageing. The steady friction stress is
# measured at velocities from 1e-9 m/s to 2 V* and compared with the exact quadrature of
# 001/Eq. 28, the large-u asymptotics (physics.md section 1) and the linear log law of
# 001/Eq. 30. Set `NANOBLOCK_NOTEBOOK_SCALE` < 1 for a quick run.

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

from nanoblock.engine import mean_field_joint, simulate
from nanoblock.params import from_mapping
from nanoblock.theory.meanfield import (
    steady_stress,
    steady_stress_asymptotic,
    steady_stress_loglaw,
)

scale = float(os.environ.get("NANOBLOCK_NOTEBOOK_SCALE", "1"))
rho_max = 2.75e-10
velocities = np.logspace(-9, 1, 11)


def steady_scenario(velocity: float):
    return from_mapping(
        {
            "joint": {
                "block_size": 2.75e-9,
                "shear_modulus": 1e9,
                "threshold_stress": 1e8,
                "attempt_frequency": 1e12,
                "temperature": 300.0,
                "k2": 0.0,
                "slip": "reset",
            },
            "interface": {
                "normal_force": 1.0,
                "hardness": 1e8,
                "n_contacts": 40,
                "blocks_per_contact": max(10, int(500 * scale)),
                "memory_length": float("inf"),
            },
            "loading": {
                "stiffness": float("inf"),
                "steps": [{"velocity": velocity, "displacement": 70 * rho_max}],
            },
            "run": {
                "seed": 1,
                "record_every": 1.37 * rho_max / velocity,
                "initial_state": "steady",
            },
        }
    )


measured = []
for velocity in velocities:
    run = simulate(steady_scenario(velocity))
    stress = (run.friction_force / run.real_contact_area).values[8:]
    measured.append((stress.mean(), stress.std(ddof=1) / np.sqrt(stress.size)))
measured = np.array(measured)
joint = mean_field_joint(steady_scenario(1e-6))

# %%
fine = np.logspace(-10, 1.5, 300)
exact = steady_stress(fine, joint)
deviation = measured[:, 0] / steady_stress(velocities, joint) - 1
fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 7), sharex=True, constrained_layout=True)
top.semilogx(fine, exact / 1e6, label="quadrature of 001/Eq. 28")
top.semilogx(fine, steady_stress_asymptotic(fine, joint) / 1e6, ls=":", label="large-u asymptotics")
top.semilogx(
    fine, steady_stress_loglaw(fine, joint) / 1e6, ls="--", label="linear log law 001/Eq. 30"
)
top.errorbar(
    velocities,
    measured[:, 0] / 1e6,
    yerr=measured[:, 1] / 1e6,
    fmt="o",
    ms=4,
    label="simulation (2e4 blocks)",
)
top.axvline(joint.v_star, color="grey", lw=0.8)
top.set_ylabel("steady friction stress [MPa]")
top.legend()
bottom.semilogx(velocities, 100 * deviation, "o")
bottom.axhline(0, color="k", lw=0.8)
bottom.set_ylabel("simulation / quadrature - 1 [%]")
bottom.set_xlabel("drive velocity V [m/s]")
os.makedirs("figures", exist_ok=True)
fig.savefig("figures/steady_stress.png", dpi=120)
print("max |deviation| = %.3f %%" % (100 * np.abs(deviation).max()))
