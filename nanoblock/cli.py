"""The ``nanoblock`` command line (typer).

Exit codes: 0 success, 1 a sweep finished with failed tasks, 2 bad input (the message
names the key, value, path or address).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from importlib.resources import files
from pathlib import Path
from typing import Annotated, NoReturn

import typer

from nanoblock.params import Scenario, ScenarioError, load_scenario, resolve_seed

app = typer.Typer(
    help="nanoblock: Persson's nanoblock model of dry friction, from blocks to rate-and-state.",
    no_args_is_help=True,
    add_completion=False,
)

QUICKSTART = "quickstart.toml"

Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")]


def default_scenario() -> Path:
    """The built-in default scenario (``scenarios/quickstart.toml``)."""
    return Path(str(files("nanoblock.scenarios").joinpath(QUICKSTART)))


def _fail(message: object) -> NoReturn:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code=2)


@contextmanager
def _bad_input(*errors: type[Exception]) -> Iterator[None]:
    """Report a refused scenario (or one of ``errors``) and exit with code 2."""
    try:
        yield
    except (ScenarioError, *errors) as error:
        _fail(error)


def _require_store(path: Path) -> None:
    from nanoblock.store import RunStore

    if not RunStore(path).exists():
        _fail(f"{path}: not a nanoblock run store (no zarr.json)")


def _announce_resume(out: Path, scenario: Scenario) -> None:
    """Say so when ``out`` holds an unfinished run of ``scenario`` (it will be resumed)."""
    from nanoblock.store import RunStore

    attrs = RunStore(out).attrs if RunStore(out).exists() else {}
    if attrs.get("scenario") == scenario.resolved_json() and not attrs["complete"]:
        at = attrs.get("checkpoint", {"samples": 0, "simulated_time": 0.0})
        typer.echo(f"resuming {out} from sample {at['samples']} (t = {at['simulated_time']} s)")


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
    flush_seconds: Annotated[
        float | None,
        typer.Option(min=0.0, help="wall time between flushes and checkpoints [s] (default 5)"),
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Run a scenario, stream it into a zarr store, draw friction vs slip, print a summary.

    Running the same command again on an unfinished store resumes it from its last
    checkpoint.
    """
    from nanoblock.engine import simulate
    from nanoblock.figures import plot_friction
    from nanoblock.summary import summarize

    path = scenario or default_scenario()
    with _bad_input():
        parsed = resolve_seed(load_scenario(path), seed)
        _announce_resume(out, parsed)
        started = time.perf_counter()
        result = simulate(parsed, out, progress=not quiet, flush_seconds=flush_seconds)
    wall = time.perf_counter() - started
    png = plot_friction(result, figure or out.with_suffix(".png"), title=path.stem)
    typer.echo(summarize(result, wall))
    typer.echo(f"store                 {out}")
    typer.echo(f"figure                {png}")


@app.command()
def sweep(
    scenario: Annotated[Path, typer.Argument(help="base scenario TOML file")],
    assignments: Annotated[
        list[str] | None,
        typer.Option(
            "--set",
            metavar="KEY=V1,V2,...",
            help="a swept scenario key and its values (repeatable); "
            "e.g. joint.temperature=280,300 or loading.steps.0.velocity=1e-7,1e-6",
        ),
    ] = None,
    seeds: Annotated[
        int, typer.Option(min=1, help="seeds per point: run.seed (or 0) + 0 .. N-1")
    ] = 1,
    out: Annotated[Path, typer.Option("--out", "-o", help="sweep directory")] = Path(
        "nanoblock-sweep"
    ),
    scheduler: Annotated[
        str | None,
        typer.Option(help="address of a running Dask scheduler (default: a LocalCluster)"),
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option(min=1, help="LocalCluster worker processes (default: one per CPU)"),
    ] = None,
    connect_timeout: Annotated[
        float, typer.Option(min=0.0, help="seconds to wait for --scheduler")
    ] = 10.0,
    quiet: Quiet = False,
) -> None:
    """Run the product of the --set values (and seeds) as independent tasks on Dask.

    One run store per task in OUT/tasks, a manifest OUT/sweep.json; combine them with
    nanoblock.sweep.open_sweep(OUT). Running the same command again skips finished
    tasks and resumes unfinished ones.
    """
    from nanoblock.sweep import Sweep, SweepError, describe, run_sweep

    with _bad_input(SweepError):
        spec = Sweep.from_file(scenario, assignments or [], seeds)
        report = run_sweep(
            spec,
            out,
            scheduler=scheduler,
            workers=workers,
            connect_timeout=connect_timeout,
            progress=not quiet,
        )
    failed = report.entries("failed")
    total = len(report.manifest["tasks"])
    for entry in failed:
        typer.echo(f"failed: task {describe(entry)}: {entry['error']}", err=True)
    typer.echo(
        f"sweep {out}: {total} tasks, {len(report.ran)} run now, "
        f"{total - len(report.ran)} finished before, {len(failed)} failed"
    )
    if failed:
        typer.echo("run the same command again to retry the failed tasks", err=True)
        raise typer.Exit(code=1)


@app.command()
def plot(
    store: Annotated[Path, typer.Argument(exists=True, help="run store (zarr directory)")],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="directory (default: next to STORE)")
    ] = None,
) -> None:
    """Write the standard figures of a run store as PNGs.

    Friction vs slip and time, velocities, and with block snapshots the stress histogram
    (against the mean-field Q_st where it applies) and the contact-age distribution.
    """
    from nanoblock.figures import standard_figures

    _require_store(store)
    for path in standard_figures(store, out):
        typer.echo(str(path))


@app.command()
def info(
    store: Annotated[Path, typer.Argument(exists=True, help="run store, or sweep directory")],
) -> None:
    """Print a run store's provenance and summary, or a sweep directory's task status.

    Provenance: completion, progress, seed, versions and the resolved scenario.
    """
    from nanoblock.store import RunStore
    from nanoblock.summary import provenance_text, summarize
    from nanoblock.sweep import MANIFEST, sweep_summary

    if (store / MANIFEST).exists():
        typer.echo(sweep_summary(store))
        return
    _require_store(store)
    run = RunStore(store).open()
    typer.echo(f"store                 {store}")
    typer.echo(provenance_text(run))
    if run.sizes["time"]:
        typer.echo(summarize(run))


@app.command()
def fit(
    data: Annotated[Path, typer.Argument(help="measured data: CSV, netCDF or zarr")],
    law: Annotated[str, typer.Option(help="RSF law (aging, slip, tabor, silicon, two_state)")] = (
        "aging"
    ),
    out: Annotated[Path, typer.Option("--out", "-o", help="output directory")] = Path("fit"),
    stiffness: Annotated[
        float | None,
        typer.Option(help="stiffness per normal load K/W [1/m] (default: metadata, or fit)"),
    ] = None,
    trend: Annotated[bool, typer.Option(help="fit a linear friction trend with slip")] = False,
    mcmc: Annotated[bool, typer.Option(help="sample the posterior with emcee")] = False,
    mcmc_steps: Annotated[int, typer.Option(min=10, help="MCMC steps per walker")] = 2000,
) -> None:
    """Fit a rate-and-state law to velocity steps or slide-hold-slide data.

    Writes OUT/fit.json (law, params with mu0, a, b, dc [m], stderr, rms_residual,
    n_points), OUT/report.md and OUT/fit.png (data, fit and residuals).
    """
    from nanoblock.measured import DataError, load_measurement
    from nanoblock.rsf.fit import fit_rsf
    from nanoblock.rsf.report import write_fit

    with _bad_input(DataError, ValueError):
        measurement = load_measurement(data)
        result = fit_rsf(
            measurement,
            law,
            stiffness=stiffness,
            trend=trend,
            method="mcmc" if mcmc else "lsq",
            mcmc_steps=mcmc_steps,
        )
    written = write_fit(result, measurement, out)
    for key in ("mu0", "a", "b", "dc"):
        value, error = result.contract[key], result.contract_stderr[key]
        typer.echo(f"{key:<6}{value:>12.5g}  +- {error if error is not None else 0:.2g}")
    typer.echo(f"rms residual {result.rms_residual:.3g} over {result.n_points} samples")
    for path in written.values():
        typer.echo(str(path))


@app.command()
def diagnose(
    data: Annotated[
        Path, typer.Argument(help="measured data (CSV, netCDF, zarr) or a simulator store")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="output directory")] = Path("diagnosis"),
    progress: Annotated[bool, typer.Option(help="show a progress bar")] = True,
    workers: Annotated[
        int, typer.Option(min=1, help="processes fitting the candidate models in parallel")
    ] = 1,
    simulate: Annotated[
        bool, typer.Option(help="check the verdict with the nanoblock simulator")
    ] = True,
) -> None:
    """Diagnose what the base nanoblock model gets wrong on DATA, and why.

    Fits the base model's coarse-grained surrogate and every testable catalogue
    extension (physics.md section 5), ranks them by held-out error and information
    criterion, and writes OUT/diagnosis.json (cause, ranking, base, extended, gain,
    simulation_check), OUT/report.md, OUT/fits.png and OUT/residuals.png.
    """
    from nanoblock.diagnosis import DiagnosisError, diagnose, load_for_diagnosis
    from nanoblock.diagnosis.report import write_diagnosis
    from nanoblock.measured import DataError

    with _bad_input(DiagnosisError, DataError, ValueError):
        measurement = load_for_diagnosis(data)
        result = diagnose(measurement, progress=progress, workers=workers, simulate=simulate)
    written = write_diagnosis(result, out, data.name)
    gain = result.gain()
    typer.echo(f"cause: {result.cause}")
    typer.echo(f"base rms {result.base.rms:.3g} vs noise {result.noise:.3g}")
    if gain["heldout_error_ratio"] is not None:
        typer.echo(
            f"best extension {(result.extended or result.best).id}: held-out ratio "
            f"{gain['heldout_error_ratio']:.3f}, "
            f"Delta IC {gain['delta_information_criterion']:+.1f}"
        )
    for path in written.values():
        typer.echo(str(path))


@app.command()
def version() -> None:
    """Print the package version."""
    import nanoblock

    typer.echo(nanoblock.__version__)


if __name__ == "__main__":
    app()
