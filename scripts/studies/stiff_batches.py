"""The stiff-part batches of docs/reproduction.md, run through the simulator with the robust
scenario (config/scenarios/robust_clearance.yaml) and one line printed per batch:

    .venv/bin/python scripts/studies/stiff_batches.py hard --seed 5
    .venv/bin/python scripts/studies/stiff_batches.py tight --seed 1 [--parts 64] [--set k=v]

``hard``: k 30-100 GPa, mu 0.35-0.5, 4-14 µm of radial clearance; ``tight``: k 20-100 GPa,
mu 0.1-0.5, 0.2-0.5 µm. Both: offsets 50-100 µm and tilts 0.3-2° in both planes, either sign.
``--set name=value`` changes a robust-law parameter (repeatable).
"""

from __future__ import annotations

import argparse
import dataclasses
import math

import numpy as np

from fbcc_ros.core.control.laws import params_from_mapping
from fbcc_ros.core.sim import scenario, simulation

BATCHES = {  # log10 k [Pa], mu, radial clearance [m]
    "hard": ((10.5, 11.0), (0.35, 0.5), (4e-6, 14e-6)),
    "tight": ((10.3, 11.0), (0.1, 0.5), (0.2e-6, 0.5e-6)),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("batch", choices=sorted(BATCHES))
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--parts", type=int, default=64)
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    args = parser.parse_args()
    sc = scenario.load("config/scenarios/robust_clearance.yaml")
    if args.set:
        values = {k: float(v) for k, v in (item.split("=", 1) for item in args.set)}
        sc = dataclasses.replace(sc, params=params_from_mapping(values))
    (k_lo, k_hi), mu, gap = BATCHES[args.batch]
    rng = np.random.default_rng(args.seed)
    n = args.parts
    peg = sc.geometry.peg_radius
    parts = [dataclasses.replace(sc.geometry, stiffness=10 ** rng.uniform(k_lo, k_hi),
                                 friction=rng.uniform(*mu), peg_radius=peg,
                                 hole_radius=peg + rng.uniform(*gap))
             for _ in range(n)]  # fmt: skip
    sign = rng.choice([-1, 1], (n, 4))
    initial = np.c_[sign[:, :2] * rng.uniform(50e-6, 100e-6, (n, 2)), np.zeros(n),
                    sign[:, 2:] * rng.uniform(0.005, 0.035, (n, 2))]  # fmt: skip
    o, _ = simulation.simulate(sc, "fbcc", initial=initial, geometries=parts, record=False)
    t = o.insertion_time
    print(f"{args.batch} seed {args.seed}: {int(o.success.sum())}/{n} assembled, "
          f"{int(o.force_limited.sum())} force-limited, time median {np.nanmedian(t):.2f} s, "
          f"max {np.nanmax(t):.2f} s, {int((t > 3).sum())} over 3 s, "
          f"{int((np.degrees(o.tilt_overshoot) > 0.2).sum())} overshoots past 0.2°, "
          f"misadjustment max {math.degrees(o.tilt_misadjustment.max()):.2f}°")


if __name__ == "__main__":
    main()
