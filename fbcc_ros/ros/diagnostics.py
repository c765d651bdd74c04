"""``/diagnostics`` (diagnostic_msgs/DiagnosticArray), once a second per node: the counters a
user checks first when a cell misbehaves, in the format rqt_robot_monitor and the diagnostic
aggregator read. The topic is absolute, as those tools expect."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

TOPIC = "/diagnostics"
OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR


def publish_diagnostics(
    node: Node, report: Callable[[], tuple[bytes, str, dict[str, Any]]], period: float = 1.0
) -> None:
    """Publishes ``report()`` — (level, message, values) — as the node's status every period."""
    pub = node.create_publisher(DiagnosticArray, TOPIC, 10)

    def tick() -> None:
        level, message, values = report()
        status = DiagnosticStatus(
            level=level,
            name=node.get_fully_qualified_name(),
            message=message,
            hardware_id=node.get_name(),
            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()],
        )
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = node.get_clock().now().to_msg()
        pub.publish(msg)

    node.create_timer(period, tick)


def counter_report(
    counts: Callable[[], Mapping[str, float]], bad: tuple[str, ...], what: str
) -> Callable[[], tuple[bytes, str, dict[str, Any]]]:
    """A report of running counters: WARN while any of the ``bad`` ones grew in the last
    period (the message says which, by how much), OK otherwise."""
    last: dict[str, float] = {}

    def report() -> tuple[bytes, str, dict[str, Any]]:
        now = dict(counts())
        grew = {k: now[k] - last.get(k, 0) for k in bad if now[k] > last.get(k, 0)}
        last.update(now)
        if grew:
            return (
                WARN,
                ", ".join(f"{n} {k}" for k, n in grew.items()) + " in the last period",
                now,
            )
        return OK, f"{what}: ok", now

    return report
