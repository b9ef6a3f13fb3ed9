"""MkDocs hook: quote benchmark results from ``benchmarks/results_*.json`` in the pages.

In a page, ``{{ bench("results_core.json", "key", ".3g") }}`` becomes that value of the
JSON file, formatted with the format spec; nested keys are joined by ``::``
(``"results::synthetic_5000::seconds"``) and a list index is an integer key. A scale may
follow the format: ``{{ bench("results_sweep.json", "key", ".1f", 100) }}`` quotes the
value times 100 (percentages). A missing file or key fails the build, so the pages never
quote a number the benchmarks no longer write.
"""

from __future__ import annotations

import json
import re
from functools import cache
from pathlib import Path

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks"
PATTERN = re.compile(
    r"\{\{\s*bench\(\s*\"([^\"]+)\"\s*,\s*\"([^\"]+)\"\s*,\s*\"([^\"]*)\"\s*"
    r"(?:,\s*([0-9.eE+-]+)\s*)?\)\s*\}\}"
)


@cache
def _results(name: str) -> object:
    return json.loads((RESULTS / name).read_text())


def quote(name: str, key: str, spec: str, scale: str | None = None) -> str:
    """The value of ``key`` in ``benchmarks/<name>``, formatted."""
    value = _results(name)
    for part in key.split("::"):
        value = value[int(part)] if isinstance(value, list) else value[part]
    if scale is not None:
        value = float(value) * float(scale)
    text = format(value, spec)
    if spec.endswith(("e", "g")):
        text = re.sub(r"e\+?(-?)0*(\d)", r"e\1\2", text)  # 2.37e+07 -> 2.37e7
    return text


def on_page_markdown(markdown: str, **kwargs: object) -> str:
    return PATTERN.sub(lambda match: quote(*match.groups()), markdown)
