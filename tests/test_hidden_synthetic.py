"""The renewal spring-slider of the hidden-effect matrix against its closed-form steady
states, and the matrix's layout (every case of a kind shows the same columns)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import exp1

from nanoblock.rsf.laws import law
from nanoblock.rsf.slider import LoadPointHistory, solve_slider
from tests.diagnosis_synthetic import NOISE
from tests.hidden_matrix import VISIBLE_CHI2, Case, cases
from tests.hidden_synthetic import (
    BASE_TAU,
    MAKERS,
    V1,
    _protocol,
    _sample_times,
    draw_interface,
    stated_stiffness,
)
from tests.renewal_synthetic import Renewal, renewal_slider

STEADY_ATOL = 1e-5
"""Renewal slider after 30 D at a new velocity vs its closed-form steady friction: the
transient left after 30 D (e^-30) is nil; what the 0.02 D cohorts and the steps leave is
checked by ``test_rsf_laws.py`` against the renewal law; the noise of the matrix is 2e-4."""


def _mean_log_area(velocity: float, p: Renewal) -> float:
    """<ln(1 + phi / tau_m)> over steady ages: exponential of mean D / (V + v_theta)
    (e^x E_1(x), x = tau_m / mean), or for slip_like the fixed ln(1 + D / (V tau_m))."""
    if p.slip_like:
        return math.log1p(p.d0 / (velocity * p.tau_m))
    x = p.tau_m * (velocity + p.v_theta) / p.d0
    return math.exp(x) * exp1(x)


@pytest.mark.parametrize(
    "variant",
    [{}, {"v_theta": 3e-6}, {"tau_m": 4.0}, {"slip_like": True}],
    ids=["base", "cutoff", "saturation", "slip_like"],
)
def test_renewal_slider_reaches_its_closed_form_steady_state(variant: dict) -> None:
    """mu after an up-step v1 -> 10 v1 held for 30 D: a ln 10 + b (S(10 v1) - S(v1))."""
    p = Renewal(**{"mu0": 0.6, "a": 0.01, "b": 0.012, "d0": 2e-5, "tau_m": 0.02, **variant})
    v1 = 1e-6
    segments = [(v1, 2 * p.d0 / v1), (10 * v1, 30 * p.d0 / (10 * v1))]
    _, mu = renewal_slider(p, segments, stiffness=2.0 / p.d0)
    closed = p.a * math.log(10.0) + p.b * (_mean_log_area(10 * v1, p) - _mean_log_area(v1, p))
    assert mu[-1] - p.mu0 == pytest.approx(closed, abs=STEADY_ATOL)


def test_every_case_of_a_kind_has_the_same_layout() -> None:
    """The columns, runs, loads and temperatures carry no answer: the same for each effect
    (first case of each effect; the time series also share their sample count)."""
    layouts: dict[str, set] = {}
    for case in cases(1, 1):
        if case.kind == "time_series" and case.effect not in ("none", "load_dependent_dc"):
            continue  # a renewal record takes seconds; two of them suffice
        data, _ = MAKERS[case.kind](case.effect, case.rng())
        layout = (
            tuple(sorted(data.data_vars)),
            tuple(np.unique(data["normal_force"].values)) if "normal_force" in data else (),
            tuple(np.unique(data["temperature"].values)) if "temperature" in data else (),
            data.sizes["sample"],
            tuple(sorted(data.attrs)),
        )
        layouts.setdefault(case.kind, set()).add(layout)
    assert all(len(found) == 1 for found in layouts.values()), layouts


def test_engine_records_share_the_renewal_generators_layout(monkeypatch) -> None:
    """An engine-made record (a second population switched on; 50 contacts, the layout
    not the statistics under test) has the columns, loads, sample count and attributes of
    the renewal generator's time series, so its layout carries no answer."""
    from tests import engine_synthetic
    from tests.hidden_matrix import ENGINE_KIND

    monkeypatch.setattr(engine_synthetic, "N_CONTACTS", 50)

    def layout(data) -> tuple:
        forces = tuple(np.unique(data["normal_force"].values))
        return (
            tuple(sorted(data.data_vars)),
            forces,
            data.sizes["sample"],
            tuple(sorted(data.attrs)),
        )

    renewal, _ = MAKERS["time_series"]("none", Case("time_series", "none", 0).rng())
    case = Case(ENGINE_KIND, "two_state_variable", 0)
    data, clean = engine_synthetic.engine_time_series(case.effect, case.rng())
    assert clean is None and layout(data) == layout(renewal)
    assert np.all(np.isfinite(data["mu"].values))


GENERATOR_DRAWS = 12
"""Effect-free time-series draws of the matrix checked against the renewal law."""


@pytest.mark.slow
def test_effect_free_records_are_in_the_renewal_laws_family() -> None:
    """An effect-free record must be one the base model describes: on the matrix's first
    effect-free draws (protocol, stated stiffness, true a, b, D, mu0) the generator and
    :mod:`nanoblock`'s renewal law (its own code path, LSODA) differ by chi^2 per run,
    at the record's sample times and the smallest noise the matrix draws, below the
    expected-answer rule's visibility, VISIBLE_CHI2 = 25 (measured on draws 0-35: at
    most 17.4, median 0.8; with the predictor-corrector step but the stiffness without the
    hold's healing, 13 of 36 were above 1000, up to 2e5)."""
    worst = []
    for index in range(GENERATOR_DRAWS):
        a, b, d0, mu0 = draw_interface(Case("time_series", "none", index).rng())
        stiffness = stated_stiffness(a, b, d0)
        segments = _protocol(d0, V1)
        times = _sample_times(segments)
        p = Renewal(mu0=mu0, a=a, b=b, d0=d0, tau_m=BASE_TAU * d0 / V1)
        t, mu = renewal_slider(p, segments, stiffness)
        own = {"mu0": mu0, "a": a, "b": b, "dc": d0, "v0": p.v0}
        history = LoadPointHistory.from_segments(segments)
        model = solve_slider(law("renewal"), own, history, times, stiffness).friction
        chi2 = np.sum((np.interp(times, t, mu) - model) ** 2) / (0.7 * NOISE["time_series"]) ** 2
        worst.append(float(chi2))
    assert max(worst) < VISIBLE_CHI2, worst
