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
# # Temperature and the activation volume (001/Figs. 9, 12, Eqs. 18-19, 33)
#
# `scenarios/temperature_sweep.toml`: the reference mean-field joint, its parameters held
# fixed from 20 C to 100 C (10 K below the T_g of PMMA), no ageing, a 1 -> 10 um/s step on
# a stiff drive. A(T) = (mu_ss(10 um/s) - mu_ss(1 um/s)) / ln 10 and Persson's
# v_act(T) = k_B T / (p A) (001/Eq. 19) against v_act = 8 b^3 sigma_bar / E_J (001/Eq. 33).
# At finite T the blocks fire below sigma_a, so Eq. 19 reads a smaller volume; its
# T -> 0 intercept recovers Eq. 33. The mean-field quadrature (001/Eq. 28) is drawn at
# every T as the theory line. `NANOBLOCK_NOTEBOOK_SCALE` < 1 scales the contacts.

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

from nanoblock.barriers import BOLTZMANN
from nanoblock.coarse.activation import measure_activation
from nanoblock.coarse.runs import scenario_file, scenario_path, sweep_of, varied
from nanoblock.engine import mean_field_joint
from nanoblock.theory.meanfield import steady_stress

scale = float(os.environ.get("NANOBLOCK_NOTEBOOK_SCALE", "1"))
os.makedirs("figures", exist_ok=True)
path = scenario_path("temperature_sweep.toml")
base = scenario_file(path, scale)
temperatures = np.array(sweep_of(path).axes[0].values, dtype=float)
result = measure_activation(base, temperatures)
theory_v = float(result.v_act_theory)
nm3 = 1e-27

# %%
fine = np.linspace(60.0, temperatures.max() * 1.05, 120)  # u <= 250: within the tested range
theory_a = []
for t in fine:
    joint = mean_field_joint(varied(base, {"joint.temperature": float(t)}))
    gain = steady_stress(1e-5, joint) - steady_stress(1e-6, joint)
    theory_a.append(float(gain) / np.log(10) / base.interface.hardness)
theory_a = np.array(theory_a)
theory_v_t = BOLTZMANN * fine / (base.interface.hardness * theory_a)
error = float(result.v_act) / theory_v - 1
print("A(T):", np.round(result.a.values, 5).tolist())
print("v_act(T) / v_act:", np.round(result.v_act_t.values / theory_v, 3).tolist())
print(
    f"T -> 0 intercept: {float(result.v_act) / nm3:.2f} +- {float(result.v_act_stderr) / nm3:.2f}"
    f" nm^3 vs 8 b^3 sigma_bar / E_J = {theory_v / nm3:.2f} nm^3 ({error:+.1%})"
)

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
celsius = temperatures - 273.15
left.errorbar(celsius, result.a, yerr=result.a_stderr, fmt="o", label="simulation")
left.plot(fine - 273.15, theory_a, label="mean-field quadrature (001/Eq. 28)")
left.plot(
    fine - 273.15,
    BOLTZMANN * fine / (base.interface.hardness * theory_v),
    ls="--",
    label="k_B T / (p v_act), 001/Eqs. 19, 33",
)
left.set_xlim(celsius.min() - 10, celsius.max() + 10)
left.set_ylim(0, None)
left.set_xlabel("temperature [C]")
left.set_ylabel("direct effect A (1 -> 10 um/s)")
left.legend()
right.errorbar(
    temperatures,
    result.v_act_t / nm3,
    yerr=result.v_act_t_stderr / nm3,
    fmt="o",
    label="k_B T / (p A), 001/Eq. 19",
)
right.plot(fine, theory_v_t / nm3, label="same, mean-field quadrature")
to_zero = np.linspace(0.0, fine[-1], 2)
line = float(result.v_act) + float(result.v_act_slope) * to_zero
right.plot(to_zero, line / nm3, ls=":", label="straight line to T = 0")
right.axhline(theory_v / nm3, color="k", ls="--", label="8 b^3 sigma_bar / E_J (001/Eq. 33)")
right.set_xlabel("temperature [K]")
right.set_ylabel("activation volume [nm^3]")
right.legend()
fig.savefig("figures/activation_volume.png", dpi=120)
