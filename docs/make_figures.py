"""Regenerate every figure the README and the documentation show.

    python docs/make_figures.py                  # all figures, full scale
    python docs/make_figures.py --scale 0.1      # reduced run (what tests/test_docs.py does)
    python docs/make_figures.py --only quickstart

``quickstart`` runs the built-in default scenario (``scenarios/quickstart.toml``, the one
``nanoblock run`` runs) and draws friction against time with its steady-state prediction,
and the slider velocity on a logarithmic axis. Every other figure is drawn by an analysis
notebook (``analysis/*.py``, jupytext): the script runs that notebook with
``NANOBLOCK_NOTEBOOK_SCALE = scale`` and copies its PNG into ``docs/figures/``.
``rsf_real_data`` needs the laboratory records (``NANOBLOCK_SHARED_DATA``, see the
measured-data page) and is skipped with a message when they are absent.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy.special import exp1

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "figures"

NOTEBOOK_FIGURES: dict[str, str] = {
    "steady_stress": "direct_effect.py",
    "agents": "ageing_renewal.py",
    "ageing_steady": "ageing_renewal.py",
    "slide_hold_slide": "ageing_renewal.py",
    "velocity_step": "velocity_steps.py",
    "mapping": "velocity_steps.py",
    "activation_volume": "temperature.py",
    "silicon_fig2": "silicon_apparatus.py",
    "silicon_fig3": "silicon_apparatus.py",
    "rsf_real_data": "rsf_real_data.py",
}
"""Figure name (``docs/figures/<name>.png``) -> the notebook in ``analysis/`` that draws it."""

FIGURES: tuple[str, ...] = ("quickstart", *NOTEBOOK_FIGURES)
"""Every figure this script produces."""


def steady_friction(scenario, velocity: np.ndarray) -> np.ndarray:
    """mu_ss(V) of a mean-field joint on ageing, renewing contacts: sigma_s(V) / p
    (001/Eq. 28) times the mean area factor 1 + m E[ln(1 + age / tau_m)] over Exp(D0 / V)
    contact ages (001/Eq. 5), E[ln(1 + X / c)] = e^c E1(c) for X ~ Exp(1)."""
    from nanoblock.engine import mean_field_joint
    from nanoblock.theory.meanfield import steady_stress

    interface = scenario.interface
    ratio = interface.aging_time * velocity / interface.memory_length
    area = 1.0 + interface.aging_m * np.exp(ratio) * exp1(ratio)
    return steady_stress(velocity, mean_field_joint(scenario)) / interface.hardness * area


def load_point_velocity(scenario, t: np.ndarray) -> np.ndarray:
    """The protocol's piecewise-constant load-point velocity [m/s] at times ``t`` (0 in holds)."""
    velocity = np.zeros_like(t)
    start = 0.0
    for step in scenario.loading.steps:
        if step.hold is not None:
            start += step.hold
            continue
        duration = step.duration if step.duration is not None else step.displacement / step.velocity
        velocity[(t > start) & (t <= start + duration)] = step.velocity
        start += duration
    return velocity


def quickstart(scale: float, out: Path) -> dict[str, float]:
    """The quick-start figure and its numbers (``quickstart.json``)."""
    from nanoblock.cli import default_scenario
    from nanoblock.coarse.runs import scenario_file
    from nanoblock.engine import simulate

    scenario = scenario_file(default_scenario(), scale)
    run = simulate(scenario)

    t = run.time.values
    load = load_point_velocity(scenario, t)
    moving = load > 0.0
    prediction = np.full_like(t, np.nan)
    prediction[moving] = steady_friction(scenario, load[moving])

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True, constrained_layout=True)
    top.plot(t, run.friction_coefficient, lw=1.0, label="simulation")
    top.plot(t, prediction, lw=1.2, ls="--", color="k", label="steady state mu_ss(V)")
    top.set_ylabel("friction coefficient mu = F / W")
    top.legend(loc="upper left")
    slider = run.slider_velocity.values
    positive = np.where(slider > 0.0, slider, np.nan)
    bottom.semilogy(t, positive, lw=1.0, label="slider")
    bottom.semilogy(t, np.where(moving, load, np.nan), lw=1.2, ls="--", label="load point")
    bottom.set_ylim(1e-11, 1e-4)
    bottom.set_xlabel("time [s]")
    bottom.set_ylabel("velocity [m/s]")
    bottom.legend(loc="lower left")
    n = scenario.interface.n_contacts
    top.set_title(f"nanoblock run (scenarios/quickstart.toml, {n} contacts)")
    fig.savefig(out / "quickstart.png", dpi=120)
    plt.close(fig)

    mu = run.friction_coefficient.values
    numbers = {
        "n_contacts": n,
        "mu_min": float(np.min(mu)),
        "mu_max": float(np.max(mu)),
        "mu_ss_1um_s": float(steady_friction(scenario, np.array([1e-6]))[0]),
        "mu_ss_10um_s": float(steady_friction(scenario, np.array([1e-5]))[0]),
    }
    (out / "quickstart.json").write_text(json.dumps(numbers, indent=2) + "\n")
    return numbers


def notebook_figures(names: list[str], scale: float, out: Path) -> list[str]:
    """Run the notebooks that draw ``names`` and copy their PNGs; return those skipped."""
    skipped = []
    for notebook in sorted({NOTEBOOK_FIGURES[name] for name in names}):
        path = ROOT / "analysis" / notebook
        if "NANOBLOCK_SHARED_DATA" in path.read_text() and not os.environ.get(
            "NANOBLOCK_SHARED_DATA"
        ):
            wanted = [name for name in names if NOTEBOOK_FIGURES[name] == notebook]
            print(f"skipped {notebook}: set NANOBLOCK_SHARED_DATA to the laboratory records")
            skipped += wanted
            continue
        env = {**os.environ, "NANOBLOCK_NOTEBOOK_SCALE": str(scale), "MPLBACKEND": "Agg"}
        with tempfile.TemporaryDirectory() as work:
            print(f"running analysis/{notebook} at scale {scale}", flush=True)
            subprocess.run(
                [sys.executable, str(path)], cwd=work, env=env, check=True, capture_output=True
            )
            for name, source in NOTEBOOK_FIGURES.items():
                if source == notebook and name in names:
                    shutil.copyfile(Path(work) / "figures" / f"{name}.png", out / f"{name}.png")
    return skipped


def parser() -> argparse.ArgumentParser:
    """The command line of this script."""
    parse = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parse.add_argument("--scale", type=float, default=1.0, help="fraction of full size (0-1]")
    parse.add_argument("--only", action="append", choices=FIGURES, help="figure(s) to make")
    parse.add_argument("--out", type=Path, default=OUT, help="output directory")
    return parse


def main(argv: list[str] | None = None) -> None:
    parse = parser()
    args = parse.parse_args(argv)
    if not 0.0 < args.scale <= 1.0:
        parse.error("--scale must be in (0, 1]")
    names = args.only or list(FIGURES)
    args.out.mkdir(parents=True, exist_ok=True)
    if "quickstart" in names:
        print("quickstart:", quickstart(args.scale, args.out), flush=True)
    notebook_figures([name for name in names if name != "quickstart"], args.scale, args.out)


if __name__ == "__main__":
    main()
