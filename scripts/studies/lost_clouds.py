"""Is an insertion the deviation filter names wrong lost, or short of information? Each insertion
named is replayed with the filter and, beside it, a particle at the part's true parameters
(docs/boundary-mapping.md, "A lost cloud is drawn again"):

    .venv/bin/python scripts/studies/lost_clouds.py --seed 9 --case clearance:1e10 \
        --insertions 9,10,11,12

Per insertion: the share of states named right; the share a cloud of particles at the truth,
read the same way, names right; how many nats better the truth explains the samples than the
cloud (the truth's log-likelihood less the log of the cloud's weighted mean likelihood, summed
over the updates after the annealing: hundreds when the cloud is lost, a few when the samples
do not tell); the cloud's final error and spread; and, over the last 100 updates, how the
samples' log-likelihood changes along the straight line from the cloud's mean to the truth (a
steady rise: a cloud that could walk there; a plateau ending at the truth: one that cannot).
The insertions are ``filter_along.py``'s (same seed and trials: the same parts and filter).
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import feature_state
from fbcc_ros.core.control.contact_state import most_probable
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.control.deviation_filter import DeviationFilter
from fbcc_ros.core.control.state_feed import StateFeed
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.simulation import simulate
from fbcc_ros.core.sim.state_study import drawn_insertions

#: Particles of the cloud at the truth (identical: they only read the states as the filter does).
AT_TRUTH = 100
#: Points on the line from the cloud's mean to the truth, and the updates it is summed over.
LINE_POINTS, LINE_UPDATES = 11, 100
#: The error's units in the printout: µm, mrad, µm for (dx, dy, θx, θy, g).
UNITS = np.array([1e6, 1e6, 1e3, 1e3, 1.0, 1e6, 1.0])


def at(nominal: PegHole, unc: Uncertainty, rows: np.ndarray) -> DeviationFilter:
    """A filter whose particles are ``rows`` (n, 7), never resampled (they are not updated)."""
    f = DeviationFilter(nominal, unc, particles=max(100, len(rows)),
                        converged_particles=max(100, len(rows)))  # fmt: skip
    f._theta = np.array(rows, dtype=float)  # the study places the particles; the filter never does
    f._table = np.tile(f._table[:, :1], (1, len(rows)))
    f._logw = np.zeros(len(rows))
    return f


def replay(fit: str, k: float, trials: int, seed: int, which: list[int]) -> None:
    sc = scenario_io.load(scenario_io.find(f"config/scenarios/robust_{fit}.yaml"))
    unc = Uncertainty()
    nominal = sc.geometry.replace(stiffness=k)
    parts, dev = drawn_insertions(sc, unc, k, trials, seed)
    _, traj = simulate(sc, "fbcc", initial=dev, geometries=parts, seed=seed)
    assert traj is not None
    for i in which:
        x, pose, part = traj.features[:, i], traj.pose[:, i], parts[i]
        gap = (part.hole_radius - part.peg_radius) - (nominal.hole_radius - nominal.peg_radius)
        truth = np.array([dev[i][0], dev[i][1], dev[i][3], dev[i][4], part.friction, gap,
                          math.log(part.stiffness)])  # fmt: skip
        rows, handed = StateFeed(5).samples(pose, traj.measured[:, i])
        cloud = DeviationFilter(nominal, unc, seed=i)  # as filter_along.py runs it
        at_truth = at(nominal, unc, np.tile(truth, (AT_TRUTH, 1)))
        better = 0.0
        right, right_truth = [], []
        for j, sample in enumerate(handed):
            if j >= cloud.anneal:
                weights = cloud.weights
                ll = cloud.log_likelihoods(*sample, weights)
                top = ll.max()
                better += (at_truth.log_likelihoods(*sample)[0]
                           - (math.log(weights @ np.exp(ll - top)) + top))  # fmt: skip
            named, _ = most_probable(cloud.update(*sample)[None])
            named_truth, _ = most_probable(
                at_truth.states(at_truth.true_features(sample.now))[None])
            if x[rows[j], 2] > 0:
                true_state = feature_state(x[rows[j]:rows[j] + 1], part)
                right.append(np.mean([named[0, p] == true_state[p][0] for p in range(2)]))
                right_truth.append(np.mean([named_truth[0, p] == true_state[p][0]
                                            for p in range(2)]))  # fmt: skip
        mean, spread = cloud.deviation()
        line = mean + np.linspace(0.0, 1.0, LINE_POINTS)[:, None] * (truth - mean)
        along = at(nominal, unc, line)
        summed = sum(along.log_likelihoods(*s) for s in handed[-LINE_UPDATES:])
        e = (mean - truth) * UNITS
        print(f"{fit} {k / 1e9:g} GPa, seed {seed}, insertion {i}: right {np.mean(right):.3f}, "
              f"at the truth {np.mean(right_truth):.3f}; the truth explains the "
              f"{len(handed) - cloud.anneal} updates after the annealing {better:+.0f} nats "
              f"better; cloud off by dx {e[0]:+.2f} dy {e[1]:+.2f} gap {e[5]:+.2f} µm, "
              f"θx {e[2]:+.3f} θy {e[3]:+.3f} mrad, {spread[0] * 1e6:.2f} µm and gap "
              f"{spread[5] * 1e6:.2f} µm wide, redrawn {cloud.redraws}\n  last "
              f"{LINE_UPDATES} updates along the line cloud → truth [nats]: "
              + " ".join(f"{v - summed[0]:+.0f}" for v in summed), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=9)
    parser.add_argument("--trials", type=int, default=16)
    parser.add_argument("--case", default="clearance:1e10", help="fit:k[Pa]")
    parser.add_argument("--insertions", default="0", help="comma-separated, each < --trials")
    args = parser.parse_args()
    fit, _, k = args.case.partition(":")
    try:
        which = [int(v) for v in args.insertions.split(",")]
        stiffness = float(k)
    except ValueError:
        parser.error(f"--case {args.case!r} --insertions {args.insertions!r}: expected "
                     "clearance:k or interference:k and integers")
    if fit not in ("clearance", "interference") or not stiffness > 0:
        parser.error(f"--case {args.case!r}: expected clearance:k or interference:k, k > 0")
    if args.trials < 1 or args.seed < 0 or not all(0 <= i < args.trials for i in which):
        parser.error(f"--trials {args.trials} --seed {args.seed} --insertions "
                     f"{args.insertions}: expected >= 1, >= 0 and each in 0..trials-1")
    replay(fit, stiffness, args.trials, args.seed, which)


if __name__ == "__main__":
    main()
