"""Record layout of the scalar parameters every kernel reads (one structured array).

Per strength class k (physics.md section 5, strength_heterogeneity) the kernels also read
``strength[k] = (sigma_a, rho~_max)`` [Pa, m] and the hazard table ``tables[k]``;
contact c belongs to class c mod K (K = 1 without a threshold spread).
"""

from __future__ import annotations

import numpy as np

PARAMS = np.dtype(
    [
        ("omega_a", np.float64),  # attempt frequency [1/s]
        ("kappa", np.float64),  # k2 / k1
        ("slip_chain", np.int64),  # 1: Eq. 21 dynamics, 0: reset to zero force
        ("hop_period", np.float64),  # 1: back jumps, hops of one period x -> x - sign(x); 0: off
        ("eta_free", np.float64),  # landing overshoot of an isolated block, no neighbours
        ("eta_end", np.float64),  # the same for a chain-end block (one neighbour)
        ("eta_interior", np.float64),  # the same for an interior block (two neighbours)
        ("omega1_sq", np.float64),  # k1 / m_b [1/s^2]
        ("damping", np.float64),  # gamma [1/s]
        ("memory_length", np.float64),  # D0 [m] (inf: no renewal)
        ("memory_length2", np.float64),  # D0_2 [m] of the second population
        ("second_from", np.int64),  # first contact of the second population (N_c: none)
        ("aging_m", np.float64),  # m of 001/Eq. 5
        ("aging_time", np.float64),  # tau_m [s]
        ("state_cutoff", np.float64),  # v_theta [m/s] of 000/Eq. 7 (0: the clock always runs)
        ("contact_area", np.float64),  # Sigma_0 of one contact at birth [m^2]
        ("stiffness", np.float64),  # drive spring K [N/m] (inf: rigid drive)
        ("step_slip", np.float64),  # drift (rigid: whole) slider slip per internal step [m]
        ("force_step", np.float64),  # max spring force change per step / F (transients)
    ]
)
"""Fields of the parameter record, with units."""

SLIDER = np.dtype(
    [
        ("time", np.float64),  # t [s]
        ("position", np.float64),  # X, balanced (pending jump included) [m]
        ("load_point", np.float64),  # X_L(t) [m]
        ("pending", np.float64),  # elastic jump still to apply to the blocks [m]
        ("drift", np.float64),  # predicted slider velocity beyond the pinned response [m/s]
        ("smooth_drift", np.float64),  # drift averaged over recent depinnings [m/s]
        ("smooth_noise", np.float64),  # standard deviation of smooth_drift [m/s]
        ("last_dt", np.float64),  # previous internal step [s]
        ("force", np.float64),  # interface force F at the last step [N]
        ("stiffness", np.float64),  # interface stiffness dF/dX at the last step [N/m]
        ("steps", np.int64),  # internal steps taken
    ]
)
"""Slider and load-point state carried between kernel calls."""
