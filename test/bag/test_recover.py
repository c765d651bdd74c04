"""fbcc-recover: bags cut as a SIGKILL or a full disk leaves them, made whole, then read by two
independent readers (rosbags, mcap's indexed reader) against what our reader read from the cut
bag; and the command's answers to bad input."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import Reader
from std_msgs.msg import String

from fbcc_ros.bag.reader import Bag, read_bag
from fbcc_ros.bag.recover import is_complete, recover
from fbcc_ros.bag.schema import message_definition, type_hash
from fbcc_ros.bag.writer import BagWriter
from fbcc_ros.cli import recover as cli
from test.bag.test_bag import FOXY_QOS, T0, _joints, _wrench, _write

ROOT = Path(__file__).resolve().parents[2]


def _open_writer(folder: Path, n: int) -> BagWriter:
    """A recording in progress, never closed: n wrenches and joint states, sent 0.25 ms before
    they were received, and a latched phase."""
    bag = BagWriter(folder, chunk_size=4096)
    bag.add_topic("/ft_sensor/raw", "geometry_msgs/msg/WrenchStamped", [QoSProfile(depth=10)])
    bag.add_topic("/joint_states", "sensor_msgs/msg/JointState", [QoSProfile(depth=10)])
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    bag.add_topic("/fbcc/phase", "std_msgs/msg/String", [latched])
    bag.write("/fbcc/phase", serialize_message(String(data="idle")), T0)
    for i in range(n):
        t = T0 + (i + 1) * 1_000_000
        bag.write("/ft_sensor/raw", serialize_message(_wrench(i)), t, t - 250_000)
        bag.write("/joint_states", serialize_message(_joints(i)), t + 1, t - 249_999)
    return bag


def _described(path: Path) -> tuple[dict[str, tuple[str, bytes]], dict[str, dict[str, str]]]:
    """The schemas (name -> encoding, text) and channels (topic -> metadata) of an mcap's
    whole records, read with mcap's stream reader."""
    schemas: dict[str, tuple[str, bytes]] = {}
    channels: dict[str, dict[str, str]] = {}
    try:
        for record in StreamReader(str(path)).records:
            if isinstance(record, Schema):
                schemas[record.name] = (record.encoding, record.data)
            elif isinstance(record, Channel):
                channels[record.topic] = record.metadata
    except Exception:
        pass  # the cut tail
    return schemas, channels


def _metadata(folder: Path) -> dict[str, Any]:
    return dict(yaml.safe_load((folder / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"])  # fmt: skip


def _refused(folder: Path) -> None:
    """What recovery is for: both independent readers refuse the cut bag."""
    with pytest.raises(Exception, match="magic"), Reader(folder):
        pass
    with (folder / "run_0.mcap").open("rb") as f, pytest.raises(Exception):  # noqa: B017
        make_reader(f).get_summary()


def _assert_whole(folder: Path, cut: Bag) -> None:
    """``folder`` holds exactly what our reader read from the cut bag ``cut``: every message's
    topic, bytes, log and publish time, in order, for rosbags and for mcap's indexed reader;
    the schemas and channel metadata of the cut file; a metadata.yaml and a rosbag2 record
    that count what the new file holds."""
    expected = [(m.topic, m.log_time_ns, m.publish_time_ns, m.data) for m in cut.messages]
    with Reader(folder) as reader:
        assert {c.topic: c.msgcount for c in reader.connections if c.msgcount} == cut.counts
        assert [(c.topic, t, raw) for c, t, raw in reader.messages()] == [
            (topic, t, data) for topic, t, _, data in expected]  # fmt: skip
    file = folder / f"{folder.name}_0.mcap"
    with file.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count == len(cut.messages)
        got = [(c.topic, m.log_time, m.publish_time, m.data)
               for _, c, m in reader.iter_messages(log_time_order=False)]  # fmt: skip
        assert got == expected
        assert all(c.compression == "zstd" for c in summary.chunk_indexes)
        rosbag2 = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
    assert _described(file) == _described(cut.path)  # schemas and channels, verbatim
    meta = _metadata(folder)
    assert meta["version"] == 9 and meta["relative_file_paths"] == [file.name]
    assert meta["message_count"] == len(cut.messages)
    counted = {t["topic_metadata"]["name"]: t["message_count"]
               for t in meta["topics_with_message_count"]}  # fmt: skip
    assert {topic: n for topic, n in counted.items() if n} == cut.counts
    times = [m.log_time_ns for m in cut.messages]
    assert meta["starting_time"]["nanoseconds_since_epoch"] == min(times)
    assert meta["duration"]["nanoseconds"] == max(times) - min(times)
    assert meta["custom_data"]["recovered_from"] == str(cut.path)
    assert [yaml.safe_load(r.metadata["serialized_metadata"]) for r in rosbag2] == [meta]
    assert is_complete(file)


@pytest.mark.parametrize("tail", ["whole chunks", "half a chunk"])
def test_a_killed_recorders_bag_is_recovered_whole(tmp_path: Path, tail: str) -> None:
    """What a SIGKILL leaves: the bytes the writer had handed to the system (its whole chunks)
    and the last metadata.yaml; with "half a chunk", the kill came while a chunk was being
    written."""
    writer = _open_writer(tmp_path / "run", n=400)
    killed = tmp_path / "killed"
    shutil.copytree(writer.folder, killed)
    (killed / "fbcc_params.yaml").write_text("fbcc_controller: {ros__parameters: {}}\n")
    partial = 0
    if tail == "half a chunk":
        size = writer.path.stat().st_size
        i = 400
        while writer.path.stat().st_size == size:
            i += 1
            writer.write("/ft_sensor/raw", serialize_message(_wrench(i)), T0 + i * 1_000_000)
        grown = writer.path.read_bytes()[size:]
        partial = len(grown) // 2
        with (killed / "run_0.mcap").open("ab") as f:
            f.write(grown[:partial])
    cut = read_bag(killed)
    assert cut.truncated and 200 < len(cut.messages) < 801
    _refused(killed)
    result = recover(killed)
    assert result is not None and result.bag == tmp_path / "killed_recovered"
    assert result.dropped_bytes == partial
    assert result.kept_bytes + partial == (killed / "run_0.mcap").stat().st_size
    assert result.counts == cut.counts and result.copied == ["fbcc_params.yaml"]
    assert (result.bag / "fbcc_params.yaml").read_text() == (killed / "fbcc_params.yaml"
                                                               ).read_text()  # fmt: skip
    _assert_whole(result.bag, cut)


def _chunks(path: Path) -> list[tuple[int, int, int]]:
    """Each chunk of a whole mcap: its offset, length [bytes] and message count."""
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
        assert summary is not None
        chunks = []
        for index in summary.chunk_indexes:
            f.seek(index.chunk_start_offset)
            chunk = next(iter(StreamReader(f, skip_magic=True, emit_chunks=True).records))
            assert isinstance(chunk, Chunk)
            n = sum(isinstance(r, Message) for r in breakup_chunk(chunk))
            chunks.append((index.chunk_start_offset, index.chunk_length, n))
    return chunks


def test_a_bag_cut_inside_a_chunk_keeps_every_chunk_before_it(tmp_path: Path) -> None:
    """A closed bag cut at random bytes inside chunks (as a full disk cuts a write), its
    metadata.yaml kept (counting more than the file) or gone: every message of the chunks
    before the cut is recovered, and only the part of the cut chunk is dropped."""
    _write(tmp_path / "run", n=2000)
    whole = (tmp_path / "run" / "run_0.mcap").read_bytes()
    chunks = _chunks(tmp_path / "run" / "run_0.mcap")
    assert len(chunks) > 20
    rng = np.random.default_rng(21)
    for k, i in enumerate(rng.choice(np.arange(1, len(chunks) - 1), size=3, replace=False)):
        start, length, _ = chunks[i]
        cut_at = start + int(rng.integers(1, length))
        folder = tmp_path / f"cut{k}"
        folder.mkdir()
        (folder / "run_0.mcap").write_bytes(whole[:cut_at])
        if k % 2 == 0:
            shutil.copy(tmp_path / "run" / "metadata.yaml", folder)
        cut = read_bag(folder)
        assert len(cut.messages) == sum(n for s, n_bytes, n in chunks if s + n_bytes <= cut_at)
        result = recover(folder, tmp_path / f"out{k}")
        assert result is not None and result.dropped_bytes == cut_at - start
        _assert_whole(result.bag, cut)


WRITER = """
import sys, time
from pathlib import Path
from rclpy.qos import QoSProfile
from rclpy.serialization import serialize_message
from std_msgs.msg import String
from fbcc_ros.bag.writer import BagWriter

bag = BagWriter(Path(sys.argv[1]), chunk_size=4096)
bag.add_topic("/fbcc/phase", "std_msgs/msg/String", [QoSProfile(depth=10)])
i = 0
while True:
    i += 1
    t = time.time_ns()
    bag.write("/fbcc/phase", serialize_message(String(data=f"message {i}")), t, t - 1000)
    if i % 50 == 0:
        time.sleep(0.001)
"""


def test_a_sigkilled_writer_leaves_metadata_at_most_a_chunk_behind_and_a_recoverable_bag(
    tmp_path: Path,
) -> None:
    """A writer process SIGKILLed mid-recording: metadata.yaml counts no more than the file
    holds and at most one chunk less; the bag recovers whole."""
    folder = tmp_path / "killed"
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(folder)], cwd=ROOT,
                              stderr=subprocess.PIPE, text=True)  # fmt: skip
    try:
        deadline = time.monotonic() + 60
        while _counted(folder) < 3000:
            assert writer.poll() is None, writer.communicate()[1]
            assert time.monotonic() < deadline
            time.sleep(0.05)
        writer.send_signal(signal.SIGKILL)
        writer.wait(timeout=10)
    finally:
        if writer.poll() is None:
            writer.kill()
            writer.wait()
    cut = read_bag(folder)
    assert cut.truncated
    per_chunk = []
    try:
        for record in StreamReader(str(folder / "killed_0.mcap"), emit_chunks=True).records:
            if isinstance(record, Chunk):
                per_chunk.append(sum(isinstance(r, Message) for r in breakup_chunk(record)))
    except Exception:
        pass  # the cut tail
    on_disk = len(cut.messages)
    assert on_disk == sum(per_chunk)
    assert on_disk - per_chunk[-1] <= _counted(folder) <= on_disk
    result = recover(folder)
    assert result is not None and result.counts == {"/fbcc/phase": on_disk}
    _assert_whole(result.bag, cut)


def _counted(folder: Path) -> int:
    try:
        return int(_metadata(folder)["message_count"])
    except FileNotFoundError:
        return 0


def test_a_foxy_qos_channel_is_kept_as_written_and_rosbags_reads_it(tmp_path: Path) -> None:
    """A cut bag whose channel holds the Foxy-era infinite durations: the channel keeps them
    verbatim, metadata.yaml repeats them (rosbags matches topics to channels by QoS), and our
    reader reads them as infinite."""
    bag = BagWriter(tmp_path / "run", chunk_size=4096)
    definition = message_definition("std_msgs/msg/String").encode()
    described = {"offered_qos_profiles": FOXY_QOS,
                 "topic_type_hash": type_hash("std_msgs/msg/String")}  # fmt: skip
    bag.add_channel("/old", "std_msgs/msg/String", definition, described)
    for i in range(500):
        bag.write("/old", serialize_message(String(data=f"m{i}")), T0 + i)
    cut = read_bag(bag.folder)
    assert cut.truncated and cut.counts["/old"] > 300
    result = recover(bag.folder)
    assert result is not None
    _assert_whole(result.bag, cut)
    listed = _metadata(result.bag)["topics_with_message_count"][0]["topic_metadata"]
    assert listed["offered_qos_profiles"] == yaml.safe_load(FOXY_QOS)
    deadline = read_bag(result.bag).qos["/old"][0]["deadline"]
    assert deadline == {"sec": 9223372036, "nsec": 854775807}


def test_a_whole_file_without_its_metadata_is_recovered_with_nothing_dropped(
    tmp_path: Path,
) -> None:
    _write(tmp_path / "run", n=100)
    (tmp_path / "run" / "metadata.yaml").unlink()
    whole = read_bag(tmp_path / "run")
    assert whole.truncated == ""
    result = recover(tmp_path / "run")
    assert result is not None and result.dropped_bytes == 0 and result.truncated == ""
    assert result.counts == {"/ft_sensor/raw": 100, "/joint_states": 100, "/fbcc/phase": 1}
    _assert_whole(result.bag, whole)


def test_a_complete_bag_is_left_alone_with_or_without_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _write(tmp_path / "run", n=50)
    assert recover(tmp_path / "run") is None
    assert cli.main([str(tmp_path / "run"), "--out", str(tmp_path / "copy")]) == 0
    out = capsys.readouterr().out
    assert "is complete" in out and "nothing written" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_the_command_prints_what_it_recovered(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    writer = _open_writer(tmp_path / "run", n=300)
    cut = read_bag(writer.folder)
    assert cli.main([str(writer.folder), "--out", str(tmp_path / "fixed")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == (f"recovered {writer.path} into {tmp_path / 'fixed'}: "
                        f"{len(cut.messages)} messages")  # fmt: skip
    for topic, n in cut.counts.items():
        assert any(line.split() == [topic, str(n)] for line in lines), lines
    assert any(line.startswith("time span: 2026-09-21 14:13:20.000 to ") for line in lines), lines
    assert any(line.startswith("dropped 0 bytes (kept") for line in lines), lines


def _missing(tmp: Path) -> list[str]:
    return [str(tmp / "nope")]


def _no_mcap(tmp: Path) -> list[str]:
    (tmp / "empty").mkdir()
    return [str(tmp / "empty")]


def _not_mcap(tmp: Path) -> list[str]:
    (tmp / "notes").mkdir()
    (tmp / "notes" / "notes_0.mcap").write_text("not a bag")
    return [str(tmp / "notes")]


def _out_taken(tmp: Path) -> list[str]:
    return [str(_killed(tmp)), "--out", str(_occupied(tmp / "taken"))]


def _default_out_taken(tmp: Path) -> list[str]:
    _occupied(tmp / "run_recovered")
    return [str(_killed(tmp))]


def _killed(tmp: Path) -> Path:
    return _open_writer(tmp / "run", n=300).folder


def _occupied(path: Path) -> Path:
    path.mkdir()
    (path / "keep.txt").write_text("mine")
    return path


@pytest.mark.parametrize(
    ("make", "fragment"),
    [
        (_missing, "an existing .mcap file or bag folder"),
        (_no_mcap, "exactly one .mcap file (found 0)"),
        (_not_mcap, "mcap magic bytes"),
        (_out_taken, "a new or empty folder"),
        (_default_out_taken, "a new or empty folder"),
    ],
    ids=["missing folder", "no mcap", "not mcap", "--out not empty", "default out not empty"],
)
def test_bad_input_is_one_line_and_exit_2_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], make: Any, fragment: str
) -> None:
    argv = make(tmp_path)
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    [line] = captured.err.splitlines()
    assert line.startswith("fbcc-recover: ") and fragment in line
    assert str(tmp_path) in line  # names the value
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before


def test_the_installed_command_exits_2_without_a_traceback(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "fbcc_ros.cli.recover", str(tmp_path / "nope")],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)  # fmt: skip
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip() == (f"fbcc-recover: bag='{tmp_path / 'nope'}' is not allowed: "
                                   "expected an existing .mcap file or bag folder")  # fmt: skip


@pytest.mark.parametrize("where", ["data", "header"])
def test_a_closed_bag_damaged_in_its_middle_is_read_past_the_damage_and_recovered(
        tmp_path: Path, where: str, capsys) -> None:  # fmt: skip
    """Zeros written over one chunk of a closed bag (its compressed data, or its record header
    too): our reader, fbcc-report and fbcc-recover agree that it is not whole and how many
    messages were lost; every other chunk is read through the file's index, and the recovered
    bag holds exactly those messages (rosbags reads it back)."""
    folder = tmp_path / "bag"
    bag = _open_writer(folder, 400)
    bag.close()
    whole = read_bag(folder)
    file = whole.path
    assert not whole.truncated and is_complete(file)
    with file.open("rb") as f:
        summary = make_reader(f).get_summary()
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    assert len(chunks) >= 5
    hit = chunks[len(chunks) // 2]
    with file.open("rb") as f:  # what that chunk holds
        f.seek(hit.chunk_start_offset)
        chunk = next(iter(StreamReader(f, skip_magic=True, emit_chunks=True).records))
        held = sum(isinstance(r, Message) for r in breakup_chunk(chunk))
    start = hit.chunk_start_offset + (0 if where == "header" else hit.chunk_length // 2)
    with file.open("r+b") as f:
        f.seek(start)
        f.write(b"\0" * 64)
    damaged = read_bag(folder)
    assert damaged.truncated.startswith(f"damaged: 1 of {len(chunks)} chunks unreadable"), \
        damaged.truncated  # fmt: skip
    assert f"{held} messages" in damaged.truncated
    assert len(damaged.messages) == len(whole.messages) - held
    got = {(m.topic, m.log_time_ns) for m in damaged.messages}
    assert got < {(m.topic, m.log_time_ns) for m in whole.messages}
    assert not is_complete(file)  # fbcc-recover does not call it complete
    assert cli.main([str(folder), "--out", str(tmp_path / "whole")]) == 0
    said = capsys.readouterr().out
    assert f"damaged: 1 of {len(chunks)} chunks" in said and f"dropped {hit.chunk_length}" in said
    with Reader(tmp_path / "whole") as r:
        assert sum(c.msgcount for c in r.connections) == len(damaged.messages)
    assert read_bag(tmp_path / "whole").counts == damaged.counts
