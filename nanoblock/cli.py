"""The ``nanoblock`` command line (typer).

Exit codes: 0 success, 1 a sweep finished with failed tasks, 2 any failure: one message
on stderr naming the file, key, path or option, the value and what is allowed; an
unexpected error is reported in one line too (``nanoblock --debug ...`` shows its
traceback). Nothing that nanoblock did not write is deleted or overwritten: ``run --out``
is a new path, an empty directory or a store of the same scenario and seed, and a figure
replaces only a PNG that nanoblock drew of the same store.
"""

from __future__ import annotations

import gc
import importlib
import os
import sys
import tempfile
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from importlib.resources import files
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NoReturn

import typer
from typer.core import TyperGroup
from typer.exceptions import TyperException

from nanoblock.params import (
    Scenario,
    ScenarioError,
    check_feasible,
    load_scenario,
    resolve_seed,
)
from nanoblock.store import UNSTARTED, RunStore, StoreError, scenario_damage

if TYPE_CHECKING:
    import xarray as xr

DEBUG = "nanoblock.debug"
"""``typer.Context.meta`` key of the ``--debug`` flag."""

STAMP = "nanoblock-store"
"""PNG text key naming the run store a figure was drawn from (its path relative to the
figure's directory, so that the two may move together)."""


def _warning_line(message: Warning | str, category: type[Warning], *args: Any, **kw: Any) -> str:
    """A warning as the command line shows it: one line, without the source line that
    raised it (``warnings.formatwarning`` of the commands)."""
    return f"warning: {message}\n"


class _OneMessage(TyperGroup):
    """Turn an unexpected error into one line on stderr and exit code 2 (with
    ``--debug``, the traceback)."""

    def invoke(self, ctx: typer.Context) -> Any:
        warnings.formatwarning = _warning_line
        try:
            result = super().invoke(ctx)
            sys.stdout.flush()  # a closed pipe is found here, not at interpreter exit
            return result
        except (typer.Exit, typer.Abort, TyperException):  # typer reports these itself
            raise
        except BrokenPipeError:  # the reader left (``nanoblock info STORE | head``)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            raise typer.Exit(code=1) from None
        except Exception as error:
            if ctx.meta.get(DEBUG):
                raise
            _fail(
                f"unexpected {type(error).__name__}: {error} "
                "(run 'nanoblock --debug ...' for the traceback)"
            )


app = typer.Typer(
    cls=_OneMessage,
    help="nanoblock: Persson's nanoblock model of dry friction, from blocks to rate-and-state.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

QUICKSTART = "quickstart.toml"

Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")]


@app.callback()
def main(
    ctx: typer.Context,
    debug: Annotated[
        bool, typer.Option("--debug", help="show the traceback of an unexpected error")
    ] = False,
) -> None:
    """nanoblock: Persson's nanoblock model of dry friction, from blocks to rate-and-state."""
    ctx.meta[DEBUG] = debug


def default_scenario() -> Path:
    """The built-in default scenario (``scenarios/quickstart.toml``)."""
    return Path(str(files("nanoblock.scenarios").joinpath(QUICKSTART)))


def _fail(message: object) -> NoReturn:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code=2)


@contextmanager
def _imports_without_gc() -> Iterator[None]:
    """Import a command's heavy modules (Numba kernels, scipy, matplotlib) with the cyclic
    garbage collector off, then freeze what exists: otherwise it scans the growing heap
    of module objects again and again while they load (about 0.2 s of ``nanoblock run``),
    and later collections scan them too, though they live as long as the process."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


@contextmanager
def _bad_input(*errors: type[Exception], data: Path | None = None) -> Iterator[None]:
    """Report a refused scenario or store (or one of ``errors``) and exit with code 2; a
    message that does not name the ``data`` file it is about starts with it."""
    try:
        yield
    except (ScenarioError, StoreError, *errors) as error:
        named = data is None or str(data) in str(error) or data.name in str(error)
        _fail(error if named else f"{data}: {error}")


def _open_store(path: Path) -> RunStore:
    """The run store at ``path``, refused unless it is one whose metadata can be read."""
    if not path.exists():
        _fail(f"{path}: does not exist; give a run store (zarr directory)")
    store = RunStore(path)
    if not store.exists():
        if damage := store.root_damage():
            _fail(f"{path}: damaged: {damage[0]}")
        _fail(f"{path}: not a nanoblock run store (no zarr.json)")
    try:
        attrs = store.attrs
    except Exception as error:  # any unreadable root metadata
        _fail(f"{path}: zarr.json unreadable ({type(error).__name__}: {error})")
    if "scenario" not in attrs:
        _fail(f"{path}: a zarr store, but not a nanoblock run (no 'scenario' attribute)")
    if damage := scenario_damage(attrs):
        _fail(f"{path}: damaged: {damage[0]}")
    return store


def _intact(store: RunStore, checkpoint: bool = False) -> None:
    """Refuse a store with missing or unreadable chunks, naming array and sample range
    (with ``checkpoint``, those of an unfinished run's last checkpoint too)."""
    if store.unstarted():
        _fail(f"{store.path}: {UNSTARTED}")
    damage = store.damage()
    pointer = store.attrs.get("checkpoint")
    if checkpoint and pointer and not store.attrs.get("complete"):
        damage += store.checkpoint_damage(pointer["slot"])
    if damage:
        _fail(f"{store.path}: damaged: {'; '.join(damage)}")


@contextmanager
def _sweep_interrupt(out: Path) -> Iterator[None]:
    """Ctrl-C during a sweep: the cluster's shutdown is not logged (it printed scheduler
    errors, pending asyncio tasks and tracebacks of its threads); one line says how many
    tasks are done and that the same command resumes the rest (or that none is left, when
    the interrupt came as the cluster shut down after the last task), exit 130."""
    import logging
    import signal

    def interrupt(signum: int, frame: object) -> None:
        logging.disable(logging.CRITICAL)  # before the cluster starts shutting down
        sys.unraisablehook = lambda unraisable: None
        raise KeyboardInterrupt

    previous = signal.getsignal(signal.SIGINT)
    if previous is signal.default_int_handler:  # not where Ctrl-C is ignored or handled
        signal.signal(signal.SIGINT, interrupt)
    try:
        yield
    except KeyboardInterrupt:
        from nanoblock.sweep import MANIFEST, read_manifest

        if (out / MANIFEST).exists():
            tasks = read_manifest(out)["tasks"]
            done = sum(entry["status"] == "done" for entry in tasks)
            rest = "the same command resumes the rest" if done < len(tasks) else "none is left"
            typer.echo(
                f"interrupted: {done} of {len(tasks)} tasks done ({out / MANIFEST}); {rest}",
                err=True,
            )
        else:
            typer.echo("interrupted before the first task; nothing was written", err=True)
        raise typer.Exit(130) from None
    finally:
        signal.signal(signal.SIGINT, previous)


def _claim_store(out: Path, scenario: Scenario) -> None:
    """Refuse an ``--out`` that is not a new path, an empty directory or a run store of
    this scenario and seed (so nothing else can be replaced)."""
    store = RunStore(out)
    if damage := store.root_damage():
        _fail(f"{out}: damaged: {damage[0]}; nothing was written")
    if out.is_dir() and not store.exists():
        entries = sorted(entry.name for entry in out.iterdir())
        if entries:
            _fail(
                f"{out}: --out is a directory that is not a nanoblock run store (it holds "
                f"{', '.join(entries[:3])}{', ...' if len(entries) > 3 else ''}); nothing was "
                "written: it must be a new path or a store of this scenario and seed"
            )
    elif out.exists() or out.is_symlink():
        if not out.is_dir():
            _fail(f"{out}: --out is an existing file; it must be a new path or a run store")
        stored = _open_store(out).attrs
        if stored["scenario"] != scenario.resolved_json():
            _fail(
                f"{out}: holds a run of another scenario or seed (stored seed "
                f"{stored.get('seed')}, this run's {scenario.run.seed}); --out must be a "
                "new path or a store of this same scenario and seed"
            )
        if stored.get("complete"):
            _intact(store)


def _claim_file(target: Path, store: Path, option: str) -> None:
    """Refuse to write figure ``target`` over anything but a figure drawn of ``store``."""
    if target.is_dir():
        _fail(f"{target}: {option} names a directory; a PNG file path is required")
    if target.exists() and not _drawn_of(target, store):
        _fail(
            f"{target}: exists and is not a figure nanoblock drew of {store}; nothing was "
            f"written: choose another {option} or move the file"
        )


def _drawn_of(png: Path, store: Path) -> bool:
    """Whether ``png`` is a figure nanoblock drew of ``store``."""
    from PIL import Image

    try:
        with Image.open(png) as image:
            return getattr(image, "text", {}).get(STAMP) == _stamp(png, store)
    except (OSError, ValueError):
        return False


def _stamp(png: Path, store: Path) -> str:
    """The :data:`STAMP` of a figure ``png`` drawn of ``store``."""
    return os.path.relpath(store.resolve(), png.parent.resolve())


def _place_figure(rendered: Path, target: Path, store: Path) -> Path:
    """Move a PNG drawn in scratch space to ``target`` (atomically), stamped with ``store``."""
    from PIL import Image, PngImagePlugin

    info = PngImagePlugin.PngInfo()
    partial = target.with_name(f".{target.name}.partial")
    target.parent.mkdir(parents=True, exist_ok=True)
    with Image.open(rendered) as image:
        for key, value in image.text.items():
            info.add_text(key, value)
        info.add_text(STAMP, _stamp(target, store))
        image.save(partial, format="PNG", pnginfo=info)
    os.replace(partial, target)
    return target


def _output_directory(out: Path, option: str = "--out", writes: tuple[str, ...] = ()) -> None:
    """Refuse an output directory that is an existing file (or lies under one), or whose
    nearest existing directory refuses a new file, and, when
    the command ``writes`` these file names, one that holds anything else (a user's
    files are never overwritten; a previous output of the same command is)."""
    for path in (out, *out.parents):
        if path.exists():
            if not path.is_dir():
                _fail(f"{path}: {option} {out} needs a directory there; it is an existing file")
            try:  # a probe that leaves nothing behind: the work is not done for nothing
                tempfile.TemporaryFile(dir=path).close()
            except OSError as error:
                _fail(
                    f"{path}: refuses a new file ({error.strerror}); nothing was written: "
                    f"{option} must lie in a writable directory"
                )
            break
    if writes and out.is_dir():
        foreign = sorted(p.name for p in out.iterdir() if p.name not in writes)
        if foreign:
            _fail(
                f"{out}: {option} is a directory holding {', '.join(foreign[:3])}"
                + (" ..." if len(foreign) > 3 else "")
                + "; nothing was written: it must be a new path, an empty directory or a "
                f"previous output of this command ({', '.join(writes)})"
            )


def _require_module(module: str, option: str, install: str) -> None:
    """Refuse ``option`` before any work when the optional ``module`` is not installed."""
    try:
        importlib.import_module(module)
    except ImportError:
        _fail(f"{option} needs the {module} package, which is not installed: {install}")


def _announce_resume(out: Path) -> None:
    """Say so when ``out`` holds an unfinished run (it will be resumed, from the last
    intact checkpoint)."""
    store = RunStore(out)
    if not store.exists() or store.attrs.get("complete"):
        return
    last = store.attrs.get("checkpoint", {})
    checkpoint = store.read_checkpoint()
    at = checkpoint[1] if checkpoint else {"samples": 0, "simulated_time": 0.0}
    if checkpoint and at["samples"] != last["samples"]:
        typer.echo(
            f"the checkpoint at sample {last['samples']} is damaged "
            f"({'; '.join(store.checkpoint_damage(last['slot']))}): using the one before"
        )
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
    seed: Annotated[
        int | None, typer.Option(min=0, max=2**63 - 1, help="random seed (overrides run.seed)")
    ] = None,
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

    Running the same command again on an unfinished store resumes it from its last intact
    checkpoint. --out must be a new path, an empty directory or a store of the same
    scenario and seed; the figure replaces only a figure drawn of the same store.
    """
    with _imports_without_gc():
        from nanoblock.engine import simulate
        from nanoblock.figures import plot_friction
        from nanoblock.summary import summarize

    path = scenario or default_scenario()
    png = figure or out.with_suffix(".png")
    with _bad_input():
        parsed = resolve_seed(load_scenario(path), seed)
        check_feasible(parsed, str(path))
        _output_directory(out.parent)
        _output_directory(png.parent, "--figure")
        _claim_store(out, parsed)
        _claim_file(png, out, "--figure")
        _announce_resume(out)
        result = simulate(parsed, out, progress=not quiet, flush_seconds=flush_seconds, lazy=False)
    with tempfile.TemporaryDirectory() as scratch:
        drawn = plot_friction(result, Path(scratch) / png.name, title=path.stem)
        _place_figure(drawn, png, out)
    typer.echo(summarize(result))
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

    _output_directory(out)
    with _bad_input(SweepError), _sweep_interrupt(out):
        spec = Sweep.from_file(scenario, assignments or [], seeds)
        for task in spec.tasks():
            check_feasible(task.scenario, f"{scenario}, task {task.name} {task.params}")
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
    before = [e for e in report.entries("done") if e["task"] not in report.ran]
    typer.echo(
        f"sweep {out}: {total} tasks, {len(report.ran)} run now, "
        f"{len(before)} finished before, {len(failed)} failed"
    )
    if failed:
        typer.echo("run the same command again to retry the failed tasks", err=True)
        raise typer.Exit(code=1)


@app.command()
def plot(
    store: Annotated[Path, typer.Argument(help="run store (zarr directory)")],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="directory (default: next to STORE)")
    ] = None,
) -> None:
    """Write the standard figures of a run store as PNGs.

    Friction vs slip and time, velocities, and with block snapshots the stress histogram
    (against the mean-field Q_st where it applies) and the contact-age distribution.
    """
    from nanoblock.figures import standard_figures

    run = _open_store(store)
    _intact(run)
    directory = out if out is not None else store.parent
    _output_directory(directory)
    with tempfile.TemporaryDirectory() as scratch:
        drawn = standard_figures(store, scratch)
        for figure in drawn:
            _claim_file(directory / figure.name, store, "--out")
        directory.mkdir(parents=True, exist_ok=True)
        for figure in drawn:
            typer.echo(str(_place_figure(figure, directory / figure.name, store)))


@app.command()
def info(
    store: Annotated[Path, typer.Argument(help="run store, or sweep directory")],
) -> None:
    """Print a run store's provenance and summary, or a sweep directory's task status.

    Provenance: completion, progress, seed, versions and the resolved scenario; a damaged
    store (missing or unreadable chunks) is reported by array and sample range, exit 2.
    """
    import xarray as xr

    from nanoblock.summary import provenance_text, summarize
    from nanoblock.sweep import MANIFEST, SweepError, sweep_summary

    if (store / MANIFEST).exists():
        with _bad_input(SweepError):
            typer.echo(sweep_summary(store))
        return
    run = _open_store(store)
    typer.echo(f"store                 {store}")
    typer.echo(provenance_text(xr.Dataset(attrs=run.attrs)))
    if run.unstarted():
        typer.echo(UNSTARTED)
        return
    _intact(run, checkpoint=True)
    opened = run.open()
    if opened.sizes["time"]:
        typer.echo(summarize(opened))


FIT_FILES = ("fit.json", "report.md", "fit.png")
"""What ``nanoblock fit`` writes into --out."""
DIAGNOSIS_FILES = (
    "diagnosis.json", "report.md", "fits.png", "residuals.png", "base.toml", "extended.toml",
)  # fmt: skip
"""What ``nanoblock diagnose`` writes into --out."""
WINDOW = typer.Option(
    help="fit window BEFORE,AFTER: load-point travel [m] kept before and after each step "
    "(one run per step, parameters shared), e.g. 5e-5,3e-4"
)
RECIPE = typer.Option(help="xlook reduction recipe, when DATA is an xlook binary")
ROWS = typer.Option(help="xlook rows FIRST:LAST (inclusive, after the recipe)")


def _xlook(recipe: Path | None, rows: str | None) -> dict[str, Any]:
    """Keyword arguments of the readers for an xlook binary (none for other files)."""
    from nanoblock.measured import DataError
    from nanoblock.xlook import parse_rows

    if recipe is not None and not recipe.is_file():
        raise DataError(f"{recipe}: --recipe names no file; give the xlook reduction recipe")
    return {"recipe": recipe, "rows": None if rows is None else parse_rows(rows)}


def _windowed(measurement: xr.Dataset, window: str | None) -> xr.Dataset:
    """The record cut to windows around its steps when ``--window`` is given."""
    if window is None:
        return measurement
    from nanoblock.rsf.windows import parse_window, step_windows

    return step_windows(measurement, *parse_window(window))


@app.command()
def fit(
    data: Annotated[Path, typer.Argument(help="measured data: CSV, netCDF or zarr")],
    law: Annotated[
        str,
        typer.Option(help="RSF law (aging, slip, aging2, slip2, renewal, cutoff, saturation, ...)"),
    ] = "aging",
    out: Annotated[Path, typer.Option("--out", "-o", help="output directory")] = Path("fit"),
    stiffness: Annotated[
        float | None,
        typer.Option(help="stiffness per normal load K/W [1/m] (default: metadata, or fit)"),
    ] = None,
    trend: Annotated[bool, typer.Option(help="fit a linear friction trend with slip")] = False,
    fit_stiffness: Annotated[
        bool, typer.Option(help="fit K/W even where the metadata state it (from there)")
    ] = False,
    initial_state: Annotated[
        bool, typer.Option(help="fit each run's initial state and slip velocity (unsteady start)")
    ] = False,
    window: Annotated[str | None, WINDOW] = None,
    recipe: Annotated[Path | None, RECIPE] = None,
    rows: Annotated[str | None, ROWS] = None,
    mcmc: Annotated[bool, typer.Option(help="sample the posterior with emcee")] = False,
    mcmc_steps: Annotated[int, typer.Option(min=10, help="MCMC steps per walker")] = 2000,
    loss: Annotated[
        str,
        typer.Option(
            help="linear (least squares) or huber: spikes beyond 1.345 robust standard "
            "deviations of the residuals pull with a constant force"
        ),
    ] = "linear",
    per_step: Annotated[
        bool,
        typer.Option(
            help="also fit every step (window or run) on its own and test per-step against "
            "shared parameters (report section, fit.json 'per_step')"
        ),
    ] = False,
) -> None:
    """Fit a rate-and-state law to velocity steps or slide-hold-slide data.

    Writes OUT/fit.json (law, params with mu0, a, b, dc [m], stderr, rms_residual,
    n_points), OUT/report.md and OUT/fit.png (data, fit and residuals).
    """
    from nanoblock.measured import DataError, load_measurement
    from nanoblock.rsf.fit import check_loss, check_state_evolves, fit_rsf
    from nanoblock.rsf.report import write_fit

    _output_directory(out, writes=FIT_FILES)
    with _bad_input(ValueError):
        check_loss(loss, "mcmc" if mcmc else "lsq")
    if per_step and loss != "linear":
        _fail(
            f"--per-step compares information criteria of least-squares fits; it does not "
            f"go with --loss {loss} (drop one of them)"
        )
    if mcmc:
        _require_module("emcee", "--mcmc", "pip install 'nanoblock[mcmc]'")
    with _bad_input(DataError, ValueError, RuntimeError, data=data):
        measurement = _windowed(load_measurement(data, **_xlook(recipe, rows)), window)
        result = fit_rsf(
            measurement,
            law,
            stiffness=stiffness,
            trend=trend,
            fit_stiffness=fit_stiffness,
            initial_state=initial_state,
            method="mcmc" if mcmc else "lsq",
            mcmc_steps=mcmc_steps,
            loss=loss,
        )
        if "dc" in result.free:
            check_state_evolves(measurement, result.contract["dc"], result.contract_stderr["dc"])
        steps = None
        if per_step:
            from nanoblock.rsf.steps import compare_steps

            steps = compare_steps(
                measurement, law, stiffness=stiffness, trend=trend,
                fit_stiffness=fit_stiffness, initial_state=initial_state,
            )  # fmt: skip
    written = write_fit(result, measurement, out, steps)
    if steps is not None:
        verdict = "differ" if steps.differ else "agree"
        typer.echo(f"per-step parameters {verdict}: Delta IC {steps.delta:.1f}")
    for key in ("mu0", "a", "b", "dc"):
        value, error = result.contract[key], result.contract_stderr[key]
        typer.echo(f"{key:<6}{value:>12.5g}  +- {error if error is not None else 0:.2g}")
    typer.echo(f"rms residual {result.rms_residual:.3g} over {result.n_points} samples")
    if result.loss == "huber":
        typer.echo(
            f"huber loss: {result.downweighted} samples beyond its corner "
            f"{result.loss_corner:.3g} (report.md)"
        )
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
    window: Annotated[str | None, WINDOW] = None,
    recipe: Annotated[Path | None, RECIPE] = None,
    rows: Annotated[str | None, ROWS] = None,
    closure: Annotated[
        str,
        typer.Option(
            help="time series: base law's closure of the contacts' renewal: aging, renewal "
            "(the population without the aging closure, 2-5x the cost), auto (the one "
            "whose base fits better) or best (both in full, each with its own simulation "
            "check; the verdict whose final model has the lower information criterion)"
        ),
    ] = "aging",  # nanoblock.diagnosis.core.DEFAULT_CLOSURE (not imported: start-up time)
) -> None:
    """Diagnose what the base nanoblock model gets wrong on DATA, and why.

    Fits the base model's coarse-grained surrogate and every testable catalogue
    extension (physics.md section 5), ranks them by held-out error and information
    criterion, and writes OUT/diagnosis.json (cause, ranking, base, extended, gain,
    simulation_check), OUT/report.md, OUT/fits.png and OUT/residuals.png.
    """
    from nanoblock.diagnosis import DiagnosisError, diagnose, load_for_diagnosis
    from nanoblock.diagnosis.core import check_closure
    from nanoblock.diagnosis.report import write_diagnosis
    from nanoblock.measured import DataError

    _output_directory(out, writes=DIAGNOSIS_FILES)
    with _bad_input(ValueError):
        check_closure(closure)
    with _bad_input(DiagnosisError, DataError, ValueError, RuntimeError, data=data):
        measurement = _windowed(load_for_diagnosis(data, **_xlook(recipe, rows)), window)
        result = diagnose(
            measurement, progress=progress, workers=workers, simulate=simulate, closure=closure
        )
    written = write_diagnosis(result, out, data.name, measurement)
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
