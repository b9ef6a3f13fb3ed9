"""The ``nanoblock`` command line (typer)."""

from __future__ import annotations

import time
from importlib.resources import files
from pathlib import Path
from typing import Annotated

import typer

from nanoblock.params import ScenarioError, load_scenario

app = typer.Typer(
    help="nanoblock: Persson's nanoblock model of dry friction, from blocks to rate-and-state.",
    no_args_is_help=True,
    add_completion=False,
)

QUICKSTART = "quickstart.toml"


def default_scenario() -> Path:
    """The built-in default scenario (``scenarios/quickstart.toml``)."""
    return Path(str(files("nanoblock.scenarios").joinpath(QUICKSTART)))


@app.command()
def run(
    scenario: Annotated[
        Path | None,
        typer.Argument(help="scenario TOML file (default: the built-in quickstart)"),
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="zarr store to write")] = Path(
        "nanoblock-run.zarr"
    ),
    seed: Annotated[int | None, typer.Option(help="random seed (overrides run.seed)")] = None,
    figure: Annotated[
        Path | None, typer.Option(help="PNG of friction vs slip (default: STORE with .png)")
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")] = False,
) -> None:
    """Run a scenario, stream it into a zarr store, draw friction vs slip, print a summary.

    Running the same command again on an unfinished store resumes it from its last
    checkpoint.
    """
    from nanoblock.engine import simulate
    from nanoblock.figures import plot_friction
    from nanoblock.summary import summarize

    path = scenario or default_scenario()
    try:
        parsed = load_scenario(path)
        started = time.perf_counter()
        result = simulate(parsed, out, seed=seed, progress=not quiet)
    except ScenarioError as error:
        typer.echo(f"error: {error}", err=True)
        raise typer.Exit(code=2) from None
    wall = time.perf_counter() - started
    png = plot_friction(result, figure or out.with_suffix(".png"), title=path.stem)
    typer.echo(summarize(result, wall))
    typer.echo(f"store                 {out}")
    typer.echo(f"figure                {png}")


@app.command()
def version() -> None:
    """Print the package version."""
    import nanoblock

    typer.echo(nanoblock.__version__)
