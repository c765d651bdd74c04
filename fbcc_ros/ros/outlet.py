"""A publisher whose messages can also go, as the same message (serialised bytes on the 1 kHz
path), straight to callbacks in this process: the cell's nodes chained in one callback where they
share a process, the way rclcpp's intra-process communication short-cuts DDS. Every message is
still published, for observers, the recorder and nodes in other processes."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


class Outlet:
    """Args:
    publisher: The rclpy publisher.
    latched: Its QoS is transient-local: a callback linked later first gets the last message,
        as a late subscriber would (a restarted node must hear a trip that happened while it
        was down).
    """

    def __init__(self, publisher: Any, latched: bool = False) -> None:
        self.publisher = publisher
        self.latched = latched
        self.last: Any = None
        #: callbacks in this process that take the message instead of a subscription
        self.local: list[Callable[[Any], None]] = []

    def publish(self, data: Any) -> None:
        self.publisher.publish(data)
        if self.latched:
            self.last = data
        for callback in self.local:
            callback(data)

    def link(self, callback: Callable[[Any], None]) -> None:
        """``callback`` takes every message from now on (and the last one, if latched)."""
        self.local.append(callback)
        if self.latched and self.last is not None:
            callback(self.last)
