"""fbcc-kinematics: can this arm follow this assembly? The TCP solution along a simulated run.

    fbcc-kinematics SCENARIO.yaml --robot iiwa14 --out DIR [--law fbcc]
                    [--hole-xyz X Y Z --hole-rpy R P Y] [--tool-xyz X Y Z --tool-rpy R P Y]

Simulates the scenario with one law (the closed loop of ``fbcc-sim``), then drives the robot's
TCP solution with the command features of every control step, warm-started and bounded by the
joint velocity limits over one period, as the kinematics node does. DIR receives

* ``joints.csv``: per step the time, the command features, the joints, the IK iterations and
  the IK time;
* ``summary.json``: the largest feature error of the reached joints, the IK iterations and
  time (median, p99), and each joint's travel and peak speed against its limit;
* ``joints.png``: joint travel from the start [mrad] and the feature error over time.

The hole is placed, by default, aligned under the peg at the robot's home configuration with its
top face at the peg's tip; ``--hole-xyz/--hole-rpy`` give {H} in the base frame instead. Exit
status 1 when the robot cannot follow (the step and the reason are printed), 2 on bad input.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from fbcc_ros.cli.common import out_dir
from fbcc_ros.core.contact.model import FEATURE_NAMES
from fbcc_ros.core.errors import command
from fbcc_ros.core.kinematics.cell import CellKinematics, FollowResult, aligned_hole_at, follow
from fbcc_ros.core.kinematics.ik import IkError, solve_ik
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel, Tool, pose
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.simulation import simulate


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fbcc-kinematics",
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("scenario", type=Path, help="scenario YAML (DESIGN §4)")
    parser.add_argument("--robot", default="iiwa14", choices=sorted(ROBOTS))
    parser.add_argument("--law", default=None, help="law to simulate (default: the first)")
    parser.add_argument("--out", required=True, help="output folder")
    for name, unit in (
        ("hole-xyz", "m"),
        ("hole-rpy", "rad"),
        ("tool-xyz", "m"),
        ("tool-rpy", "rad"),
    ):
        parser.add_argument(
            f"--{name}", type=float, nargs=3, metavar=("X", "Y", "Z"), help=f"[{unit}]"
        )
    return parser


def _summary(
    robot: RobotModel, result: FollowResult, commands: np.ndarray, dt: float
) -> dict[str, Any]:
    error = np.abs(result.features - commands).max(axis=0)
    speed = np.abs(np.diff(result.q, axis=0)).max(axis=0) / dt
    us = result.seconds * 1e6
    return {
        "robot": robot.name,
        "steps": len(commands),
        "max_feature_error": dict(zip(FEATURE_NAMES, error.tolist(), strict=True)),
        "ik_iterations": {
            "median": float(np.median(result.iterations)),
            "max": int(result.iterations.max()),
        },
        "ik_time_us": {"median": float(np.median(us)), "p99": float(np.percentile(us, 99))},
        "joints": {
            name: {
                "travel": float(np.ptp(result.q[:, i])),
                "peak_speed": float(speed[i]),
                "speed_limit": float(robot.velocity_limit[i]),
            }
            for i, name in enumerate(robot.joint_names)
        },
    }


def _plot(
    robot: RobotModel, result: FollowResult, commands: np.ndarray, dt: float, path: Path
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.arange(len(commands)) * dt
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for i, name in enumerate(robot.joint_names):
        top.plot(t, (result.q[:, i] - result.q[0, i]) * 1e3, label=name)
    top.set_ylabel("joint travel from start [mrad]")
    top.legend(fontsize=7, ncol=2)
    top.set_title(f"{robot.name}: TCP solution along the simulated assembly")
    error = result.features - commands
    units = ("nm", "nm", "nm", "nrad", "nrad")
    for i, (name, unit) in enumerate(zip(FEATURE_NAMES, units, strict=True)):
        bottom.plot(t, error[:, i] * 1e9, label=f"{name} [{unit}]")
    bottom.set_ylabel("features(q) - command")
    bottom.set_xlabel("t [s]")
    bottom.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


@command("fbcc-kinematics")
def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    out = out_dir(parser, args.out)
    sc = scenario_io.load(args.scenario)
    law = args.law or sc.laws[0]
    if law not in sc.laws:
        parser.error(f"--law {law!r}: the scenario runs {list(sc.laws)}")
    tool = None
    if args.tool_xyz or args.tool_rpy:
        tool = Tool(tuple(args.tool_xyz or Tool().xyz), tuple(args.tool_rpy or Tool().rpy))
    robot = RobotModel.from_name(args.robot, tool)
    if args.hole_xyz:
        hole = pose(args.hole_xyz, args.hole_rpy or (0.0, 0.0, 0.0))
    else:
        hole = aligned_hole_at(robot.peg_in_base(robot.home))
    cell = CellKinematics(robot, hole, sc.geometry.peg_radius)
    dt = 1.0 / sc.rate_hz
    print(f"simulating {sc.name} with {law} ...", flush=True)
    _, trajectory = simulate(sc, law, record=True)
    assert trajectory is not None
    commands = trajectory.command[:, 0, :]
    try:
        q_start = solve_ik(robot, cell.peg_target(commands[0], 0.0), robot.home).q
        print(f"following {len(commands)} steps on {robot.name} ...", flush=True)
        result = follow(cell, commands, q_start, dt)
    except IkError as exc:
        print(f"fbcc-kinematics: {robot.name} cannot follow {sc.name}: {exc}", file=sys.stderr)
        return 1
    summary = _summary(robot, result, commands, dt)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    with (out / "joints.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        cmd_names = [f"{n}_cmd" for n in FEATURE_NAMES]
        writer.writerow(["t", *cmd_names, *robot.joint_names, "ik_iterations", "ik_us"])
        for k in range(len(commands)):
            writer.writerow(
                [
                    f"{k * dt:.6f}",
                    *commands[k].tolist(),
                    *result.q[k].tolist(),
                    int(result.iterations[k]),
                    f"{result.seconds[k] * 1e6:.1f}",
                ]
            )
    _plot(robot, result, commands, dt, out / "joints.png")
    worst = max(summary["max_feature_error"].values())
    ik = summary["ik_time_us"]
    print(
        f"{robot.name} followed all {len(commands)} steps: features within {worst:.2e} of the "
        f"command, IK {ik['median']:.0f} µs median / {ik['p99']:.0f} µs p99; wrote {out}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
