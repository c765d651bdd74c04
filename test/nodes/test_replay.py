"""fbcc_replay over DDS: the committed bag republished at its recorded pace (scaled), its latched
phase offered as latched; and its command line on bad input."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from fbcc_ros.bag.reader import read_bag
from fbcc_ros.bag.writer import BagWriter
from fbcc_ros.ros import topics
from fbcc_ros.ros.cdr import decode_joints
from test.nodes.conftest import kill_left

ROOT = Path(__file__).resolve().parents[2]
BAG = ROOT / "test" / "data" / "bags" / "short_interference"


def _replay(*args: str) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "fbcc_ros.nodes.fbcc_replay", *args]
    return subprocess.Popen(cmd, cwd=ROOT, env=os.environ, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip


@pytest.mark.flaky(reruns=2)  # a live replay's pace over DDS (test_cell_ros)
def test_republished_at_the_recorded_pace_scaled_by_the_rate() -> None:
    bag = read_bag(BAG)
    recorded = [decode_joints(m.data)[0] for m in bag.of("/joint_states")]
    span = (bag.messages[-1].log_time_ns - bag.messages[0].log_time_ns) * 1e-9
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = EventsExecutor(context=context)
    node = Node("listener", context=context)
    got: list[tuple[float, tuple[int, int]]] = []
    phases: list[str] = []
    node.create_subscription(JointState, "/replay/joint_states",
                             lambda d: got.append((time.monotonic(), decode_joints(d)[0])),
                             1000, raw=True)  # fmt: skip
    node.create_subscription(String, "/replay/fbcc/phase", lambda m: phases.append(m.data),
                             topics.PHASE_QOS)  # fmt: skip
    executor.add_node(node)
    topics_ = ("--topics", "/joint_states", "/fbcc/phase")
    proc = _replay(str(BAG), "--rate", "0.5", *topics_, "--wait-for-subscribers", "20")
    try:
        deadline = time.monotonic() + 30.0
        while proc.poll() is None and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
        for _ in range(50):  # what is still in flight
            executor.spin_once(timeout_sec=0.01)
        out, err = proc.communicate(timeout=10)
    finally:
        kill_left(proc)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    assert proc.returncode == 0, err
    assert "published" in out and "s of" in out, out  # the summary and the progress
    assert [stamp for _, stamp in got] == recorded  # all of them, in order, the recorded bytes
    paced = got[-1][0] - got[0][0]
    expected = span / 0.5
    assert 0.85 * expected <= paced <= 1.3 * expected, (paced, expected)
    assert phases and phases[-1] == "inserted", phases


def _bag_with_only_the_phase(folder: Path) -> Path:
    from rclpy.qos import QoSProfile
    from rclpy.serialization import serialize_message

    with BagWriter(folder) as bag:
        bag.add_topic("/fbcc/phase", "std_msgs/msg/String", [QoSProfile(depth=1)])
        bag.write("/fbcc/phase", serialize_message(String(data="idle")), 1)
    return folder


@pytest.mark.parametrize(
    ("case", "args", "message"),
    [
        ("missing", ["no/such/bag"], "an existing .mcap file or bag folder"),
        ("not mcap", ["{junk}"], "an mcap file"),
        ("no joint states", ["{phase_only}", "--offline"], "<namespace>/joint_states"),
        ("unknown topic", [str(BAG), "--topics", "/nope"], "topics of the bag"),
        ("bad rate", [str(BAG), "--rate", "0"], "--rate"),
        ("bad wait", [str(BAG), "--wait-for-subscribers", "-1"], "--wait-for-subscribers"),
        ("relative prefix", [str(BAG), "--prefix", "replay"], "--prefix='replay'"),
    ],
)
def test_bad_input_is_one_line_and_exit_two(case, args, message, tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not a bag at all")
    phase_only = _bag_with_only_the_phase(tmp_path / "phase_only")
    args = [a.format(junk=junk, phase_only=phase_only) for a in args]
    proc = _replay(*args)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 2, (out, err)
    assert message in err and "Traceback" not in err, err


def test_the_schedule_filters_topics_and_skips_the_start() -> None:
    from fbcc_ros.nodes.fbcc_replay import schedule

    bag = read_bag(BAG)
    chosen = schedule(bag, ["/ft_sensor/raw"], start=0.5)
    first = min(m.log_time_ns for m in bag.of("/ft_sensor/raw"))
    times = [m.log_time_ns for m in chosen]
    assert {m.topic for m in chosen} == {"/ft_sensor/raw"} and times == sorted(times)
    assert times[0] >= first + 0.5e9 and times[-1] == max(
        m.log_time_ns for m in bag.messages if m.topic == "/ft_sensor/raw"
    )
    expected = sum(first + 0.5e9 <= m.log_time_ns for m in bag.of("/ft_sensor/raw"))
    assert len(chosen) == expected > 300


@pytest.mark.flaky(reruns=2)  # a live replay's pace over DDS (test_cell_ros)
def test_a_topic_nobody_hears_is_named_after_the_wait_and_published_anyway() -> None:
    proc = _replay(str(BAG), "--topics", "/fbcc/phase", "--wait-for-subscribers", "0.3")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "no subscriber after 0.3 s on ['/replay/fbcc/phase']" in err, err
    assert "published 4 messages" in out, out  # four phases: idle, armed, inserting, inserted


def test_onto_the_recorded_names_never_the_commands_nor_the_phase() -> None:
    """``--prefix /``: the commands and the phase are left out, and said so; a bag of only
    those has nothing left to publish (one line, exit 2)."""
    proc = _replay(str(BAG), "--prefix", "/", "--topics", "/fbcc/phase", "/joint_command")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 2, (out, err)
    assert "not published onto the recorded names: ['/fbcc/phase', '/joint_command']" in out
    assert "Traceback" not in err and "--topics" in err.strip().splitlines()[-1], err


def test_a_topic_with_a_live_publisher_refuses_the_replay_naming_it() -> None:
    """A cell running: its joint states have a publisher; a replay onto the recorded names
    refuses before its first message, naming the live publisher; under the default prefix the
    same replay runs beside it."""
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("live_arm", context=context)
    node.create_publisher(JointState, "/joint_states", 10)
    try:
        proc = _replay(str(BAG), "--prefix", "/", "--topics", "/joint_states", "/ft_sensor/raw",
                       "--rate", "20")  # fmt: skip
        out, err = proc.communicate(timeout=60)
        assert proc.returncode == 2, (out, err)
        last = err.strip().splitlines()[-1]
        assert "/joint_states (/live_arm) publish there now (a cell is running)" in last, err
        assert "published" not in out and "Traceback" not in err
        beside = _replay(str(BAG), "--topics", "/joint_states", "--rate", "20")
        out, err = beside.communicate(timeout=60)
        assert beside.returncode == 0 and "under /replay" in out, (out, err)
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)
