"""A naive pure-NumPy, event-by-event reference of the quasi-static spring-slider
(physics.md section 2) on a mean-field interface (k2 = 0, reset; 001/Eqs. 23-27), with
ageing (001/Eq. 5) and renewal, for the stepper of :mod:`nanoblock.kernels.stepper`.

The slider is rebalanced, K (X_L - X) = F, after every depinning: no prediction, no
internal step. Measured (16 seeds, the scenario of :func:`velocity_step`): a fixed-step
coin-flip variant (step rho~_max / 2000 and / 500 of load travel) converges to it linearly
in the step, the finer one within 0.1e-3 of friction coefficient. ``python -m
tests.naive_quasistatic`` writes :data:`REFERENCE_FILE` (about 5 minutes), ``python -m
tests.naive_quasistatic runaway`` :data:`RUNAWAY_FILE` (about 10 minutes).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from nanoblock.engine import initial_state, kernel_parameters, mean_field_joint, strength_classes
from nanoblock.params import Scenario
from tests.conftest import scenario

REFERENCE_FILE = Path(__file__).with_name("velocity_step_reference.json")
"""Per-seed friction of :func:`velocity_step` by :func:`simulate_events`."""

RUNAWAY_FILE = Path(__file__).with_name("runaway_reference.json")
"""Per-seed friction of :func:`runaway` by :func:`simulate_events`."""

STEP_TIME = 0.01
"""Time of the velocity step in :func:`velocity_step` [s]."""

SAMPLE_EVERY = 1e-4
"""Sample interval of :func:`velocity_step` [s]."""


def velocity_step(seed: int, step_slip: float | None = None) -> Scenario:
    """A 10x velocity step on a lab spring (K / W = 3e6 1/m, 1e-3 of the interface's
    stiffness), mean field with ageing and renewal, 200 contacts x 5 blocks: 1 um/s for
    10 ms (from the steady state), then 10 um/s for 3 ms; samples every 0.1 ms."""
    return scenario(
        interface={
            "memory_length": 2e-7,
            "aging_m": 0.05,
            "aging_time": 1e-3,
            "n_contacts": 200,
            "blocks_per_contact": 5,
        },
        loading={
            "stiffness": 3e6,
            "steps": [
                {"velocity": 1e-6, "displacement": 1e-8},
                {"velocity": 1e-5, "displacement": 3e-8},
            ],
        },
        run={"record_every": SAMPLE_EVERY, "seed": seed, "step_slip": step_slip},
    )


def runaway(seed: int, step_slip: float | None = None) -> Scenario:
    """A soft spring on a velocity-weakening interface: K / W = 4e4 1/m, below the
    critical stiffness of contacts ageing with m = 0.05 over tau_m = 0.1 ms and renewed
    over D0 = 0.5 um. Started in the steady state at 1 um/s, on most seeds the slider runs
    away within 0.1 um of load travel and slides about 3.7 um, renewing every contact
    several times, before the spring arrests it (the slip phase of stick-slip, 001/Fig.
    15). 200 one-block contacts; samples every 1 ms."""
    return scenario(
        joint={"temperature": 293.15},
        interface={
            "n_contacts": 200,
            "blocks_per_contact": 1,
            "memory_length": 0.5e-6,
            "aging_m": 0.05,
            "aging_time": 1e-4,
        },
        loading={"stiffness": 4e4, "steps": [{"velocity": 1e-6, "displacement": 1e-7}]},
        run={"seed": seed, "record_every": 1e-3, "step_slip": step_slip},
    )


def sample_times(run: Scenario) -> np.ndarray:
    """The engine's sample times of ``run`` (every record_every, and the protocol's end)."""
    total, every = run.total_time, run.run.record_every
    times = np.arange(0.0, total, every)
    return np.append(times[times < total - 1e-9 * every], total)


def simulate_events(run: Scenario, sample_times: np.ndarray) -> tuple[np.ndarray, int]:
    """The same dynamics event by event (Gillespie): between depinnings every block stays
    pinned and the slider creeps at K V_L / (K + k_int) (and yields to the contacts'
    ageing), so the escape rates change only by that creep; the waiting time to the next
    escape is Exp(sum of the rates at the last event), the block that escapes is drawn in
    proportion to its rate, and the slider jumps to the new balance (thresholds, deaths)
    at once. Exact in the limit of a soft spring (the creep's change of the rates over one
    waiting time neglected). Friction coefficient at ``sample_times`` [s] and depinnings.
    """
    params = kernel_parameters(run)
    record = params[0]
    strength = strength_classes(run)
    if strength.shape[0] != 1 or record["kappa"] != 0.0 or record["slip_chain"] != 0:
        raise ValueError("the naive reference is the mean-field reset joint, one class")
    if record["state_cutoff"] != 0.0:
        raise ValueError("the naive reference has no state cutoff")
    state = initial_state(run, params, strength)
    y, age, lifetime = state.y.copy(), state.age.copy(), state.lifetime.copy()
    slip = np.zeros_like(age)
    sigma_a, rho = strength[0]
    joint = mean_field_joint(run)
    u, omega = joint.u, joint.attempt_frequency
    spring = run.loading.stiffness
    sigma0, m, tau = record["contact_area"], record["aging_m"], record["aging_time"]
    memory = record["memory_length"]
    rng = np.random.default_rng([run.run.seed, 11])
    starts = np.concatenate(([0.0], np.cumsum([step.length for step in run.loading.steps])))
    velocities = np.array([step.load_velocity for step in run.loading.steps] + [0.0])
    loads = np.concatenate(([0.0], np.cumsum(np.diff(starts) * velocities[:-1])))

    def load_at(t: float) -> float:
        k = min(int(np.searchsorted(starts, t, side="right")) - 1, len(velocities) - 2)
        return loads[k] + velocities[k] * (t - starts[k])

    def balance(t: float) -> int:
        """Slider to K (X_L(t) - X) = F at time t, then thresholds and deaths (each followed
        by a rebalance) until nothing changes; returns the threshold depinnings."""
        nonlocal position
        fired = 0
        while True:
            area = sigma0 * (1.0 + m * np.log1p(age / tau))
            force = float(np.sum(area * sigma_a * y.mean(axis=1)))
            k_int = float(np.sum(area)) * sigma_a / rho
            dx = (spring * (load_at(t) - position) - force) / (spring + k_int)
            y[...] += dx / rho
            slip[...] += dx
            position += dx
            over = y >= 1.0
            dead = slip >= lifetime
            if not over.any() and not dead.any():
                return fired
            fired += int(over.sum())
            y[over] = 0.0
            for c in np.flatnonzero(dead):
                y[c] = 0.0
                age[c] = 0.0
                slip[c] = 0.0
                lifetime[c] = memory * rng.standard_exponential()

    area0 = sigma0 * (1.0 + m * np.log1p(age / tau))
    position = -float(np.sum(area0 * sigma_a * y.mean(axis=1))) / spring
    t = 0.0
    events = 0
    out = np.empty(len(sample_times))
    flat = y.reshape(-1)
    for i, t_sample in enumerate(sample_times):
        while True:
            rates = omega * np.exp(-u * (1.0 - flat * flat))
            total = float(rates.sum())
            wait = rng.standard_exponential() / total
            if t + wait > t_sample:
                age[...] += t_sample - t
                t = t_sample
                events += balance(t)
                break
            t += wait
            age[...] += wait
            events += balance(t)  # the creep up to the escape
            block = int(np.searchsorted(np.cumsum(rates), rng.random() * total))
            flat[min(block, flat.size - 1)] = 0.0
            events += 1 + balance(t)
        out[i] = spring * (load_at(t) - position) / run.interface.normal_force
    return out, events


def write_reference(seeds: range = range(1, 17)) -> None:
    """Friction of :func:`velocity_step` by :func:`simulate_events` for ``seeds``, from
    1 ms before the step to the end, into :data:`REFERENCE_FILE`."""
    curves = {}
    for seed in seeds:
        run = velocity_step(seed)
        times = sample_times(run)
        mu, events = simulate_events(run, times)
        keep = times >= STEP_TIME - 1e-3 - 1e-9
        curves[str(seed)] = mu[keep].tolist()
        print(seed, events, flush=True)
    first = float(times[keep][0])
    REFERENCE_FILE.write_text(json.dumps({"first_time": first, "curves": curves}) + "\n")


def write_runaway_reference(seeds: range = range(1, 13)) -> None:
    """Friction of :func:`runaway` by :func:`simulate_events` for ``seeds`` into
    :data:`RUNAWAY_FILE`."""
    curves = {}
    for seed in seeds:
        run = runaway(seed)
        mu, events = simulate_events(run, sample_times(run))
        curves[str(seed)] = mu.tolist()
        print(seed, events, flush=True)
    RUNAWAY_FILE.write_text(json.dumps({"curves": curves}) + "\n")


if __name__ == "__main__":
    write_runaway_reference() if sys.argv[1:] == ["runaway"] else write_reference()
