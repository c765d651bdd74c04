"""Monte Carlo studies of several cases side by side: success (assembled within the force
limit) with its 95 % interval, how the others failed, peak Fz and insertion time, and success
against the drawn friction, as a table and a figure.

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
import sys
from pathlib import Path

import numpy as np

from fbcc_ros.core.sim.montecarlo import wilson_interval
from fbcc_ros.studies.trials_csv import Study, friction_bins, join_parts


def friction_range(cases: dict[str, Study]) -> tuple[float, float]:
    """The friction every case drew, lowest and highest: the cases' common bins."""
    mu = [row["friction"] for case in cases.values() for row in case.values()]
    return min(mu), max(mu)


def by_friction(case: Study, low: float, high: float) -> list[tuple[int, int]]:
    """(successes, trials) of each friction bin over [low, high]."""
    mu = np.array([row["friction"] for row in case.values()])
    ok = np.array([bool(row["success"]) for row in case.values()])
    return [(int(ok[inside].sum()), int(inside.sum()))
            for _lo, _hi, inside in friction_bins(mu, low, high)]  # fmt: skip


def _percent(k: int, n: int) -> str:
    if not n:
        return "-"
    lo, hi = wilson_interval(k, n)
    return f"{k / n:.1%} ({lo:.1%}-{hi:.1%})"


def markdown(cases: dict[str, Study]) -> str:
    """The cases' table (a trial succeeded, or failed on the force limit, or else was not
    assembled at the end) and the table of success against friction."""
    lines = ["| case | trials | succeeded (95 %) | failed: force limit | failed: not assembled at "
             "the end | peak Fz median, p99 | insertion time median |",
             "|---|---|---|---|---|---|---|"]  # fmt: skip
    for name, case in cases.items():
        rows = list(case.values())
        ok = np.array([bool(r["success"]) for r in rows])
        limited = np.array([bool(r["force_limited"]) for r in rows])
        time = np.array([r["insertion_time"] for r in rows])
        peak = np.array([r["peak_fz"] for r in rows])
        assembled = ~np.isnan(time)
        median_time = f"{np.median(time[ok]):.2f} s" if ok.any() else "-"
        lines.append(f"| {name} | {len(rows)} | {_percent(int(ok.sum()), len(rows))} | "
                     f"{int(limited.sum())} | {int((~assembled & ~limited).sum())} | "
                     f"{np.median(peak):.1f}, {np.percentile(peak, 99):.1f} N | {median_time} |")
    low, high = friction_range(cases)
    lines += ["", "| μ | " + " | ".join(cases) + " |", "|---" * (len(cases) + 1) + "|"]
    counts = {name: by_friction(case, low, high) for name, case in cases.items()}
    bins = friction_bins(np.array([]), low, high)
    for b, (lo, hi, _none) in enumerate(bins):
        cells = [f"{k}/{n}" + (f" ({k / n:.0%})" if n else "") for k, n in
                 (counts[name][b] for name in cases)]  # fmt: skip
        lines.append(f"| {lo:.2f}-{hi:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def draw(cases: dict[str, Study], path: Path) -> None:
    """Success against friction, one line per case, with the bins' 95 % intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    low, high = friction_range(cases)
    centres = [0.5 * (lo + hi) for lo, hi, _none in friction_bins(np.array([]), low, high)]
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for j, (name, case) in enumerate(cases.items()):
        counts = by_friction(case, low, high)
        shown = [(c, k / n, *wilson_interval(k, n))
                 for c, (k, n) in zip(centres, counts, strict=True) if n]  # fmt: skip
        x, rate, lo, hi = (np.array(v) for v in zip(*shown, strict=True))
        shift = (j - (len(cases) - 1) / 2) * 0.004  # the error bars side by side
        ax.errorbar(x + shift, 100 * rate, yerr=100 * np.array([rate - lo, hi - rate]),
                    marker="o", capsize=3, label=f"{name} ({len(case)} trials)")
    ax.set(xlabel="friction μ (bin centre)", ylabel="succeeded [%] (95 % interval)",
           ylim=(0, 100))  # fmt: skip
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
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
    parser.add_argument("--figure", type=Path, help="draw success against friction here (PNG)")
    args = parser.parse_args(argv)
    cases: dict[str, Study] = {}
    for name, *given in args.case:
        paths = [p for arg in given for p in arg.split(",")]  # parts: apart, or comma-joined
        if not paths:
            parser.error(f"--case {name!r} names no trials.csv: expected NAME TRIALS_CSV...")
        if name in cases:
            parser.error(f"--case {name!r} is given twice: expected distinct names")
        for path in map(Path, paths):
            if not path.is_file():
                parser.error(f"{path}: no such file (a study's trials.csv)")
        try:
            cases[name] = join_parts([Path(p) for p in paths], args.law)
        except ValueError as exc:
            parser.error(str(exc))
    print(markdown(cases))
    if args.figure:
        draw(cases, args.figure)
        print(f"wrote {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
