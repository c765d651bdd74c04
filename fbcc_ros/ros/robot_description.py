"""The robot's URDF from the ``robot_description`` topic, as ROS stacks share it.

robot_state_publisher (and ros2_control's stacks through it, lbr_fri_ros2_stack included)
latches the URDF text on ``robot_description`` (std_msgs/String, reliable, transient local): a
node started at any time gets the current one. A node whose ``robot`` parameter is
``robot_description`` waits for it in its constructor, before it makes its stage, so every
stage is built whole, as with a built-in model.
"""

from __future__ import annotations

import time
from typing import Any

from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.pipeline.kinematics import DESCRIPTION, needs_description
from fbcc_ros.ros import topics
from fbcc_ros.ros.process import StopSignalError, stopping

#: How robot_state_publisher offers the description (a late subscriber still gets it).
DESCRIPTION_QOS = QoSProfile(
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
#: Seconds between "still waiting" lines.
SAY_EVERY = 5.0


def description_for(node: Node, values: dict[str, Any]) -> str | None:
    """The URDF text for the node's stage when its parameters ask for it (``robot:
    robot_description``), waiting ``description_timeout`` seconds (0: for ever); else None."""
    if not needs_description(values):
        return None
    return wait_for_description(node, values["description_timeout"])


def wait_for_description(node: Node, timeout: float) -> str:
    """The latest URDF on the node's ``robot_description`` (namespace and remaps apply),
    spinning the node alone until it comes. Call it before the node has callbacks of its own.
    Raises :class:`ConfigError` after ``timeout`` seconds (0: never), naming the topic."""
    topic = node.resolve_topic_name(topics.ROBOT_DESCRIPTION)
    got: list[str] = []

    def on_description(msg: String) -> None:
        got.append(msg.data)

    sub = node.create_subscription(String, topics.ROBOT_DESCRIPTION, on_description,
                                   DESCRIPTION_QOS)  # fmt: skip
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    start = said = time.monotonic()
    try:
        while not got:
            if stopping():
                raise StopSignalError(f"stopped while waiting for {topic}")
            executor.spin_once(timeout_sec=0.05)
            now = time.monotonic()
            if timeout and now - start > timeout:
                raise ConfigError("robot", DESCRIPTION, f"a URDF on {topic} within "
                                  f"description_timeout ({timeout:g} s): none came; start "
                                  "robot_state_publisher (or the robot's bringup), or name a "
                                  "built-in model")  # fmt: skip
            if now - said > SAY_EVERY:
                node.get_logger().info(f"waiting for the robot's URDF on {topic}")
                said = now
    finally:
        executor.remove_node(node)
        executor.shutdown()
        node.destroy_subscription(sub)
    node.get_logger().info(f"robot model from {topic} ({len(got[-1])} characters)")
    return got[-1]
