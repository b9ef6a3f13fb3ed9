"""The activation volume from the temperature dependence of the direct effect.

A joint without ageing or renewal (m = 0, D0 = inf) slides steadily at V1 and, in a second
run, at V2; the direct effect is A = (mu_ss(V2) - mu_ss(V1)) / ln(V2 / V1) and 001/Eq. 19
turns it into v_act(T) = k_B T / (p A). That falls short of Persson's
v_act = 8 b^3 sigma_bar / E_J (001/Eq. 33) at finite T: the blocks fire at x_f sigma_a <
sigma_a, where the barrier's stress derivative is x_f times smaller, so
v_act(T) ~ v_act [x_f(T) - 1/(2u x_f)] with 1 - x_f^2 and 1/u both proportional to T
(physics.md section 1). Hence v_act(T) is close to linear in T and its T -> 0 intercept is
v_act (001/Eq. 30 becomes exact as T -> 0).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from nanoblock.barriers import BOLTZMANN
from nanoblock.coarse.estimates import estimate, fit_line, rate_coefficient, stack
from nanoblock.coarse.runs import run_scenarios, varied
from nanoblock.coarse.steady import SETTLE, steady_curve, steady_scenarios
from nanoblock.engine import mean_field_joint
from nanoblock.params import Scenario

__all__ = ["activation_volume", "direct_effect", "measure_activation"]

STEADY_TRAVEL = 300.0
"""Slip of each steady run of :func:`measure_activation`, in rho~_max."""


def direct_effect(runs: Sequence[xr.Dataset], settle: float = SETTLE) -> xr.Dataset:
    """A = (mu_ss(V2) - mu_ss(V1)) / ln(V2 / V1) from two steady runs of a joint whose
    contacts neither age nor renew (then the whole rate dependence is the direct effect,
    001/Eq. 12), each level after ``settle`` rho~_max."""
    curve = steady_curve(runs, settle).sortby("velocity")
    mu, err, v = curve.mu_ss.values, curve.mu_ss_stderr.values, curve.velocity.values
    temperature = Scenario.from_json(runs[0].attrs["scenario"]).joint.temperature
    return xr.Dataset(
        {
            **rate_coefficient(
                (mu[0], err[0]), (mu[-1], err[-1]), v[-1] / v[0], "direct effect A (001/Eq. 12)"
            ),
            **estimate("mu_ss", mu[0], err[0], "1", "steady friction at the lower velocity"),
            "temperature": xr.Variable(
                (), temperature, {"units": "K", "long_name": "temperature T"}
            ),
        },
        attrs={"v1": v[0], "v2": v[-1]},
    )


def activation_volume(
    effects: xr.Dataset, hardness: float, v_act: float | None = None
) -> xr.Dataset:
    """v_act(T) = k_B T / (p A(T)) (001/Eq. 19) at each temperature of ``effects`` (the
    :func:`direct_effect` results over a temperature dim), and its T -> 0 intercept from a
    weighted straight line in T (the activation volume of 001/Eq. 33).

    ``hardness`` p [Pa]; ``v_act`` [m^3], if given, is stored as ``v_act_theory``.
    """
    temperature = effects.temperature.values
    a, a_err = effects.a.values, effects.a_stderr.values
    per_t = BOLTZMANN * temperature / (hardness * a)
    per_t_err = per_t * a_err / a
    line = fit_line(temperature, per_t, per_t_err)
    dims = effects.a.dims
    data_vars = {
        **estimate("v_act_t", per_t, per_t_err, "m3", "k_B T / (p A) at T (001/Eq. 19)", dims),
        **estimate(
            "v_act",
            line.intercept,
            line.intercept_stderr,
            "m3",
            "activation volume, T -> 0 intercept of k_B T / (p A)",
        ),
        **estimate("v_act_slope", line.slope, line.slope_stderr, "m3/K", "d v_act(T) / dT"),
    }
    if v_act is not None:
        data_vars["v_act_theory"] = xr.Variable(
            (), v_act, {"units": "m3", "long_name": "8 b^3 sigma_bar / E_J (001/Eq. 33)"}
        )
    return xr.Dataset(data_vars, effects.coords)


def measure_activation(
    base: Scenario,
    temperatures: ArrayLike,
    velocities: tuple[float, float] = (1e-6, 1e-5),
    *,
    travel: float | None = None,
    directory: str | Path | None = None,
    workers: int | None = None,
) -> xr.Dataset:
    """Steady runs of ``base`` (no ageing: m = 0, D0 = inf) at the two ``velocities``
    [m/s] and each temperature [K], each over ``travel`` [m] (default
    :data:`STEADY_TRAVEL` rho~_max); returns :func:`activation_volume` with the
    :func:`direct_effect` per temperature (dim ``joint.temperature``)."""
    temperatures = np.asarray(temperatures, dtype=float)
    travel = STEADY_TRAVEL * base.joint.rho_max if travel is None else travel
    key = "joint.temperature"
    scenarios = [
        scenario
        for t in temperatures
        for scenario in steady_scenarios(varied(base, {key: float(t)}), velocities, travel)
    ]
    runs = run_scenarios(scenarios, directory, workers=workers)
    effects = stack(
        [direct_effect(runs[2 * i : 2 * i + 2]) for i in range(temperatures.size)],
        key,
        temperatures,
    )
    joint = mean_field_joint(base)
    result = activation_volume(effects, base.interface.hardness, joint.activation_volume)
    return xr.merge([effects.drop_vars("temperature"), result])
