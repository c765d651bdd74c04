"""Every fbcc_record parameter changes what the recorder does, over DDS.

Each session: the recorder starts, a talker starts 0.2 s later on a cell topic and another
topic, and the session ends 2 s after the recorder started. What is observed: where the bag
went, which topics it holds, and whether metadata.yaml was written before the close. Each
parameter is changed from its default to a value that must change one of these.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest
import rclpy
from rclpy.parameter import Parameter
from std_msgs.msg import Float64MultiArray

from fbcc_ros.bag.reader import read_bag
from fbcc_ros.nodes.fbcc_record import TABLE, FbccRecordNode
from fbcc_ros.ros.executor import make_executor

#: The changed value of each parameter, and why it must show.
CHANGED: dict[str, Any] = {
    "out": "elsewhere/session",  # the bag lands there, not in bags/fbcc_<date>_<time>
    "topics": ["other_topic"],  # the other topic recorded, the cell's not
    "discovery_period": 5.0,  # the talker, started late, is not found within the session
    "checkpoint_period": 100.0,  # no metadata.yaml before the close
}


def _talker(context: Any) -> Any:
    """A node publishing on a cell topic and on another, at 100 Hz."""
    node = rclpy.create_node("talker", context=context)
    pubs = [node.create_publisher(Float64MultiArray, name, 10)
            for name in ("joint_command", "other_topic")]  # fmt: skip

    def publish() -> None:
        for pub in pubs:
            pub.publish(Float64MultiArray(data=[1.0]))

    node.create_timer(0.01, publish)
    return node


def _session(folder: Path, overrides: dict[str, Any]) -> dict[str, Any]:
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = make_executor(context)
    params = [Parameter(k, value=v) for k, v in overrides.items()]
    try:
        recorder = FbccRecordNode(context=context, parameter_overrides=params)
        executor.add_node(recorder)
        start = time.monotonic()
        talker = None
        while time.monotonic() - start < 2.0:
            if talker is None and time.monotonic() - start > 0.2:
                talker = _talker(context)
                executor.add_node(talker)
            executor.spin_once(timeout_sec=0.01)
        # written by the checkpoints (with the counts of the flushed chunks) and the close
        checkpointed = (recorder.folder / "metadata.yaml").exists()
        recorder.destroy_node()  # closes the bag
    finally:
        rclpy.try_shutdown(context=context)
    return {
        "where": recorder.folder.resolve().relative_to(folder.resolve()).parts[0],
        "recorded": sorted(t for t, n in read_bag(recorder.folder).counts.items() if n),
        "checkpointed_before_close": checkpointed,
    }


def test_every_parameter_has_a_change_to_show() -> None:
    assert sorted(CHANGED) == sorted(p.name for p in TABLE)


@pytest.mark.parametrize("name", sorted(CHANGED))
def test_every_parameter_changes_what_the_recorder_does(
    name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # the default folder is relative to the working directory
    base = _session(tmp_path, {})
    assert base["where"] == "bags" and base["recorded"] == ["/joint_command"]
    assert base["checkpointed_before_close"]
    value = CHANGED[name]
    changed = _session(tmp_path, {name: str(tmp_path / value) if name == "out" else value})
    assert changed != base, f"{name} = {value!r} changed nothing"
