"""kinematics node: the feature solution and the TCP solution (Fig. 7).

Subscribes ``joint_states`` (JointState) and ``fbcc/command`` (PoseStamped: the command
features as the peg's pose in {H}). Publishes ``fbcc/features`` (PoseStamped: the measured peg
pose in {H}, from which the features, depth included, follow by ``features_from_pose``),
``fbcc/tcp_command`` (PoseStamped: the peg's target in the base frame) and the command on
``command_topic`` (``joint_command`` by default), of ``command_type``:

* ``positions``: Float64MultiArray of positions in the robot's joint order, what
  ros2_controllers' forward position controller takes at the control rate (the default);
* ``trajectory``: a JointTrajectory of one point, named joints, reached one period from now —
  for a JointTrajectoryController, which re-plans on each (so prefer ``positions`` where the
  stack has it);
* ``pose``: the flange's PoseStamped in ``base_frame``, for a Cartesian position controller.

The robot model is built in, a URDF file, or the URDF latched on ``robot_description``
(:mod:`fbcc_ros.ros.robot_description`), from which the joint names follow. The feature and TCP
solutions are :class:`~fbcc_ros.pipeline.kinematics.KinematicsStage`'s. An unreachable command
(``IkError``) publishes nothing (the robot holds its last command) and says why on
``fbcc/kinematics_status``; the controller then faults.
"""

from __future__ import annotations

from typing import Any

from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseStamped
from rclpy.duration import Duration as Timeout
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from fbcc_ros.core.errors import FbccError
from fbcc_ros.core.kinematics.cell import TcpCommand
from fbcc_ros.core.kinematics.ik import IkError
from fbcc_ros.pipeline.kinematics import TABLE, KinematicsStage
from fbcc_ros.pipeline.parameters import frame_id
from fbcc_ros.ros import topics
from fbcc_ros.ros.convert import (
    joints_from_cdr,
    pose_from_cdr,
    pose_to_cdr,
    positions_to_cdr,
    seconds_to_stamp,
)
from fbcc_ros.ros.diagnostics import counter_report, publish_diagnostics
from fbcc_ros.ros.inputs import subscribe_input
from fbcc_ros.ros.outlet import Outlet
from fbcc_ros.ros.params import declare, run
from fbcc_ros.ros.process import ACKED_WITHIN
from fbcc_ros.ros.robot_description import description_for
from fbcc_ros.ros.sources import SourceWatch

__all__ = ["TABLE", "KinematicsNode"]


class KinematicsNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("kinematics", **kwargs)
        values = declare(self, TABLE)
        self.stage = KinematicsStage(values, description_for(self, values))
        self.failures = 0
        self.out_features = Outlet(self.create_publisher(PoseStamped, topics.FEATURES, 10))
        self.pub_tcp = self.create_publisher(PoseStamped, topics.TCP_COMMAND, 10)
        self.command_type = values["command_type"]
        self.hole_frame = frame_id(values, "hole_frame")
        self.base_frame = values["base_frame"] or self.stage.cell.robot.model.frames[1].name
        kind = {"positions": Float64MultiArray, "trajectory": JointTrajectory,
                "pose": PoseStamped}[self.command_type]  # fmt: skip
        self.pub_joints = self.create_publisher(kind, values["command_topic"], 10)
        self.pub_status = self.create_publisher(String, topics.KINEMATICS_STATUS, 10)
        # raw: CDR bytes, decoded by fbcc_ros.ros.convert (no rclpy message objects at 1 kHz)
        subscribe_input(self, JointState, values["joint_states_topic"], self.on_joints,
                        values["joint_states_qos"])
        self.create_subscription(PoseStamped, topics.COMMAND, self.on_command, 10, raw=True)
        self.sources = SourceWatch(self, (values["joint_states_topic"], topics.COMMAND),
                                   (values["command_topic"],), self.on_source)
        # the controller's reset acknowledged the fault: a problem still there is said anew
        self.create_subscription(String, topics.REARM, lambda _: self.sources.forget(), 10)
        publish_diagnostics(
            self, counter_report(lambda: {"ik_failures": self.failures}, ("ik_failures",), "IK")
        )

    def preload(self) -> None:
        """Load the compiled code of the stage now (called before the loop, by ``run``)."""
        self.stage.preload()

    def on_joints(self, data: bytes) -> None:
        try:
            stamp, q, _ = joints_from_cdr(data, self.stage.joint_names)
            peg = self.stage.joints(q, stamp, self.get_clock().now().nanoseconds * 1e-9)
        except FbccError as exc:
            self.get_logger().warn(f"joint state rejected: {exc}", throttle_duration_sec=1.0)
            return
        self.out_features.publish(pose_to_cdr(peg, self.hole_frame, stamp))

    def on_source(self, problem: str) -> None:
        """A second publisher on an input, or another commander of the arm
        (:mod:`fbcc_ros.ros.sources`): the controller faults on the report."""
        self.get_logger().error(problem)
        self.pub_status.publish(String(data=problem))

    def on_command(self, data: bytes) -> None:
        try:
            stamp, pose = pose_from_cdr(data)
            solution = self.stage.command(pose, self.get_clock().now().nanoseconds * 1e-9)
        except (IkError, FbccError) as exc:
            self.failures += 1
            self.pub_status.publish(String(data=f"IK failed: {exc}"))
            self.get_logger().error(f"command not followed: {exc}", throttle_duration_sec=1.0)
            return
        if solution is None:  # no joints measured yet
            return
        self.pub_joints.publish(self._command(solution, stamp))
        if self.pub_tcp.get_subscription_count():  # an observer's topic: skip it unheard
            self.pub_tcp.publish(pose_to_cdr(solution.peg_in_base, self.base_frame, stamp))

    def on_shutdown(self) -> None:
        """Stopped while it commands the arm (SIGINT, SIGTERM: ``run``), it leaves the arm at
        its last measured joints: the arm does not go on to a command nobody follows up."""
        now = self.get_clock().now().nanoseconds * 1e-9
        hold = self.stage.hold(now)
        if hold is None:
            return
        self.pub_joints.publish(self._command(hold, now))
        self.get_logger().info("stopping while commanding the arm: held at its measured joints")
        self.pub_joints.wait_for_all_acked(Timeout(seconds=ACKED_WITHIN))

    def _command(self, solution: TcpCommand, stamp: float) -> bytes | JointTrajectory:
        """The command message of ``command_type`` (module doc)."""
        if self.command_type == "positions":
            return positions_to_cdr(solution.q)
        if self.command_type == "pose":
            return pose_to_cdr(solution.flange_in_base, self.base_frame, stamp)
        sec, nanosec = seconds_to_stamp(self.stage.dt)
        period = Duration(sec=sec, nanosec=nanosec)
        point = JointTrajectoryPoint(positions=solution.q.tolist(), time_from_start=period)
        # an unset header stamp: start now (a JointTrajectoryController's convention)
        return JointTrajectory(joint_names=list(self.stage.joint_names), points=[point])




def main() -> None:
    run(KinematicsNode)


if __name__ == "__main__":
    main()
