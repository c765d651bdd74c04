"""The kinematics node's ``command_type``, ``command_topic`` and ``base_frame`` over DDS: the
command goes where the robot stack listens, as the message its controller takes — joint
positions for a forward position controller, a one-period JointTrajectory for a
JointTrajectoryController, the flange's pose for a Cartesian controller."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

from fbcc_ros.core.kinematics.robot import RobotModel
from fbcc_ros.nodes.kinematics import KinematicsNode
from fbcc_ros.pipeline.parameters import HOLE_FRAME
from fbcc_ros.ros import topics
from fbcc_ros.ros.convert import joints_to_cdr, pose_to_cdr
from fbcc_ros.ros.executor import make_executor

ROBOT = RobotModel.from_name("iiwa14")
TARGET = np.array([1e-5, -2e-5, 1.5e-5])  # the command's move of the peg in {H} [m]
RATE_HZ = 250.0


def _command_heard(command_type: str, base_frame: str) -> tuple[Any, Any]:
    """The first command the node sends on ``arm/commands`` for a peg target next to its
    current pose, and the kinematics stage (for the expected joints)."""
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = KinematicsNode(context=context, parameter_overrides=[
            Parameter("command_type", value=command_type),
            Parameter("command_topic", value="arm/commands"),
            Parameter("base_frame", value=base_frame),
            Parameter("rate_hz", value=RATE_HZ)])  # fmt: skip
        stack = rclpy.create_node("stack", context=context)
        kind = {"positions": Float64MultiArray, "trajectory": JointTrajectory,
                "pose": PoseStamped}[command_type]  # fmt: skip
        heard: list[Any] = []
        stack.create_subscription(kind, "arm/commands", heard.append, 10)
        joints = stack.create_publisher(JointState, topics.JOINT_STATES, 10)
        commands = stack.create_publisher(PoseStamped, topics.COMMAND, 10)
        executor = make_executor(context)
        for n in (node, stack):
            executor.add_node(n)
        peg = node.stage.cell.peg_in_hole(ROBOT.home)
        target = pin.SE3(peg.rotation, peg.translation + TARGET)
        deadline = time.monotonic() + 5.0
        while not heard and time.monotonic() < deadline:
            joints.publish(joints_to_cdr(ROBOT.joint_names, ROBOT.home, np.zeros(7), 1.0))
            commands.publish(pose_to_cdr(target, HOLE_FRAME.default, 1.0))
            executor.spin_once(timeout_sec=0.02)
        expected = node.stage.command(target)
        executor.shutdown()
        node.destroy_node()
        stack.destroy_node()
        return heard[0] if heard else None, expected
    finally:
        rclpy.try_shutdown(context=context)
        context.destroy()


@pytest.mark.flaky(reruns=2)
def test_joint_positions_for_a_forward_position_controller() -> None:
    msg, expected = _command_heard("positions", "")
    assert msg is not None, "no command on arm/commands"
    np.testing.assert_allclose(msg.data, expected.q, atol=1e-12)
    assert np.abs(expected.q - ROBOT.home).max() > 1e-6  # it moved


@pytest.mark.flaky(reruns=2)
def test_a_one_period_trajectory_for_a_joint_trajectory_controller() -> None:
    msg, expected = _command_heard("trajectory", "")
    assert msg is not None, "no command on arm/commands"
    assert list(msg.joint_names) == list(ROBOT.joint_names) and len(msg.points) == 1
    np.testing.assert_allclose(msg.points[0].positions, expected.q, atol=1e-12)
    period = msg.points[0].time_from_start
    assert period.sec + period.nanosec * 1e-9 == pytest.approx(1.0 / RATE_HZ)


@pytest.mark.flaky(reruns=2)
@pytest.mark.parametrize("base_frame", ["", "world"])
def test_the_flange_pose_for_a_cartesian_controller(base_frame: str) -> None:
    msg, expected = _command_heard("pose", base_frame)
    assert msg is not None, "no command on arm/commands"
    assert msg.header.frame_id == (base_frame or "iiwa_link_0")  # the URDF's root link
    p = msg.pose.position
    np.testing.assert_allclose([p.x, p.y, p.z], expected.flange_in_base.translation, atol=1e-9)
    o = msg.pose.orientation
    rotation = pin.Quaternion(o.w, o.x, o.y, o.z).toRotationMatrix()
    np.testing.assert_allclose(rotation, expected.flange_in_base.rotation, atol=1e-9)
