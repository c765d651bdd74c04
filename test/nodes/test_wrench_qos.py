"""The compensation's ``wrench_qos`` over DDS: F/T drivers publish sensor-data QoS
(best-effort), which a reliable subscription never matches; with ``best_effort`` the node hears
them, and it still hears a reliable publisher."""

from __future__ import annotations

import time

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import WrenchStamped
from rclpy.parameter import Parameter

from fbcc_ros.nodes.dynamic_compensation import DynamicCompensationNode
from fbcc_ros.ros import topics
from fbcc_ros.ros.convert import wrench_to_cdr
from fbcc_ros.ros.executor import make_executor


def _heard(wrench_qos: str, publisher_qos: str, topic: str = topics.RAW_WRENCH,
           wrench_topic: str = topics.RAW_WRENCH) -> int:
    """How many of 200 readings, published with ``publisher_qos`` on ``topic``, the node
    (``wrench_qos``, ``wrench_topic``) compensated."""
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = DynamicCompensationNode(
            context=context, parameter_overrides=[Parameter("wrench_qos", value=wrench_qos),
                                                  Parameter("wrench_topic", value=wrench_topic),
                                                  Parameter("tare_samples", value=0)])
        sensor = rclpy.create_node("ft_driver", context=context)
        pub = sensor.create_publisher(WrenchStamped, topic,
                                      topics.input_qos(publisher_qos))  # fmt: skip
        executor = make_executor(context)
        for n in (node, sensor):
            executor.add_node(n)
        deadline = time.monotonic() + (3.0 if topic == wrench_topic else 1.0)  # discovery
        while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
        for _ in range(200):
            stamp = node.now()
            pub.publish(wrench_to_cdr(np.array([0.0, 0.0, -1.0, 0, 0, 0]), "ft_sensor", stamp))
            executor.spin_once(timeout_sec=0.002)
        for _ in range(50):
            executor.spin_once(timeout_sec=0.01)
        heard = node.stage.comp.counts["accepted"]
        executor.shutdown()
        node.destroy_node()
        sensor.destroy_node()
        return int(heard)
    finally:
        rclpy.try_shutdown(context=context)
        context.destroy()


@pytest.mark.flaky(reruns=2)
def test_a_best_effort_sensor_is_heard_only_when_told() -> None:
    assert _heard("reliable", "best_effort") == 0  # incompatible: never matched
    assert _heard("best_effort", "best_effort") > 150
    assert _heard("best_effort", "reliable") > 150
    assert _heard("reliable", "reliable") > 150
    # the publishers', whichever they are
    assert _heard("match", "best_effort") > 150
    assert _heard("match", "reliable") > 150


@pytest.mark.flaky(reruns=2)
def test_the_wrench_is_read_where_wrench_topic_says() -> None:
    """The LBR stack's estimated wrench comes on force_torque_broadcaster/wrench."""
    lbr = "force_torque_broadcaster/wrench"
    assert _heard("reliable", "reliable", topic=lbr, wrench_topic=lbr) > 150
    assert _heard("reliable", "reliable", topic=topics.RAW_WRENCH, wrench_topic=lbr) == 0
