"""Reads a bag written by :mod:`fbcc_ros.bag.writer` (or by rosbag2): a folder or a ``.mcap``.

The file is read front to back (mcap's StreamReader), not through its summary, so a bag whose
recorder was killed still gives every message up to its last whole chunk; ``truncated`` then
says so and why. :class:`WholeRecords` is that front-to-back reading, shared with
:mod:`fbcc_ros.bag.recover`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import yaml
from mcap.records import Channel, Footer, McapRecord, Message, Schema
from mcap.stream_reader import StreamReader

from fbcc_ros.bag.schema import offered_qos
from fbcc_ros.core.errors import InputError

MAGIC = b"\x89MCAP0\r\n"
T = TypeVar("T")


@dataclass
class BagMessage:
    topic: str
    type: str
    log_time_ns: int  # received [ns since the epoch]
    data: bytes  # CDR
    publish_time_ns: int  # sent (the publisher's source timestamp where recorded)


@dataclass
class Bag:
    path: Path  # the .mcap file
    messages: list[BagMessage]
    topics: dict[str, str]  # topic -> pkg/msg/Type
    truncated: str = ""  # why the file ends early; empty if it is whole
    counts: Counter[str] = field(default_factory=Counter)
    qos: dict[str, list[dict[str, Any]]] = field(default_factory=dict)  # offered, per topic

    def of(self, topic: str) -> Iterator[BagMessage]:
        return (m for m in self.messages if m.topic == topic)

    def require(self, topics: dict[str, str]) -> None:
        """Raises InputError naming the first of ``topics`` (name -> type) the bag lacks."""
        for name, kind in topics.items():
            if self.topics.get(name) != kind or not self.counts[name]:
                have = {t: f"{k} ({self.counts[t]})" for t, k in self.topics.items()}
                raise InputError("bag topics", have, f"messages on {name} ({kind})")


def mcap_file(path: Path) -> Path:
    """The .mcap of a bag folder (its only one), or ``path`` itself if it is a file; either way
    a file that starts with the mcap magic bytes."""
    path = Path(path)
    if path.is_dir():
        files = sorted(path.glob("*.mcap"))
        if len(files) != 1:
            raise InputError("bag", str(path), "a folder with exactly one .mcap file "
                             f"(found {len(files)})")  # fmt: skip
        path = files[0]
    if not path.is_file():
        raise InputError("bag", str(path), "an existing .mcap file or bag folder")
    with path.open("rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise InputError("bag", str(path), "an mcap file (it does not start with the "
                             "mcap magic bytes)")  # fmt: skip
    return path


class WholeRecords:
    """The records of an mcap ``file`` front to back, up to its last whole one: a file whose
    writer was killed ends without a footer, perhaps inside a record (a chunk written in
    part), and the records of a chunk come only once the whole chunk is read (and its CRC
    checks). After the iteration, ``end`` [bytes] is the offset just past the last whole
    record (the file's size if it has its footer) and ``truncated`` says why the file ends
    early ("" if it does not)."""

    def __init__(self, file: Path) -> None:
        self.file = file
        self.end = 0
        self.messages = 0
        self.truncated = ""

    def __iter__(self) -> Iterator[McapRecord]:
        self.end, self.messages = 0, 0
        self.truncated = "no footer: the recorder did not close the file"
        with self.file.open("rb") as f:
            try:
                for record in StreamReader(f, validate_crcs=True).records:
                    self.end = f.tell()
                    self.messages += isinstance(record, Message)
                    if isinstance(record, Footer):
                        self.truncated = ""
                    yield record
                self.end = f.tell()  # the closing magic bytes
            # whatever the parser trips on past the last whole record (EndOfFile, a short
            # struct, a cut zstd frame, a CRC) means the same thing: the file ends early
            except Exception as exc:
                why = ": ".join(filter(None, (type(exc).__name__, str(exc))))
                self.truncated = f"cut short after {self.messages} messages ({why})"


def channel_of(channels: dict[int, T], message: Message, file: Path) -> T:
    """What ``channels`` holds for ``message``'s channel; an InputError naming ``file`` if the
    file has not described that channel before the message."""
    if message.channel_id not in channels:
        raise InputError("bag", str(file), "an mcap whose channels come before their messages "
                         f"(channel {message.channel_id} does not)")  # fmt: skip
    return channels[message.channel_id]


def bag_information(folder: Path) -> Any:
    """The ``rosbag2_bagfile_information`` of the folder's metadata.yaml; None if it is missing
    or not YAML."""
    try:
        return yaml.safe_load((Path(folder) / "metadata.yaml").read_text())[
            "rosbag2_bagfile_information"]
    except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError):
        return None


def metadata_counts(folder: Path) -> dict[str, int] | None:
    """Messages per topic as the folder's metadata.yaml counts them; None without a readable
    one."""
    return counts_of(bag_information(folder))


def counts_of(info: Any) -> dict[str, int] | None:
    """Messages per topic as a ``rosbag2_bagfile_information`` counts them; None if it is not
    one."""
    try:
        return {t["topic_metadata"]["name"]: t["message_count"]
                for t in info["topics_with_message_count"]}  # fmt: skip
    except (KeyError, TypeError):
        return None


def read_bag(path: Path) -> Bag:
    records = WholeRecords(mcap_file(path))
    schemas: dict[int, str] = {}
    channels: dict[int, tuple[str, str]] = {}
    qos: dict[str, list[dict[str, Any]]] = {}
    messages: list[BagMessage] = []
    for record in records:
        if isinstance(record, Schema):
            schemas[record.id] = record.name
        elif isinstance(record, Channel):
            channels[record.id] = (record.topic, schemas.get(record.schema_id, ""))
            qos[record.topic] = offered_qos(record.metadata.get("offered_qos_profiles", ""))
        elif isinstance(record, Message):
            topic, kind = channel_of(channels, record, records.file)
            messages.append(BagMessage(topic, kind, record.log_time, record.data,
                                       record.publish_time))  # fmt: skip
    counts = Counter(m.topic for m in messages)
    topics = {topic: kind for topic, kind in channels.values()}
    return Bag(records.file, messages, topics, records.truncated, counts, qos)
