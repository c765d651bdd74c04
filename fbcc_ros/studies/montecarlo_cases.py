"""Monte Carlo studies of several cases side by side: success (assembled within the force
limit) with its 95 % interval, how the others failed, peak Fz and insertion time; success
against the drawn friction and against the wedging ratio theta0 / (c/mu) (over 1, a peg in
two-point contact can wedge), as tables and a figure.

A case is one study's ``trials.csv``, or the parts of one study run with ``--first``
(``fbcc-montecarlo``): their trials are joined by number, and a trial found in two parts must
be the same row.

Command::

    python -m fbcc_ros.studies.montecarlo_cases \\
        --case "10 um" A/trials.csv A_REST/trials.csv --case "30 um" B/trials.csv \\
        --figure cases.png
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

from fbcc_ros.core.sim.montecarlo import wilson_interval
from fbcc_ros.studies.trials_csv import Study, bin_masks, friction_edges, join_parts, study_parts

#: The bins of the wedging ratio (:func:`wedging_ratio`): under 1 a two-point contact cannot
#: wedge, over 1 it can.
WEDGING_EDGES = np.array([0.0, 0.5, 1.0, 2.0, 4.0, math.inf])


def wedging_ratio(row: dict[str, float]) -> float:
    """A trial's initial tilt theta0 over c / mu, c = (R - r) / R the clearance ratio: a peg in
    two-point contact can wedge when its tilt there exceeds c / mu (Whitney, "Quasi-static
    assembly of compliantly supported rigid parts", J. Dyn. Sys., Meas., Control 104, 1982). The
    initial tilt stands for the tilt at two-point contact, which a compliant grip changes on
    the way; infinite for an interference fit."""
    c = (row["hole_radius"] - row["peg_radius"]) / row["hole_radius"]
    tilt = math.atan(math.hypot(math.tan(row["theta_x0"]), math.tan(row["theta_y0"])))
    return tilt * row["friction"] / c if c > 0 else math.inf


def binned(case: Study, value: Callable[[dict[str, float]], float], edges: np.ndarray
           ) -> list[tuple[int, int]]:  # fmt: skip
    """(successes, trials) of each bin of ``value`` over the case's trials."""
    v = np.array([value(row) for row in case.values()])
    ok = np.array([bool(row["success"]) for row in case.values()])
    return [(int(ok[inside].sum()), int(inside.sum())) for inside in bin_masks(v, edges)]


def binnings(cases: dict[str, Study]) -> list[tuple[str, Callable[[dict[str, float]], float],
                                                     np.ndarray]]:  # fmt: skip
    """The tables' and the figure's binnings: (label, value, edges); the friction's over every
    case's draws."""
    mu = np.array([row["friction"] for case in cases.values() for row in case.values()])
    return [("μ", lambda row: row["friction"], friction_edges(mu)),
            ("θ0 / (c/μ)", wedging_ratio, WEDGING_EDGES)]


def _percent(k: int, n: int) -> str:
    if not n:
        return "-"
    lo, hi = wilson_interval(k, n)
    return f"{k / n:.1%} ({lo:.1%}-{hi:.1%})"


def markdown(cases: dict[str, Study]) -> str:
    """The cases' table (a trial succeeded, or was stopped by the force limit or the wrench
    guard, or else was not assembled at the end) and the tables of success against friction
    and against the wedging ratio (:func:`wedging_ratio`)."""
    lines = ["| case | trials | succeeded (95 %) | failed: stopped | failed: not assembled at "
             "the end | failed trials' final depth, median | peak Fz median, p99 | insertion "
             "time of the succeeded, median |", "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for name, case in cases.items():
        rows = list(case.values())
        ok = np.array([bool(r["success"]) for r in rows])
        limited = np.array([bool(r["stopped"]) for r in rows])
        time = np.array([r["insertion_time"] for r in rows])
        peak = np.array([r["peak_fz"] for r in rows])
        median_time = f"{np.median(time[ok]):.2f} s" if ok.any() else "-"
        depth = np.array([r["final_l"] for r in rows])[~ok] * 1e3
        stuck = f"{np.median(depth):.2f} mm" if len(depth) else "-"  # on the rim, or wedged
        lines.append(f"| {name} | {len(rows)} | {_percent(int(ok.sum()), len(rows))} | "
                     f"{int(limited.sum())} | {int((~ok & ~limited).sum())} | {stuck} | "
                     f"{np.median(peak):.1f}, {np.percentile(peak, 99):.1f} N | {median_time} |")
    for label, value, edges in binnings(cases):
        lines += ["", f"| {label} | " + " | ".join(cases) + " |", "|---" * (len(cases) + 1) + "|"]
        counts = [binned(case, value, edges) for case in cases.values()]
        for b, (lo, hi) in enumerate(itertools.pairwise(edges)):
            cells = [f"{k}/{n}" + (f" ({k / n:.0%})" if n else "") for k, n in
                     (c[b] for c in counts)]  # fmt: skip
            lines.append(f"| {lo:.2f}-{hi:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def draw(cases: dict[str, Study], path: Path) -> None:
    """Success against friction and against the wedging ratio, one line per case, with the
    bins' 95 % intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.0))
    for ax, (label, value, edges) in zip(axes, binnings(cases), strict=True):
        # an open last bin [a, inf) drawn as [a, 2a]
        finite = np.minimum(edges, 2 * edges[-2]) if np.isinf(edges[-1]) else edges
        centres = 0.5 * (finite[:-1] + finite[1:])
        for j, (name, case) in enumerate(cases.items()):
            shown = [(c, k / n, *wilson_interval(k, n)) for c, (k, n) in
                     zip(centres, binned(case, value, edges), strict=True) if n]  # fmt: skip
            if not shown:
                continue
            x, rate, lo, hi = (np.array(v) for v in zip(*shown, strict=True))
            shift = (j - (len(cases) - 1) / 2) * 0.01 * (finite[-1] - finite[0])  # side by side
            bars = np.maximum(0.0, [rate - lo, hi - rate])  # Wilson's bounds, to rounding
            ax.errorbar(x + shift, 100 * rate, yerr=100 * bars,
                        marker="o", capsize=3, label=f"{name} ({len(case)} trials)")
        ax.set(xlabel=f"{label} (bin centre)", ylabel="succeeded [%] (95 % interval)",
               ylim=(0, 103))  # fmt: skip
        ax.grid(alpha=0.3)
    axes[1].axvline(1.0, color="grey", linestyle="--", linewidth=1)  # can wedge to its right
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fbcc_ros.studies.montecarlo_cases",
                                     description=__doc__.splitlines()[0])  # fmt: skip
    parser.add_argument("--case", nargs="+", action="append", required=True,
                        metavar=("NAME", "TRIALS_CSV"),
                        help="a case's name and its study's trials.csv (a study in parts: theirs)")
    parser.add_argument("--law", default="fbcc", help="the law's rows (fbcc)")
    parser.add_argument("--figure", type=Path,
                        help="draw success against friction and the wedging ratio here (PNG)")
    args = parser.parse_args(argv)
    cases: dict[str, Study] = {}
    for name, *given in args.case:
        if name in cases:
            parser.error(f"--case {name!r} is given twice: expected distinct names")
        try:
            paths = study_parts(given)
            if not paths:
                parser.error(f"--case {name!r} names no trials.csv: expected NAME TRIALS_CSV...")
            cases[name] = join_parts(paths, args.law)
        except ValueError as exc:
            parser.error(str(exc))
    print(markdown(cases))
    if args.figure:
        draw(cases, args.figure)
        print(f"wrote {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
