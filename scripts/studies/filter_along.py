"""The deviation filter along the state study's insertions, on any seed (docs/boundary-mapping.md):
per fit and stiffness, the share of states named right, the filter's CPU a 1 kHz sample, how
many scored samples rest free (true P0) or touch with less than 3 noise deviations, and the
calibration of the probability it states.

    .venv/bin/python scripts/studies/filter_along.py --seed 3 --trials 32
    .venv/bin/python scripts/studies/filter_along.py --seed 0 --trials 8 --cases clearance:1e10
    .venv/bin/python scripts/studies/filter_along.py --seed 5 --trials 32 --cases clearance:1e10 \
        --per-insertion
    .venv/bin/python scripts/studies/filter_along.py --seed 7 --trials 16 \
        --readout-spreads 1e-7,3e-7
    .venv/bin/python scripts/studies/filter_along.py --seed 2,3 --trials 16 --cases \
        interference:1.84e8,interference:5e8,interference:1e9 --powers 1,2,2.5,3,4

The insertions are those of ``fbcc-mapping-study --estimator`` (F/T under the hole, or with
``--wrist`` at the wrist): parts and
deviations by ``state_study.drawn_insertions``, the filter as the controller runs it
(``deviation_filter.along``'s feed and filter, stepped here to watch it: every 5th sample, seed
``trial``, told the case's k as the part's nominal one, or with ``--unknown-k`` nothing of it),
scored where the peg is in the hole, both planes. ``--per-insertion`` adds a line per insertion:
its share named right, the lowest running mean of the filter's surprise (``LOST`` and under:
redrawn) and how often it was redrawn. ``--readout-spreads`` adds, per readout spread of the
offset (the tilt's 100 rad/m times it, the ratio of ``READOUT_SPREAD``), the share named right,
the expected calibration error and the calibration of the same clouds read with it after each
update (the CPU figure then includes these readouts). ``--powers`` runs the filter with its
votes uncalibrated (``state_calibration.SHARPNESS`` set to 1) and, pooled over every seed and
case run, scores them raised to each power: the share right, the calibration error, the
log-loss of the true state and the calibration (how ``SHARPNESS`` was chosen). With several
seeds, a last line per case pools them: the share right over all its insertions, and how often a
case of ``--trials`` insertions drawn from them falls under 90 %; and a line per fit run at
several stiffnesses, how often a study of ``--trials`` at each (the state study's pooled row)
falls under 90 %. ``--by-time`` adds, per case
pooled over the seeds, the share named right and the probability stated by the time since the
insertion's first scored sample (``TIME_EDGES``).
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from fbcc_ros.cli.state_study import STIFFNESS
from fbcc_ros.core.contact.segmentation import STATES, feature_state
from fbcc_ros.core.control.contact_state import most_probable
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.control.deviation_filter import UNKNOWN_STIFFNESS, DeviationFilter
from fbcc_ros.core.control.state_calibration import SHARPNESS, sharpened
from fbcc_ros.core.control.state_feed import StateFeed
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.simulation import simulate
from fbcc_ros.core.sim.state_study import Tally, calibration_text, drawn_insertions

#: The state study's cases.
CASES = ",".join(f"{fit}:{k:g}" for fit, ks in STIFFNESS.items() for k in ks)
#: A touch under this many deviations of the sensor's noise in |F| is below what one sample
#: shows.
FAINT = 3.0


def case(fit: str, k: float, trials: int, seed: int, unknown_k: bool = False,
         per_insertion: bool = False, spreads: tuple[float, ...] = (), wrist: bool = False,
         votes: list[tuple[np.ndarray, np.ndarray]] | None = None,
         shares: list[float] | None = None, by_time: np.ndarray | None = None,
         ) -> str:  # fmt: skip
    """The share named right, the CPU, the free and the faint shares; ``per_insertion``, first
    a line per insertion. The filter is told the part's k (to within the uncertainty's
    factor), or, ``unknown_k``, nothing of it. ``votes`` collects each insertion's P(state)
    where scored (n, 2, 9) and the true states' indices (n, 2); ``shares`` each insertion's share
    named right; ``by_time`` (len(TIME_EDGES) - 1, 3) adds, per window of the time since the
    insertion's first scored sample, the samples, those named right and the probabilities
    stated."""
    sc = scenario_io.load(scenario_io.find(f"config/scenarios/robust_{fit}.yaml"))
    if wrist:
        sc = dataclasses.replace(sc, geometry=sc.geometry.replace(acting_point="peg_top"))
    unc = Uncertainty()
    parts, dev = drawn_insertions(sc, unc, k, trials, seed)
    _, traj = simulate(sc, "fbcc", initial=dev, geometries=parts, seed=seed)
    assert traj is not None
    right = scored = free = faint = 0
    tally = Tally()
    cpu = 0.0
    lines = []
    read = {s: Tally() for s in spreads}
    for i in range(trials):
        x, w, pose = traj.features[:, i], traj.measured[:, i], traj.pose[:, i]
        start = time.process_time()
        rows, handed = StateFeed(5).samples(pose, w)
        filt = DeviationFilter(sc.geometry.replace(stiffness=k), unc, seed=i,
                               **({"stiffness": UNKNOWN_STIFFNESS} if unknown_k else {}))
        p, lowest = np.empty((len(rows), 2, len(STATES))), 0.0
        again = np.empty((len(spreads), len(rows), 2, len(STATES)))
        for j, sample in enumerate(handed):
            p[j] = filt.update(*sample)
            lowest = min(lowest, filt.surprise_mean)
            if spreads:
                x_now = filt.true_features(sample.now)
                for m, s in enumerate(spreads):
                    again[m, j] = filt.states(x_now, spread=(s, 100.0 * s))
        cpu += time.process_time() - start
        named, stated = most_probable(p)
        inside = x[rows, 2] > 0
        truth = feature_state(x[rows[inside]], parts[i])
        if votes is not None:
            votes.append((p[inside], np.array([[STATES.index(s) for s in truth[plane]]
                                               for plane in range(2)]).T))  # fmt: skip
        tally.add(np.column_stack(truth), named[inside], stated[inside])
        for m, s in enumerate(spreads):
            n_s, p_s = most_probable(again[m])
            read[s].add(np.column_stack(truth), n_s[inside], p_s[inside])
        force = np.linalg.norm(traj.response[rows[inside], i, :3], axis=1)
        hits = sum(int((named[inside, plane] == truth[plane]).sum()) for plane in range(2))
        for plane in range(2):
            free += int((truth[plane] == "P0").sum())
            faint += int(((truth[plane] != "P0") & (force < FAINT * unc.noise[2])).sum())
        right += hits
        if by_time is not None:
            since = traj.t[rows[inside]] - traj.t[rows[inside][0]]
            window = np.searchsorted(TIME_EDGES, since, side="right") - 1
            for plane in range(2):
                np.add.at(by_time, (window, 0), 1)
                np.add.at(by_time, (window, 1), named[inside, plane] == truth[plane])
                np.add.at(by_time, (window, 2), stated[inside, plane])
        if shares is not None:
            shares.append(hits / (2 * int(inside.sum())))
        scored += 2 * int(inside.sum())
        lines.append(f"  insertion {i}: right {hits / (2 * inside.sum()):.2f}, lowest surprise "
                     f"mean {lowest:.1f}, redrawn {filt.redraws}")
    summary = (f"{fit} {k / 1e9:g} GPa, seed {seed}, {trials} insertions: right "
               f"{right / scored:.3f}, CPU {cpu / (trials * traj.t.size) * 1e6:.0f} µs a sample; "
               f"of {scored} scored: free {free / scored:.2f}, touching under {FAINT:g} σ "
               f"{faint / scored:.2f}\n  calibration (stated: share right, samples): "
               f"{calibration_text(tally.calibration())}")
    for s, t in read.items():
        summary += (f"\n  readout spread {s:g} m: right {t.accuracy:.3f}, calibration error "
                    f"{t.calibration_error():.3f}; {calibration_text(t.calibration())}")
    return "\n".join([*lines, summary] if per_insertion else [summary])


#: The windows of time since an insertion's first scored sample [s] that ``--by-time`` reads
#: the share right in: the first updates in the hole, before the history says much.
TIME_EDGES = np.array([0.0, 0.05, 0.125, 0.25, 0.5, 1.0, np.inf])


def by_time_text(item: str, seeds: list[int], tally: np.ndarray) -> str:
    """Per window of TIME_EDGES, pooled over ``seeds``: the share of the scored samples in it,
    the share named right and the mean probability stated (``case``'s ``by_time``)."""
    total = tally[:, 0].sum()
    windows = zip(TIME_EDGES[:-1], TIME_EDGES[1:], tally, strict=True)
    cells = [f"{lo:g}-{hi:g} s: {n / total:.3f} of the samples, right {r / n:.3f}, stated "
             f"{p / n:.3f}" for lo, hi, (n, r, p) in windows if n]  # fmt: skip
    return (f"{item} by the time since the first scored sample (seeds "
            f"{','.join(map(str, seeds))}):\n  " + "\n  ".join(cells))


#: Cases drawn from the pooled insertions to tell how often a case falls under 90 %.
BOOTSTRAP = 100_000


def drawn_studies(shares: list[list[float]], trials: int) -> np.ndarray:
    """The shares right of BOOTSTRAP studies of ``trials`` insertions at each stiffness, each
    drawn with replacement from that stiffness's insertions' ``shares`` (one list each), each
    insertion counted alike (the state study weighs them by their samples: they hold about
    as many, 1 600 each)."""
    rng = np.random.default_rng(0)
    return np.mean([rng.choice(np.array(v), size=(BOOTSTRAP, trials)).mean(axis=1)
                    for v in shares], axis=0)  # fmt: skip


def pooled_text(item: str, seeds: list[int], shares: list[float], trials: int) -> str:
    """The share named right pooled over ``seeds`` (the insertions' mean) and, drawing cases of
    ``trials`` insertions from them with replacement, how often a case falls under 0.90."""
    v = np.array(shares)
    cases = drawn_studies([shares], trials)
    return (f"{item} pooled over seeds {','.join(map(str, seeds))} ({len(v)} insertions): right "
            f"{v.mean():.3f}, under 0.8 right {int(np.sum(v < 0.8))}; a case of {trials} falls "
            f"under 0.90 with probability {np.mean(cases < 0.9):.3f} (5th percentile "
            f"{np.percentile(cases, 5):.3f})")


def fit_pooled_text(fit: str, seeds: list[int], shares: list[list[float]], trials: int) -> str:
    """A fit as the state study pools it (``fbcc-mapping-study --estimator``: ``trials``
    insertions at each of its stiffnesses): its share pooled over ``seeds``, and how often such
    a study falls under 0.90 (:func:`drawn_studies`; ``shares``, one list per stiffness)."""
    studies = drawn_studies(shares, trials)
    return (f"{fit}, its {len(shares)} stiffnesses pooled over seeds {','.join(map(str, seeds))}"
            f": right {np.mean([np.mean(v) for v in shares]):.3f}; a study of {trials} a "
            f"stiffness falls under 0.90 with probability {np.mean(studies < 0.9):.3f} (5th "
            f"percentile {np.percentile(studies, 5):.3f})")


def powers_text(votes: list[tuple[np.ndarray, np.ndarray]], power: float) -> str:
    """The uncalibrated ``votes`` (``case``'s) raised to ``power`` and normalised
    (``state_calibration.sharpened``): share right, calibration error, log-loss of the true
    state [nats] and the calibration, pooled."""
    p = np.concatenate([v for v, _ in votes]).reshape(-1, len(STATES))
    truth = np.concatenate([t for _, t in votes]).ravel()
    sharp = sharpened(p, power)
    tally = Tally()
    tally.add(np.array(STATES)[truth], np.array(STATES)[sharp.argmax(axis=1)], sharp.max(axis=1))
    loss = -np.mean(np.log(np.maximum(sharp[np.arange(len(truth)), truth], 1e-12)))
    return (f"votes raised to {power:g}: right {tally.accuracy:.3f}, calibration error "
            f"{tally.calibration_error():.3f}, log-loss {loss:.3f}; "
            f"{calibration_text(tally.calibration())}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", default="0", help="a seed, or several comma-separated")
    parser.add_argument("--trials", type=int, default=8)
    parser.add_argument("--cases", default=CASES, help=f"fit:k[Pa],... (default {CASES})")
    parser.add_argument("--unknown-k", action="store_true",
                        help="the filter is not told k (a prior over UNKNOWN_STIFFNESS)")
    parser.add_argument("--readout-spreads", default="",
                        help="offset spreads [m], comma-separated: each one's readout of the "
                             "same clouds, its share right and calibration")
    parser.add_argument("--wrist", action="store_true",
                        help="the F/T sensor at the wrist (default: under the hole)")
    parser.add_argument("--powers", default="",
                        help="powers, comma-separated: the filter runs uncalibrated, and the "
                             "votes of every case and seed run, raised to each, are scored "
                             "pooled (state_calibration's choice)")
    parser.add_argument("--by-time", action="store_true",
                        help="per case, pooled over the seeds: the share named right by the "
                             "time since the first scored sample")
    parser.add_argument("--per-insertion", action="store_true",
                        help="a line per insertion: right, lowest surprise mean, redraws")
    args = parser.parse_args()
    try:
        seeds = [int(v) for v in args.seed.split(",")]
        powers = [float(v) for v in args.powers.split(",") if v.strip()]
        spreads = tuple(float(v) for v in args.readout_spreads.split(",") if v.strip())
    except ValueError:
        parser.error(f"--seed {args.seed!r} --powers {args.powers!r} --readout-spreads "
                     f"{args.readout_spreads!r}: expected comma-separated numbers")
    if args.trials < 1 or min(seeds) < 0 or not all(a > 0 for a in powers):
        parser.error(f"--trials {args.trials} --seed {args.seed} --powers {args.powers}: "
                     "expected >= 1, >= 0 and > 0")
    if not all(s > 0 for s in spreads):
        parser.error(f"--readout-spreads {args.readout_spreads!r}: expected offsets [m] > 0, "
                     "comma-separated")
    votes: list[tuple[np.ndarray, np.ndarray]] | None = [] if powers else None
    if powers:  # the votes as the particles cast them
        SHARPNESS.update(dict.fromkeys(SHARPNESS, 1.0))
    items = args.cases.split(",")
    for item in items:
        if item.partition(":")[0] not in ("clearance", "interference"):
            parser.error(f"--cases {item!r}: expected clearance:k or interference:k")
    shares: dict[str, list[float]] = {item: [] for item in items}
    times = {item: np.zeros((len(TIME_EDGES) - 1, 3)) for item in items}
    for seed in seeds:
        for item in items:
            fit, _, k = item.partition(":")
            print(case(fit, float(k), args.trials, seed, args.unknown_k, args.per_insertion,
                       spreads, args.wrist, votes, shares[item],
                       times[item] if args.by_time else None), flush=True)
    if len(seeds) > 1:
        for item in items:
            print(pooled_text(item, seeds, shares[item], args.trials), flush=True)
        for fit in ("clearance", "interference"):
            of_fit = [shares[item] for item in items if item.partition(":")[0] == fit]
            if len(of_fit) > 1:
                print(fit_pooled_text(fit, seeds, of_fit, args.trials), flush=True)
    if args.by_time:
        for item in items:
            print(by_time_text(item, seeds, times[item]), flush=True)
    for power in powers:
        print(powers_text(votes or [], power), flush=True)


if __name__ == "__main__":
    main()
