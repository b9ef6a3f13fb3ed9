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
# # Ageing and renewal: from contact ages to the rate-and-state state
#
# Contacts age (their area grows as m ln(1 + age/tau_m), 001/Eq. 5) and die after an
# Exp(D0) slip, so in steady sliding their ages are Exp with mean D0 / V: Dieterich's
# state theta = D0 / V (001/Eq. 3). Three views of it, each against its theory:
# 1. the contact ages of a steady run (block snapshots) against (V/D0) exp(-age V/D0),
#    and the block stresses against the mean-field Q_st (001/Eq. 27);
# 2. `scenarios/steady_velocity_sweep.toml`: mu_ss(V) from 1 nm/s to 1 mm/s weakens as
#    (A - B) ln V with A = alpha mu_ss and B = m sigma_s / p, and the weakening stops above
#    V_sat = D0 / tau_m (001/Eq. 8);
# 3. `scenarios/slide_hold_slide.toml`: reload peaks after holds of 1-1000 s grow as
#    ln(hold) (static ageing, 001/Eq. 11).
# `NANOBLOCK_NOTEBOOK_SCALE` < 1 scales the number of contacts (and, below 0.2, the slip
# of each steady run).

# %%
import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy.special import exp1

from nanoblock.coarse.distributions import age_distribution, stress_distribution
from nanoblock.coarse.runs import scenario_file, scenario_path, sweep_of, varied
from nanoblock.coarse.steady import measure_steady
from nanoblock.engine import mean_field_joint, protocol_table, simulate
from nanoblock.snapshots import open_snapshots
from nanoblock.theory.meanfield import steady_stress

scale = float(os.environ.get("NANOBLOCK_NOTEBOOK_SCALE", "1"))
os.makedirs("figures", exist_ok=True)
um = 1e-6

# %% [markdown]
# ## 1. Agents in steady sliding

# %%
steady_path = scenario_path("steady_velocity_sweep.toml")
base = scenario_file(steady_path, scale)
d0 = base.interface.memory_length
agents = varied(
    base,
    {
        "loading.steps": [{"velocity": 1e-6, "displacement": 5 * d0}],
        "run.record_every": base.joint.rho_max / 1e-6,
        "run.snapshot_every": 50,
        "interface.blocks_per_contact": 5,
    },
)
with tempfile.TemporaryDirectory() as scratch:
    store = Path(scratch) / "agents.zarr"
    simulate(agents, store)
    snaps = open_snapshots(store)
    ages = age_distribution(snaps, agents).load()
    stresses = stress_distribution(snaps, agents).load()
mean_age = float((ages.density * ages.age).sum() * np.diff(ages.age.values)[0])
print(f"mean contact age {mean_age:.4g} s vs D0/V = {d0 / 1e-6:.4g} s")

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4), constrained_layout=True)
left.errorbar(ages.age, ages.density, yerr=ages.density_stderr, fmt=".", label="simulation")
left.plot(ages.age, ages.density_theory, label="(V/D0) exp(-age V/D0) (001/Eq. 3)")
left.set_yscale("log")
left.set_xlabel("contact age [s]")
left.set_ylabel("density [1/s]")
left.legend()
rho = stresses.rho.values / base.joint.rho_max
right.errorbar(
    rho,
    stresses.q_rho * base.joint.rho_max,
    yerr=stresses.q_rho_stderr * base.joint.rho_max,
    fmt=".",
    label="blocks (snapshots)",
)
right.plot(rho, stresses.q_theory * base.joint.rho_max, label="mean-field Q_st (001/Eq. 27)")
right.set_xlabel("rho~ / rho~_max = sigma / sigma_a")
right.set_ylabel("density")
right.legend()
fig.savefig("figures/agents.png", dpi=120)

# %% [markdown]
# ## 2. Steady friction over six decades
# The theory line: sigma_s(V) / p times the mean area factor 1 + m E[ln(1 + age/tau_m)]
# over Exp(D0/V) ages (the mean-field joint on ageing contacts); its slope is A - B with
# A = alpha mu_ss (exact alpha) and B = m sigma_s / p well below V_sat, and A alone above.

# %%
velocities = np.array(sweep_of(steady_path).axes[0].values, dtype=float)
travel = base.loading.steps[0].displacement * min(1.0, 5 * scale)
curve = measure_steady(base, velocities, travel)
joint = mean_field_joint(base)
fine = np.logspace(np.log10(velocities[0]) - 0.3, np.log10(velocities[-1]) + 0.3, 120)
interface = base.interface
# E[ln(1 + X/c)] = e^c E1(c) for X ~ Exp(1), c = tau_m V / D0
ratio = interface.aging_time * fine / d0
area = 1 + interface.aging_m * np.exp(ratio) * exp1(ratio)
theory_mu = steady_stress(fine, joint) / interface.hardness * area
weakening = np.gradient(theory_mu, np.log(fine))  # includes the saturation near V_sat
print("mu_ss:", np.round(curve.mu_ss.values, 4).tolist())
print("V_sat = D0 / tau_m =", d0 / interface.aging_time, "m/s")

fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 7), sharex=True, constrained_layout=True)
top.errorbar(curve.velocity, curve.mu_ss, yerr=curve.mu_ss_stderr, fmt="o", label="simulation")
top.semilogx(fine, theory_mu, label="sigma_s(V)/p x mean area factor")
top.axvline(d0 / interface.aging_time, color="grey", ls=":", label="V_sat = D0 / tau_m")
top.set_ylabel("steady friction mu_ss")
top.legend()
log_v = np.log(curve.velocity.values)
secant = np.diff(curve.mu_ss.values) / np.diff(log_v)
middle = np.exp(0.5 * (log_v[1:] + log_v[:-1]))
bottom.semilogx(middle, secant, "o", label="simulated secant slope")
bottom.semilogx(fine, weakening, label="slope of the line above (A - B below V_sat)")
bottom.axhline(0, color="k", lw=0.8)
bottom.set_xlabel("velocity V [m/s]")
bottom.set_ylabel("d mu_ss / d ln V")
bottom.legend()
fig.savefig("figures/ageing_steady.png", dpi=120)

# %% [markdown]
# ## 3. Slide-hold-slide
# Peak on reloading minus the sliding level before the hold, against ln(hold): its slope
# is the static ageing rate, compared with B = m sigma_s / p.

# %%
shs = scenario_file("slide_hold_slide.toml", scale)
run = simulate(shs)
starts = protocol_table(shs)[0]
time, mu = run.time.values, run.friction_coefficient.values
holds, peaks = [], []
for i, step in enumerate(shs.loading.steps):
    if step.hold is None:
        continue
    before = mu[(time > starts[i] - 0.2 * d0 / 1e-6) & (time <= starts[i])].mean()
    after = mu[(time > starts[i + 1]) & (time <= starts[i + 2])].max()
    holds.append(step.hold)
    peaks.append(after - before)
slope = np.polyfit(np.log(holds), peaks, 1)[0]
shs_b = (
    shs.interface.aging_m
    * float(steady_stress(1e-6, mean_field_joint(shs)))
    / shs.interface.hardness
)
print(f"d(peak)/d ln(hold) = {slope:.4f}; m sigma_s / p = {shs_b:.4f}")

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4), constrained_layout=True)
left.plot(time, mu, lw=0.7)
left.set_xscale("symlog", linthresh=10)
left.set_xlabel("time [s]")
left.set_ylabel("friction coefficient")
right.semilogx(holds, peaks, "o", label="simulated peak - level before the hold")
grid = np.logspace(0, 3, 20)
right.semilogx(
    grid,
    np.polyval(np.polyfit(np.log(holds), peaks, 1), np.log(grid)),
    ls="--",
    label=f"slope {slope:.4f} per e-fold (B = m sigma_s / p = {shs_b:.4f})",
)
right.set_xlabel("hold time [s]")
right.set_ylabel("reload peak [friction coefficient]")
right.legend()
fig.savefig("figures/slide_hold_slide.png", dpi=120)
