"""The robust law behind a cell's delay (docs/reproduction.md): the simulator's plant with its
commands reaching the robot ``robot.delay`` late, one line per run.

    .venv/bin/python scripts/studies/delays.py unstated   # the default loop_delay (10 ms)
    .venv/bin/python scripts/studies/delays.py stiff      # 10 GPa, loop_delay 55 ms stated

``unstated``: interference 0.184 GPa and clearance 1 and 10 GPa, lateral deviations 50/-30 µm,
20-80 ms of delay behind the default gains. ``stiff``: clearance 10 GPa, 60/-40 µm, 30-70 ms
behind a stated 55 ms, with and without the lateral lead.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from fbcc_ros.core.control.robust_params import RobustParams
from fbcc_ros.core.sim.scenario import validate
from fbcc_ros.core.sim.simulation import simulate

#: The hole radius of each fit; the peg is 5.04 mm, the hole 10 mm deep.
FITS = {"clearance": 5.05e-3, "interference": 5.03e-3}


def run(fit: str, k: float, dev: tuple[float, float], delay: float, params: RobustParams
        ) -> str:  # fmt: skip
    """One 4 s insertion, as a line: assembled, final depth, peak |F|, and how far the depth
    command went back over the run (the depth loop's oscillation)."""
    sc = validate({"geometry": {"hole_radius": FITS[fit], "peg_radius": 5.04e-3,
                                "hole_depth": 0.01, "base_thickness": 0.005, "friction": 0.3,
                                "stiffness": k},
                   "initial": {"dx": dev[0], "dy": dev[1], "theta_x": 0.0, "theta_y": 0.0},
                   "robot": {"delay": delay}, "duration": 4.0})  # fmt: skip
    sc = dataclasses.replace(sc, params=params)
    outcome, traj = simulate(sc, "fbcc")
    assert traj is not None
    depth_cmd = traj.command[:, 0, 2]
    back = -np.diff(depth_cmd).clip(max=0.0).sum()
    lead = f"{params.lateral_lead * 1e6:g} µm" if params.lateral_lead < 1e-3 else "unbounded"
    return (f"{fit} {k / 1e9:g} GPa, delay {delay * 1e3:.0f} ms, loop_delay "
            f"{params.loop_delay * 1e3:.0f} ms, lateral_lead {lead}: "
            f"{'assembled' if outcome.success[0] else 'not assembled'}"
            f"{', force-limited' if outcome.force_limited[0] else ''}, depth "
            f"{traj.pose[-1, 0, 2] * 1e3:.2f} mm, peak |F| {outcome.peak_force[0]:.0f} N, "
            f"depth command back {back * 1e3:.2f} mm")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("study", choices=["unstated", "stiff"])
    args = parser.parse_args()
    if args.study == "unstated":
        for fit, k in (("interference", 1.84e8), ("clearance", 1e9), ("clearance", 1e10)):
            for delay in (0.02, 0.04, 0.06, 0.08):
                print(run(fit, k, (5e-5, -3e-5), delay, RobustParams()), flush=True)
    else:
        for lead in (RobustParams().lateral_lead, 1.0):
            for delay in (0.03, 0.05, 0.07):
                print(run("clearance", 1e10, (6e-5, -4e-5), delay,
                          RobustParams(loop_delay=0.055, lateral_lead=lead)), flush=True)


if __name__ == "__main__":
    main()
