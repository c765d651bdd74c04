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
import itertools
import sys
from pathlib import Path

import numpy as np

from fbcc_ros.core.sim.montecarlo import wilson_interval
from fbcc_ros.studies.plants_trial_by_trial import BINS, read_trials

Case = dict[int, dict[str, float]]


def join_parts(paths: list[Path], law: str) -> Case:
    """The trials of one study run in parts, by number."""
    joined: Case = {}
    for path in paths:
        for number, row in read_trials(path, law).items():
            if number in joined and joined[number] != row:
                raise ValueError(f"trial {number} is in two parts of the case with different "
                                 f"rows ({path} and an earlier one): not one study")  # fmt: skip
            joined[number] = row
    return joined


def friction_edges(cases: dict[str, Case]) -> np.ndarray:
    """:data:`BINS` bins over the friction every case drew."""
    mu = np.array([row["friction"] for case in cases.values() for row in case.values()])
    return np.linspace(mu.min(), mu.max(), BINS + 1)


def by_friction(case: Case, edges: np.ndarray) -> list[tuple[int, int]]:
    """(successes, trials) of each friction bin."""
    mu = np.array([row["friction"] for row in case.values()])
    ok = np.array([bool(row["success"]) for row in case.values()])
    counts = []
    for lo, hi in itertools.pairwise(edges):
        inside = (mu >= lo) & ((mu < hi) | (hi == edges[-1]))
        counts.append((int(ok[inside].sum()), int(inside.sum())))
    return counts


def _percent(k: int, n: int) -> str:
    if not n:
        return "-"
    lo, hi = wilson_interval(k, n)
    return f"{k / n:.1%} ({lo:.1%}-{hi:.1%})"


def markdown(cases: dict[str, Case]) -> str:
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
    edges = friction_edges(cases)
    lines += ["", "| μ | " + " | ".join(cases) + " |", "|---" * (len(cases) + 1) + "|"]
    counts = {name: by_friction(case, edges) for name, case in cases.items()}
    for b, (lo, hi) in enumerate(itertools.pairwise(edges)):
        cells = [f"{k}/{n}" + (f" ({k / n:.0%})" if n else "") for k, n in
                 (counts[name][b] for name in cases)]  # fmt: skip
        lines.append(f"| {lo:.2f}-{hi:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def draw(cases: dict[str, Case], path: Path) -> None:
    """Success against friction, one line per case, with the bins' 95 % intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    edges = friction_edges(cases)
    centres = 0.5 * (edges[:-1] + edges[1:])
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for j, (name, case) in enumerate(cases.items()):
        counts = by_friction(case, edges)
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
                        help="a case's name and its study's trials.csv (several: its parts)")
    parser.add_argument("--law", default="fbcc", help="the law's rows (fbcc)")
    parser.add_argument("--figure", type=Path, help="draw success against friction here (PNG)")
    args = parser.parse_args(argv)
    cases: dict[str, Case] = {}
    for name, *paths in args.case:
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
