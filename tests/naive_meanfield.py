"""A naive pure-NumPy reference of the mean-field nanoblock model (001/Eqs. 23-27), and of
its back-jump extension (physics.md section 5).

Fixed time step, one coin flip per block per step with probability 1 - exp(-dt / tau):
the textbook way, which the event-driven kernel must agree with statistically.
"""

from __future__ import annotations

import numpy as np


def simulate_mean_field(
    x: np.ndarray,
    velocity: float,
    rho_max: float,
    omega_a: float,
    u: float,
    duration: float,
    dt: float,
    rng: np.random.Generator,
    sample_every: int,
) -> tuple[np.ndarray, int]:
    """Advance reduced stresses ``x`` (in place) and return sampled mean stresses, events."""
    x_step = velocity / rho_max * dt
    samples = []
    events = 0
    for step in range(round(duration / dt)):
        x += x_step
        probability = -np.expm1(-omega_a * np.exp(-u * (1.0 - x * x)) * dt)
        fire = (rng.random(x.size) < probability) | (x >= 1.0)
        x[fire] = 0.0
        events += int(fire.sum())
        if step % sample_every == 0:
            samples.append(x.mean())
    return np.array(samples), events


def simulate_lattice(
    x: np.ndarray,
    velocity: float,
    rho_max: float,
    omega_a: float,
    u: float,
    u_elastic: float,
    duration: float,
    dt: float,
    rng: np.random.Generator,
    sample_every: int,
) -> tuple[np.ndarray, int]:
    """The same with back jumps on the periodic characteristic (Persson's barrier): a block
    at x > 0 hops to x - 1 at omega_a exp(-u (1 - x^2)), one at x < 0 hops to x + 1 at
    omega_a exp(-u (1 - (x + 1)^2) - u_el (x + 1/2)) (detailed balance), and |x| >= 1
    hops at once. Advances ``x`` in place; returns sampled mean stresses and hops."""
    x_step = velocity / rho_max * dt
    samples = []
    events = 0
    for step in range(round(duration / dt)):
        x += x_step
        upper = np.where(x > 0.0, x, x + 1.0)  # stress of the upper branch at this phase
        barrier = u * (1.0 - upper * upper) + np.where(x > 0.0, 0.0, u_elastic * (upper - 0.5))
        probability = -np.expm1(-omega_a * np.exp(-barrier) * dt)
        hop = (rng.random(x.size) < probability) | (np.abs(x) >= 1.0)
        x[hop] -= np.sign(x[hop])
        events += int(hop.sum())
        if step % sample_every == 0:
            samples.append(x.mean())
    return np.array(samples), events
