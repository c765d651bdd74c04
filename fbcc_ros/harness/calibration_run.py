"""``fbcc_bringup --calibration-motion``: the calibration flow of a real cell, rehearsed on the
mock.

The mock cell (the scenario's robot and stack, its wrist F/T sensor on:
:mod:`fbcc_ros.core.sim.wrist_sensor`) is driven through a calibration motion
(:mod:`fbcc_ros.core.compensation.calibration_motion`: lifted clear of the hole, the poses of
``calibration_poses`` each held, and back) by :class:`CalibrationMover`, which commands joint
positions on the command topic of the stack the mock plays, from the joint state it measured
first. ``fbcc_record`` records the joint states, the wrist sensor's readings and the robot
description, as a real cell's recording would hold them. The summary holds the poses, the
bag and the command that fits the payload and the bias from it (``fbcc-calibrate BAG``), and
the mock's true payload and bias to judge the fit by.
"""

from __future__ import annotations

import argparse
import functools
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from fbcc_ros.core.compensation.calibration_motion import (
    HOLD,
    CalibrationMotion,
    calibration_motion,
)
from fbcc_ros.core.errors import FbccError, InputError
from fbcc_ros.core.kinematics.robot import RobotModel
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.harness.cell_nodes import CellSetup, profile_of
from fbcc_ros.harness.cell_nodes import cell_nodes as harness_cell_nodes
from fbcc_ros.harness.cell_run import CellRun, NodeSpec
from fbcc_ros.ros import topics
from fbcc_ros.ros.convert import joints_from_cdr, positions_to_cdr

#: What the calibration's bag holds: what fbcc-calibrate BAG reads.
RECORDED = [topics.JOINT_STATES, topics.WRIST_WRENCH, topics.ROBOT_DESCRIPTION]
#: After the motion ends, the cell runs this long, for the arm to settle and the recorder to
#: take the last readings [s].
SETTLE = 0.5


class CalibrationMover(Node):
    """Commands the calibration motion from the first joint state it hears, at ``rate_hz``."""

    def __init__(self, robot: RobotModel, rate_hz: float, command_topic: str, poses: int,
                 hold: float, **kwargs: Any) -> None:  # fmt: skip
        super().__init__("calibration_motion", **kwargs)
        self.robot, self.poses, self.hold = robot, poses, hold
        self.motion: CalibrationMotion | None = None
        self._start = 0.0
        self.pub = self.create_publisher(Float64MultiArray, command_topic, 10)
        self.create_subscription(JointState, topics.JOINT_STATES, self.on_joints, 10, raw=True)
        self.create_timer(1.0 / rate_hz, self.on_tick)

    def on_joints(self, data: bytes) -> None:
        if self.motion is None:  # from where the arm is
            q = joints_from_cdr(data, self.robot.joint_names)[1]
            self.motion = calibration_motion(self.robot, q, self.poses, hold=self.hold)
            self._start = time.monotonic()

    @property
    def elapsed(self) -> float:
        return time.monotonic() - self._start if self.motion is not None else 0.0

    @property
    def done(self) -> bool:
        return self.motion is not None and self.elapsed > self.motion.duration + SETTLE

    def on_tick(self) -> None:
        if self.motion is not None:
            self.pub.publish(positions_to_cdr(self.motion.at(self.elapsed)))


def calibration_specs(scenario_path: str, poses: int, hold: float, processes: bool
                      ) -> tuple[list[NodeSpec], scenario_io.Scenario]:  # fmt: skip
    """The mock (its wrist sensor on) and the mover, for the scenario's robot and stack."""
    from fbcc_ros.nodes.mock_cell import MockCellNode
    from fbcc_ros.pipeline.mock_cell import LBR_NAME

    path = str(scenario_io.find(scenario_path))
    sc = scenario_io.load(path)
    cell = sc.cell
    setup = CellSetup(profile_of(cell.conventions), path, namespace=cell.namespace)
    mock = next(n for n in harness_cell_nodes(setup) if n.name == "mock_cell")
    robot = RobotModel.from_name(cell.model, lbr_name=LBR_NAME if cell.conventions == "lbr"
                                 else "")  # fmt: skip
    mover = functools.partial(CalibrationMover, robot, sc.rate_hz,
                              topics.joint_command(cell.conventions), poses, hold)
    return [NodeSpec("mock_cell", MockCellNode, {**mock.parameters, "wrist_sensor": True},
                     own_process=processes, files=mock.files, namespace=cell.namespace),
            NodeSpec("calibration_motion", mover, namespace=cell.namespace)], sc  # fmt: skip


def run_calibration(scenario_path: str, bag: Path, poses: int = 12, hold: float = HOLD,
                    processes: bool = False, log_dir: Path | None = None
                    ) -> dict[str, Any]:  # fmt: skip
    """Records the calibration motion into ``bag``; returns the summary (module doc)."""
    from fbcc_ros.nodes.bringup import bag_contents, recorder, wait_recording

    specs, sc = calibration_specs(scenario_path, poses, hold, processes)
    cell = sc.cell
    specs.append(recorder(bag, RECORDED, cell.namespace))
    with CellRun(specs, log_dir=log_dir, namespace=cell.namespace, chain=False) as run:
        wait_recording(run, 30.0, RECORDED)
        mover = run.nodes["calibration_motion"]
        run.spin_until(lambda: mover.motion is not None, 30.0, "no joint state from the mock")
        motion = mover.motion
        print(f"calibration motion: {len(motion.poses)} poses (condition number "
              f"{motion.condition:.3g}), each held {hold:g} s, {motion.duration:.1f} s in all",
              flush=True)  # fmt: skip

        def progress(elapsed: float) -> None:
            held = sum(1 for _, end in motion.holds() if end <= mover.elapsed)
            print(f"  t = {elapsed:4.1f} s  poses held {held}/{len(motion.poses)}", flush=True)

        run.spin_for(motion.duration + SETTLE - mover.elapsed, progress)
        if not mover.done:
            run.spin_until(lambda: mover.done, 5.0, "the motion did not end")
    mock = specs[0].parameters
    recorded = bag_contents(bag)
    return {
        "scenario": sc.name,
        "robot": cell.model,
        "poses": np.round(motion.poses, 6).tolist(),
        "condition": motion.condition,
        "duration": motion.duration,
        "truth": _truth(mock),
        "bag": recorded,
        "calibrate": calibrate_command(bag, cell.namespace, mover.robot),
    }


def calibrate_command(bag: Path, namespace: str, robot: RobotModel) -> list[str]:
    """``fbcc-calibrate`` on the calibration's bag: the model from its robot_description, the
    sensor at the flange (a built-in model's locks its gripper's joints)."""
    from fbcc_ros.core.kinematics.robot import ROBOTS

    prefix = namespace.rstrip("/")
    locked = list(ROBOTS[robot.name]().locked_joints) if robot.name in ROBOTS else []
    return ["fbcc-calibrate", str(bag), "--joint-states", f"{prefix}/{topics.JOINT_STATES}",
            "--wrench", f"{prefix}/{topics.WRIST_WRENCH}", "--flange-frame", robot.flange_frame,
            *(["--locked-joints", *locked] if locked else [])]  # fmt: skip


def _truth(mock: dict[str, Any]) -> dict[str, Any]:
    """The wrist sensor's true payload and bias: the mock's parameters, or their defaults."""
    from fbcc_ros.pipeline.mock_cell import TABLE

    values = {p.name: mock.get(p.name, p.default) for p in TABLE if p.name.startswith("wrist_")}
    return {"mass": values["wrist_payload.mass"], "com": values["wrist_payload.com"],
            "bias": values["wrist_bias"]}  # fmt: skip


def fit_error(truth: dict[str, Any], payload_yaml: Path) -> dict[str, float]:
    """The fit's error against the truth: mass [kg], centre of mass [m], bias [N], [N m]."""
    from fbcc_ros.core.compensation.calibration_file import load_calibration

    payload, bias = load_calibration(payload_yaml)
    if not np.isfinite(bias).all():
        raise FbccError(f"{payload_yaml}: a bias of non-finite values")
    b = np.asarray(truth["bias"], dtype=float)
    return {"mass": abs(payload.mass - truth["mass"]),
            "com": float(np.abs(np.asarray(payload.com) - truth["com"]).max()),
            "bias_force": float(np.abs(bias[:3] - b[:3]).max()),
            "bias_moment": float(np.abs(bias[3:] - b[3:]).max())}  # fmt: skip


def bringup_calibration(args: argparse.Namespace) -> int:
    """``--calibration-motion``: record it, fit it, say how near the truth the fit came."""
    from fbcc_ros.bag.writer import check_new_folder
    from fbcc_ros.cli import calibrate
    from fbcc_ros.nodes.fbcc_record import default_folder

    options = (("--fault", args.fault), ("--no-record", args.no_record), ("--law", args.law),
               ("--draw-geometry", args.draw_geometry),
               ("--wait-for-recorder", args.wait_for_recorder))  # fmt: skip
    given = [name for name, on in options if on]
    if given:
        raise InputError(given[0], True, "none of it with --calibration-motion (it records a "
                         "motion, no assembly)")  # fmt: skip
    if not 3 <= args.poses <= 30:
        raise InputError("--poses", args.poses, "3 to 30 poses")
    bag = args.bag or default_folder(args.out or Path("."))
    check_new_folder(bag)
    print(f"fbcc_bringup: calibration motion on the mock ({args.scenario}), recording into "
          f"{bag}", flush=True)  # fmt: skip
    summary = run_calibration(args.scenario, bag, args.poses, processes=args.processes,
                              log_dir=args.out / "logs" if args.out else None)  # fmt: skip
    messages = summary["bag"]["messages"]
    print(f"recorded {sum(messages.values())} messages: "
          + ", ".join(f"{t} {n}" for t, n in messages.items()))
    fit_out = bag / "payload.yaml"
    command_line = [*summary["calibrate"], "--out", str(fit_out)]
    print("$ " + " ".join(command_line), flush=True)
    status = calibrate.main(command_line[1:])
    if status == 0:
        summary["fit"] = {"file": str(fit_out), "error": fit_error(summary["truth"], fit_out)}
        e = summary["fit"]["error"]
        truth = summary["truth"]
        print(f"against the mock's truth (mass {truth['mass']} kg, centre of mass "
              f"{truth['com']} m, bias {truth['bias']}): mass off by {e['mass'] * 1e3:.2f} g, "
              f"centre of mass by {e['com'] * 1e3:.2f} mm, bias by {e['bias_force']:.3f} N "
              f"and {e['bias_moment'] * 1e3:.2f} N mm (largest component)")  # fmt: skip
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        print(f"wrote {args.out / 'summary.json'}")
    return status
