"""MkDocs hook: every analysis notebook (``analysis/*.py``, jupytext) becomes a page.

Each notebook is executed at reduced scale while the site is built and rendered to
Markdown as ``notebooks/<name>.md`` (its figures as ``notebooks/<name>_files/*.png``), so
the pages show what the notebooks compute now, not what they computed when a figure was
last committed. ``mkdocs.yml``'s nav lists the pages; a notebook without a nav entry, or a
nav entry without a notebook, fails the strict build.

Environment:

- ``NANOBLOCK_NOTEBOOK_SCALE`` (default ``0.05``, what ``.ci/run`` sets): the fraction of
  full size every notebook runs at, as in ``tests/test_notebooks.py``;
- ``NANOBLOCK_DOCS_EXECUTE=0``: render every notebook unexecuted (a quick build while
  writing pages);
- ``NANOBLOCK_SHARED_DATA``: the laboratory records ``rsf_real_data.py`` reads (default,
  as in the notebook, ``shared/data`` beside the repository). When they are absent the
  notebook is rendered unexecuted with a note saying so; the build still passes.

Notebooks run two at a time (the machine's two cores), each in its own kernel and its own
scratch directory (they write ``figures/*.png`` in the working directory). A notebook
that raises fails the build, naming the notebook and the cell. Under ``mkdocs serve`` a
notebook is executed again only when its text, the scale or the data change.
"""

from __future__ import annotations

import asyncio
import hashlib
import logging
import os
import tempfile
from pathlib import Path

import jupytext
import nbformat
from jupyter_client.manager import AsyncKernelManager
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError
from nbconvert import MarkdownExporter

ROOT = Path(__file__).resolve().parents[2]
ANALYSIS = ROOT / "analysis"
PAGES = "notebooks"
"""Folder of the generated pages inside the site."""
NEEDS_DATA = "NANOBLOCK_SHARED_DATA"
"""Notebooks that read the laboratory records mention this environment variable."""
DEFAULT_SCALE = "0.05"
PARALLEL = 2
TIMEOUT = 900
"""Seconds one cell may take (the slowest notebook takes ~90 s in all at scale 0.05)."""

log = logging.getLogger("mkdocs.hooks.notebooks")
_rendered: dict[str, tuple[str, dict[str, bytes]]] = {}
"""Rendered pages by notebook text, scale and data (``mkdocs serve`` rebuilds)."""


def notebooks() -> list[Path]:
    """The analysis notebooks, by name."""
    return sorted(ANALYSIS.glob("*.py"))


def _data_dir() -> Path:
    return Path(os.environ.get(NEEDS_DATA, str(ROOT.parent / "shared" / "data")))


def _note(path: Path, scale: str, executed: bool, reason: str = "") -> str:
    run = f"`python analysis/{path.name}`"
    if executed:
        return (
            f'!!! note "Executed at reduced scale"\n'
            f"    This page was executed while the site was built, with "
            f"`NANOBLOCK_NOTEBOOK_SCALE={scale}`: noisier and coarser than the full run "
            f"({run}, scale 1).\n"
        )
    return f'!!! warning "Not executed"\n    {reason} Run it with {run}.\n'


def _with_note(markdown: str, note: str) -> str:
    """The note placed right below the page's first ``# `` title."""
    lines = markdown.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("# "):
            return "\n".join([*lines[: i + 1], "", note, *lines[i + 1 :]]) + "\n"
    return note + "\n" + markdown


async def _execute(notebook: nbformat.NotebookNode, env: dict[str, str], name: str) -> None:
    with tempfile.TemporaryDirectory(prefix=f"nb-{name}-") as work:
        kernel = AsyncKernelManager(kernel_name="python3", transport="ipc")
        kernel.connection_file = str(Path(work) / "kernel.json")  # ipc sockets beside it
        client = NotebookClient(
            notebook, km=kernel, timeout=TIMEOUT, resources={"metadata": {"path": work}}
        )
        try:
            await client.async_execute(env=env)
        finally:  # a kernel manager given to the client is ours to stop
            if kernel.has_kernel:
                await kernel.shutdown_kernel(now=True)


def _render(path: Path, notebook: nbformat.NotebookNode, note: str) -> tuple[str, dict]:
    exporter = MarkdownExporter()
    body, resources = exporter.from_notebook_node(
        notebook, resources={"output_files_dir": f"{path.stem}_files"}
    )
    return _with_note(body, note), resources.get("outputs", {})


async def _run_all(jobs: list[tuple[Path, nbformat.NotebookNode, dict[str, str]]]) -> None:
    slots = asyncio.Semaphore(PARALLEL)

    async def one(path: Path, notebook: nbformat.NotebookNode, env: dict[str, str]) -> None:
        async with slots:
            log.info("executing analysis/%s", path.name)
            try:
                await _execute(notebook, env, path.stem)
            except CellExecutionError as error:
                raise PluginError(f"analysis/{path.name} failed while building:\n{error}") from None

    await asyncio.gather(*(one(*job) for job in jobs))


def _key(path: Path, scale: str, execute: bool, data: bool) -> str:
    text = path.read_bytes() + f"{scale}|{execute}|{data}".encode()
    return hashlib.sha256(text).hexdigest()


def on_files(files: Files, config, **kwargs: object) -> Files:
    scale = os.environ.get("NANOBLOCK_NOTEBOOK_SCALE", DEFAULT_SCALE)
    execute = os.environ.get("NANOBLOCK_DOCS_EXECUTE", "1") != "0"
    data = _data_dir()
    has_data = data.is_dir() and any(data.glob("*.csv"))
    env = {**os.environ, "NANOBLOCK_NOTEBOOK_SCALE": scale}
    env.pop("MPLBACKEND", None)  # the kernel's inline backend captures the figures
    quiet = "ignore:IProgress not found"  # tqdm.auto's warning without ipywidgets
    env["PYTHONWARNINGS"] = ",".join(filter(None, [env.get("PYTHONWARNINGS"), quiet]))
    if has_data:
        env[NEEDS_DATA] = str(data)

    pending, keys, fresh = [], {}, {}
    for path in notebooks():
        needs_data = NEEDS_DATA in path.read_text()
        runs = execute and (has_data or not needs_data)
        keys[path] = _key(path, scale, runs, has_data)
        if keys[path] in _rendered:
            continue
        notebook = jupytext.read(path)
        if runs:
            pending.append((path, notebook, env))
            fresh[path] = (notebook, _note(path, scale, True))
        elif not execute:
            reason = "`NANOBLOCK_DOCS_EXECUTE=0` was set for this build."
            fresh[path] = (notebook, _note(path, scale, False, reason))
        else:
            reason = (
                f"It reads the laboratory records (`{NEEDS_DATA}`), absent where the site "
                "was built."
            )
            fresh[path] = (notebook, _note(path, scale, False, reason))
    if pending:
        asyncio.run(_run_all(pending))
    for path, (notebook, note) in fresh.items():
        _rendered[keys[path]] = _render(path, notebook, note)
    for path in notebooks():
        markdown, outputs = _rendered[keys[path]]
        files.append(File.generated(config, f"{PAGES}/{path.stem}.md", content=markdown))
        for name, content in outputs.items():
            files.append(File.generated(config, f"{PAGES}/{name}", content=content))
    return files
