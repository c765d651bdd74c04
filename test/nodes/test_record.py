"""fbcc_record over DDS: what it writes reads back with rosbags; killed, it leaves a bag."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import rclpy
import yaml
from rclpy.experimental import EventsExecutor
from rclpy.parameter import Parameter
from rosbags.highlevel import AnyReader

from fbcc_ros.bag.reader import read_bag
from fbcc_ros.nodes.fbcc_record import FbccRecordNode
from fbcc_ros.nodes.mock_cell import MockCellNode
from fbcc_ros.ros import cdr
from test.nodes.conftest import kill_left, recorder_and_cell

ROOT = Path(__file__).resolve().parents[2]
TOPICS = ["joint_states", "ft_sensor/raw"]


def _record_mock_cell(
    folder: Path, seconds: float, check: Callable[[FbccRecordNode], None] = lambda _: None
) -> tuple[int, int, list[str]]:
    """A mock cell recorded into ``folder`` by fbcc_record for ``seconds``, in one executor;
    ``check`` looks at the recorder before it closes its bag. Returns the wall-clock times [ns]
    around the recording and the mock's joint names."""
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = EventsExecutor(context=context)
    try:
        mock = MockCellNode(context=context)
        recorder = FbccRecordNode(context=context, parameter_overrides=[
            Parameter("out", value=str(folder)), Parameter("topics", value=TOPICS)])  # fmt: skip
        for node in (mock, recorder):
            executor.add_node(node)
        start = time.time_ns()
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
        check(recorder)
        recorder.destroy_node()  # closes the bag
        end = time.time_ns()
        joint_names = list(mock.names)
        mock.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
    return start, end, joint_names


def test_a_recorded_mock_cell_reads_back_with_rosbags(tmp_path: Path) -> None:
    folder = tmp_path / "session"
    start, end, joint_names = _record_mock_cell(folder, 2.0)
    with AnyReader([folder]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert {c.msgtype for c in reader.connections} == {
            "sensor_msgs/msg/JointState", "geometry_msgs/msg/WrenchStamped"}  # fmt: skip
        assert counts["/joint_states"] > 500 and counts["/ft_sensor/raw"] > 500, counts
        rows = [(c.topic, t, raw, reader.deserialize(raw, c.msgtype))
                for c, t, raw in reader.messages()]  # fmt: skip
    times = [t for _, t, _, _ in rows]
    assert times == sorted(times) and start <= times[0] and times[-1] <= end
    for topic, t, raw, msg in rows[:: max(1, len(rows) // 50)]:
        stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        assert 0 <= t - stamp < 0.5e9  # received after it was stamped, not long after
        if topic == "/joint_states":  # two decoders of the same bytes agree
            _, _, names, position, _, _ = cdr.decode_joints(raw)
            assert list(msg.name) == names and list(msg.position) == list(position)
            assert names == joint_names
    assert read_bag(folder).truncated == ""


def test_a_killed_recorder_leaves_a_readable_truncated_bag_the_report_says_so(
    tmp_path: Path,
) -> None:
    """A whole cell (the bringup, not recording itself) recorded by fbcc_record, which is
    SIGKILLed mid-insertion, once its checkpoint counts 400 commands: the bag reads up to its
    last flushed chunk, and fbcc-report draws it and says it is truncated. The bringup waits for
    the recorder (under load its discovery took 3.5 s, longer than the insertion). The trigger
    is early because a starved two-core machine delivers a third of the 4000 commands (1270 in
    one CI run, the checkpoint still short of 1000 when the cell ended)."""
    folder = tmp_path / "killed"
    log_path = tmp_path / "log.txt"
    log = log_path.open("w")
    recorder, cell = recorder_and_cell(folder, log)
    run = [sys.executable, "-m"]
    try:
        deadline = time.monotonic() + 90.0
        while _recorded(folder, "/fbcc/command") < 400:
            assert cell.poll() is None, log_path.read_text()  # killed while the cell runs
            assert time.monotonic() < deadline, log_path.read_text()
            time.sleep(0.1)
        assert recorder.poll() is None, log_path.read_text()
        recorder.send_signal(signal.SIGKILL)
        recorder.wait(timeout=10)
    finally:
        kill_left(cell, recorder)
    bag = read_bag(folder)
    assert bag.truncated, "a killed recorder cannot have written the footer"
    # up to the last flushed chunk: at least half of what the checkpoint counted
    assert bag.counts["/joint_states"] >= bag.counts["/fbcc/command"] > 200, bag.counts
    assert (folder / "metadata.yaml").exists()  # the last checkpoint's
    out = tmp_path / "report"
    scenario = ROOT / "config" / "scenarios" / "bringup_interference.yaml"
    proc = subprocess.run([*run, "fbcc_ros.cli.report", str(folder), "--out", str(out),
                           "--scenario", str(scenario)], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "NOT WHOLE" in proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["truncated"] == bag.truncated
    assert "**The bag is not whole**" in (out / "summary.md").read_text()
    # the last phase the bag holds, not the run's (the ramp may end right at the kill)
    phases = [cdr.decode_string(m.data) for m in bag.messages if m.topic == "/fbcc/phase"]
    assert phases[-1] in ("inserting", "inserted") and summary["final_phase"] == phases[-1]


def _recorded(folder: Path, topic: str) -> int:
    """Messages of ``topic`` in the recorder's last checkpoint (metadata.yaml), 0 before one."""
    import yaml

    try:
        info = yaml.safe_load((folder / "metadata.yaml").read_text())
    except FileNotFoundError:
        return 0
    counts = info["rosbag2_bagfile_information"]["topics_with_message_count"]
    return next((t["message_count"] for t in counts if t["topic_metadata"]["name"] == topic), 0)


def test_a_full_disk_stops_the_recording_not_the_node(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The disk fills 100 kB into a mock cell's recording: the recorder stops recording (its
    subscriptions gone, one error line), keeps spinning without an exception, and closes a bag
    whose metadata counts what the file holds (the chunks written before)."""
    from test.bag.test_bag import _SmallDisk

    class Disk(_SmallDisk):
        LIMIT = 100_000

    opened = Path.open
    monkeypatch.setattr(Path, "open", lambda self, mode="r", *a, **k: Disk(str(self), "wb")
                        if self.suffix == ".mcap" else opened(self, mode, *a, **k))  # fmt: skip
    folder = tmp_path / "full"

    def stopped(recorder: FbccRecordNode) -> None:
        assert recorder.bag.failed is not None and "No space left" in recorder.bag.failed
        assert not list(recorder.subscriptions)

    _record_mock_cell(folder, 3.0, stopped)
    monkeypatch.undo()
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    bag = read_bag(folder)
    assert 0 < meta["message_count"] == sum(bag.counts.values())


def test_a_bag_folder_that_cannot_be_made_stops_the_recorder_with_one_line(
    tmp_path: Path,
) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    out = subprocess.run(
        [sys.executable, "-m", "fbcc_ros.nodes.fbcc_record", "--ros-args", "-p",
         f"out:={blocker / 'bag'}"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert out.returncode == 2, out.stderr
    assert "Traceback" not in out.stderr and f"{blocker}" in out.stderr.strip().splitlines()[-1]
