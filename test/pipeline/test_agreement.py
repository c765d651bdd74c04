"""The simulator and the ROS cell run the same controller: the controller stage (what the node
wraps and the offline replay drives), fed the inputs the simulator's law got, commands what the
simulator commanded, to 1e-9."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from fbcc_ros.core.compensation.wrench import wrench_from_response
from fbcc_ros.core.contact.features import features_from_pose, pose_from_features
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.simulation import simulate
from fbcc_ros.pipeline import controller
from fbcc_ros.pipeline.parameters import resolve

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("name", "law"),
    [("robust_clearance", "fbcc"), ("robust_interference", "fbcc"),
     ("fig9_clearance", "fbcc"), ("fig9_interference", "admittance")],
)  # fmt: skip
def test_the_controller_stage_commands_what_the_simulator_commanded(name: str, law: str) -> None:
    path = ROOT / "config" / "scenarios" / f"{name}.yaml"
    sc = scenario_io.load(path)
    _, traj = simulate(sc, law)
    assert traj is not None
    dt = 1.0 / sc.rate_hz
    alpha = 1.0 - math.exp(-dt / sc.lag) if sc.lag > 0 else 1.0
    stage = controller.ControllerStage(resolve("fbcc_controller", controller.TABLE, {
        "scenario": str(path), "law": law, "rate_hz": sc.rate_hz}))  # fmt: skip
    radius = sc.geometry.peg_radius
    pose = np.zeros(5)  # the robot's pose as features: what the simulator's law read
    commands = np.empty((len(traj.t), 5))
    for k, t in enumerate(traj.t):
        stage.features(t, pin.SE3(*pose_from_features(pose, radius)))
        if k == 0:
            stage.sup.on_response(t, np.zeros(5))  # idle: a start needs a recent wrench
            assert stage.sup.start(t)[0]
        wrench = wrench_from_response(traj.measured[k, 0], 0.0, stage.acting_point)  # about O
        command = stage.wrench(t, t, wrench)
        assert command is not None
        commands[k] = features_from_pose(command.rotation, command.translation, radius)
        pose = pose + alpha * (traj.command[k, 0] - pose)  # the simulator's robot
    assert stage.sup.phase in ("inserting", "inserted")
    error = np.abs(commands - traj.command[:, 0]).max()
    assert error < 1e-9, error
    assert np.abs(np.diff(commands[:, 2])).max() > 1e-6  # it moved: not two held commands
