"""The executor the nodes spin on: rclpy's EventsExecutor (its 1 kHz loop costs the cell about
half the CPU of the single-threaded executor's wait sets), which rclpy still ships as
experimental; the SingleThreadedExecutor where it is missing (an rclpy without it) or chosen
with the environment variable ``FBCC_EXECUTOR=single`` (``events``, the default, or ``single``).
"""

from __future__ import annotations

import os
from typing import Any

from fbcc_ros.core.errors import ConfigError

CHOICES = ("events", "single")


def make_executor(context: Any = None) -> Any:
    """A new executor of the kind ``FBCC_EXECUTOR`` names (module doc), on ``context``."""
    kind = os.environ.get("FBCC_EXECUTOR", "events")
    if kind not in CHOICES:
        raise ConfigError("FBCC_EXECUTOR", kind, f"one of {list(CHOICES)}")
    if kind == "events":
        try:
            from rclpy.experimental import EventsExecutor
        except ImportError:
            pass
        else:
            return EventsExecutor(context=context)
    from rclpy.executors import SingleThreadedExecutor

    return SingleThreadedExecutor(context=context)
