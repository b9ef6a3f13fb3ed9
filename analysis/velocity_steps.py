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
# # Velocity steps: the direct effect A, and A, B, Dc from rate-and-state fits
#
# `scenarios/velocity_step.toml` (001/Fig. 2): the reference mean-field joint at 20 C with
# ageing contacts (m = 0.05) renewed after D0 = 0.5 um, 1 -> 10 um/s on a stiff drive.
# The spike gives A (001/Eq. 12); the aging and slip laws are fitted through the same path
# as measured data (`nanoblock fit`). Then the mapping A = alpha mu0, B = m mu0, Dc ~ D0
# (001/Eq. 16) is measured on 1 -> 2 -> 1 um/s step pairs at D0 = 0.05-0.2 um and
# m = 0.025-0.1 (the interface of `tests/test_coarse_acceptance.py`, at 300 K).
# `NANOBLOCK_NOTEBOOK_SCALE` < 1 scales the number of contacts (noisier; the step pairs keep
# at least half of them: fits of noisier pairs wander into stiff corners and cost more
# than the runs).

# %%
import os

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from nanoblock.coarse.runs import quiet_seed, scenario_file, varied
from nanoblock.coarse.transients import fit_transient, measure_steps, spike
from nanoblock.engine import simulate

scale = float(os.environ.get("NANOBLOCK_NOTEBOOK_SCALE", "1"))
os.makedirs("figures", exist_ok=True)
um = 1e-6

# %% [markdown]
# ## The 1 -> 10 um/s step
# The spike is the direct effect at constant contact ages: A = (mu_peak - mu_before) /
# ln 10, against alpha mu_before with the exact mean-field secant alpha of 001/Eq. 28
# (001/Eq. 30's alpha = 1/2u is ~30 % lower at these velocities). The fits see the same
# record: the one-state laws cannot follow the renewal model's relaxation exactly (a newborn
# contact has the area at birth, so the area falls faster at first than ln theta does in
# the aging law), and their A absorbs part of the mismatch.

# %%
step_scenario = scenario_file("velocity_step.toml", scale)
run = simulate(step_scenario)
peak = spike(run)
fits = {law: fit_transient(run, law) for law in ("aging", "slip")}
d0 = step_scenario.interface.memory_length
print(
    f"spike: A = {float(peak.a):.5f} +- {float(peak.a_stderr):.1g}, alpha mu0 = "
    f"{float(peak.a_theory):.5f} ({float(peak.a / peak.a_theory - 1):+.1%}); "
    f"001/Eq. 30: {float(peak.a_eq30):.5f}"
)
for law, fit in fits.items():
    print(
        f"{law:6s} a = {float(fit.a):.5f} ({float(fit.a / fit.a_theory - 1):+.0%} of alpha mu0), "
        f"b = {float(fit.b):.5f} ({float(fit.b / fit.b_theory - 1):+.0%} of m sigma_s/p), "
        f"Dc = {float(fit.dc) / d0:.2f} D0, rms {float(fit.rms_residual):.1e}"
    )

fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
travel = run.load_point_displacement.values
ax.plot(travel / um, run.friction_coefficient, color="k", lw=0.8, label="simulation")
for law, fit in fits.items():
    ax.plot(fit.load_point_displacement / um, fit.mu_fit, lw=1.2, label=f"{law} law fit")
before = float(peak.mu_before)
ax.axhline(
    before + float(peak.a_theory) * np.log(10),
    ls=":",
    color="grey",
    label="mu_before + alpha mu0 ln 10 (001/Eqs. 12, 28)",
)
ax.set_xlabel("load-point displacement [um]")
ax.set_ylabel("friction coefficient")
ax.set_title(f"1 -> 10 um/s, D0 = {d0 / um:.1f} um, {step_scenario.interface.n_contacts} contacts")
ax.legend()
fig.savefig("figures/velocity_step.png", dpi=120)

# %% [markdown]
# ## The mapping across D0 and m
# Step pairs 1 -> 2 -> 1 um/s (3 D0 each) on a stiff drive, aging-law fits. Dc is
# proportional to D0 (the renewal process is self-similar in D0 while D0 >> rho~_max and
# D0 / V >> tau_m), at about D0 / 2 (the linearised renewal response ln(1 + s/r)/(s/r)
# matches the aging law's 1/(1 + s Dc/V) to first order in s for Dc = D0 / 2). B is
# m sigma_s / p: the state acts on the area at birth, not on the aged friction mu0.

# %%
pair = varied(
    scenario_file("velocity_step.toml", max(scale, 0.5)),
    {
        "joint.temperature": 300.0,
        "interface.memory_length": 1e-7,
        "loading.steps": [
            {"velocity": 1e-6, "displacement": 0.5e-7},
            {"velocity": 2e-6, "displacement": 3e-7},
            {"velocity": 1e-6, "displacement": 3e-7},
        ],
        "run.record_every": 1e-7 / 2e-6 / 200,
    },
)
pair = quiet_seed(pair)
by_d0 = measure_steps(pair, "interface.memory_length", [0.5e-7, 1e-7, 2e-7], "aging")
# m = 0.05 at D0 = 0.1 um is the pair itself, already run and fitted in by_d0
others = measure_steps(pair, "interface.aging_m", [0.025, 0.1], "aging")
middle = by_d0.sel({"interface.memory_length": 1e-7}).drop_vars("interface.memory_length")
middle = middle.expand_dims({"interface.aging_m": [pair.interface.aging_m]})
by_m = xr.concat(
    [others.isel({"interface.aging_m": [0]}), middle, others.isel({"interface.aging_m": [1]})],
    dim="interface.aging_m",
)
print("Dc / D0:", np.round((by_d0.dc / by_d0.dc_theory).values, 3))
print("B / (m sigma_s / p):", np.round((by_m.b / by_m.b_theory).values, 3))
print("A / (alpha mu0):", np.round((by_m.a / by_m.a_theory).values, 3))

fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
d0s = by_d0["interface.memory_length"].values
left.errorbar(d0s / um, by_d0.dc / um, yerr=by_d0.dc_stderr / um, fmt="o", label="fitted Dc")
ratio = float(np.mean(by_d0.dc / by_d0.dc_theory))
left.plot(d0s / um, ratio * d0s / um, ls="--", label=f"Dc = {ratio:.2f} D0")
left.set_xlabel("D0 [um]")
left.set_ylabel("Dc [um]")
left.legend()
ms = by_m["interface.aging_m"].values
right.errorbar(ms, by_m.b, yerr=by_m.b_stderr, fmt="o", label="fitted B")
right.plot(ms, by_m.b_theory, ls="--", label="m sigma_s / p (001/Eq. 16)")
right.errorbar(ms, by_m.a, yerr=by_m.a_stderr, fmt="s", label="fitted A")
right.plot(ms, by_m.a_theory, ls=":", label="alpha mu0 (exact alpha)")
right.set_xlabel("ageing coefficient m")
right.set_ylabel("rate-and-state coefficient")
right.legend()
fig.savefig("figures/mapping.png", dpi=120)
