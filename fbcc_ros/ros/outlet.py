"""A publisher whose messages can also go, as the same bytes, straight to callbacks in this
process: the cell's nodes chained in one callback where they share a process, the way rclcpp's
intra-process communication short-cuts DDS. Every message is still published, for observers,
the recorder and nodes in other processes."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


class Outlet:
    def __init__(self, publisher: Any) -> None:
        self.publisher = publisher
        #: callbacks in this process that take the serialised message instead of a subscription
        self.local: list[Callable[[bytes], None]] = []

    def publish(self, data: bytes) -> None:
        self.publisher.publish(data)
        for callback in self.local:
            callback(data)
