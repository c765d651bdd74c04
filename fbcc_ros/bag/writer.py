"""Writes a rosbag2 bag folder: ``<name>_0.mcap`` (profile ros2, zstd chunks) + metadata.yaml.

Crash safety: the chunks are small (256 KiB, about 0.3 s of the cell's topics) and the file
is flushed as soon as a chunk lands in it, so a recorder killed mid-write leaves every finished
chunk on disk; :func:`fbcc_ros.bag.reader.read_bag` reads such a bag up to its last whole chunk
and says it is truncated, and :func:`fbcc_ros.bag.recover.recover` makes it whole.
``metadata.yaml`` (version 9, as rosbag2 Jazzy writes it) is rewritten, atomically, each time a
chunk lands, with the counts of the chunks on disk: after a SIGKILL it never counts more than
the file holds, and lags it by at most the chunk being written when the process died. On close
it counts everything, and the same YAML goes into the file as rosbag2_storage_mcap's metadata
record (``McapStorage::update_metadata``: name ``rosbag2``, key ``serialized_metadata``).
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import Any

import yaml
from mcap.records import Attachment
from mcap.writer import CompressionType, Writer

from fbcc_ros.bag.schema import message_definition, offered_qos, qos_profiles, type_hash
from fbcc_ros.core.errors import InputError

CHUNK_SIZE = 256 * 1024
METADATA_VERSION = 9  # rosbag2 on Jazzy
#: rosbag2_storage_mcap's metadata record: its name and the key of the bag's metadata YAML
ROSBAG2_RECORD, SERIALIZED_METADATA = "rosbag2", "serialized_metadata"
#: metadata.yaml is rewritten per chunk: libyaml's dumper takes 1.7 ms where PyYAML's takes 9
_dump = partial(yaml.dump, Dumper=getattr(yaml, "CSafeDumper", yaml.SafeDumper),
                sort_keys=False)  # fmt: skip


def check_new_folder(folder: Path) -> Path:
    """``folder`` if it is new or empty: a bag never overwrites anything."""
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise InputError("bag folder", str(folder), "a new or empty folder")
    return folder


class BagWriter:
    """``add_topic`` once per topic, then ``write`` serialised (CDR) messages; ``close``."""

    def __init__(self, folder: Path, chunk_size: int = CHUNK_SIZE) -> None:
        self.folder = check_new_folder(Path(folder))
        self.folder.mkdir(parents=True, exist_ok=True)
        self.path = self.folder / f"{self.folder.name}_0.mcap"
        self._file = self.path.open("wb")
        self._mcap = Writer(self._file, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._mcap.start(profile="ros2", library="fbcc_ros")
        self._flush()  # the header: a later change of size is a chunk
        self._schemas: dict[str, int] = {}
        #: name -> type, serialization format, offered QoS, type hash and message count
        self.topics: dict[str, dict[str, Any]] = {}
        self._channels: dict[str, int] = {}
        self.start_ns: int | None = None
        self.end_ns = 0
        self.closed = False
        #: metadata.yaml's ``custom_data`` (rosbag2's map of strings), ``closed`` added
        self.custom_data = {"writer": "fbcc_ros"}
        #: why writing failed (disk full, the folder gone), None while it works
        self.failed: str | None = None
        self._on_disk: dict[str, int] = {}  # the counts and end time of what is flushed
        self._end_on_disk = 0

    def add_topic(self, topic: str, type_name: str, qos: list[Any]) -> None:
        """``qos``: the publishers' offered rclpy QoSProfiles."""
        if topic in self._channels:
            return
        profiles = qos_profiles(qos)
        self.add_channel(topic, type_name, message_definition(type_name).encode(), {
            "offered_qos_profiles": yaml.safe_dump(profiles, sort_keys=False),
            "topic_type_hash": type_hash(type_name),
        })  # fmt: skip

    def add_channel(self, topic: str, type_name: str, definition: bytes,
                    metadata: dict[str, str], schema_encoding: str = "ros2msg",
                    message_encoding: str = "cdr") -> None:  # fmt: skip
        """A topic as a bag describes it: the schema's ``definition`` and the channel's
        ``metadata`` (rosbag2's ``offered_qos_profiles`` YAML and ``topic_type_hash``), kept
        verbatim. A type's first schema serves every topic of that type."""
        if topic in self._channels:
            return
        if type_name not in self._schemas:
            self._schemas[type_name] = self._mcap.register_schema(
                name=type_name, encoding=schema_encoding, data=definition
            )
        self._channels[topic] = self._mcap.register_channel(
            topic=topic, message_encoding=message_encoding, schema_id=self._schemas[type_name],
            metadata=metadata,
        )  # fmt: skip
        self.topics[topic] = {
            "type": type_name,
            "format": message_encoding,
            "qos": offered_qos(metadata.get("offered_qos_profiles", ""), jazzy=False),
            "hash": metadata.get("topic_type_hash", ""),
            "count": 0,
        }

    def write(self, topic: str, data: bytes, log_time_ns: int | None = None,
              publish_time_ns: int | None = None) -> None:  # fmt: skip
        """One CDR message, received at ``log_time_ns`` (now if None) and sent at
        ``publish_time_ns`` (the publisher's source timestamp, which rosbag2 Jazzy stores as
        publish time; the receipt if None) [ns since the epoch]. An ``OSError`` (disk full) is
        raised once and ends the writing: the counts go back to what is on disk, and later
        messages are dropped."""
        if self.failed is not None:
            return  # after a failed write nothing more goes in: the file ends where it failed
        t = time.time_ns() if log_time_ns is None else log_time_ns
        sent = t if publish_time_ns is None else publish_time_ns
        try:  # not _writing(): a generator per message on the recorder's hot path
            self._mcap.add_message(self._channels[topic], log_time=t, data=data,
                                   publish_time=sent)  # fmt: skip
            self.topics[topic]["count"] += 1
            self.start_ns = t if self.start_ns is None else min(self.start_ns, t)
            self.end_ns = max(self.end_ns, t)
            if self._file.tell() != self._flushed:  # a chunk, this message last: to disk
                self._flush()
                self._on_disk = self.counts()
                self._end_on_disk = self.end_ns
                self._write_metadata(self._on_disk, self._end_on_disk)  # after the chunk
        except OSError as exc:
            self.fail(exc)
            raise

    def counts(self) -> dict[str, int]:
        """Messages written per topic."""
        return {name: t["count"] for name, t in self.topics.items()}

    def _flush(self) -> None:
        """To disk, and remembered as flushed."""
        self._file.flush()
        self._flushed = self._file.tell()

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """An mcap Metadata record (a name and a map of strings), on disk at once."""
        with self._writing():
            self._mcap.add_metadata(name, data)
            self._flush()

    def add_attachment(self, attachment: Attachment) -> None:
        """An mcap Attachment record (a named file), on disk at once."""
        with self._writing():
            self._mcap.add_attachment(attachment.create_time, attachment.log_time,
                                      attachment.name, attachment.media_type,
                                      attachment.data)  # fmt: skip
            self._flush()

    @contextmanager
    def _writing(self) -> Iterator[None]:
        """An ``OSError`` inside ends the writing (:meth:`fail`) and is raised."""
        try:
            yield
        except OSError as exc:
            self.fail(exc)
            raise

    def fail(self, exc: OSError) -> None:
        """Writing failed: say why (``failed``); the file is cut back to its last flushed chunk
        (a record written in part would hold messages the counts do not), and the counts are
        what it holds."""
        self.failed = f"{exc.filename or self.path}: {exc.strerror or exc}"
        for name, meta in self.topics.items():  # what the file holds, for the metadata
            meta["count"] = self._on_disk.get(name, 0)
        self.end_ns = self._end_on_disk
        self._cut_back()

    def _cut_back(self) -> None:
        try:
            os.truncate(self.path, self._flushed)
        except OSError:
            pass  # the file stays longer: our reader still stops at its last whole chunk

    def checkpoint(self) -> None:
        """Rewrites metadata.yaml with the counts of what is on disk (the flushed chunks), as
        each chunk does; before the first chunk, it lists the topics. An ``OSError`` ends the
        writing as in :meth:`write`."""
        if self.failed is not None:
            return
        with self._writing():
            self._write_metadata(self._on_disk, self._end_on_disk)

    def close(self) -> None:
        """Finishes the file (the ``rosbag2`` metadata record, summary, footer) and the
        metadata; after a failed write, only what can still be written (the file then reads as
        truncated after its last chunk)."""
        if self.closed:
            return
        self.closed = True
        if self.failed is None:
            info = self._info()  # the record and metadata.yaml: the same
            self._mcap.add_metadata(ROSBAG2_RECORD, {SERIALIZED_METADATA: _dump(info)})
            self._mcap.finish()
            self._file.close()
            self._write_info(info)
            return
        for step in (self._file.close, self._cut_back, self._write_metadata):
            try:
                step()
            except OSError:
                pass  # the disk is still full: the bag keeps what was flushed

    def _info(self, counts: dict[str, int] | None = None, end_ns: int | None = None
              ) -> dict[str, Any]:  # fmt: skip
        """The bag's metadata (rosbag2's BagMetadata, version 9) with ``counts`` per topic up
        to ``end_ns`` (default: all written)."""
        counts = counts if counts is not None else self.counts()
        end = self.end_ns if end_ns is None else end_ns
        start = self.start_ns or 0
        duration = max(end - start, 0) if self.start_ns is not None else 0
        count = sum(counts.values())
        return {
            "version": METADATA_VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": count,
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": name,
                        "type": t["type"],
                        "serialization_format": t["format"],
                        "offered_qos_profiles": t["qos"],
                        "type_description_hash": t["hash"],
                    },
                    "message_count": counts.get(name, 0),
                }
                for name, t in self.topics.items()
            ],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [self.path.name],
            "files": [
                {
                    "path": self.path.name,
                    "starting_time": {"nanoseconds_since_epoch": start},
                    "duration": {"nanoseconds": duration},
                    "message_count": count,
                }
            ],
            "custom_data": {**self.custom_data, "closed": str(self.closed).lower()},
            "ros_distro": "jazzy",
        }

    def _write_metadata(self, counts: dict[str, int] | None = None, end_ns: int | None = None
                        ) -> None:  # fmt: skip
        """metadata.yaml of :meth:`_info`."""
        self._write_info(self._info(counts, end_ns))

    def _write_info(self, info: dict[str, Any]) -> None:
        """metadata.yaml holding ``info``, replaced atomically (a reader never sees half)."""
        tmp = self.folder / "metadata.yaml.tmp"
        tmp.write_text(_dump({"rosbag2_bagfile_information": info}))
        tmp.replace(self.folder / "metadata.yaml")

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
