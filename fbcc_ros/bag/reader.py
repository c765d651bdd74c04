"""Reads a bag written by :mod:`fbcc_ros.bag.writer` (or by rosbag2): a folder or a ``.mcap``.

The file is read front to back (mcap's StreamReader), not through its summary, so a bag whose
recorder was killed still gives every message up to its last whole chunk; ``truncated`` then
says so and why.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from mcap.records import Channel, Footer, Message, Schema
from mcap.stream_reader import StreamReader

from fbcc_ros.core.errors import InputError

MAGIC = b"\x89MCAP0\r\n"


@dataclass
class BagMessage:
    topic: str
    type: str
    log_time_ns: int
    data: bytes  # CDR


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
    """The .mcap of a bag folder (its only one), or ``path`` itself if it is a file."""
    path = Path(path)
    if path.is_dir():
        files = sorted(path.glob("*.mcap"))
        if len(files) != 1:
            raise InputError("bag", str(path), "a folder with exactly one .mcap file "
                             f"(found {len(files)})")  # fmt: skip
        return files[0]
    if not path.is_file():
        raise InputError("bag", str(path), "an existing .mcap file or bag folder")
    return path


def read_bag(path: Path) -> Bag:
    file = mcap_file(path)
    with file.open("rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise InputError("bag", str(file), "an mcap file (it does not start with the "
                             "mcap magic bytes)")  # fmt: skip
        f.seek(0)
        schemas: dict[int, str] = {}
        channels: dict[int, tuple[str, str]] = {}
        qos: dict[str, list[dict[str, Any]]] = {}
        messages: list[BagMessage] = []
        truncated = "no footer: the recorder did not close the file"
        try:
            for record in StreamReader(f).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record.name
                elif isinstance(record, Channel):
                    channels[record.id] = (record.topic, schemas.get(record.schema_id, ""))
                    qos[record.topic] = _offered_qos(record.metadata)
                elif isinstance(record, Message):
                    topic, kind = channels[record.channel_id]
                    messages.append(BagMessage(topic, kind, record.log_time, record.data))
                elif isinstance(record, Footer):
                    truncated = ""
        # whatever the parser trips on past the last whole record (EndOfFile, a short struct,
        # a cut zstd frame) means the same thing: the file ends early
        except Exception as exc:
            truncated = f"cut short after {len(messages)} messages ({type(exc).__name__})"
    counts = Counter(m.topic for m in messages)
    topics = {topic: kind for topic, kind in channels.values()}
    return Bag(file, messages, topics, truncated, counts, qos)


def _offered_qos(metadata: dict[str, str]) -> list[dict[str, Any]]:
    """A channel's ``offered_qos_profiles`` (rosbag2's YAML list); none if absent or garbled."""
    try:
        profiles = yaml.safe_load(metadata.get("offered_qos_profiles", "") or "[]")
    except yaml.YAMLError:
        return []
    return [p for p in profiles if isinstance(p, dict)] if isinstance(profiles, list) else []
