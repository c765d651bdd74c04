"""Reads a bag written by :mod:`fbcc_ros.bag.writer` (or by rosbag2): a folder or a ``.mcap``.

The file is read front to back (mcap's StreamReader), not through its summary, so a bag whose
recorder was killed still gives every message up to its last whole chunk; ``truncated`` then
says so and why. A closed file damaged in its middle (a chunk that does not decompress, or
fails its CRC) is read on past the damage through its summary's chunk index: every chunk that
reads is kept, and ``truncated`` says how many were not and how many messages they held.
:class:`WholeRecords` is that reading, shared with :mod:`fbcc_ros.bag.recover`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import yaml
from mcap.reader import make_reader
from mcap.records import Channel, ChunkIndex, Footer, McapRecord, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

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
    truncated: str = ""  # why the file is not whole (cut short, or damaged); empty if it is
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
    checks). A file with its summary that is damaged in its middle is read on through the
    summary's chunk index (:meth:`_past_damage`). After the iteration, ``truncated`` says why
    the file is not whole ("" if it is), ``end`` [bytes] is the offset just past the last
    whole record read front to back, and ``lost_bytes`` how much of the file was not read
    (the cut tail, or the damaged chunks)."""

    def __init__(self, file: Path) -> None:
        self.file = file
        self.end = 0
        self.messages = 0
        self.truncated = ""
        self.lost_bytes = 0

    def __iter__(self) -> Iterator[McapRecord]:
        self.end, self.messages, self.lost_bytes = 0, 0, 0
        self.truncated = "no footer: the recorder did not close the file"
        seen: set[tuple[type, int]] = set()  # schemas and channels given
        with self.file.open("rb") as f:
            try:
                for record in StreamReader(f, validate_crcs=True).records:
                    self.end = f.tell()
                    self.messages += isinstance(record, Message)
                    if isinstance(record, Schema | Channel):
                        seen.add((type(record), record.id))
                    if isinstance(record, Footer):
                        self.truncated = ""
                    yield record
                self.end = f.tell()  # the closing magic bytes
            # whatever the parser trips on past the last whole record (EndOfFile, a short
            # struct, a cut zstd frame, a CRC) means the same thing: the file ends early, or
            # is damaged there
            except Exception as exc:
                why = ": ".join(filter(None, (type(exc).__name__, str(exc))))
                self.truncated = f"cut short after {self.messages} messages ({why})"
                self.lost_bytes = self.file.stat().st_size - self.end
                yield from self._past_damage(f, why, seen)

    def _past_damage(self, f: Any, why: str, seen: set[tuple[type, int]]
                     ) -> Iterator[McapRecord]:  # fmt: skip
        """The chunks after the damage at ``end``, each found through the summary's chunk
        index and read alone; nothing for a file without a summary (a cut one)."""
        try:
            f.seek(0)
            summary = make_reader(f).get_summary()
        except Exception:  # no footer, no summary: the file was cut, not damaged
            return
        if summary is None or not summary.chunk_indexes:
            return
        later = sorted((c for c in summary.chunk_indexes if c.chunk_start_offset >= self.end),
                       key=lambda c: c.chunk_start_offset)  # fmt: skip
        described: list[Schema | Channel] = [*summary.schemas.values(),
                                             *summary.channels.values()]  # fmt: skip
        for record in described:
            if (type(record), record.id) not in seen:  # the damage may have held them
                seen.add((type(record), record.id))
                yield record
        damaged: list[ChunkIndex] = []
        for index in later:
            try:
                f.seek(index.chunk_start_offset)
                reader = StreamReader(f, skip_magic=True, emit_chunks=True, validate_crcs=True)
                records = breakup_chunk(next(iter(reader.records)), validate_crc=True)  # type: ignore[arg-type]
            except Exception:
                damaged.append(index)
                continue
            for item in records:
                if isinstance(item, Schema | Channel):
                    if (type(item), item.id) in seen:
                        continue
                    seen.add((type(item), item.id))
                self.messages += isinstance(item, Message)
                yield item
        total = summary.statistics.message_count if summary.statistics else None
        lost = "" if total is None else f", {total - self.messages} messages"
        self.lost_bytes = sum(c.chunk_length for c in damaged)
        self.truncated = (f"damaged: {len(damaged)} of {len(summary.chunk_indexes)} chunks "
                          f"unreadable ({self.lost_bytes} bytes{lost}), the first at byte "
                          f"{self.end} ({why}); every other chunk was read through the file's "
                          "index")  # fmt: skip


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
