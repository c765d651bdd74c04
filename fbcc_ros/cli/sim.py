"""fbcc-sim: simulate assemblies from scenario files (DESIGN §4) and write what happened.

    fbcc-sim SCENARIO.yaml [MORE.yaml ...] --out DIR [--plant model|mujoco]

Every law of every scenario is one run. DIR receives

* ``summary.json``: the summary of DESIGN §4; with more than one run, a mapping from the run's
  name (the law, the scenario's file stem, or ``stem/law``) to its summary;
* ``trajectory.csv``: one row per run and time step: true features, true responses, measured
  responses and commands;
* ``trajectories.png`` and ``planes.png``: Fig. 8-10 style plots, all runs on the same axes.

A scenario that fails validation stops the command before anything is simulated, with the key,
the value and what is expected (exit status 2).
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from fbcc_ros.cli.common import out_dir
from fbcc_ros.cli.sim_plots import Series, draw_planes, draw_trajectories
from fbcc_ros.core.contact.model import FEATURE_NAMES, RESPONSE_NAMES
from fbcc_ros.core.errors import command
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.plants.spec import PLANTS
from fbcc_ros.core.sim.simulation import SimResult, run_scenario


def run_files(paths: list[Path], plant: str | None = None) -> list[tuple[str, SimResult]]:
    """Validate every file first, then run every law of each (on ``plant`` if given, else on
    each scenario's own): ``[(run name, result)]``."""
    scenarios = [scenario_io.load(p) for p in paths]
    if plant is not None:
        scenarios = [sc.on_plant(plant) for sc in scenarios]
    runs = []
    for sc in scenarios:
        for law in sc.laws:
            if len(scenarios) == 1:
                name = law
            elif len(sc.laws) == 1:
                name = sc.name
            else:
                name = f"{sc.name}/{law}"
            runs.append((name, run_scenario(sc, law)))
    return runs


def write_csv(runs: list[tuple[str, SimResult]], path: Path) -> Path:
    measured = [f"{n}_measured" for n in RESPONSE_NAMES]
    commands = [f"{n}_cmd" for n in FEATURE_NAMES]
    header = ["run", "t", *FEATURE_NAMES, *RESPONSE_NAMES, *measured, *commands]
    with path.open("w", newline="") as f:
        out = csv.writer(f)
        out.writerow(header)
        for name, res in runs:
            tr = res.trajectory
            table = np.column_stack([tr.t, tr.features[:, 0], tr.response[:, 0],
                                     tr.measured[:, 0], tr.command[:, 0]])  # fmt: skip
            out.writerows([name, *(f"{v:.9g}" for v in row)] for row in table)
    return path


def write_run(runs: list[tuple[str, SimResult]], out: Path, plots: bool = True) -> None:
    """``summary.json`` (one run's summary, or a mapping from run names to summaries),
    ``trajectory.csv`` and, with ``plots``, ``trajectories.png`` and ``planes.png`` in out."""
    summaries = {name: res.summary for name, res in runs}
    doc = summaries[runs[0][0]] if len(runs) == 1 else summaries
    (out / "summary.json").write_text(json.dumps(doc, indent=2) + "\n")
    write_csv(runs, out / "trajectory.csv")
    if plots:
        series = [Series.simulated(name, res) for name, res in runs]
        draw_trajectories(series, out / "trajectories.png")
        draw_planes(series, out / "planes.png")


#: The header of :func:`summary_line`'s columns.
SUMMARY_HEADER = (
    f"{'run':<28} {'success':>7} {'t_ins':>8} {'peak_Fz':>8} {'resid_F':>9} "
    f"{'overshoot':>9} {'dx[µm]':>8} {'dy[µm]':>8} {'θx[°]':>7} {'θy[°]':>7}"
)


def summary_line(name: str, s: dict[str, Any]) -> str:
    t_ins = "-" if s["insertion_time"] is None else f"{s['insertion_time']:.3f}"
    f = s["final_features"]
    return (
        f"{name:<28} {'yes' if s['success'] else 'NO':>7} {t_ins:>8} {s['peak_fz']:8.1f} "
        f"{s['residual_force']:9.2f} {np.degrees(s['tilt_overshoot']):9.3f} "
        f"{f['dx'] * 1e6:8.2f} {f['dy'] * 1e6:8.2f} {np.degrees(f['theta_x']):7.3f} "
        f"{np.degrees(f['theta_y']):7.3f}"
    )


@command("fbcc-sim")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fbcc-sim", description=__doc__.split("\n\n")[0])
    parser.add_argument("scenarios", nargs="+", type=Path, metavar="SCENARIO.yaml")
    parser.add_argument("--out", required=True, help="output folder (created if missing)")
    parser.add_argument("--no-plots", action="store_true", help="skip the figures")
    parser.add_argument("--plant", choices=PLANTS, default=None,
                        help="the plant to run on (default: each scenario's plant.type, "
                             "model if absent): model (eq. 5-13) or mujoco (MuJoCo's physics)")
    args = parser.parse_args(argv)
    out = out_dir(parser, args.out)
    start = time.perf_counter()
    runs = run_files(args.scenarios, args.plant)
    elapsed = time.perf_counter() - start
    write_run(runs, out, plots=not args.no_plots)
    summaries = {name: res.summary for name, res in runs}
    simulated = sum(res.scenario.duration for _, res in runs)
    print(SUMMARY_HEADER)
    for name, s in summaries.items():
        print(summary_line(name, s))
    print(f"{len(runs)} run(s), {simulated:.1f} s simulated in {elapsed:.2f} s; wrote {out}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
