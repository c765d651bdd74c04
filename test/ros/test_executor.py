"""The nodes' executor: the EventsExecutor, or the single-threaded one where it is missing or
chosen."""

from __future__ import annotations

import sys

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.ros.executor import make_executor


def test_the_executor_is_the_events_one_unless_missing_or_chosen(monkeypatch) -> None:
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        monkeypatch.delenv("FBCC_EXECUTOR", raising=False)
        assert type(make_executor(context)).__name__ == "EventsExecutor"
        monkeypatch.setenv("FBCC_EXECUTOR", "single")
        assert isinstance(make_executor(context), SingleThreadedExecutor)
        monkeypatch.setenv("FBCC_EXECUTOR", "events")
        monkeypatch.setitem(sys.modules, "rclpy.experimental", None)  # an rclpy without it
        assert isinstance(make_executor(context), SingleThreadedExecutor)
        monkeypatch.setenv("FBCC_EXECUTOR", "multi")
        with pytest.raises(ConfigError, match=r"FBCC_EXECUTOR='multi'.*events"):
            make_executor(context)
    finally:
        rclpy.try_shutdown(context=context)
