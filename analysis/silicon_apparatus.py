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
# # Silicon on steel: 000/Figs. 2 and 3 from the apparatus equations
#
# The clamped-sample apparatus of 000 (Eqs. 9-14, `nanoblock.rsf.apparatus`) with the
# silicon law (000/Eqs. 1, 7) and the parameters of 000/Tables 1-2 (printed c-values).
# Fig. 2: four 30 um steps of the motor over 16 s, each held 284 s, N = 467 N, Si/steel 1.
# Fig. 3: a 0 -> 127 um ramp over 370 s at six normal forces (not listed in 000; we take
# 100-600 N), Si/steel 2. The slow-ramp closed form 000/Eq. 15 is overlaid; it is exact
# only for A -> 0 and v << v_theta. Set `NANOBLOCK_NOTEBOOK_SCALE` < 1 for fewer samples.

# %%
import os

import matplotlib.pyplot as plt
import numpy as np

from nanoblock.rsf.apparatus import (
    APPARATUS,
    FIG2_NORMAL_FORCE,
    FIG2_PROTOCOL,
    FIG3_NORMAL_FORCES,
    FIG3_PROTOCOL,
    SURFACES,
    solve_apparatus,
)
from nanoblock.rsf.closed_forms import slow_ramp_limit, slow_ramp_sample_extension
from nanoblock.rsf.laws import law

scale = float(os.environ.get("NANOBLOCK_NOTEBOOK_SCALE", "1"))
samples = max(101, int(2400 * scale))
silicon, apparatus = law("silicon"), APPARATUS["silicon"]
os.makedirs("figures", exist_ok=True)
um = 1e-6

# %% [markdown]
# ## Fig. 2: steps and holds
# During each hold the sample creeps back, linearly in ln(t - t_hold) (panel B: the last
# hold, with the fit s = s0 - s1 ln(t - t_hold) from 1 s on). Eq. 15 at the same s_ext is
# the rate-free response: it jumps with each step and never creeps. It overshoots the
# simulated steps because the slip velocity during a rise (~7 nm/s) is a quarter of
# v_theta = 29.5 nm/s, which slows the growth of theta per unit slip (000/Eq. 7).

# %%
surface = SURFACES["si_steel_1"]
times = np.linspace(0.0, FIG2_PROTOCOL.times[-1], samples)
fig2 = solve_apparatus(silicon, surface.params, apparatus, FIG2_NORMAL_FORCE, FIG2_PROTOCOL, times)
closed2 = slow_ramp_sample_extension(
    fig2.s_ext.values, apparatus, FIG2_NORMAL_FORCE, surface.params
)
hold_start = FIG2_PROTOCOL.times[-2]
hold = fig2.sel(time=slice(hold_start + 1.0, None))
log_time = np.log(hold.time.values - hold_start)
slope, intercept = np.polyfit(log_time, hold.s.values, 1)
fit = intercept + slope * log_time
r2 = 1 - np.var(hold.s.values - fit) / np.var(hold.s.values)
lost = 1 - float(fig2.s.sel(time=16.0, method="nearest")) / (
    apparatus.c_ext * 30 * um / apparatus.k_s
)
print(f"first step: {100 * lost:.0f} % of the no-slip extension lost to slip (000: ~80 %)")
print(f"last hold: ds/dln t = {slope / 1e-9:.2f} nm, R^2 = {r2:.5f}")

fig, (top, bottom) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
top.plot(fig2.time, fig2.s / um, label="simulation (000/Eqs. 14)")
top.plot(fig2.time, closed2 / um, ls="--", label="slow-ramp closed form (000/Eq. 15)")
top.set_xlabel("time t [s]")
top.set_ylabel("sample extension s [um]")
motor = top.twinx()
motor.plot(fig2.time, fig2.s_ext / um, color="grey", lw=0.8)
motor.set_ylabel("motor extension s_ext [um] (grey)")
top.set_title(f"A: Si/steel 1, N = {FIG2_NORMAL_FORCE:.0f} N")
top.legend(loc="lower right")
bottom.plot(hold.time - hold_start, hold.s / um, label="simulation")
bottom.plot(hold.time - hold_start, fit / um, ls="--", label=f"s0 - s1 ln(t - t0), R^2 = {r2:.5f}")
bottom.set_xscale("log")
bottom.set_xlabel("time since the last hold began, t - t0 [s]")
bottom.set_ylabel("sample extension s [um]")
bottom.set_title("B: back-creep during the last hold")
bottom.legend()
fig.savefig("figures/silicon_fig2.png", dpi=120)

# %% [markdown]
# ## Fig. 3: slow ramps at six normal forces
# Dotted: no slip until static friction gives way, s = min(c_ext s_ext, 2 mu_s N) / k_s.
# Dashed: Eq. 15 (through its root-found inverse). The lower panel is the departure of the
# full law from Eq. 15, in per cent of the plateau 2 mu_s N / k_s.

# %%
surface = SURFACES["si_steel_2"]
times = np.linspace(0.0, FIG3_PROTOCOL.times[-1], samples)
fig, (top, bottom) = plt.subplots(
    2, 1, figsize=(7, 8), sharex=True, height_ratios=[3, 1], constrained_layout=True
)
departures = []
for normal_force in FIG3_NORMAL_FORCES:
    run = solve_apparatus(silicon, surface.params, apparatus, normal_force, FIG3_PROTOCOL, times)
    closed = slow_ramp_sample_extension(run.s_ext.values, apparatus, normal_force, surface.params)
    plateau = slow_ramp_limit(apparatus, normal_force, surface.params)
    rigid = np.minimum(apparatus.c_ext * run.s_ext.values, apparatus.k_s * plateau) / apparatus.k_s
    departure = (run.s.values - closed) / plateau
    departures.append(np.abs(departure).max())
    (line,) = top.plot(run.s_ext / um, run.s / um, label=f"N = {normal_force:.0f} N")
    top.plot(run.s_ext / um, closed / um, ls="--", color=line.get_color())
    top.plot(run.s_ext / um, rigid / um, ls=":", color=line.get_color())
    bottom.plot(run.s_ext / um, 100 * departure, color=line.get_color())
print(
    "max |full law - Eq. 15| / s_max per force [%]:",
    np.round(100 * np.array(departures), 2).tolist(),
)
top.set_ylabel("sample extension s [um]")
top.set_title("Si/steel 2: solid simulation, dashed 000/Eq. 15, dotted no slip")
top.legend()
bottom.axhline(0, color="k", lw=0.8)
bottom.set_xlabel("motor extension s_ext [um]")
bottom.set_ylabel("(s - s_Eq.15) / s_max [%]")
fig.savefig("figures/silicon_fig3.png", dpi=120)

# %% [markdown]
# ## The same experiments on a nanoblock interface
# `scenarios/silicon_stepped.toml` and `silicon_ramped.toml`: one friction interface of
# the clamped sample is a spring-slider with K = c_x / 2, W = N, load point
# X_L = (c_ext / c_x) s_ext, and s = 2 mu N / k_s. The mean-field joint is chosen so that
# its direct effect and sliding friction are Table 2's A and mu_s (block size from
# A / mu_s = d ln sigma_s / d ln V, hardness from mu_s = sigma_s / p), with D0 = Dc and no
# ageing (see the files' comments). The interface starts in steady sliding (the engine
# cannot yet start this joint unloaded, see the files), so the curves start at the
# plateau: the base model has no counterpart of 000's zero static threshold, the silicon
# law's state rising from 0 over Dc of slip. What can be compared is the rate response:
# the steps of Fig. 2 and the logarithmic back-creep during its holds, and the plateau of
# Fig. 3 at each normal force. `NANOBLOCK_NOTEBOOK_SCALE` < 1 simulates every other force.

# %%
from nanoblock.coarse.runs import run_scenarios, scenario_file, varied  # noqa: E402

stepped = scenario_file("silicon_stepped.toml", scale)
ramped = scenario_file("silicon_ramped.toml", scale)
forces = FIG3_NORMAL_FORCES if scale == 1 else FIG3_NORMAL_FORCES[::2]
block_runs = run_scenarios(
    [stepped] + [varied(ramped, {"interface.normal_force": n}) for n in forces]
)


def sample_extension(run, scenario):
    """Motor and sample extensions [m] of a nanoblock run in 000's apparatus."""
    motor = run.load_point_displacement.values * apparatus.c_x / apparatus.c_ext
    force = scenario.interface.normal_force
    return motor, np.asarray(apparatus.sample_extension(force, run.friction_coefficient.values))


fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
motor, sample = sample_extension(block_runs[0], stepped)
block_time = block_runs[0].time.values
last_hold = block_time > hold_start + 1.0
block_slope = np.polyfit(np.log(block_time[last_hold] - hold_start), sample[last_hold], 1)[0]
direct_creep = -2 * FIG2_NORMAL_FORCE * SURFACES["si_steel_1"].a / apparatus.k_s
print(
    f"last hold back-creep ds/dln t: nanoblock {block_slope / 1e-9:.2f} nm, silicon law "
    f"{slope / 1e-9:.2f} nm, -2NA/k_s = {direct_creep / 1e-9:.2f} nm"
)
left.plot(block_runs[0].time, sample / um, label="nanoblock interface")
left.plot(fig2.time, fig2.s / um, ls="--", label="silicon law (000/Eqs. 1, 7, 14)")
left.set_xlabel("time t [s]")
left.set_ylabel("sample extension s [um]")
left.set_title(f"000/Fig. 2 protocol, Si/steel 1, N = {FIG2_NORMAL_FORCE:.0f} N")
left.legend()
surface = SURFACES["si_steel_2"]
for normal_force, run in zip(forces, block_runs[1:], strict=True):
    scenario = varied(ramped, {"interface.normal_force": normal_force})
    motor, sample = sample_extension(run, scenario)
    (line,) = right.plot(motor / um, sample / um, label=f"N = {normal_force:.0f} N")
    law_run = solve_apparatus(
        silicon, surface.params, apparatus, normal_force, FIG3_PROTOCOL, times
    )
    right.plot(law_run.s_ext / um, law_run.s / um, ls="--", color=line.get_color())
    print(
        f"N = {normal_force:.0f} N: nanoblock peak mu {float(run.friction_coefficient.max()):.3f},"
        f" final {float(run.friction_coefficient[-1]):.3f} (mu_s = {surface.mu_s})"
    )
right.set_xlabel("motor extension s_ext [um]")
right.set_ylabel("sample extension s [um]")
right.set_title("000/Fig. 3 protocol, Si/steel 2: solid nanoblock, dashed silicon law")
right.legend(fontsize=8)
fig.savefig("figures/silicon_nanoblock.png", dpi=120)
