"""fbcc-montecarlo: the success rate of each law over many random assemblies.

    fbcc-montecarlo SCENARIO.yaml --trials 1000 --workers 2 --out DIR

The scenario gives the nominal geometry, gains, sensor, robot and timing (its ``initial`` is
replaced by the random deviations). Each trial draws the deviations (default ±0.1 mm, ±2° in both
planes) and the true radii (the spreads of Table II); see :mod:`fbcc_ros.core.montecarlo`. Every
law runs the same trials. DIR receives ``trials.csv`` (one row per trial and law),
``summary.json`` (success rate with its 95 % Wilson interval, percentiles of the metrics) and
``histograms.png``.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fbcc_ros.cli.common import out_dir
from fbcc_ros.core import scenario as scenario_io
from fbcc_ros.core.contact import FEATURE_NAMES
from fbcc_ros.core.control import LAWS
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.montecarlo import (
    Trials,
    draw_trials,
    run_montecarlo,
    wilson_interval,
)
from fbcc_ros.core.simulation import Outcome

#: Metrics summarised by percentiles: (name, scale to the printed unit, unit).
_METRICS = (
    ("peak_fz", 1.0, "N"),
    ("residual_force", 1.0, "N"),
    ("residual_moment", 1.0, "N·m"),
    ("tilt_overshoot", 180 / math.pi, "deg"),
    ("insertion_time", 1.0, "s"),
)


class ProgressBar:
    """A one-line progress bar on stderr (only redrawn when stderr is a terminal or at the end)."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.start = time.perf_counter()
        self.tty = sys.stderr.isatty()

    def __call__(self, done: int, total: int) -> None:
        if not (self.tty or done == total):
            return
        width = 30
        filled = round(width * done / total)
        elapsed = time.perf_counter() - self.start
        eta = elapsed / done * (total - done) if done else math.nan
        bar = "#" * filled + "-" * (width - filled)
        end = "\n" if done == total else ""
        print(f"\r{self.label} [{bar}] {done}/{total} batches, {elapsed:5.1f} s, eta {eta:4.1f} s",
              end=end, file=sys.stderr, flush=True)  # fmt: skip


def summarise(outcome: Outcome) -> dict[str, Any]:
    n = len(outcome.success)
    k = int(outcome.success.sum())
    lo, hi = wilson_interval(k, n)
    out: dict[str, Any] = {
        "trials": n, "successes": k, "success_rate": k / n, "success_ci95": [lo, hi],
        "force_limited": int(outcome.force_limited.sum()),
    }  # fmt: skip
    for name, scale, unit in _METRICS:
        v = getattr(outcome, name) * scale
        v = v[np.isfinite(v)]
        stats = {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)),
                 "max": float(v.max())} if len(v) else None  # fmt: skip
        out[f"{name} [{unit}]"] = stats
    return out


def write_trials(trials: Trials, results: dict[str, Outcome], path: Path) -> None:
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["law", "trial", "dx0", "dy0", "theta_x0", "theta_y0", "hole_radius",
                    "peg_radius", "success", "insertion_time", "peak_fz", "residual_force",
                    "residual_moment", "tilt_overshoot", "force_limited",
                    *(f"final_{n}" for n in FEATURE_NAMES)])  # fmt: skip
        for law, o in results.items():
            for i in range(len(trials)):
                d, g = trials.initial[i], trials.geometries[i]
                w.writerow([law, i, *(f"{v:.6g}" for v in (d[0], d[1], d[3], d[4])),
                            f"{g.hole_radius:.7g}", f"{g.peg_radius:.7g}", int(o.success[i]),
                            f"{o.insertion_time[i]:.4g}", f"{o.peak_fz[i]:.4g}",
                            f"{o.residual_force[i]:.4g}", f"{o.residual_moment[i]:.4g}",
                            f"{o.tilt_overshoot[i]:.4g}", int(o.force_limited[i]),
                            *(f"{v:.6g}" for v in o.final_features[i])])  # fmt: skip


def draw(results: dict[str, Outcome], path: Path) -> None:
    fig, axes = plt.subplots(1, len(_METRICS), figsize=(4 * len(_METRICS), 3.6))
    for ax, (name, scale, unit) in zip(axes, _METRICS, strict=True):
        for law, o in results.items():
            v = getattr(o, name) * scale
            v = v[np.isfinite(v)]
            rate = o.success.mean()
            ax.hist(v, bins=40, alpha=0.6, label=f"{law} ({rate:.1%} success)")
        ax.set(xlabel=f"{name} [{unit}]", ylabel="trials")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fbcc-montecarlo", description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", type=Path, metavar="SCENARIO.yaml")
    parser.add_argument("--out", required=True, help="output folder (created if missing)")
    parser.add_argument("--trials", type=int, default=1000, help="number of trials (1000)")
    parser.add_argument("--workers", type=int, default=2, help="processes (2)")
    parser.add_argument("--laws", nargs="+", choices=sorted(LAWS), default=None,
                        help="laws to run (default: the scenario's controller.type)")  # fmt: skip
    parser.add_argument("--seed", type=int, default=0, help="seed of the random trials (0)")
    parser.add_argument("--max-offset-mm", type=float, default=0.1, help="± initial dx, dy [mm]")
    parser.add_argument("--max-tilt-deg", type=float, default=2.0, help="± initial tilts [deg]")
    args = parser.parse_args(argv)
    for flag, value in (("--trials", args.trials), ("--workers", args.workers)):
        if value < 1:
            parser.error(f"{flag}={value} is not allowed: expected an integer >= 1")
    if not (0 <= args.max_offset_mm <= 10 and 0 <= args.max_tilt_deg <= 20):
        parser.error("--max-offset-mm must be in [0, 10] mm and --max-tilt-deg in [0, 20] deg")
    out = out_dir(parser, args.out)
    try:
        sc = scenario_io.load(args.scenario)
    except ConfigError as exc:
        print(f"fbcc-montecarlo: {exc}", file=sys.stderr)
        return 2
    laws = args.laws or list(sc.laws)
    trials = draw_trials(sc.geometry, args.trials, args.seed, args.max_offset_mm * 1e-3,
                         math.radians(args.max_tilt_deg))  # fmt: skip
    start = time.perf_counter()
    results = run_montecarlo(sc, laws, trials, workers=args.workers,
                             progress=ProgressBar(f"{sc.name}: {', '.join(laws)}"))  # fmt: skip
    elapsed = time.perf_counter() - start
    summary = {law: summarise(o) for law, o in results.items()}
    summary["_run"] = {
        "scenario": str(args.scenario), "trials": args.trials, "seed": args.seed,
        "workers": args.workers, "seconds": elapsed, "max_offset_mm": args.max_offset_mm,
        "max_tilt_deg": args.max_tilt_deg,
    }  # fmt: skip
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    write_trials(trials, results, out / "trials.csv")
    draw(results, out / "histograms.png")
    for law in laws:
        s = summary[law]
        lo, hi = s["success_ci95"]
        pf = s["peak_fz [N]"]
        rf = s["residual_force [N]"]
        print(f"{law:<11} success {s['successes']}/{s['trials']} = {s['success_rate']:.1%} "
              f"(95 % CI {lo:.1%}-{hi:.1%}); peak Fz median {pf['median']:.1f} N, "
              f"max {pf['max']:.1f} N; residual force median {rf['median']:.2f} N")  # fmt: skip
    print(f"{args.trials} trials x {len(laws)} law(s) in {elapsed:.1f} s on {args.workers} "
          f"worker(s); wrote {out}/")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
