"""Scenario validation: bad input is refused with the key and the allowed range."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
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


def test_a_scenario_saved_with_a_byte_order_mark_reads_as_without(tmp_path) -> None:
    """Some editors start UTF-8 files with a BOM: it was 'not valid TOML (Invalid
    statement (at line 1, column 1))'."""
    marked = tmp_path / "bom.toml"
    marked.write_bytes(b"\xef\xbb\xbf" + default_scenario().read_bytes())
    assert load_scenario(marked) == load_scenario(default_scenario())


def test_missing_file_is_a_clear_error(tmp_path) -> None:
    with pytest.raises(ScenarioError, match="not found"):
        load_scenario(tmp_path / "nope.toml")


OPTIONAL = {
    "joint": ["k1", "block_mass", "damping", "barrier", "threshold_spread", "strength_classes"],
    "interface": ["aging_time", "state_cutoff_velocity", "reference_force"],
    "run": ["step_slip", "snapshot_every"],
}
LEAVES = sorted(
    {
        (section, key)
        for section, values in REFERENCE.items()
        if section != "loading"
        for key in values
    }
    | {(section, key) for section, keys in OPTIONAL.items() for key in keys}
    | {("loading", "stiffness"), ("joint", "colour"), ("run", "speed")}
    | {("steps", key) for key in ("velocity", "displacement", "duration", "hold")}
)
KEY_NAMES = {key for _, key in LEAVES} | {"steps", "velocity", "number of blocks"}
ANY_VALUE = st.one_of(
    st.floats(),
    st.sampled_from([5e-324, 1e-300, 1e-20, 1e20, 1e300, 1.7e308]),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.booleans(),
    st.text(max_size=4),
    st.none(),
    st.lists(st.integers(), max_size=2),
)
WRONG_TYPE = st.one_of(st.booleans(), st.text(max_size=4), st.lists(st.floats(), max_size=2))
NUMERIC = [
    leaf
    for leaf in LEAVES
    if isinstance(REFERENCE.get(leaf[0], {}).get(leaf[1]), float | int)
    and not isinstance(REFERENCE[leaf[0]][leaf[1]], bool)
]


def _mutated(changes: list[tuple[tuple[str, str], object]]) -> dict:
    data = merged(REFERENCE, {})
    for (section, key), value in changes:
        target = data["loading"]["steps"][0] if section == "steps" else data[section]
        target[key] = value
    return data


@settings(max_examples=300, deadline=None, database=None)
@given(st.lists(st.tuples(st.sampled_from(LEAVES), ANY_VALUE), min_size=1, max_size=3))
@example([(("joint", "block_size"), 1e-300)])  # division by zero in the derived springs
@example([(("joint", "block_size"), 1e300)])  # overflow
@example([(("joint", "threshold_stress"), 5e-324)])  # rho~_max = 0
@example([(("joint", "temperature"), True)])
def test_any_scenario_mapping_is_accepted_or_refused_by_name(changes) -> None:
    """Whatever the values (a step's too), the reader returns a scenario that reproduces
    itself, or a ScenarioError naming a key (never another exception)."""
    try:
        scenario = from_mapping(_mutated(changes))
    except ScenarioError as error:
        message = str(error)
        assert any(name in message for name in KEY_NAMES), message
        return
    assert Scenario.from_json(scenario.resolved_json()) == scenario


@settings(max_examples=200, deadline=None, database=None)
@given(st.sampled_from(NUMERIC), WRONG_TYPE)
def test_a_number_of_the_wrong_type_is_refused_by_its_key(leaf, value) -> None:
    """Booleans, strings and lists are never read as numbers."""
    with pytest.raises(ScenarioError, match=rf"{leaf[0]}\.{leaf[1]}"):
        from_mapping(_mutated([(leaf, value)]))


@settings(max_examples=200, deadline=None, database=None)
@given(st.sampled_from(NUMERIC), st.floats(max_value=0.0) | st.just(math.nan))
def test_a_non_positive_or_nan_number_is_refused_by_its_key(leaf, value) -> None:
    if leaf[1] in {"k2", "aging_m", "seed"} and value == 0.0:
        return  # zero is allowed there
    with pytest.raises(ScenarioError, match=leaf[1]):
        from_mapping(_mutated([(leaf, value)]))


def test_a_strength_spread_is_refused_where_a_class_never_depins_and_the_limit_is_exact() -> None:
    """threshold_spread = 2 (the reference only said >= 0) ended in an unexpected ValueError
    of the rate tables: the strongest of 8 lognormal classes has u = 2068, beyond U_MAX.
    The refusal names the largest spread allowed, and that spread is one that runs."""
    import re

    message = refused({"joint": {"threshold_spread": 2.0}})
    assert "strongest has u = U_a / k_B T = 2068 > 700" in message, message
    assert "allowed for this joint: threshold_spread <= 1.06" in message  # scenarios/README
    limit = float(re.search(r"threshold_spread <= ([0-9.e+-]+)", message).group(1))
    assert 1.0 < limit < 2.0
    from_mapping(merged(REFERENCE, {"joint": {"threshold_spread": limit * 0.999}}))
    assert "threshold_spread <=" in refused({"joint": {"threshold_spread": limit * 1.01}})


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        # the contact area W / p overflowed: every stored friction value was NaN, exit 0
        ({"interface": {"hardness": 1e-300}}, "interface.hardness = 1e-300 Pa"),
        ({"interface": {"normal_force": 1e300}}, "interface.normal_force = 1e+300 N"),
    ],
)
def test_an_interface_whose_forces_leave_double_precision_cannot_run(changes, expected) -> None:
    from nanoblock.params import check_feasible

    with pytest.raises(ScenarioError, match="leave double precision") as error:
        check_feasible(from_mapping(merged(REFERENCE, changes)), "s.toml")
    assert str(error.value).startswith("s.toml: cannot run: ") and expected in str(error.value)


def test_an_overflowing_load_dependent_memory_length_is_refused_by_its_keys() -> None:
    changes = {"memory_length_exponent": 1e3, "reference_force": 1e-3}  # was OverflowError
    message = refused({"interface": changes})
    assert "memory_length_exponent = 1000.0" in message and "double precision" in message


def test_a_kernel_division_by_zero_is_a_named_refusal_not_an_unexpected_error() -> None:
    """joint.k1 = 1e-300 makes rho~_max 7.6e290 m and a kernel divide by zero: a
    ScenarioError naming the scales (the CLI printed 'unexpected ZeroDivisionError').
    :func:`simulate` now refuses it before it runs (its interface is 1.5e298 times softer
    than the drive); stepped without that check, the kernel's error is still named."""
    from nanoblock.engine import Run, simulate

    loading = {"stiffness": 2e7, "steps": [{"velocity": 1e-6, "displacement": 1e-8}]}
    run = from_mapping(merged(REFERENCE, {"joint": {"k1": 1e-300}, "loading": loading}))
    with pytest.raises(ScenarioError, match=r"loading.stiffness = 20000000.0 N/m is 1.51e\+298"):
        simulate(run)
    stepped = Run(run)
    with pytest.raises(ScenarioError, match=r"ZeroDivisionError.*joint.k1 = 1e-300"):
        while not stepped.done:
            stepped.step_to_next_sample()


def test_a_drive_a_million_times_stiffer_than_the_interface_is_refused_as_rigid() -> None:
    """K / k_int > 1e6 (k_int = W sigma_a / (p rho~_max), 3.6e10 N/m for the reference
    interface): refused naming the stiffness, k_int and the rigid drive; the hold of such a
    run sat at 0 % for minutes (K = 1e300 N/m, or W = 1e-300 N, or p = 1e300 Pa). 1e6
    times is allowed, as is the rigid drive itself."""
    from nanoblock.params import check_feasible, requirements

    k_int = requirements(from_mapping(REFERENCE)).interface_stiffness
    assert k_int == pytest.approx(
        REFERENCE["interface"]["normal_force"]
        / REFERENCE["interface"]["hardness"]
        * from_mapping(REFERENCE).joint.threshold_stress
        / from_mapping(REFERENCE).joint.rho_max,
        rel=1e-12,
    )
    for stiffness in (1e6 * k_int, float("inf")):
        check_feasible(from_mapping(merged(REFERENCE, {"loading": {"stiffness": stiffness}})))
    for change in (
        {"loading": {"stiffness": 1e300}},
        {"loading": {"stiffness": 1.01e6 * k_int}},
        {"interface": {"normal_force": 1e-300}, "loading": {"stiffness": 2e7}},
        {"interface": {"hardness": 1e300}, "loading": {"stiffness": 2e7}},
    ):
        with pytest.raises(
            ScenarioError, match=r"loading.stiffness = .* use loading.stiffness = inf"
        ):
            check_feasible(from_mapping(merged(REFERENCE, change)))


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"run": {"step_slip": 1e-20}}, "run.step_slip = 1e-20 m takes ~"),
        ({"interface": {"memory_length": 1e-20}}, "interface.memory_length = 1e-20 m renews"),
        (
            {"interface": {"second_memory_length": 1e-20, "second_population": 0.5}},
            "interface.second_memory_length = 1e-20 m renews",
        ),
    ],
)
def test_steps_or_renewals_no_run_would_finish_are_refused_by_key(change, key) -> None:
    """Internal steps visit every block and a renewal draws a contact's blocks afresh: in
    the quick start a step of 1e-15 m or a memory length of 1e-20 m sat at 0 % of the work
    (the estimate counted depinnings only). Refused naming the key and what it would take."""
    from nanoblock.params import MAX_BLOCK_UPDATES, check_feasible, requirements

    scenario = from_mapping(merged(REFERENCE, change))
    assert requirements(scenario).block_updates > MAX_BLOCK_UPDATES
    with pytest.raises(ScenarioError, match=re.escape(key)):
        check_feasible(scenario)


def test_the_work_estimate_counts_the_weakest_strength_class() -> None:
    """threshold_spread = 1 passed the estimate made with the mean barrier (u = 50) and sat
    at 0 % of the work: its weakest class (sigma_a x 0.13, u = 0.8) hops 5e11 times a
    second per block. The estimate averages the classes' rates; a spread of 0.3 (weakest
    u = 17) still runs."""
    from nanoblock.params import check_feasible, requirements

    with pytest.raises(ScenarioError, match=r"weakest strength class 0\.799"):
        check_feasible(from_mapping(merged(REFERENCE, {"joint": {"threshold_spread": 1.0}})))
    mild = from_mapping(merged(REFERENCE, {"joint": {"threshold_spread": 0.3}}))
    check_feasible(mild)
    u = mild.joint.class_barriers()
    expected = mild.joint.attempt_frequency * np.mean(np.exp(-u))
    assert requirements(mild).thermal_rate == pytest.approx(expected, rel=1e-12)
    assert u[0] == pytest.approx(mild.joint.u * mild.joint.class_factors()[0] ** 2, rel=1e-12)
