"""Recovering a bag whose recorder was killed (SIGKILL) or cut by a full disk, or whose file was
damaged in its middle.

Such a bag's mcap has no summary and no footer and may end inside a record (a chunk written in
part); its metadata.yaml lags the file or is missing. rosbags ("File end magic is invalid") and
mcap's indexed reader refuse it. :func:`recover` reads its whole records front to back
(:class:`~fbcc_ros.bag.reader.WholeRecords`) into a new bag folder through
:class:`~fbcc_ros.bag.writer.BagWriter`, so the result is what a closed bag is: the same zstd
chunks, the summary and indexes, the footer, the ``rosbag2`` metadata record, and a
metadata.yaml that counts exactly what the new file holds.

Kept as they were: every message of every whole chunk (its bytes, log and publish times, in
file order), the schemas, the channels with their metadata (``offered_qos_profiles``,
``topic_type_hash``), metadata records and attachments, and the bag folder's other files
(``fbcc_params.yaml``). Written anew: the ``rosbag2`` record and metadata.yaml; their QoS are
the channels' as written, in either form of infinite duration (rosbags matches a topic to its
channel by QoS; :func:`~fbcc_ros.bag.schema.offered_qos` reads both). Lost: the part of the
file after its last whole record (for a damaged file with its summary: the chunks that do not
read, the others found through its index), and mcap's message sequence numbers (rosbag2 writes
0).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path

from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Message, Metadata, Schema

from fbcc_ros.bag.reader import (
    WholeRecords,
    bag_information,
    channel_of,
    counts_of,
    mcap_file,
)
from fbcc_ros.bag.writer import ROSBAG2_RECORD, BagWriter, check_new_folder

#: Files of a bag folder the new bag writes itself (the .mcap is the one read)
OWN_FILES = ("metadata.yaml", "metadata.yaml.tmp")
#: A channel's schema 0: none (mcap spec)
NO_SCHEMA = Schema(id=0, data=b"", encoding="", name="")


@dataclass
class Recovery:
    """What :func:`recover` wrote: ``bag``, from ``source``."""

    source: Path  # the .mcap read
    bag: Path  # the new bag folder
    counts: dict[str, int]  # messages per topic
    start_ns: int | None  # the first log time [ns since the epoch]; None without messages
    end_ns: int  # the last [ns since the epoch]
    kept_bytes: int  # the source's bytes read
    dropped_bytes: int  # the rest: a record written in part at the tail, or damaged chunks
    truncated: str  # why the source is not whole
    copied: list[str] = field(default_factory=list)  # the folder's other files


def default_out(bag: Path) -> Path:
    """``<bag>_recovered`` beside the bag folder (beside a lone ``.mcap``: its stem's)."""
    bag = Path(bag)
    name = bag.name if bag.is_dir() else bag.stem
    return bag.parent / f"{name}_recovered"


def is_complete(file: Path) -> bool:
    """Whether the bag of ``file`` needs nothing: mcap's indexed reader opens the file
    (summary, footer), the metadata.yaml beside it names the file and counts per topic what
    the summary's statistics count, and every record reads (a chunk damaged in the middle of a
    closed file does not)."""
    try:
        with file.open("rb") as f:
            summary = make_reader(f).get_summary()
    # a cut file fails wherever the reader looks for its footer (bad magic, a record length
    # past the file, a short read): each means "not complete"
    except Exception:
        return False
    if summary is None or summary.statistics is None:
        return False
    stats = summary.statistics
    in_file = {c.topic: stats.channel_message_counts.get(c.id, 0)
               for c in summary.channels.values()}  # fmt: skip
    info = bag_information(file.parent)
    try:
        in_step = bool(info["relative_file_paths"] == [file.name]
                       and counts_of(info) == in_file
                       and info["message_count"] == stats.message_count)  # fmt: skip
    except (KeyError, TypeError):
        return False  # missing or not rosbag2's
    records = WholeRecords(file)  # every chunk decompresses and checks its CRC
    for _ in records:
        pass
    return in_step and not records.truncated


def recover(bag: Path, out: Path | None = None) -> Recovery | None:
    """Writes ``bag`` (a bag folder or its ``.mcap``) whole into the new folder ``out``
    (default :func:`default_out`; new or empty, else an InputError before anything is
    written). None, writing nothing, if the bag is complete (:func:`is_complete`)."""
    bag = Path(bag)
    source = mcap_file(bag)
    if is_complete(source):
        return None
    records = WholeRecords(source)
    writer = BagWriter(check_new_folder(Path(out) if out is not None else default_out(bag)))
    writer.custom_data["recovered_from"] = str(source)
    schemas: dict[int, Schema] = {}
    topics: dict[int, str] = {}  # channel id -> topic
    for record in records:
        if isinstance(record, Schema):
            schemas[record.id] = record
        elif isinstance(record, Channel):
            schema = schemas.get(record.schema_id, NO_SCHEMA)
            writer.add_channel(record.topic, schema.name, schema.data, record.metadata,
                               schema.encoding, record.message_encoding)  # fmt: skip
            topics[record.id] = record.topic
        elif isinstance(record, Message):
            writer.write(channel_of(topics, record, source), record.data, record.log_time,
                         record.publish_time)  # fmt: skip
        elif isinstance(record, Metadata) and record.name != ROSBAG2_RECORD:
            writer.add_metadata(record.name, record.metadata)  # the rosbag2 one is written anew
        elif isinstance(record, Attachment):
            writer.add_attachment(record)
    writer.close()
    copied = []
    if bag.is_dir():
        for other in sorted(bag.iterdir()):
            if other.is_file() and other != source and other.name not in OWN_FILES:
                shutil.copy2(other, writer.folder / other.name)
                copied.append(other.name)
    return Recovery(
        source=source,
        bag=writer.folder,
        counts=writer.counts(),
        start_ns=writer.start_ns,
        end_ns=writer.end_ns,
        kept_bytes=source.stat().st_size - records.lost_bytes,
        dropped_bytes=records.lost_bytes,
        truncated=records.truncated,
        copied=copied,
    )
