"""The bringup's and the benchmark's view of a running cell, from its topics only.

It needs nothing but the ROS graph, so the nodes it watches may run in this process or in
others. It counts what flows (compensated wrenches, features, joint commands, IK failures),
keeps the controller's phase (``fbcc/phase`` is latched), records the mock's ground truth
(``mock_cell/truth``), keeps each node's last ``/diagnostics`` values, starts and aborts
through the controller's services, and, as a latency probe, times each TCP command against
the sensor stamp it answers.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import Float64MultiArray, String
from std_srvs.srv import Trigger

from fbcc_ros.ros import diagnostics, topics
from fbcc_ros.ros.cdr import decode_array, decode_pose
from fbcc_ros.ros.convert import stamp_to_seconds


class Observer(Node):
    def __init__(self, probe: bool = False, command_topic: str = topics.JOINT_COMMAND,
                 **kwargs: Any) -> None:  # fmt: skip
        super().__init__("fbcc_observer", **kwargs)
        self.counts = {"compensated": 0, "features": 0, "commands": 0, "ik_failures": 0}
        self.truth: list[tuple[float, ...]] = []
        self.latency: list[float] = []
        self.phase, self.reason = "", ""
        #: every phase message heard (``phase: reason``), in order
        self.phases: list[str] = []
        #: per node (by name): when its last status arrived (monotonic [s]) and its values
        self.status: dict[str, tuple[float, dict[str, Any]]] = {}
        #: per node: what its counters held before it restarted (a new process counts from 0)
        self._before: dict[str, dict[str, Any]] = {}
        sub = self.create_subscription
        truth = self.truth.append
        def keep_truth(data: bytes) -> None:  # raw: the CDR bytes
            truth(decode_array(data))

        self._watching = [
            sub(Float64MultiArray, topics.TRUTH, keep_truth, 100, raw=True)  # type: ignore[arg-type]
        ]
        sub(String, topics.PHASE, self.on_phase, topics.PHASE_QOS)
        # the history: the latched subscription keeps only the newest of phases sent close
        sub(String, topics.PHASE, self.on_phase_history,
            QoSProfile(depth=50, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        # counting needs no decoding: raw (serialised) messages spare ~30 µs each
        for kind, topic, key in (
            (WrenchStamped, topics.COMPENSATED_WRENCH, "compensated"),
            (PoseStamped, topics.FEATURES, "features"),
            (Float64MultiArray, command_topic, "commands"),
            (String, topics.KINEMATICS_STATUS, "ik_failures"),
        ):
            handle = sub(kind, topic, self._counter(key), 10, raw=True)
            if key in ("compensated", "features"):
                self._watching.append(handle)
        sub(DiagnosticArray, diagnostics.TOPIC, self.on_diagnostics, 10)
        if probe:
            sub(PoseStamped, topics.TCP_COMMAND, self.on_tcp_command, 10, raw=True)
        self.start_client = self.create_client(Trigger, topics.START)
        self.abort_client = self.create_client(Trigger, topics.ABORT)
        self.reset_client = self.create_client(Trigger, topics.RESET)

    def _counter(self, key: str) -> Any:
        def count(_: Any) -> None:
            self.counts[key] += 1

        return count

    def on_phase_history(self, msg: String) -> None:
        self.phases.append(msg.data)

    def on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            values = {kv.key: _value(kv.value) for kv in status.values}
            last = self.status.get(status.hardware_id, (0.0, {}))[1]
            if any(isinstance(v, int) and v < last.get(k, 0) for k, v in values.items()):
                before = self._before.setdefault(status.hardware_id, {})
                for k, v in last.items():  # a counter went back: the node started anew
                    if isinstance(v, int):
                        before[k] = before.get(k, 0) + v
            self.status[status.hardware_id] = (time.monotonic(), values)

    def values(self, node: str) -> dict[str, Any]:
        """The last ``/diagnostics`` values of ``node`` (by name), its counters summed over
        its restarts (a restart's last second before it died is not counted)."""
        values = dict(self.status.get(node, (0.0, {}))[1])
        for k, v in self._before.get(node, {}).items():
            values[k] = values.get(k, 0) + v
        return values

    def on_phase(self, msg: String) -> None:
        self.phase, _, self.reason = (part.strip() for part in msg.data.partition(":"))

    def on_tcp_command(self, data: bytes) -> None:
        # sensor stamp -> this TCP command: the whole chain, both ends on the system clock
        self.latency.append(time.time() - stamp_to_seconds(decode_pose(data)[0]))

    def probe_only(self) -> None:
        """Stops watching what the latency probe does not need (the truth, the compensated
        wrenches, the features), so the instrument loads the loop it measures less: those
        are three more deliveries a period, and the mock publishes its truth only while
        heard. Joint commands (cycles), TCP commands (latency) and the phase stay."""
        for handle in self._watching:
            self.destroy_subscription(handle)
        self._watching.clear()

    def reset_counts(self) -> None:
        self.counts = dict.fromkeys(self.counts, 0)
        self.latency.clear()

    def truth_since(self, index: int) -> np.ndarray:
        """Truth samples from ``index`` on, one row each (columns ``topics.TRUTH_FIELDS``)."""
        rows = self.truth[index:]
        return np.array(rows) if rows else np.zeros((0, len(topics.TRUTH_FIELDS)))


def _value(text: str) -> Any:
    """A diagnostics value as sent (``str()`` of an int, a float, a bool, None or a string)."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return {"True": True, "False": False, "None": None}.get(text, text)
