"""A node's sensor inputs, subscribed with the reliability their publishers need.

A reliable subscription never hears a best-effort publisher (an F/T driver's sensor-data QoS);
a best-effort one hears both, and drops what the network drops. Each input's QoS parameter
(``wrench_qos``, ``joint_states_qos``) is ``reliable``, ``best_effort``, or ``match``: the
reliability of its publishers (``topics.matching_reliability``), subscribed once one is seen.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy.node import Node

from fbcc_ros.ros import topics

#: How often ``match`` looks for an input's publishers [s].
MATCH_PERIOD = 0.1


def subscribe_input(node: Node, kind: Any, topic: str, callback: Callable[[bytes], None],
                    qos: str) -> None:  # fmt: skip
    """Subscribes ``callback`` to ``topic`` (raw CDR bytes, decoded by
    :mod:`fbcc_ros.ros.convert`) with ``qos`` (one of :data:`INPUT_QOS`)."""
    if qos != "match":
        node.create_subscription(kind, topic, callback, topics.input_qos(qos), raw=True)
        return
    name = node.resolve_topic_name(topic)

    def match() -> None:
        offered = [info.qos_profile for info in node.get_publishers_info_by_topic(name)]
        if not offered:
            return
        timer.cancel()
        reliability = topics.matching_reliability(offered)
        node.create_subscription(kind, topic, callback, topics.input_qos(reliability), raw=True)
        node.get_logger().info(f"{name}: subscribed {reliability}, as its publishers offer")

    timer = node.create_timer(MATCH_PERIOD, match)
