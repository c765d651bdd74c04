"""``fbcc-bench``'s figures for the MuJoCo plant (issue "the cell on MuJoCo"): the real-time
factor of one trial on one core, against the 2x real time a 1000-trial study needs to finish
in 20 minutes on two cores, beside the model plant's on the same trial; and of a trial whose
peg wedges, as most of the MuJoCo Monte Carlo's do (docs/plant.md). The model runs with the
rim (``geometry.rim``), so its figure is the rim's cost too."""

from __future__ import annotations

import time
from collections.abc import Callable

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
    spec["geometry"] = {**base["geometry"], "rim": True, "chamfer": 3e-4}  # both plants'
    return {plant: _realtime({**spec, "plant": {"type": plant}})
            for plant in ("model", "mujoco")}  # fmt: skip


def bench_wedged(duration: float) -> float:
    """Real-time factor of MuJoCo on the same pair tilted 2° in both planes, ``duration`` [s]:
    the peg wedges at the chamfer and the law presses on (tens of contacts a timestep)."""
    base = paper_scenario("clearance")
    tilt = 0.0349
    return _realtime({**base, "initial": {"dx": 5e-5, "dy": -5e-5, "theta_x": tilt,
                                          "theta_y": -tilt},
                      "insertion": {"depth": 0.004, "speed": 0.005}, "duration": duration,
                      "holder": {"lateral": 5e4, "angular": 30.0},
                      "geometry": {**base["geometry"], "rim": True, "chamfer": 3e-4},
                      "plant": {"type": "mujoco"}})  # fmt: skip


def _realtime(spec: dict[str, object]) -> float:
    sc = validate(spec)
    t0 = time.perf_counter()
    simulate(sc, "fbcc", record=False)
    return sc.duration / (time.perf_counter() - t0)


def report_plants(short: bool, line: Callable[[str, str, str, float], None]) -> None:
    """Prints the figures (module doc) with ``line(figure, measured, target, ratio)``."""
    plants = bench_plants(0.0005 if short else 0.003)
    line("one trial on MuJoCo [x real time]", f"{plants['mujoco']:.2f}",
         f">= {PLANT_REALTIME_TARGET:.0f}", plants["mujoco"] / PLANT_REALTIME_TARGET)
    print(f"{'  the same trial on the model [x real time]':46s} {plants['model']:12.1f}")
    wedged = bench_wedged(0.4 if short else 2.5)
    line("a wedged trial on MuJoCo [x real time]", f"{wedged:.2f}",
         f">= {PLANT_REALTIME_TARGET:.0f}", wedged / PLANT_REALTIME_TARGET)
