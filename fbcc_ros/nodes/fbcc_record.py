"""fbcc_record node: records the cell's topics into a rosbag2-compatible mcap bag.

Each wanted topic is subscribed as soon as a publisher offers it (checked every
``discovery_period``), with the publisher's type, reliability and durability (so a latched
topic such as ``fbcc/phase`` gives its current value), and raw: the CDR bytes go to the bag as
they came. The bag (:mod:`fbcc_ros.bag.writer`) holds the publishers' QoS and type hash per
channel; ``metadata.yaml`` is rewritten every ``checkpoint_period`` and on exit. SIGINT or
SIGTERM closes the bag.
"""

from __future__ import annotations

import time
from datetime import datetime
from pathlib import Path
from typing import Any

from rclpy.node import Node
from rclpy.qos import QoSProfile

from fbcc_ros.bag.schema import message_class
from fbcc_ros.bag.writer import BagWriter
from fbcc_ros.pipeline.parameters import Param
from fbcc_ros.ros import topics
from fbcc_ros.ros.diagnostics import counter_report, publish_diagnostics
from fbcc_ros.ros.params import declare, run

#: What a session of the cell needs for replay and report (topics.py names, relative).
CELL_TOPICS = [
    topics.JOINT_STATES, topics.JOINT_COMMAND, topics.RAW_WRENCH, topics.COMPENSATED_WRENCH,
    topics.BIAS, topics.NOISE,
    topics.FEATURES, topics.COMMAND, topics.TCP_COMMAND, topics.PHASE, topics.CONTACT_STATE,
    topics.KINEMATICS_STATUS, topics.GUARD, topics.REARM, topics.TRUTH, topics.CONTACT_ESTIMATE,
    topics.CONTACT_STATE_ESTIMATE,
    topics.ROBOT_DESCRIPTION,
]  # fmt: skip

TABLE = (
    Param("out", "", "bag folder to create (new or empty); empty: bags/fbcc_<date>_<time> in "
          "the working directory"),
    Param("topics", CELL_TOPICS, "topics to record (relative names follow the namespace)"),
    Param("discovery_period", 0.5, "how often to look for publishers of topics not yet "
          "recorded", "s", 0.01, 60.0),
    Param("checkpoint_period", 1.0, "how often metadata.yaml is rewritten with the counts",
          "s", 0.1, 3600.0),
)  # fmt: skip


def default_folder(root: Path = Path(".")) -> Path:
    """``root/bags/fbcc_<date>_<time>``: a new folder per session, as ``ros2 bag record``."""
    return root / "bags" / datetime.now().strftime("fbcc_%Y%m%d_%H%M%S")


class FbccRecordNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("fbcc_record", **kwargs)
        values = declare(self, TABLE)
        self.folder = Path(values["out"]) if values["out"] else default_folder()
        self.bag = BagWriter(self.folder)
        self.wanted = [self.resolve_topic_name(t) for t in values["topics"]]
        self.get_logger().info(f"recording {len(self.wanted)} topics into {self.folder}")
        self.create_timer(values["discovery_period"], self.discover)
        self.create_timer(values["checkpoint_period"], self.checkpoint)
        publish_diagnostics(self, counter_report(self.counts, (), "recording"))
        self.discover()

    def counts(self) -> dict[str, int]:
        return self.bag.counts()

    def discover(self) -> None:
        for name in self.wanted:
            if name in self.bag.topics:
                continue
            offered = self.get_publishers_info_by_topic(name)
            if not offered:
                continue
            type_name = offered[0].topic_type
            qos = [info.qos_profile for info in offered]
            self.bag.add_topic(name, type_name, qos)
            self.create_subscription(message_class(type_name), name, self._writer(name),
                                     self._subscription_qos(qos), raw=True)  # fmt: skip
            self.get_logger().info(f"recording {name} ({type_name})")

    @staticmethod
    def _subscription_qos(offered: list[QoSProfile]) -> QoSProfile:
        """Deep enough for bursts; the publishers' reliability (``topics.matching_reliability``)
        and the first one's durability (a latched topic's last message comes too)."""
        qos = topics.input_qos(topics.matching_reliability(offered), depth=1000)
        qos.durability = offered[0].durability
        return qos

    def _writer(self, name: str) -> Any:
        write = self.bag.write

        def record(data: bytes) -> None:
            try:
                write(name, data, time.time_ns())
            except OSError:
                self._stop()

        return record

    def checkpoint(self) -> None:
        try:
            self.bag.checkpoint()
        except OSError:
            self._stop()

    def _stop(self) -> None:
        """Writing failed (disk full, the folder gone): stop recording, say so in one line;
        the bag keeps what was flushed and the node stays up (the cell runs on)."""
        for sub in list(self.subscriptions):
            self.destroy_subscription(sub)
        self.wanted = []
        self.get_logger().error(f"recording stopped: {self.bag.failed}; {self.folder} keeps "
                                "what was written before")  # fmt: skip

    def destroy_node(self) -> None:
        self.bag.close()
        self.get_logger().info(f"bag closed: {self.folder} ({sum(self.counts().values())} "
                               "messages)")  # fmt: skip
        super().destroy_node()


def main() -> None:
    run(FbccRecordNode)


if __name__ == "__main__":
    main()
