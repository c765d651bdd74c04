"""kinematics node: the feature solution and the TCP solution (Fig. 7).

Subscribes ``joint_states`` (JointState) and ``fbcc/command`` (PoseStamped: the command
features as the peg's pose in {H}). Publishes ``fbcc/features`` (PoseStamped: the measured peg
pose in {H}, from which the features, depth included, follow by ``features_from_pose``),
``fbcc/tcp_command`` (PoseStamped: the peg's target in the base frame) and ``joint_command``
(Float64MultiArray of positions in the robot's joint order).

The feature and TCP solutions are :class:`~fbcc_ros.pipeline.kinematics.KinematicsStage`'s.
Why Float64MultiArray: it is what ros2_controllers' forward position controller streams at the
control rate; a JointTrajectory per 1 ms step would make a trajectory controller re-plan every
period. An unreachable command (``IkError``) publishes nothing (the robot holds its last
command) and says why on ``fbcc/kinematics_status``; the controller then faults.
"""

from __future__ import annotations

from typing import Any

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String

from fbcc_ros.core.errors import FbccError
from fbcc_ros.core.kinematics.ik import IkError
from fbcc_ros.pipeline.kinematics import TABLE, KinematicsStage
from fbcc_ros.ros import topics
from fbcc_ros.ros.convert import joints_from_cdr, pose_from_cdr, pose_to_cdr, positions_to_cdr
from fbcc_ros.ros.diagnostics import counter_report, publish_diagnostics
from fbcc_ros.ros.outlet import Outlet
from fbcc_ros.ros.params import declare, run

__all__ = ["TABLE", "KinematicsNode"]


class KinematicsNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("kinematics", **kwargs)
        self.stage = KinematicsStage(declare(self, TABLE))
        self.failures = 0
        self.out_features = Outlet(self.create_publisher(PoseStamped, topics.FEATURES, 10))
        self.pub_tcp = self.create_publisher(PoseStamped, topics.TCP_COMMAND, 10)
        self.pub_joints = self.create_publisher(Float64MultiArray, topics.JOINT_COMMAND, 10)
        self.pub_status = self.create_publisher(String, topics.KINEMATICS_STATUS, 10)
        # raw: CDR bytes, decoded by fbcc_ros.ros.convert (no rclpy message objects at 1 kHz)
        self.create_subscription(JointState, topics.JOINT_STATES, self.on_joints, 10, raw=True)
        self.create_subscription(PoseStamped, topics.COMMAND, self.on_command, 10, raw=True)
        publish_diagnostics(
            self, counter_report(lambda: {"ik_failures": self.failures}, ("ik_failures",), "IK")
        )

    def preload(self) -> None:
        """Load the compiled code of the stage now (called before the loop, by ``run``)."""
        self.stage.preload()

    def on_joints(self, data: bytes) -> None:
        try:
            stamp, q, _ = joints_from_cdr(data, self.stage.joint_names)
            peg = self.stage.joints(q, stamp)
        except FbccError as exc:
            self.get_logger().warn(f"joint state rejected: {exc}", throttle_duration_sec=1.0)
            return
        self.out_features.publish(pose_to_cdr(peg, topics.HOLE_FRAME, stamp))

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
        self.pub_joints.publish(positions_to_cdr(solution.q))
        if self.pub_tcp.get_subscription_count():  # an observer's topic: skip it unheard
            self.pub_tcp.publish(pose_to_cdr(solution.peg_in_base, topics.BASE_FRAME, stamp))


def main() -> None:
    run(KinematicsNode)


if __name__ == "__main__":
    main()
