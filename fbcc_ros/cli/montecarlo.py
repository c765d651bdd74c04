"""fbcc-montecarlo: the success rate of each law over many random assemblies.

    fbcc-montecarlo SCENARIO.yaml --trials 1000 --out DIR
    fbcc-montecarlo SCENARIO.yaml --trials 10000 --stiffness-gpa 0.1 100 --friction 0.1 0.5

The scenario gives the nominal geometry, gains, sensor, robot and timing (its ``initial`` is
replaced by the random deviations). Each trial draws the deviations (default ±0.1 mm, ±2° in both
planes), the true radii (the spreads of Table II) and, when asked, the material: k log-uniform
(``--stiffness-gpa``; on MuJoCo, whose contact ignores k, the contact's time constant,
``--contact-ms``) and mu uniform (``--friction``); see :mod:`fbcc_ros.core.sim.montecarlo`. A
part that no controller could push in (quasi-static push-in force above 2/3 of the force limit) is
drawn again and counted, unless ``--all-parts``. Every law runs the same trials, on all local
cores by default or on a Dask cluster (``--scheduler``), with identical results for one seed.

DIR receives ``trials.csv`` (one row per trial and law, with its material), ``summary.json`` (the
simulator's success, assembled within the force limit, with its 95 % Wilson interval; percentiles
of the metrics; the goals of the robustness study with the measured figures, whose success is a
trial that met every per-trial goal; every trial that missed one, with what reproduces it:
:mod:`fbcc_ros.core.sim.study_goals`), ``histograms.png`` and, when k is drawn, ``stiffness.png``
(success, peak Fz and insertion time against k); with the robust law, ``friction.png`` (the
friction its lever measured against each part's μ; ``summary.json``'s ``friction_estimate`` gives
its error).

    fbcc-montecarlo SCENARIO.yaml ... --seed 0 --out DIR --trial 2653 [5412 ...]

replays those trials of the study instead of running it. A trial is its seed: trial N of
``--seed S`` is the same in a study of any size (its draw and its noise are its own), so only
those trials are simulated, and DIR/trial_N receives what ``fbcc-sim`` writes for one run
(``summary.json``, ``trajectory.csv``, ``trajectories.png``, ``planes.png``), per law.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from fbcc_ros.cli.common import out_dir
from fbcc_ros.cli.montecarlo_plots import METRICS, draw, draw_friction, draw_stiffness
from fbcc_ros.cli.sim import SUMMARY_HEADER, summary_line, write_run
from fbcc_ros.core.control.laws import LAWS
from fbcc_ros.core.errors import ConfigError, command
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.montecarlo import (
    BATCH,
    Trials,
    draw_trials,
    replay_trial,
    run_montecarlo,
    wilson_interval,
)
from fbcc_ros.core.sim.plants.spec import MAX_TIMECONST, PLANTS, TIMESTEPS_PER_TIMECONST
from fbcc_ros.core.sim.simulation import Outcome
from fbcc_ros.core.sim.study_goals import failures, goals, missed_goals, targets
from fbcc_ros.studies import trials_csv


class ProgressBar:
    """Progress on stderr: a one-line bar redrawn in a terminal; in a log (not a terminal), one
    line at every tenth of the work, so a long study in CI or under nohup still shows it."""

    def __init__(self, label: str, unit: str = "batches") -> None:
        self.label = label
        self.unit = unit
        self.start = time.perf_counter()
        self.tty = sys.stderr.isatty()
        self._tenths = 0

    def __call__(self, done: int, total: int) -> None:
        tenths = 10 * done // total
        if not (self.tty or tenths > self._tenths):
            return
        self._tenths = tenths
        width = 30
        filled = round(width * done / total)
        elapsed = time.perf_counter() - self.start
        eta = elapsed / done * (total - done) if done else math.nan
        bar = "#" * filled + "-" * (width - filled)
        start, end = ("\r", "\n" if done == total else "") if self.tty else ("", "\n")
        print(f"{start}{self.label} [{bar}] {done}/{total} {self.unit}, {elapsed:5.1f} s, "
              f"eta {eta:4.1f} s", end=end, file=sys.stderr, flush=True)  # fmt: skip


def summarise(outcome: Outcome) -> dict[str, Any]:
    n = len(outcome.success)
    k = int(outcome.success.sum())
    lo, hi = wilson_interval(k, n)
    out: dict[str, Any] = {
        "trials": n, "successes": k, "success_rate": k / n, "success_ci95": [lo, hi],
        "force_limited": int(outcome.force_limited.sum()),
        "wrench_guard_tripped": int(outcome.wrench_guard_tripped.sum()),
        "guard_tripped": int((outcome.guard_trips > 0).sum()),  # the oscillation guard
        # a compliant holder's equilibria the solver left unconverged (holder_solver.py)
        "holder_unconverged_steps": {"trials": int((outcome.holder_unconverged > 0).sum()),
                                     "max": int(outcome.holder_unconverged.max(initial=0))},
    }  # fmt: skip
    for name, scale, unit in METRICS:
        v = getattr(outcome, name) * scale
        v = v[np.isfinite(v)]
        stats = {"median": float(np.median(v)), **{f"p{q}": float(np.percentile(v, q)) for q
                 in (95, 99)}, "max": float(v.max())} if len(v) else None  # fmt: skip
        out[f"{name} [{unit}]"] = stats
    return out


#: The most trials one study draws: its parts, initial errors and outcomes are held in memory
#: together (a billion asked for ended in a MemoryError); a million take hours on two cores.
MAX_TRIALS = 1_000_000


def friction_accuracy(outcome: Outcome, trials: Trials) -> dict[str, Any] | None:
    """The friction the robust law's lever (eq. 24) measured against each part's μ: on how
    many trials it measured one, and its error there; None when it measured none."""
    est = outcome.friction_estimate
    measured = np.isfinite(est)
    if not measured.any():
        return None
    err = est[measured] - np.array([g.friction for g in trials.geometries])[measured]
    return {"measured": int(measured.sum()), "trials": len(est),
            "error_median": float(np.median(err)),
            "abs_error_median": float(np.median(np.abs(err))),
            "abs_error_p95": float(np.percentile(np.abs(err), 95)),
            "abs_error_max": float(np.abs(err).max())}  # fmt: skip


def _range(parser: argparse.ArgumentParser, flag: str, value: list[float] | None,
           low: float, high: float, unit: str) -> tuple[float, float] | None:  # fmt: skip
    if value is None:
        return None
    lo, hi = value
    if not (low <= lo <= hi <= high):
        parser.error(f"{flag} {lo:g} {hi:g} is not allowed: expected LOW HIGH with "
                     f"{low:g} <= LOW <= HIGH <= {high:g} {unit}")  # fmt: skip
    return lo, hi


def replay(sc: scenario_io.Scenario, laws: list[str], trials: Trials, out: Path) -> int:
    """``--trial``: each trial's run per law, written as fbcc-sim writes one."""
    print(SUMMARY_HEADER)
    for index in trials.numbers:
        runs = [(law, replay_trial(sc, law, trials, index)) for law in laws]
        folder = out / f"trial_{index}"
        folder.mkdir(exist_ok=True)
        write_run(runs, folder)
        for law, res in runs:
            print(summary_line(f"trial {index} {law}", res.summary))
    print("wrote " + ", ".join(f"{out}/trial_{index}/" for index in trials.numbers))
    return 0


@command("fbcc-montecarlo")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fbcc-montecarlo", description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", type=Path, metavar="SCENARIO.yaml")
    parser.add_argument("--out", required=True, help="output folder (created if missing)")
    parser.add_argument("--trials", type=int, default=1000, help="number of trials (1000)")
    parser.add_argument("--first", type=int, default=0, help="the first trial's number (0): a "
                        "study run in parts (--first 300 ...) runs the same trials")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                        help="local processes (default: every core)")  # fmt: skip
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on the Dask cluster of this scheduler (tcp://host:8786) "
                        "instead of local processes; the same results for the same seed")
    parser.add_argument("--laws", nargs="+", choices=sorted(LAWS), default=None,
                        help="laws to run (default: the scenario's controller.type)")  # fmt: skip
    parser.add_argument("--seed", type=int, default=0, help="seed of the random trials (0)")
    parser.add_argument("--max-offset-mm", type=float, default=0.1, help="± initial dx, dy [mm]")
    parser.add_argument("--max-tilt-deg", type=float, default=2.0, help="± initial tilts [deg]")
    parser.add_argument("--stiffness-gpa", type=float, nargs=2, metavar=("LOW", "HIGH"),
                        help="draw eq. 8's k log-uniform in [LOW, HIGH] GPa per trial")
    parser.add_argument("--friction", type=float, nargs=2, metavar=("LOW", "HIGH"),
                        help="draw mu uniform in [LOW, HIGH] per trial")
    parser.add_argument("--clearance-um", type=float, nargs=2, metavar=("LOW", "HIGH"),
                        help="draw the radial clearance uniform in [LOW, HIGH] µm per trial")
    parser.add_argument("--chamfer-mm", type=float, nargs=2, metavar=("LOW", "HIGH"),
                        help="draw the 45° chamfer's width uniform in [LOW, HIGH] mm per trial "
                        "(a scenario with geometry.rim: true)")
    parser.add_argument("--grip", type=float, nargs=4,
                        metavar=("N_PER_M_LO", "N_PER_M_HI", "NM_PER_RAD_LO", "NM_PER_RAD_HI"),
                        help="draw each trial's grip log-uniform in these lateral and angular "
                        "ranges (instead of --holder and the scenario's holder)")
    parser.add_argument("--contact-ms", type=float, nargs=2, metavar=("LOW", "HIGH"),
                        help="on MuJoCo, draw each trial's contact time constant (solref) "
                        "log-uniform in [LOW, HIGH] ms, its impedance's width following: 0.2 the "
                        "shipped metal-like contact, 1 a plastic-like one (instead of "
                        "plant.timeconst)")
    parser.add_argument("--holder", type=float, nargs=2, metavar=("N_PER_M", "NM_PER_RAD"),
                        help="hold the peg in a holder of this lateral and angular stiffness "
                        "(overrides the scenario's holder; fbcc_ros/core/sim/holder.py)")
    parser.add_argument("--plant", choices=PLANTS, default=None,
                        help="the plant (default: the scenario's plant.type, model if absent)")
    parser.add_argument("--rate-hz", type=float, default=None,
                        help="control rate of the trials (the stack's: 100, 250, 1000) "
                        "instead of the scenario's rate_hz")
    parser.add_argument("--all-parts", action="store_true",
                        help="keep parts whose push-in force exceeds 2/3 of the force limit")
    parser.add_argument("--trial", type=int, nargs="+", metavar="N",
                        help="replay these trials of the study (same arguments but --trials) "
                        "with their trajectories and figures, instead of running it")
    args = parser.parse_args(argv)
    for flag, value in (("--trials", args.trials), ("--workers", args.workers)):
        if value < 1:
            parser.error(f"{flag}={value} is not allowed: expected an integer >= 1")
    if args.first < 0 or (args.first and args.trial):
        parser.error(f"--first={args.first} is not allowed: expected a trial number >= 0, "
                     "and not with --trial (which names the trials to replay)")
    if args.trials > MAX_TRIALS:
        parser.error(f"--trials={args.trials} is not allowed: expected at most {MAX_TRIALS} "
                     "(run several seeds for more)")
    if not (0 <= args.max_offset_mm <= 10 and 0 <= args.max_tilt_deg <= 20):
        parser.error("--max-offset-mm must be in [0, 10] mm and --max-tilt-deg in [0, 20] deg")
    out = out_dir(parser, args.out)
    sc = scenario_io.load(args.scenario)
    laws = args.laws or list(sc.laws)
    stiffness_gpa = _range(parser, "--stiffness-gpa", args.stiffness_gpa, 1e-3, 1e3, "GPa")
    friction = _range(parser, "--friction", args.friction, 1e-3, 0.99, "")
    clearance_um = _range(parser, "--clearance-um", args.clearance_um, 0.1, 500.0, "µm")
    chamfer_mm = _range(parser, "--chamfer-mm", args.chamfer_mm, 0.0,
                        0.999e3 * min(sc.plant.face_width, sc.geometry.hole_depth), "mm")
    if chamfer_mm is not None and not sc.geometry.rim:
        parser.error(f"--chamfer-mm needs a scenario whose pair has its rim: {args.scenario} "
                     "has no geometry.rim: true")  # fmt: skip
    if args.seed < 0:
        parser.error(f"--seed={args.seed} is not allowed: expected an integer >= 0")
    for index in args.trial or ():
        if index < 0:
            parser.error(f"--trial {index} is not allowed: expected a trial number >= 0")
    if args.plant is not None:
        sc = sc.on_plant(args.plant)
    if args.rate_hz is not None:
        low, high = scenario_io.RATE_HZ
        if not low <= args.rate_hz <= high:
            parser.error(f"--rate-hz={args.rate_hz:g} is not allowed: expected {low:g} to "
                         f"{high:g} Hz")
        sc = dataclasses.replace(sc, rate_hz=args.rate_hz)
    contact_ms = None
    if args.contact_ms is not None:
        if sc.plant.type != "mujoco":
            parser.error(f"--contact-ms draws MuJoCo's contact: {args.scenario} runs on the "
                         f"{sc.plant.type} (add --plant mujoco; the model's is --stiffness-gpa)")
        least = TIMESTEPS_PER_TIMECONST * sc.plant.timestep * 1e3
        contact_ms = _range(parser, "--contact-ms", args.contact_ms, least, MAX_TIMECONST * 1e3,
                            f"ms (at least {TIMESTEPS_PER_TIMECONST} of plant.timestep)")
    grip = args.grip
    if grip is not None:
        if args.holder is not None:
            parser.error("--grip draws each trial's grip: not with --holder, which fixes it")
        try:
            Holder(grip[0], grip[2])
            Holder(grip[1], grip[3])
        except ConfigError as exc:
            parser.error(f"--grip {' '.join(f'{g:g}' for g in grip)}: {exc}")
    if args.holder is not None:
        try:
            sc = dataclasses.replace(sc, holder=Holder(*args.holder))
        except ConfigError as exc:
            parser.error(f"--holder {args.holder[0]:g} {args.holder[1]:g}: {exc}")
    feasible = None if args.all_parts else 2.0 / 3.0 * sc.params.F_ext_limit
    trials = draw_trials(
        sc.geometry, args.trials, args.seed, args.max_offset_mm * 1e-3,
        math.radians(args.max_tilt_deg),
        stiffness=None if stiffness_gpa is None else (stiffness_gpa[0] * 1e9,
                                                      stiffness_gpa[1] * 1e9),
        friction=friction, feasible_force=feasible,
        clearance=None if clearance_um is None else (clearance_um[0] * 1e-6,
                                                     clearance_um[1] * 1e-6),
        chamfer=None if chamfer_mm is None else (chamfer_mm[0] * 1e-3, chamfer_mm[1] * 1e-3),
        grip=None if grip is None else tuple(grip),
        contact=None if contact_ms is None else (contact_ms[0] * 1e-3, contact_ms[1] * 1e-3),
        numbers=args.trial or range(args.first, args.first + args.trials),
    )  # fmt: skip
    if args.trial:
        return replay(sc, laws, trials, out)
    unit = "trials" if BATCH[sc.plant.type] == 1 else "batches"  # the tasks counted
    start = time.perf_counter()
    # a ConfigError (no scheduler answering, dask missing) ends in one line (@command)
    results = run_montecarlo(sc, laws, trials, workers=args.workers,
                             progress=ProgressBar(f"{sc.name}: {', '.join(laws)}", unit),
                             scheduler=args.scheduler)  # fmt: skip
    elapsed = time.perf_counter() - start
    summary: dict[str, Any] = {}
    missed: dict[str, list[list[str]]] = {}
    target = targets(sc)
    deadline = target.deadline
    for law, o in results.items():
        summary[law] = summarise(o)
        missed[law] = missed_goals(o, deadline)
        summary[law]["goals"] = goals(o, trials, missed[law], target)
        summary[law]["failures"] = failures(o, trials, missed[law])
        summary[law]["friction_estimate"] = friction_accuracy(o, trials)
    summary["_run"] = {
        "scenario": str(args.scenario), "trials": args.trials, "first": args.first,
        "seed": args.seed,
        "workers": args.workers, "scheduler": args.scheduler, "seconds": elapsed,
        "max_offset_mm": args.max_offset_mm,
        "max_tilt_deg": args.max_tilt_deg, "stiffness_gpa": stiffness_gpa,
        "friction": friction, "clearance_um": clearance_um, "chamfer_mm": chamfer_mm,
        "feasible_force": feasible, "parts_redrawn": trials.redrawn,
        "holder": None if sc.holder is None else [sc.holder.lateral, sc.holder.angular],
        "grip": grip, "contact_ms": contact_ms,
        "plant": dataclasses.asdict(sc.plant), "rate_hz": sc.rate_hz,
    }  # fmt: skip
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    trials_csv.write_trials(trials, results, out / "trials.csv")
    draw(results, out / "histograms.png")
    if stiffness_gpa is not None:
        draw_stiffness(trials, results, missed, deadline, out / "stiffness.png")
    draw_friction(trials, results, out / "friction.png")
    for law in laws:
        s = summary[law]
        lo, hi = s["success_ci95"]
        pf = s["peak_fz [N]"]
        rf = s["residual_force [N]"]
        print(f"{law:<11} assembled {s['successes']}/{s['trials']} = {s['success_rate']:.1%} "
              f"(95 % CI {lo:.1%}-{hi:.1%}); peak Fz median {pf['median']:.1f} N, "
              f"max {pf['max']:.1f} N; residual force median {rf['median']:.2f} N")  # fmt: skip
        for name, g in s["goals"].items():
            share = f" on {g['share']:.3%} of trials" if "share" in g else ""
            print(f"    {'met    ' if g['met'] else 'NOT met'} {name}: {g['measured']} "
                  f"(target {g['target']}){share}")  # fmt: skip
        if (mu := s["friction_estimate"]) is not None:
            print(f"    friction in the lever measured on {mu['measured']}/{mu['trials']}: "
                  f"|error| median {mu['abs_error_median']:.3f}, p95 "
                  f"{mu['abs_error_p95']:.3f}")  # fmt: skip
        for f in s["failures"][:10]:
            # eq. 8's k is the model's; MuJoCo's contact has its own stiffness
            k = f"k {f['stiffness']:.3g} Pa, " if sc.plant.type == "model" else ""
            print(f"    failed trial {f['trial']} (--seed {f['seed']} --trial {f['trial']}): "
                  f"{f['why']}; {k}mu {f['friction']:.2f}")  # fmt: skip
    if trials.redrawn:
        print(f"{trials.redrawn} part(s) drawn again: push-in force above {feasible:.0f} N")
    where = f"the cluster at {args.scheduler}" if args.scheduler else f"{args.workers} worker(s)"
    print(f"{args.trials} trials x {len(laws)} law(s) in {elapsed:.1f} s on {where}; "
          f"wrote {out}/")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
