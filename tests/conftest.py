"""Shared scenario builders (reference joint of physics.md section 4), and a cache of
diagnosis passes for the tests that diagnose one record several ways."""

from __future__ import annotations

import copy
from typing import Any

import pytest
from dask.base import tokenize

from nanoblock.params import Scenario, from_mapping

RHO_MAX = 2.75e-10
"""rho~_max of the reference joint [m]."""

REFERENCE: dict[str, Any] = {
    "joint": {
        "block_size": 2.75e-9,
        "shear_modulus": 1.0e9,
        "threshold_stress": 1.0e8,
        "attempt_frequency": 1.0e12,
        "temperature": 300.0,
        "k2": 0.0,
        "slip": "reset",
    },
    "interface": {
        "normal_force": 1.0,
        "hardness": 1.0e8,
        "n_contacts": 40,
        "blocks_per_contact": 50,
        "memory_length": float("inf"),
        "aging_m": 0.0,
    },
    "loading": {"stiffness": float("inf"), "steps": [{"velocity": 1e-6, "displacement": 1e-8}]},
    "run": {"seed": 1, "record_every": 1e-3, "initial_state": "steady"},
}


def merged(base: dict[str, Any], changes: dict[str, Any]) -> dict[str, Any]:
    """Deep copy of ``base`` with the sections of ``changes`` updated key by key."""
    out = copy.deepcopy(base)
    for section, values in changes.items():
        if isinstance(values, dict) and isinstance(out.get(section), dict):
            out[section].update(values)
        else:
            out[section] = values
    return out


def scenario(**changes: dict[str, Any]) -> Scenario:
    """The reference mean-field scenario with some keys changed, validated."""
    return from_mapping(merged(REFERENCE, changes))


@pytest.fixture
def make_scenario():
    """Factory fixture for :func:`scenario`."""
    return scenario


_PASSES: dict[tuple, Any] = {}
"""Closure passes of the diagnoses this process has run under ``cached_passes``."""


@pytest.fixture
def cached_passes(monkeypatch) -> None:
    """Diagnoses in the test reuse the closure passes (fits, scores, ranking: everything
    before the simulation check) that this process computed for the same record, closure
    and catalogue, as deep copies (a diagnosis sets the cause a pass accepts), so tests
    that diagnose one record with and without the check, or in one and both closures,
    fit it once. Tests sharing a record share an ``xdist_group``. Not for tests of the
    passes' own paths (workers, progress)."""
    from nanoblock.diagnosis import core

    real = core._closure_pass

    def cached(measurement, testable, closure, runner):
        key = (tokenize(measurement.data), closure, tuple(sorted(testable)))
        if key not in _PASSES:
            _PASSES[key] = real(measurement, testable, closure, runner)
        return copy.deepcopy(_PASSES[key])

    monkeypatch.setattr(core, "_closure_pass", cached)
