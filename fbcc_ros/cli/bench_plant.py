"""``fbcc-bench``'s figure for the MuJoCo plant (issue "the cell on MuJoCo"): the real-time
factor of one trial on one core, against the 2x real time a 1000-trial study needs to finish
in 20 minutes on two cores, beside the model plant's on the same trial."""

from __future__ import annotations

import time

from fbcc_ros.core.paper import paper_scenario
from fbcc_ros.core.sim.scenario import validate
from fbcc_ros.core.sim.simulation import simulate

#: The MuJoCo plant's target: simulated seconds per wall second, one trial on one core.
PLANT_REALTIME_TARGET = 2.0


def bench_plants(depth: float) -> dict[str, float]:
    """Real-time factor per plant (simulated s / wall s) of the paper's clearance pair 0.1 mm
    off into a 0.3 mm chamfer, ``depth`` [m] at 5 mm/s with the shipped law, at 1 kHz: the
    peg in contact with the bore for most of the trial."""
    base = paper_scenario("clearance")
    spec = {**base, "initial": {**base["initial"], "dx": 1e-4, "theta_x": 0.0, "theta_y": 0.0},
            "insertion": {"depth": depth, "speed": 0.005}, "duration": depth / 0.005 + 0.4,
            "holder": {"lateral": 5e4, "angular": 30.0}}  # fmt: skip
    factors = {}
    for plant in ("model", "mujoco"):
        sc = validate({**spec, "plant": {"type": plant, "chamfer": 3e-4}})
        t0 = time.perf_counter()
        simulate(sc, "fbcc", record=False)
        factors[plant] = sc.duration / (time.perf_counter() - t0)
    return factors
