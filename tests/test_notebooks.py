"""Every analysis notebook (jupytext .py) runs end to end at a reduced size."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "analysis").glob("*.py"))


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
    assert any((tmp_path / "figures").glob("*.png"))


def test_there_are_notebooks() -> None:
    assert NOTEBOOKS
