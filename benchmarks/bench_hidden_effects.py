"""The hidden-effect acceptance matrix (issue 15): every effect each kind of data can
show, ``PER_EFFECT`` cases each, and effect-free cases, diagnosed on 2 processes
(``tests/hidden_matrix.py``: cases, the expected-answer rule, rates and bounds).

Run: ``python benchmarks/bench_hidden_effects.py [PER_EFFECT [NONE_PER_KIND [KIND ...]]]
[--closure=CLOSURE] [--effects=E1,E2] [--resume]`` (8, 8, every kind and the diagnosis's
default closure ``aging`` by default; ``renewal``, ``auto`` or ``best`` for the time-series
base's others; ``--effects``: only those rows, ``none`` for the effect-free one, each case
the same as in the full matrix). Writes ``benchmarks/results_hidden_effects.json`` (with
KINDs: ``results_hidden_effects_<KIND>...json``, with another closure
``..._<CLOSURE>.json``, with effects ``..._<E1>_<E2>.json``) after every case,
``complete`` false until the matrix is done (a stopped run still leaves a stratified
prefix; ``--resume`` keeps the cases such a file holds and runs the rest), and prints the
markdown confusion matrix. A case that raises is recorded with verdict ``error: ...`` (a
wrong answer) instead of stopping the matrix. KIND ``engine_time_series`` (not among the
defaults) runs the records the nanoblock engine makes (``tests/engine_synthetic.py``).
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict
from pathlib import Path

from host import describe

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nanoblock.diagnosis.core import DEFAULT_CLOSURE  # noqa: E402
from tests.hidden_matrix import (  # noqa: E402
    ALL_EFFECTS,
    KINDS,
    VISIBLE_CHI2,
    cases,
    markdown,
    run_case,
    summary,
)


def main() -> None:
    per_effect = int(sys.argv[1]) if len(sys.argv) > 1 else 8
    none_per_kind = int(sys.argv[2]) if len(sys.argv) > 2 else per_effect
    options = [arg for arg in sys.argv[3:] if arg.startswith("--")]
    kinds = [arg for arg in sys.argv[3:] if arg not in options]
    if unknown := sorted(set(kinds) - set(ALL_EFFECTS)):
        sys.exit(f"kind {unknown[0]!r} is not one of {', '.join(ALL_EFFECTS)}")
    closures = [arg.removeprefix("--closure=") for arg in options if arg.startswith("--closure=")]
    closure = closures[-1] if closures else DEFAULT_CLOSURE
    matrix = cases(per_effect, none_per_kind, tuple(kinds) or KINDS)
    chosen = [arg.removeprefix("--effects=") for arg in options if arg.startswith("--effects=")]
    effects = chosen[-1].split(",") if chosen else []
    known = {"none"}.union(*(ALL_EFFECTS[kind] for kind in (kinds or KINDS)))
    if unknown := sorted(set(effects) - known):
        sys.exit(f"effect {unknown[0]!r} is not one of {', '.join(sorted(known))}")
    if effects:  # a row of the matrix (its cases as in the full one: each has its own stream)
        matrix = [case for case in matrix if case.effect in effects]
    suffix = ([] if closure == DEFAULT_CLOSURE else [closure]) + effects
    out = ROOT / "benchmarks" / "_".join(["results_hidden_effects", *kinds, *suffix])
    started = time.perf_counter()
    header = {
        "machine": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "load_average_at_start": os.getloadavg(),
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "cases_per_effect": per_effect,
        "none_per_kind": none_per_kind,
        "visible_chi2": VISIBLE_CHI2,
        "closure": closure,
        "effects": effects or "all",
        "planned_cases": len(matrix),
        "host": describe(),
    }
    results, earlier = _resumed(out.with_suffix(".json"), header, "--resume" in options)
    if earlier:
        header = {**header, "date": earlier["date"], "resumed": earlier["resumed"]}
        started -= earlier["wall_seconds"]
    done = {(r["kind"], r["effect"], r["index"]) for r in results}
    todo = [case for case in matrix if (case.kind, case.effect, case.index) not in done]
    report = {}
    with ProcessPoolExecutor(2) as pool:
        futures = {pool.submit(run_case, case, closure): case for case in todo}
        for future in as_completed(futures):
            try:
                result = future.result()
            except Exception as error:  # recorded as a wrong answer: the matrix goes on
                case = futures[future]
                result = {**asdict(case), "expected": "?", "chi2": None,
                          "verdict": f"error: {type(error).__name__}: {error}"[:300],
                          "cpu_seconds": float("nan")}  # fmt: skip
            results.append(result)
            print(
                f"{result['kind']:15s} {result['effect']:22s} #{result['index']} expected "
                f"{result['expected']:22s} -> {result['verdict']:22s} "
                f"{result['cpu_seconds']:6.1f} s",
                flush=True,
            )
            report = {
                **header,
                "complete": len(results) == len(matrix),
                "wall_seconds": time.perf_counter() - started,
                "load_average_now": os.getloadavg(),
                **summary(results),
                "cases": results,
            }
            out.with_suffix(".json").write_text(json.dumps(report, indent=1) + "\n")
    if report:
        print(markdown(report["confusion"]))


def _resumed(path: Path, header: dict, resume: bool) -> tuple[list[dict], dict]:
    """With ``--resume``: the cases an earlier, stopped run of the same matrix (same
    planned cases, none_per_kind, visible_chi2, closure and effects) wrote to ``path``, and
    that run's date, wall seconds and the dates it was resumed at (this one appended); else
    nothing."""
    if not resume or not path.exists():
        return [], {}
    stored = json.loads(path.read_text())
    same = ("planned_cases", "none_per_kind", "visible_chi2", "closure", "effects")
    defaults = {"closure": "aging", "effects": "all"}  # files written before these keys
    if any(stored.get(key, defaults.get(key)) != header[key] for key in same):
        sys.exit(f"{path}: --resume needs the same matrix ({', '.join(same)})")
    resumed = [*stored.get("resumed", []), header["date"]]
    return stored["cases"], {**stored, "resumed": resumed}


if __name__ == "__main__":
    main()
