"""The LBR in MuJoCo against our kinematics and a position-mode arm: its flange is where
Pinocchio puts it, for every LBR; it holds a pose under gravity (and would sag without the
compensation); it follows a commanded step."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from fbcc_ros.core.kinematics.robot import RobotModel
from fbcc_ros.core.sim.plants.mujoco_arm import MujocoArm

LBRS = ("iiwa7", "iiwa14", "med7", "med14")
#: A pose with the shoulder and the elbow bent: gravity's torques near their largest.
BENT = np.array([0.3, 0.8, -0.2, -1.2, 0.4, 0.9, 0.1])


@pytest.mark.parametrize("name", LBRS)
def test_the_flange_is_where_pinocchio_puts_it(name: str) -> None:
    robot = RobotModel.from_name(name)
    arm = MujocoArm(robot.urdf_text, BENT)
    assert tuple(arm.joint_names) == robot.joint_names
    for q in np.random.default_rng(0).uniform(0.9 * robot.lower, 0.9 * robot.upper, (20, 7)):
        arm.data.qpos[:] = q
        mujoco.mj_kinematics(arm.model, arm.data)
        rotation, position = arm.frame("iiwa_flange")
        expected = robot.flange_in_base(q)
        np.testing.assert_allclose(rotation, expected.rotation, atol=1e-12)
        np.testing.assert_allclose(position, expected.translation, atol=1e-12)


def test_the_arm_holds_a_pose_under_gravity_and_would_sag_without_compensation() -> None:
    robot = RobotModel.from_name("iiwa14")
    held = MujocoArm(robot.urdf_text, BENT)
    held.step(2000)  # 2 s
    assert np.abs(held.q - BENT).max() < 1e-9
    sagging = MujocoArm(robot.urdf_text, BENT)
    sagging.model.body_gravcomp[:] = 0.0
    sagging.step(2000)
    # the servo's spring alone: tau_g / k at the shoulder
    assert np.abs(sagging.q - BENT).max() > 0.003


def test_the_arm_follows_a_commanded_step() -> None:
    robot = RobotModel.from_name("iiwa14")
    arm = MujocoArm(robot.urdf_text, BENT)
    target = BENT + np.array([0.0, 0.0, 0.0, 0.02, 0.0, 0.0, 0.02])
    arm.command(target)
    arm.step(50)
    assert 0.0 < (arm.q - BENT)[3] < 0.02  # on its way after 50 ms
    arm.step(950)
    np.testing.assert_allclose(arm.q, target, atol=1e-6)
