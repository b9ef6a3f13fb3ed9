"""The README and the documentation show only commands that run and figures that exist.

Every fenced ``bash`` block of README.md and of the documentation pages (in the order of
``mkdocs.yml``'s nav) is split into commands and each command is run in one scratch
directory, in document order, at reduced scale:

- ``nanoblock run`` and ``nanoblock sweep``: the scenario file (the built-in quick start
  when none is given) is replaced by a copy with ``REDUCED_CONTACTS`` contacts;
- ``nanoblock diagnose``: with ``--no-simulate --workers 1`` (the simulation check is
  tested in tests/test_diagnosis.py);
- ``nanoblock fit`` / ``diagnose`` of ``step.csv``: a synthetic laboratory velocity step
  made by the naive reference integrator (tests/rsf_synthetic.py);
- a command on a running Dask scheduler (``--scheduler``) cannot run here: it is checked
  as a valid invocation, every option it uses being one that ``--help`` lists;
- ``python docs/make_figures.py``: its arguments are parsed; the quick-start figure is
  made at reduced scale by ``test_figures_script_makes_the_quickstart_figure``;
- ``python analysis/NAME.py``: the notebook must exist (tests/test_notebooks.py runs
  every notebook at scale 0.05; the docs build executes each for its page,
  docs/hooks/notebooks.py);
- ``cp scenarios/...``: copies the repository file;
- not run: ``pip install`` (this test runs in the installed environment),
  ``python -m pytest`` (the suite itself) and ``dask scheduler`` / ``dask worker``
  (long-lived services).

A command of any other kind fails the test, so a new kind must be added here. Fenced
``toml`` blocks with a ``title="NAME"`` are written to NAME first, and fenced ``python``
blocks are executed in the same directory, in order.
"""

from __future__ import annotations

import importlib.util
import json
import re
import shlex
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from nanoblock.cli import app, default_scenario
from nanoblock.toml_writer import scenario_toml
from tests.rsf_synthetic import record, write_csv

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
REDUCED_CONTACTS = 4
"""Contacts of every simulated scenario in this test (the quick start has 400)."""

FENCE = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```", re.MULTILINE | re.DOTALL)
IMAGE = re.compile(r"!\[[^\]]*\]\(([^)\s]+)\)|<img\b[^>]*\bsrc=\"([^\"]+)\"")
NOTEBOOK_PAGES = "notebooks/"
"""Nav entries under this folder are generated from ``analysis/*.py`` by
docs/hooks/notebooks.py while the site is built (no file on disk)."""
SKIPPED = ("pip install", "python -m pytest", "dask scheduler", "dask worker")


def _nav() -> list[str]:
    """Every page of the site in nav order, as written in mkdocs.yml."""
    config = (ROOT / "mkdocs.yml").read_text()
    nav = yaml.safe_load(re.sub(r"!!python\S*", "", config))["nav"]

    def walk(entries: list) -> list[str]:
        found = []
        for entry in entries:
            for value in entry.values():
                found += walk(value) if isinstance(value, list) else [value]
        return found

    return walk(nav)


NAV = _nav()
PAGES = [README, *(DOCS / page for page in NAV if not page.startswith(NOTEBOOK_PAGES))]
"""README.md, then every page of the site written by hand, in nav order."""


def _blocks(page: Path) -> list[tuple[str, str, str]]:
    """(language, info string, body) of each fenced block of a page."""
    return [match.groups() for match in FENCE.finditer(page.read_text())]


def _commands(body: str) -> list[str]:
    """Shell commands of a bash block: continuations joined, comments and ``&`` dropped,
    ``a && b`` split."""
    commands = []
    for line in body.replace("\\\n", " ").splitlines():
        line = re.sub(r"\s+#.*$", "", line).strip().removesuffix("&").strip()
        if line and not line.startswith("#"):
            commands += [part.strip() for part in line.split("&&")]
    return commands


def _reduced(scenario: Path, work: Path) -> Path:
    """A copy of a scenario file with REDUCED_CONTACTS contacts."""
    from nanoblock.coarse.runs import varied
    from nanoblock.params import load_scenario

    small = varied(load_scenario(scenario), {"interface.n_contacts": REDUCED_CONTACTS})
    target = work / f"reduced_{scenario.name}"
    target.write_text(scenario_toml(small))
    return target


def _help_lists_options(args: list[str]) -> None:
    """``nanoblock SUB --help`` lists every option ``args`` use."""
    result = CliRunner().invoke(app, [args[0], "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    for option in (arg.split("=")[0] for arg in args if arg.startswith("--")):
        assert option in result.output, f"nanoblock {args[0]} has no option {option}"


def _nanoblock(args: list[str], work: Path) -> None:
    if "--scheduler" in args:
        _help_lists_options(args)
        return
    command, rest = args[0], args[1:]
    if command in ("run", "sweep"):
        given = rest[0] if rest and not rest[0].startswith("-") else None
        source = default_scenario() if given is None else work / given
        if given is not None and not source.exists():
            source = ROOT / given
        assert source.exists(), f"scenario {given} not found"
        reduced = str(_reduced(source, work))
        rest = [reduced, *rest[1:]] if given is not None else [reduced, *rest]
        rest.append("--quiet")
    if command == "diagnose":
        rest += ["--no-simulate", "--workers", "1", "--no-progress"]
    result = CliRunner().invoke(app, [command, *rest], catch_exceptions=False)
    assert result.exit_code == 0, f"nanoblock {' '.join(args)}:\n{result.output}"


def _make_figures_parser():
    spec = importlib.util.spec_from_file_location("make_figures", DOCS / "make_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _run(command: str, work: Path) -> None:
    if command.startswith(SKIPPED):
        return
    words = shlex.split(command)
    if words[0] == "nanoblock":
        _nanoblock(words[1:], work)
    elif words[0] == "cp":
        shutil.copyfile(ROOT / words[1], work / words[2])
    elif words[:2] == ["python", "docs/make_figures.py"]:
        _make_figures_parser().parser().parse_args(words[2:])
    elif words[0] == "python" and words[1].startswith("analysis/"):
        assert (ROOT / words[1]).is_file(), words[1]
    else:
        raise AssertionError(f"tests/test_docs.py does not know how to check: {command}")


@pytest.fixture(scope="module")
def step_csv(tmp_path_factory) -> Path:
    """A laboratory-like velocity step (aging law, 1 -> 10 um/s) as ``step.csv``."""
    params = {"mu0": 0.6, "a": 0.01, "b": 0.012, "dc": 1e-5, "v0": 1e-6}
    rng = np.random.default_rng(2026)
    data = record("aging", params, "velocity_step", 1e4, rng, n_samples=600)
    path = tmp_path_factory.mktemp("data") / "step.csv"
    return write_csv(data, path, {"stiffness_per_load": 1e4})


def test_readme_is_short_and_self_contained() -> None:
    text = README.read_text()
    assert len(text.splitlines()) < 150
    for page in PAGES:
        assert "../shared" not in page.read_text(), page
    for cited in ("Proc. Natl. Acad. Sci. USA", "10.1073/pnas.0806174105", "Phys. Rev. B"):
        assert cited in text
    assert "10.1103/PhysRevB.60.3928" in text


def test_readme_test_command_is_what_ci_runs() -> None:
    ci = (ROOT / ".ci" / "run").read_text()
    assert 'pip install -e ".[test]" && python -m pytest -n 2' in README.read_text()
    assert 'python3 -m pip install -q -e ".[test]" && python3 -m pytest -n 2' in ci
    assert "mkdocs build --strict" in ci


def test_every_command_shown_runs_at_reduced_scale(tmp_path, monkeypatch, step_csv) -> None:
    shutil.copyfile(step_csv, tmp_path / "step.csv")
    monkeypatch.chdir(tmp_path)
    done: set[str] = set()
    for page in PAGES:
        for language, info, body in _blocks(page):
            if language == "toml" and "title=" in info:
                name = re.search(r'title="([^"]+)"', info).group(1)
                tomllib.loads(body)
                (tmp_path / name).write_text(body)
            elif language == "bash":
                for command in _commands(body):
                    if command not in done:
                        _run(command, tmp_path)
                        done.add(command)
            elif language == "python":
                exec(compile(body, f"{page.name} python block", "exec"), {})
    assert "nanoblock run --out quickstart.zarr" in done


def _referenced_figures() -> dict[Path, list[str]]:
    """Every image the README and the pages show -> the pages that show it."""
    shown: dict[Path, list[str]] = {}
    for page in PAGES:
        for match in IMAGE.finditer(page.read_text()):
            target = match.group(1) or match.group(2)
            shown.setdefault((page.parent / target).resolve(), []).append(page.name)
    return shown


def test_every_figure_referenced_exists_and_is_made_by_the_figures_script() -> None:
    """Each image shown is a file of docs/figures that docs/make_figures.py makes: the
    quick-start figure by its own function (run by the next test), every other by the
    notebook it names, whose source saves exactly that file (tests/test_notebooks.py
    checks the run writes it). Every PNG in docs/figures is one of them."""
    module = _make_figures_parser()
    shown = _referenced_figures()
    assert len(shown) >= 10, "the image pattern no longer finds the figures"
    for path, pages in shown.items():
        assert path.is_file(), f"{pages}: {path} missing"
        assert path.parent == DOCS / "figures", f"{pages}: {path} not in docs/figures"
        assert path.stem in module.FIGURES, f"{path.name} is not made by docs/make_figures.py"
        if path.stem == "quickstart":
            continue
        notebook = ROOT / "analysis" / module.NOTEBOOK_FIGURES[path.stem]
        saved = re.findall(r"savefig\(\s*[\"']figures/([\w-]+)\.png", notebook.read_text())
        assert path.stem in saved, f"analysis/{notebook.name} does not save {path.name}"
    for png in (DOCS / "figures").glob("*.png"):
        assert png.stem in module.FIGURES, f"docs/figures/{png.name} is made by nothing"


def test_every_notebook_has_its_page() -> None:
    """The nav lists one generated page per analysis notebook (the strict build fails on
    a generated page outside the nav, and on a nav entry nothing generates)."""
    hook = (DOCS / "hooks" / "notebooks.py").read_text()
    assert f'PAGES = "{NOTEBOOK_PAGES.rstrip("/")}"' in hook
    assert "docs/hooks/notebooks.py" in (ROOT / "mkdocs.yml").read_text()
    generated = sorted(page for page in NAV if page.startswith(NOTEBOOK_PAGES))
    notebooks = sorted((ROOT / "analysis").glob("*.py"))
    assert generated == sorted(f"{NOTEBOOK_PAGES}{path.stem}.md" for path in notebooks)
    for path in notebooks:
        assert "../shared" not in path.read_text(), path.name


def test_figures_script_makes_the_quickstart_figure(tmp_path) -> None:
    module = _make_figures_parser()
    module.main(["--only", "quickstart", "--scale", "0.01", "--out", str(tmp_path)])
    assert (tmp_path / "quickstart.png").stat().st_size > 10_000
    numbers = json.loads((tmp_path / "quickstart.json").read_text())
    assert numbers["n_contacts"] == REDUCED_CONTACTS
    assert numbers["mu_ss_1um_s"] > numbers["mu_ss_10um_s"]  # velocity weakening


def test_readme_laboratory_verdicts_are_those_the_benchmark_wrote() -> None:
    """Every verdict and forecast gain in the README's laboratory table is the one
    ``benchmarks/bench_diagnosis.py`` wrote to results_diagnosis.json, in its order (the
    gain of the best extension, in brackets, where the verdict is ``unexplained``)."""
    results = json.loads((ROOT / "benchmarks" / "results_diagnosis.json").read_text())
    rows = [v for k, v in results["results"].items() if k != "synthetic_5000"]
    section = README.read_text().split("## On laboratory records")[1].split("\n## ")[0]
    shown = re.findall(r"^\| [^|]+ \| `([a-z_]+)` \| ([^|]+) \|", section, flags=re.MULTILINE)
    assert [cause for cause, _ in shown] == [row["cause"] for row in rows]
    for (_, gain), row in zip(shown, rows, strict=True):
        if row["cause"] == "unstable_sliding":
            assert gain.strip() == "-"
            continue
        assert f"{row['gain']['heldout_error_ratio']:.2f}" in gain, (gain, row["cause"])


def test_readme_hidden_effect_matrix_is_the_one_the_benchmark_wrote() -> None:
    """The README's time-series confusion matrix and its count of right verdicts are those
    ``benchmarks/bench_hidden_effects.py 8 8 time_series`` wrote, and its counts for
    ``--closure=auto`` and ``--closure=best`` those of ``..._auto.json`` and
    ``..._best.json`` (a stratified prefix is quoted beside the default's count on the
    same cases), and its counts on the engine-made records those of
    ``results_hidden_effects_engine_time_series[_best].json``, and its effect-free rerun
    that of ``..._auto_none.json``."""
    from tests.hidden_matrix import markdown

    path = ROOT / "benchmarks" / "results_hidden_effects_time_series.json"
    results = json.loads(path.read_text())
    section = README.read_text().split("## Hidden effects")[1].split("\n## ")[0]
    assert results["complete"] and markdown(results["confusion"]) in section
    right, words = results["all"], " ".join(section.split())
    assert f"{right['right']} of {right['cases']} right" in words
    assert f"lower bound {right['lower_bound']:.2f}" in words
    for closure in ("auto", "best"):
        other = json.loads(path.with_name(f"{path.stem}_{closure}.json").read_text())
        right, free = other["all"], other["none_expected"]
        assert other["closure"] == closure
        quoted = words.split(f"--closure {closure}")[1]
        assert f"{right['right']} of {right['cases']} right (lower bound" in quoted
        assert (
            f"{right['lower_bound']:.2f}), effect-free {free['right']} of {free['cases']}" in quoted
        )
        if other["complete"]:
            assert f"on all {right['cases']} cases" in quoted
            continue
        assert f"the first {right['cases']} cases" in quoted
        same = {(case["effect"], case["index"]) for case in other["cases"]}
        default = [c for c in results["cases"] if (c["effect"], c["index"]) in same]
        hits = sum(c["verdict"] == c["expected"] for c in default)
        assert f"(the default: {hits} of {len(default)})" in quoted
    engine = [
        json.loads(
            path.with_name(f"results_hidden_effects_engine_time_series{suffix}.json").read_text()
        )["all"]
        for suffix in ("", "_best")
    ]
    quoted = words.split("engine_time_series`):")[1]
    assert quoted.startswith(f" {engine[0]['right']} of {engine[0]['cases']} right,")
    assert f"`--closure best` {engine[1]['right']} of {engine[1]['cases']}" in quoted
    free = json.loads(path.with_name(f"{path.stem}_auto_none.json").read_text())["none_expected"]
    assert (
        f"calls {free['right']} of {free['cases']} fresh effect-free draws `none` (lower bound "
        f"{free['lower_bound']:.2f}" in words
    )


def test_readme_quick_start_times_are_those_the_benchmark_wrote() -> None:
    """The first-run, compile and warm-run seconds the README quotes are those
    ``benchmarks/bench_quickstart.py`` wrote to results_quickstart.json, rounded."""
    results = json.loads((ROOT / "benchmarks" / "results_quickstart.json").read_text())
    section = README.read_text().split("## Quick start")[1].split("\n## ")[0]
    quoted = [int(n) for n in re.findall(r"(\d+) s\b", section)]
    expected = [results["cold"]["wall"], results["compile"], results["warm"]["wall"]]
    assert quoted == [round(value) for value in expected]


def test_fitting_guide_renewal_numbers_are_those_the_benchmark_wrote() -> None:
    """The fitting guide's aging-closure paragraph quotes the largest RMS reductions of
    `renewal` and `aging2` over `aging`, the range of D / D_c and the fits' CPU seconds
    (also the cost ratio the law table and the README quote) that
    ``benchmarks/bench_renewal_lab.py`` wrote to results_renewal_lab.json."""
    results = json.loads((ROOT / "benchmarks" / "results_renewal_lab.json").read_text())
    fits = {(f["record"], f["law"]): f for f in results["fits"]}
    records = sorted({record for record, _ in fits})

    def gain(record: str, name: str) -> float:
        return 1.0 - fits[record, name]["rms"] / fits[record, "aging"]["rms"]

    ratios = [fits[r, "renewal"]["dc"] / fits[r, "aging"]["dc"] for r in records]
    text = " ".join((ROOT / "docs" / "guide" / "fitting.md").read_text().split())
    paragraph = text.split("**Aging law or renewal population on laboratory gouge.**")[1]
    paragraph = paragraph.split("**")[0] if "**" in paragraph else paragraph[:1500]
    assert f"by 0-{round(100 * max(gain(r, 'renewal') for r in records))} %" in paragraph
    assert f"by up to {round(100 * max(gain(r, 'aging2') for r in records))} %" in paragraph
    assert f"{min(ratios):.1f}-{max(ratios):.1f} times" in paragraph
    seconds = {
        name: [fits[r, name]["cpu_seconds"] for r in records] for name in ("renewal", "aging")
    }
    quoted = [f"{min(seconds[name]):.1f}-{max(seconds[name]):.1f}" for name in seconds]
    assert "costs {} CPU seconds against {} for the aging law".format(*quoted) in paragraph
    costs = [r / g for r, g in zip(seconds["renewal"], seconds["aging"], strict=True)]
    ratio = f"{round(min(costs))}-{round(max(costs))}x the"
    assert f"{ratio} aging law's cost" in " ".join(
        (ROOT / "docs" / "guide" / "fitting.md").read_text().split()
    )
    assert f"{ratio} cost" in " ".join((ROOT / "README.md").read_text().split())
