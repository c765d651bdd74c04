"""The bag writer and reader against two independent readers (rosbags, the mcap library)."""

from __future__ import annotations

import errno
import io
import os
import shutil
from pathlib import Path
from typing import Any

import pytest
import yaml
from geometry_msgs.msg import WrenchStamped
from mcap.reader import make_reader
from rclpy.duration import Duration, Infinite
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from fbcc_ros.bag.reader import read_bag
from fbcc_ros.bag.schema import message_definition, type_hash
from fbcc_ros.bag.writer import BagWriter
from fbcc_ros.core.errors import InputError

T0 = 1_790_000_000_000_000_000  # ns since the epoch


def _wrench(i: int) -> WrenchStamped:
    msg = WrenchStamped()
    msg.header.frame_id = "hole"
    msg.header.stamp.sec, msg.header.stamp.nanosec = 1_790_000_000, i * 1_000_000
    msg.wrench.force.x, msg.wrench.torque.y = 0.5 * i, -0.01 * i
    return msg


def _joints(i: int) -> JointState:
    return JointState(name=["a1", "a2"], position=[0.1 * i, -0.2 * i], velocity=[1.0, 2.0])


def _write(folder: Path, n: int = 300) -> None:
    with BagWriter(folder, chunk_size=4096) as bag:
        bag.add_topic("/ft_sensor/raw", "geometry_msgs/msg/WrenchStamped", [QoSProfile(depth=10)])
        bag.add_topic("/joint_states", "sensor_msgs/msg/JointState", [QoSProfile(depth=10)])
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        bag.add_topic("/fbcc/phase", "std_msgs/msg/String", [latched])
        for i in range(n):
            bag.write("/ft_sensor/raw", serialize_message(_wrench(i)), T0 + i * 1_000_000)
            bag.write("/joint_states", serialize_message(_joints(i)), T0 + i * 1_000_000 + 1)
        bag.write("/fbcc/phase", serialize_message(String(data="inserted")), T0 + n * 1_000_000)


def test_rosbags_reads_the_folder_with_types_times_and_values(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    _write(folder)
    with AnyReader([folder]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        types = {c.topic: c.msgtype for c in reader.connections}
        assert counts == {"/ft_sensor/raw": 300, "/joint_states": 300, "/fbcc/phase": 1}
        assert types["/joint_states"] == "sensor_msgs/msg/JointState"
        wrenches = [
            (t, reader.deserialize(raw, c.msgtype))
            for c, t, raw in reader.messages()
            if c.topic == "/ft_sensor/raw"
        ]
    assert [t for t, _ in wrenches] == [T0 + i * 1_000_000 for i in range(300)]
    last = wrenches[-1][1]
    assert last.wrench.force.x == 0.5 * 299 and last.header.frame_id == "hole"
    assert last.header.stamp.nanosec == 299_000_000


def test_the_mcap_library_reads_schemas_channels_and_messages(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    _write(folder, n=50)
    with (folder / "run_0.mcap").open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and reader.get_header().profile == "ros2"
        schemas = {s.name: s for s in summary.schemas.values()}
        wrench = schemas["geometry_msgs/msg/WrenchStamped"]
        assert wrench.encoding == "ros2msg"
        assert wrench.data.decode() == message_definition("geometry_msgs/msg/WrenchStamped")
        channel = next(c for c in summary.channels.values() if c.topic == "/fbcc/phase")
        assert channel.message_encoding == "cdr"
        assert channel.metadata["topic_type_hash"].startswith("RIHS01_")
        qos = yaml.safe_load(channel.metadata["offered_qos_profiles"])
        assert qos[0]["durability"] == "transient_local" and qos[0]["depth"] == 1
        assert all(c.compression == "zstd" for c in summary.chunk_indexes)
        data = [m.data for _, c, m in reader.iter_messages(topics=["/joint_states"])]
    # Decoded, not byte for byte: the serializer leaves CDR padding (e.g. bytes 64-67,
    # before the velocity doubles) uninitialised, so two encodings of one message can differ.
    assert deserialize_message(data[7], JointState) == _joints(7)


def test_our_reader_and_metadata_agree_with_what_was_written(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    _write(folder, n=120)
    bag = read_bag(folder)
    assert bag.truncated == ""
    assert bag.counts == {"/ft_sensor/raw": 120, "/joint_states": 120, "/fbcc/phase": 1}
    assert bag.topics["/fbcc/phase"] == "std_msgs/msg/String"
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap"
    assert meta["message_count"] == 241
    assert meta["starting_time"]["nanoseconds_since_epoch"] == T0
    assert meta["duration"]["nanoseconds"] == 120 * 1_000_000


def test_a_bag_cut_mid_chunk_reads_up_to_its_last_whole_chunk(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    _write(folder, n=2000)
    path = folder / "run_0.mcap"
    whole = path.read_bytes()
    path.write_bytes(whole[: len(whole) // 2])
    bag = read_bag(path)
    assert bag.truncated.startswith("cut short")
    got = bag.counts["/ft_sensor/raw"]
    assert 200 < got < 2000  # some chunks survived, not all
    kept = [deserialize_message(m.data, WrenchStamped) for m in bag.of("/ft_sensor/raw")]
    assert kept == [_wrench(i) for i in range(got)]  # in order, intact


def test_missing_and_foreign_files_are_input_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"an existing \.mcap file or bag folder"):
        read_bag(tmp_path / "nope.mcap")
    text = tmp_path / "notes.mcap"
    text.write_text("not a bag")
    with pytest.raises(InputError, match="mcap magic"):
        read_bag(text)
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"exactly one \.mcap"):
        read_bag(tmp_path / "empty")


def test_a_bag_folder_is_never_overwritten(tmp_path: Path) -> None:
    _write(tmp_path / "run", n=1)
    with pytest.raises(InputError, match="a new or empty folder"):
        BagWriter(tmp_path / "run")


class _SmallDisk(io.FileIO):
    """A file on a disk that fills up at ``LIMIT`` bytes (ENOSPC, as a full disk says)."""

    LIMIT = 20_000

    def write(self, data: Any) -> int:
        if self.tell() + len(data) > self.LIMIT:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), self.name)
        return super().write(data)


def test_a_full_disk_ends_the_writing_cleanly_and_the_metadata_counts_what_is_on_disk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The disk fills while recording: the write raises once, the writer says why, closing it
    raises nothing, and metadata.yaml counts exactly the messages the file holds (our reader
    reads them up to the last whole chunk)."""
    opened = Path.open
    monkeypatch.setattr(Path, "open", lambda self, mode="r", *a, **k: _SmallDisk(str(self), "wb")
                        if self.suffix == ".mcap" else opened(self, mode, *a, **k))  # fmt: skip
    folder = tmp_path / "full"
    bag = BagWriter(folder, chunk_size=4096)
    bag.add_topic("/ft_sensor/raw", "geometry_msgs/msg/WrenchStamped", [QoSProfile(depth=10)])
    written = 0
    with pytest.raises(OSError, match="No space left"):
        for i in range(100_000):
            bag.write("/ft_sensor/raw", serialize_message(_wrench(i)), T0 + i * 1_000_000)
            written += 1
    assert bag.failed is not None and "No space left on device" in bag.failed
    bag.close()  # no exception: what can be written is
    monkeypatch.undo()
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    on_disk = read_bag(folder)
    assert on_disk.truncated  # no summary or footer: the disk was full
    assert 0 < meta["message_count"] == on_disk.counts["/ft_sensor/raw"] < written


def _metadata(folder: Path) -> dict[str, Any]:
    return dict(yaml.safe_load((folder / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"])  # fmt: skip


def test_closing_writes_rosbag2s_metadata_record_with_the_bags_metadata(tmp_path: Path) -> None:
    """As rosbag2_storage_mcap on close: a Metadata record ``rosbag2`` whose
    ``serialized_metadata`` is the bag's metadata YAML, the same as metadata.yaml's."""
    folder = tmp_path / "run"
    _write(folder, n=50)
    with (folder / "run_0.mcap").open("rb") as f:
        reader = make_reader(f)
        indexed = [index.name for index in reader.get_summary().metadata_indexes]  # type: ignore[union-attr]
        records = list(reader.iter_metadata())
    assert indexed == ["rosbag2"] and [r.name for r in records] == ["rosbag2"]
    serialized = yaml.safe_load(records[0].metadata["serialized_metadata"])
    assert serialized == _metadata(folder)
    assert serialized["message_count"] == 101 and serialized["custom_data"]["closed"] == "true"


def test_publish_time_is_the_senders_and_defaults_to_the_receipt(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    with BagWriter(folder) as bag:
        bag.add_topic("/fbcc/phase", "std_msgs/msg/String", [QoSProfile(depth=1)])
        bag.write("/fbcc/phase", serialize_message(String(data="a")), T0 + 5_000, T0 + 1_234)
        bag.write("/fbcc/phase", serialize_message(String(data="b")), T0 + 9_000)
    with (folder / "run_0.mcap").open("rb") as f:
        times = [(m.log_time, m.publish_time) for _, _, m in make_reader(f).iter_messages()]
    assert times == [(T0 + 5_000, T0 + 1_234), (T0 + 9_000, T0 + 9_000)]
    assert [(m.log_time_ns, m.publish_time_ns) for m in read_bag(folder).messages] == times


JAZZY_INFINITE = {"sec": 9223372036, "nsec": 854775807}
#: offered_qos_profiles as earlier fbcc_ros bags (and Foxy's Fast DDS) wrote "infinite"
FOXY_QOS = yaml.safe_dump([{
    "history": "keep_last", "depth": 1, "reliability": "reliable", "durability": "volatile",
    "deadline": {"sec": 2147483647, "nsec": 4294967295},
    "lifespan": {"sec": 2147483647, "nsec": 4294967295}, "liveliness": "automatic",
    "liveliness_lease_duration": {"sec": 2147483647, "nsec": 4294967295},
    "avoid_ros_namespace_conventions": False}], sort_keys=False)  # fmt: skip


def test_qos_durations_are_written_as_jazzy_writes_them_and_read_in_both_forms(
    tmp_path: Path,
) -> None:
    """Infinite (what the graph reports for a default publisher) is RMW_DURATION_INFINITE,
    unspecified 0 s 0 ns, anything else split into sec and nsec; a channel with the Foxy-era
    infinity is kept verbatim in the file and read as infinite, and rosbags reads both."""
    folder = tmp_path / "run"
    graph = QoSProfile(depth=10, deadline=Infinite, lifespan=Infinite,
                       liveliness_lease_duration=Infinite)  # fmt: skip
    declared = QoSProfile(depth=5, deadline=Duration(seconds=1, nanoseconds=500_000_000))
    with BagWriter(folder) as bag:
        bag.add_topic("/fbcc/phase", "std_msgs/msg/String", [graph, declared])
        definition = message_definition("std_msgs/msg/String").encode()
        described = {"offered_qos_profiles": FOXY_QOS,
                     "topic_type_hash": type_hash("std_msgs/msg/String")}  # fmt: skip
        bag.add_channel("/old", "std_msgs/msg/String", definition, described)
        for topic in ("/fbcc/phase", "/old"):
            bag.write(topic, serialize_message(String(data="x")), T0)
    with (folder / "run_0.mcap").open("rb") as f:
        channels = {c.topic: c.metadata for c in make_reader(f).get_summary().channels.values()}  # type: ignore[union-attr]
    written = yaml.safe_load(channels["/fbcc/phase"]["offered_qos_profiles"])
    assert written[0]["deadline"] == written[0]["lifespan"] == JAZZY_INFINITE
    assert written[0]["liveliness_lease_duration"] == JAZZY_INFINITE
    assert written[1]["deadline"] == {"sec": 1, "nsec": 500_000_000}
    assert written[1]["lifespan"] == {"sec": 0, "nsec": 0}
    assert channels["/old"]["offered_qos_profiles"] == FOXY_QOS  # verbatim in the file
    read = read_bag(folder).qos
    assert read["/fbcc/phase"] == written
    assert read["/old"][0]["deadline"] == JAZZY_INFINITE
    assert read["/old"][0]["liveliness_lease_duration"] == JAZZY_INFINITE
    # metadata.yaml repeats each channel's QoS as written: rosbags finds a topic's channel by it
    listed = {t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"]
              for t in _metadata(folder)["topics_with_message_count"]}  # fmt: skip
    assert listed == {topic: yaml.safe_load(c["offered_qos_profiles"])
                      for topic, c in channels.items()}  # fmt: skip
    with AnyReader([folder]) as reader:
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}  # type: ignore[attr-defined]
        assert sorted(c.topic for c, _, _ in reader.messages()) == ["/fbcc/phase", "/old"]
    assert (qos["/fbcc/phase"][0].deadline.sec, qos["/fbcc/phase"][0].deadline.nsec) == (
        9223372036, 854775807)  # fmt: skip


def test_metadata_follows_every_chunk_and_never_counts_more_than_the_file(tmp_path: Path) -> None:
    """No checkpoint but one before the first chunk: after every message, what a SIGKILL would
    leave (the file's bytes, metadata.yaml) agrees: the metadata counts what the file holds,
    chunk after chunk."""
    folder = tmp_path / "run"
    bag = BagWriter(folder, chunk_size=4096)
    bag.add_topic("/ft_sensor/raw", "geometry_msgs/msg/WrenchStamped", [QoSProfile(depth=10)])
    bag.write("/ft_sensor/raw", serialize_message(_wrench(0)), T0)
    bag.checkpoint()  # no chunk yet: nothing on disk to count
    assert _metadata(folder)["message_count"] == 0
    killed = tmp_path / "killed"
    killed.mkdir()
    counted = []
    for i in range(1, 400):
        bag.write("/ft_sensor/raw", serialize_message(_wrench(i)), T0 + i * 1_000_000)
        shutil.copyfile(bag.path, killed / "run_0.mcap")
        on_disk = read_bag(killed).counts["/ft_sensor/raw"]
        counted.append(_metadata(folder)["topics_with_message_count"][0]["message_count"])
        assert counted[-1] == on_disk, i
    assert len(set(counted)) > 5  # several chunks landed
