"""Two Monte Carlo studies of the same trials on two plants, trial by trial: which trials
succeeded on each (assembled within the force limit), and success and peak Fz against the
drawn friction.

A trial is its seed (:mod:`fbcc_ros.core.sim.montecarlo`): ``fbcc-montecarlo`` with the same
scenario, seed and draws, once with ``--plant model`` and once with ``--plant mujoco``, runs
each trial's part, deviation and noise on both plants, so their rows can be paired.

Command: ``python -m fbcc_ros.studies.plants_trial_by_trial MODEL/trials.csv MUJOCO/trials.csv``
prints the tables of docs/plant.md (a study run in parts: ``PART1/trials.csv,PART2/trials.csv``).
"""

from __future__ import annotations

import argparse
import itertools
import sys

import numpy as np

from fbcc_ros.studies.trials_csv import Study, bin_masks, friction_edges, join_parts, study_parts

#: The columns a trial's draw fills: two studies pair only where all of them agree.
DRAWN = ("dx0", "dy0", "theta_x0", "theta_y0", "hole_radius", "peg_radius", "stiffness",
         "friction")


def pair_trials(a: Study, b: Study) -> list[tuple[int, dict[str, float], dict[str, float]]]:
    """The trials both studies ran, checked to be the same draws."""
    common = sorted(set(a) & set(b))
    if not common:
        raise ValueError("the two studies share no trial")
    for i in common:
        for key in DRAWN:
            if a[i][key] != b[i][key]:
                raise ValueError(f"trial {i} differs in {key} ({a[i][key]} vs {b[i][key]}): "
                                 "not the same scenario, seed and draws")  # fmt: skip
    return [(i, a[i], b[i]) for i in common]


def markdown(pairs: list[tuple[int, dict[str, float], dict[str, float]]],
             names: tuple[str, str]) -> str:  # fmt: skip
    """The trial-by-trial table and the table against friction (its range in
    :data:`~.trials_csv.BINS` bins). A success is the study's: assembled, and within the
    force limit."""
    ok = np.array([[p[1]["success"], p[2]["success"]] for p in pairs], dtype=bool)
    n = len(pairs)
    first, second = names
    lines = [f"| {n} trials | {second} succeeded | {second} not |", "|---|---|---|",
             f"| {first} succeeded | {int((ok[:, 0] & ok[:, 1]).sum())} | "
             f"{int((ok[:, 0] & ~ok[:, 1]).sum())} |",
             f"| {first} not | {int((~ok[:, 0] & ok[:, 1]).sum())} | "
             f"{int((~ok[:, 0] & ~ok[:, 1]).sum())} |", "",
             f"| μ | trials | {first} succeeded | {second} succeeded | {first} peak Fz median "
             f"| {second} peak Fz median |", "|---|---|---|---|---|---|"]  # fmt: skip
    mu = np.array([p[1]["friction"] for p in pairs])
    peak = np.array([[p[1]["peak_fz"], p[2]["peak_fz"]] for p in pairs])
    edges = friction_edges(mu)
    for (lo, hi), inside in zip(itertools.pairwise(edges), bin_masks(mu, edges), strict=True):
        k = int(inside.sum())
        if not k:
            continue
        a, b = ok[inside].mean(axis=0)
        pa, pb = np.median(peak[inside], axis=0)
        lines.append(f"| {lo:.2f}-{hi:.2f} | {k} | {a:.1%} | {b:.1%} | {pa:.1f} N | {pb:.1f} N |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fbcc_ros.studies.plants_trial_by_trial",
                                     description=__doc__.splitlines()[0])  # fmt: skip
    for name in ("first", "second"):
        parser.add_argument(name, metavar=f"{name[0].upper()}/trials.csv",
                            help="a study's trials.csv; a study run in parts: theirs, joined "
                            "by commas")  # fmt: skip
    parser.add_argument("--law", default="fbcc", help="the law's rows (fbcc)")
    parser.add_argument("--names", nargs=2, default=("model", "MuJoCo"),
                        metavar=("A", "B"), help="the plants' names in the tables")  # fmt: skip
    args = parser.parse_args(argv)
    try:
        studies = [study_parts([arg]) for arg in (args.first, args.second)]
        pairs = pair_trials(*(join_parts(parts, args.law) for parts in studies))
    except ValueError as exc:
        parser.error(str(exc))
    print(markdown(pairs, tuple(args.names)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
