"""Scenario validation: bad input is refused with the key and the allowed range."""

from __future__ import annotations

import math

import pytest
from typer.testing import CliRunner

from nanoblock.cli import app, default_scenario
from nanoblock.params import Scenario, ScenarioError, from_mapping, load_scenario
from tests.conftest import REFERENCE, merged


def refused(changes: dict) -> str:
    with pytest.raises(ScenarioError) as error:
        from_mapping(merged(REFERENCE, changes))
    return str(error.value)


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"joint": {"block_size": -1e-9}}, ["joint.block_size", "allowed range (0"]),
        ({"joint": {"threshold_stress": 0.0}}, ["joint.threshold_stress", "allowed range (0"]),
        ({"joint": {"temperature": math.nan}}, ["temperature", "NaN"]),
        ({"joint": {"shear_modulus": math.inf}}, ["joint.shear_modulus", "finite"]),
        ({"joint": {"barrier": "cubic"}}, ["joint.barrier", "persson", "spinodal"]),
        ({"joint": {"k2": -1.0}}, ["joint.k2", "allowed range [0"]),
        ({"joint": {"colour": "red"}}, ["unknown key 'joint.colour'"]),
        ({"tribology": {}}, ["unknown key 'tribology'"]),
        ({"interface": {"n_contacts": 0}}, ["interface.n_contacts", "allowed range [1"]),
        ({"interface": {"memory_length": -1.0}}, ["interface.memory_length", "allowed range (0"]),
        (
            {"loading": {"stiffness": 1e5, "steps": [{"velocity": 1e-6}]}},
            ["loading.steps.0", "'duration' (s) or 'displacement' (m)"],
        ),
        ({"loading": {"stiffness": 1e5, "steps": []}}, ["loading.steps", "at least 1"]),
        (
            {"loading": {"stiffness": 1e5, "steps": [{"hold": 1.0, "velocity": 1e-6}]}},
            ["loading.steps.0", "a hold step takes only 'hold'"],
        ),
        ({"run": {"record_every": 0.0}}, ["run.record_every", "allowed range (0"]),
        ({"run": {"initial_state": "hot"}}, ["run.initial_state", "unloaded", "steady"]),
    ],
)
def test_bad_input_names_key_and_range(changes: dict, expected: list[str]) -> None:
    message = refused(changes)
    for fragment in expected:
        assert fragment in message, message


def test_defaults_resolve_to_the_papers_estimates() -> None:
    joint = from_mapping(merged(REFERENCE, {"joint": {"k2": None, "slip": "chain"}})).joint
    b, e_j = 2.75e-9, 1e9
    assert joint.k1 == pytest.approx(e_j * b) and joint.k2 == pytest.approx(e_j * b)
    assert joint.block_mass == pytest.approx(1e3 * b**3)
    assert joint.damping == pytest.approx(2 * math.sqrt(3 * e_j * b / joint.block_mass))
    assert joint.u == pytest.approx(50.21, abs=0.01)  # physics.md section 4: u = 50
    assert joint.rho_max == pytest.approx(2.75e-10)


def test_resolved_json_round_trips_with_infinities() -> None:
    scenario = from_mapping(REFERENCE)
    text = scenario.resolved_json()
    assert "Infinity" in text
    assert Scenario.from_json(text) == scenario


def test_default_scenario_file_is_valid() -> None:
    scenario = load_scenario(default_scenario())
    assert scenario.run.seed is not None
    assert scenario.total_time > 0


def test_cli_refuses_bad_scenario_with_exit_code_2(tmp_path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(default_scenario().read_text().replace("n_contacts = 400", "n_contacts = 0"))
    result = CliRunner().invoke(app, ["run", str(bad), "--out", str(tmp_path / "x.zarr")])
    assert result.exit_code == 2
    assert "interface.n_contacts" in result.output
    assert not (tmp_path / "x.zarr").exists()


def test_missing_file_is_a_clear_error(tmp_path) -> None:
    with pytest.raises(ScenarioError, match="not found"):
        load_scenario(tmp_path / "nope.toml")
