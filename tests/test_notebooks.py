"""Every analysis notebook (jupytext .py) runs end to end at a reduced size and writes the
figures docs/make_figures.py copies from it."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "analysis").glob("*.py"))


def _figures_made_by(notebook: Path) -> set[str]:
    """The PNGs docs/make_figures.py copies from this notebook's run."""
    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "docs" / "make_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return {
        f"{name}.png" for name, source in module.NOTEBOOK_FIGURES.items() if source == notebook.name
    }


SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
NEEDS_SHARED = "NANOBLOCK_SHARED_DATA"
"""Notebooks that read the laboratory data mention this environment variable."""


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[path.stem for path in NOTEBOOKS])
def test_notebook_runs(notebook: Path, tmp_path) -> None:
    if NEEDS_SHARED in notebook.read_text() and not SHARED_DATA.is_dir():
        pytest.skip(f"{notebook.name} reads the laboratory data in {SHARED_DATA}, absent here")
    env = {
        **os.environ,
        "NANOBLOCK_NOTEBOOK_SCALE": "0.05",
        "MPLBACKEND": "Agg",
        NEEDS_SHARED: str(SHARED_DATA),  # not where an installed nanoblock happens to live
    }
    subprocess.run(
        [sys.executable, str(notebook)],
        cwd=tmp_path,
        env=env,
        check=True,
        capture_output=True,
        timeout=600,
    )
    made = {path.name for path in (tmp_path / "figures").glob("*.png")}
    assert made
    assert _figures_made_by(notebook) <= made, "a figure docs/make_figures.py copies is missing"


def test_there_are_notebooks() -> None:
    assert NOTEBOOKS
