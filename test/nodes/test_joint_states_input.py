"""``joint_states_topic`` and ``joint_states_qos`` over DDS, on the two nodes that read the arm's
joint states: the kinematics (features from them) and a wrist sensor's compensation (where the
sensor is). A best-effort publisher (sensor-data QoS) is heard only by a best-effort or matching
subscription, and only on the topic named."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from fbcc_ros.core.kinematics.robot import RobotModel
from fbcc_ros.nodes.dynamic_compensation import DynamicCompensationNode
from fbcc_ros.nodes.kinematics import KinematicsNode
from fbcc_ros.ros import topics
from fbcc_ros.ros.convert import joints_to_cdr
from fbcc_ros.ros.executor import make_executor

ROBOT = RobotModel.from_name("iiwa14")
TOPIC = "arm/joint_states"


def _heard(node_class: Any, qos: str, publisher_qos: str, topic: str = TOPIC,
           **given: Any) -> int:  # fmt: skip
    """How many of 100 joint states, published with ``publisher_qos`` on ``topic``, the node
    (reading ``arm/joint_states`` with ``qos``) took."""
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        values = {"joint_states_topic": TOPIC, "joint_states_qos": qos, **given}
        node = node_class(context=context,
                          parameter_overrides=[Parameter(k, value=v) for k, v in values.items()])
        arm = rclpy.create_node("arm_driver", context=context)
        pub = arm.create_publisher(JointState, topic, topics.input_qos(publisher_qos))
        features: list[Any] = []
        arm.create_subscription(PoseStamped, topics.FEATURES, features.append, 200)
        executor = make_executor(context)
        for n in (node, arm):
            executor.add_node(n)
        deadline = time.monotonic() + (3.0 if topic == TOPIC else 1.0)  # discovery
        while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
        for k in range(100):
            pub.publish(joints_to_cdr(ROBOT.joint_names, ROBOT.home, np.zeros(7), 1.0 + k * 1e-3))
            executor.spin_once(timeout_sec=0.002)
        for _ in range(50):
            executor.spin_once(timeout_sec=0.01)
        # the kinematics answers each with features; the compensation keeps the last
        heard = (len(features) if node_class is KinematicsNode
                 else int(node.stage.comp._joints is not None))  # fmt: skip
        executor.shutdown()
        node.destroy_node()
        arm.destroy_node()
        return int(heard)
    finally:
        rclpy.try_shutdown(context=context)
        context.destroy()


@pytest.mark.flaky(reruns=2)
def test_the_joint_states_are_read_where_and_as_told() -> None:
    """Heard or not: a quarter at least (best effort drops what a busy machine's queues do)."""
    assert _heard(KinematicsNode, "reliable", "best_effort") == 0  # never matched
    assert _heard(KinematicsNode, "best_effort", "best_effort") > 25
    assert _heard(KinematicsNode, "match", "best_effort") > 25
    assert _heard(KinematicsNode, "match", "reliable") > 25
    assert _heard(KinematicsNode, "reliable", "reliable", topic=topics.JOINT_STATES) == 0
    wrist = {"placement": "wrist", "tare_samples": 0}
    assert _heard(DynamicCompensationNode, "reliable", "best_effort", **wrist) == 0
    assert _heard(DynamicCompensationNode, "best_effort", "best_effort", **wrist) == 1
    assert _heard(DynamicCompensationNode, "reliable", "reliable", topic=topics.JOINT_STATES,
                  **wrist) == 0  # fmt: skip
