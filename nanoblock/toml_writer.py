"""Writing a scenario back as a TOML file that ``nanoblock run`` reads (the inverse of
:func:`nanoblock.params.read_toml` for the scenario layout: tables of scalars and arrays
of tables; unset (None) keys are left out, infinities written as ``inf``)."""

from __future__ import annotations

import json
import math
from typing import Any

from nanoblock.params import Scenario

__all__ = ["scenario_toml"]


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    return json.dumps(str(value))


def scenario_toml(scenario: Scenario, comment: str = "") -> str:
    """The scenario as TOML text, with ``comment`` lines on top."""
    data = json.loads(scenario.resolved_json())
    lines = [f"# {line}" for line in comment.splitlines()]
    for section, values in data.items():
        scalars = {k: v for k, v in values.items() if v is not None and not isinstance(v, list)}
        lines += ["", f"[{section}]", *(f"{k} = {_value(v)}" for k, v in scalars.items())]
        for key, items in values.items():
            if isinstance(items, list):
                for item in items:
                    lines += ["", f"[[{section}.{key}]]"]
                    lines += [f"{k} = {_value(v)}" for k, v in item.items() if v is not None]
    return "\n".join(lines) + "\n"
