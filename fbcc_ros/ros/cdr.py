"""The CDR wire format of the control loop's messages, packed and unpacked by hand.

Why: at 1 kHz rclpy's message objects cost more than the control law. Publishing a message
object converts it to C (~20 µs for a PoseStamped), and every received sample is built back
into Python objects (~25 µs) before the callback runs; the loop moves eight messages a period
(profile in ``docs/nodes.md``). So the loop's nodes subscribe raw (serialised) and publish
bytes, and this module is the only place that knows the bytes. Nothing changes for anyone
else on the graph: the bytes are the ones rclpy would send.

The format is plain little-endian CDR (XCDR1), as rmw_fastrtps writes it:

- a 4-byte encapsulation header ``00 01 00 00``;
- each primitive aligned to its own size, counted from the end of that header;
- a string is a uint32 length (NUL included), the bytes, then the NUL;
- a sequence is a uint32 count, then the elements.

A sequence with no elements is not aligned. Padding bytes are zero here, while rclpy leaves
them unset, so tests compare values, not bytes. Each function takes or returns plain Python
values; numpy and pinocchio stay in :mod:`fbcc_ros.ros.convert`. The tests check every
function both ways against ``rclpy.serialization``.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from functools import lru_cache, wraps
from typing import ParamSpec, TypeVar

from fbcc_ros.core.errors import InputError

ENCAPSULATION = b"\x00\x01\x00\x00"  # CDR, little-endian
_STAMP = struct.Struct("<iI")  # sec, nanosec
_U32 = struct.Struct("<I")
_SIX, _SEVEN = struct.Struct("<6d"), struct.Struct("<7d")

Stamp = tuple[int, int]  # (sec, nanosec)
P = ParamSpec("P")
T = TypeVar("T")


class _Layout:
    """Builds the struct format of one message shape, padding as CDR aligns."""

    def __init__(self) -> None:
        self.fmt = ["<4s"]
        self.offset = 0  # from the end of the encapsulation header

    def _align(self, size: int) -> None:
        pad = -self.offset % size
        if pad:
            self.fmt.append(f"{pad}x")
            self.offset += pad

    def primitive(self, code: str, size: int, count: int = 1) -> _Layout:
        if count:
            self._align(size)
            self.fmt.append(f"{count}{code}")
            self.offset += size * count
        return self

    def string(self, text: bytes) -> _Layout:
        self.primitive("I", 4)
        self.fmt.append(f"{len(text) + 1}s")  # struct pads the NUL
        self.offset += len(text) + 1
        return self

    def header(self, frame: bytes) -> _Layout:
        return self.primitive("i", 4).primitive("I", 4).string(frame)

    def doubles(self, count: int) -> _Layout:
        return self.primitive("I", 4).primitive("d", 8, count)

    def struct(self) -> struct.Struct:
        return struct.Struct("".join(self.fmt))


class _Reader:
    """Reads one serialised message front to back."""

    def __init__(self, data: bytes, what: str) -> None:
        _check_encapsulation(data, what)
        self.data = data
        self.pos = 4

    def _align(self, size: int) -> None:
        self.pos += -(self.pos - 4) % size

    def uint32(self) -> int:
        self._align(4)
        (value,) = _U32.unpack_from(self.data, self.pos)
        self.pos += 4
        return int(value)

    def string(self) -> str:
        self._align(4)
        text, self.pos = _string(self.data, self.pos)
        return text

    def header(self) -> tuple[Stamp, str]:
        stamp, frame, self.pos = _header(self.data)
        return stamp, frame

    def doubles(self) -> tuple[float, ...]:
        """A sequence of doubles."""
        n = self.uint32()
        if not n:
            return ()
        self._align(8)
        values = struct.unpack_from(f"<{n}d", self.data, self.pos)
        self.pos += 8 * n
        return values


def _check_encapsulation(data: bytes, what: str) -> None:
    if data[:2] != ENCAPSULATION[:2]:
        raise InputError(what, bytes(data[:4]).hex(), "little-endian CDR (00 01 ...)")


def _string(data: bytes, pos: int) -> tuple[str, int]:
    """A string whose length is at ``pos`` (aligned): (text, the offset after it)."""
    (n,) = _U32.unpack_from(data, pos)
    end = pos + 4 + n
    if n == 0 or end > len(data):
        raise struct.error(f"string of {n} bytes at {pos + 4}")
    return bytes(data[pos + 4 : end - 1]).decode(), end


def _header(data: bytes) -> tuple[Stamp, str, int]:
    """std_msgs/Header, first in the message: (stamp, frame_id, the offset after it)."""
    sec, nanosec = _STAMP.unpack_from(data, 4)
    frame, end = _string(data, 12)
    return (sec, nanosec), frame, end


def _fixed(data: bytes, what: str, doubles: struct.Struct) -> tuple[Stamp, str, tuple[float, ...]]:
    """A header then a fixed run of doubles (WrenchStamped, PoseStamped): one unpack each."""
    _check_encapsulation(data, what)
    stamp, frame, end = _header(data)
    return stamp, frame, doubles.unpack_from(data, end + -(end - 4) % 8)


def _decoding(what: str) -> Callable[[Callable[P, T]], Callable[P, T]]:
    """Decorator: a truncated or garbled message is an InputError naming the message type."""

    def wrap(decode: Callable[P, T]) -> Callable[P, T]:
        @wraps(decode)
        def decoded(*args: P.args, **kwargs: P.kwargs) -> T:
            try:
                return decode(*args, **kwargs)
            except (struct.error, UnicodeDecodeError) as exc:
                size = len(args[0])  # type: ignore[arg-type]
                raise InputError(what, f"{size} bytes ({exc})", f"a well-formed {what}") from exc

        return decoded

    return wrap


@_decoding("stamped message")
def decode_stamp(data: bytes) -> Stamp:
    """The header stamp of any message that begins with a std_msgs/Header."""
    _check_encapsulation(data, "stamped message")
    return _STAMP.unpack_from(data, 4)  # type: ignore[return-value]


# --- geometry_msgs/WrenchStamped and PoseStamped: a header, then a fixed run of doubles
#     (force, torque: 6; position, orientation x y z w: 7)


@lru_cache(maxsize=16)
def _stamped_layout(frame: bytes, count: int) -> struct.Struct:
    return _Layout().header(frame).primitive("d", 8, count).struct()


def _encode_stamped(stamp: Stamp, frame: str, values: Sequence[float], count: int) -> bytes:
    if len(values) != count:
        raise InputError("values", list(values), f"{count} numbers")
    name = frame.encode()
    return _stamped_layout(name, count).pack(ENCAPSULATION, *stamp, len(name) + 1, name, *values)


def encode_wrench(stamp: Stamp, frame: str, wrench: Sequence[float]) -> bytes:
    """``wrench`` = (fx, fy, fz, tx, ty, tz)."""
    return _encode_stamped(stamp, frame, wrench, 6)


@_decoding("geometry_msgs/WrenchStamped")
def decode_wrench(data: bytes) -> tuple[Stamp, str, tuple[float, ...]]:
    """(stamp, frame_id, (fx, fy, fz, tx, ty, tz))."""
    return _fixed(data, "geometry_msgs/WrenchStamped", _SIX)


def encode_pose(stamp: Stamp, frame: str, pose: Sequence[float]) -> bytes:
    """``pose`` = (x, y, z, qx, qy, qz, qw)."""
    return _encode_stamped(stamp, frame, pose, 7)


@_decoding("geometry_msgs/PoseStamped")
def decode_pose(data: bytes) -> tuple[Stamp, str, tuple[float, ...]]:
    """(stamp, frame_id, (x, y, z, qx, qy, qz, qw))."""
    return _fixed(data, "geometry_msgs/PoseStamped", _SEVEN)


# --- sensor_msgs/JointState: header, name (strings), position, velocity, effort (doubles)


@lru_cache(maxsize=16)
def _joints_layout(
    frame: bytes, names: tuple[bytes, ...], sizes: tuple[int, ...]
) -> struct.Struct:
    layout = _Layout().header(frame).primitive("I", 4)
    for name in names:
        layout.string(name)
    for size in sizes:
        layout.doubles(size)
    return layout.struct()


def encode_joints(
    stamp: Stamp,
    frame: str,
    names: Sequence[str],
    position: Sequence[float],
    velocity: Sequence[float] = (),
    effort: Sequence[float] = (),
) -> bytes:
    frame_id, encoded = frame.encode(), tuple(n.encode() for n in names)
    fields = (position, velocity, effort)
    layout = _joints_layout(frame_id, encoded, tuple(len(f) for f in fields))
    values: list[object] = [ENCAPSULATION, *stamp, len(frame_id) + 1, frame_id, len(encoded)]
    for name in encoded:
        values += (len(name) + 1, name)
    for field in fields:
        values += (len(field), *field)
    return layout.pack(*values)


@_decoding("sensor_msgs/JointState")
def decode_joints(
    data: bytes,
) -> tuple[Stamp, str, list[str], tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
    """(stamp, frame_id, names, position, velocity, effort)."""
    reader = _Reader(data, "sensor_msgs/JointState")
    stamp, frame = reader.header()
    start = reader.pos
    block, names = _names_seen.get(start, (b"", []))
    if block and data[start : start + len(block)] == block:
        # the same bytes from the same offset read as the same names: a robot's names never
        # change, and reading seven strings was half of this function's time
        reader.pos += len(block)
        names = names.copy()
    else:
        names = [reader.string() for _ in range(reader.uint32())]
        _names_seen[start] = (bytes(data[start : reader.pos]), names.copy())
    return stamp, frame, names, reader.doubles(), reader.doubles(), reader.doubles()


#: The last names block read at each offset (after a header, which sets the offset): its bytes
#: and the names they hold.
_names_seen: dict[int, tuple[bytes, list[str]]] = {}


# --- std_msgs/Float64MultiArray: layout (dims: label, size, stride; data_offset), data


@lru_cache(maxsize=16)
def _array_layout(labels: tuple[bytes, ...], size: int) -> struct.Struct:
    layout = _Layout().primitive("I", 4)
    for label in labels:
        layout.string(label).primitive("I", 4, 2)
    return layout.primitive("I", 4).doubles(size).struct()


def encode_array(data: Sequence[float], dims: Sequence[tuple[str, int, int]] = ()) -> bytes:
    """``dims``: the layout's (label, size, stride) entries; data_offset is 0."""
    labels = tuple(label.encode() for label, _, _ in dims)
    values: list[object] = [ENCAPSULATION, len(dims)]
    for label, (_, size, stride) in zip(labels, dims, strict=True):
        values += (len(label) + 1, label, size, stride)
    values += (0, len(data), *data)
    return _array_layout(labels, len(data)).pack(*values)


@_decoding("std_msgs/Float64MultiArray")
def decode_labelled_array(data: bytes) -> tuple[tuple[str, ...], tuple[float, ...]]:
    """The layout's labels (one per dimension) and the data."""
    reader = _Reader(data, "std_msgs/Float64MultiArray")
    labels = []
    for _ in range(reader.uint32()):
        labels.append(reader.string())
        reader.uint32()  # size
        reader.uint32()  # stride
    reader.uint32()  # data_offset
    return tuple(labels), reader.doubles()


def decode_array(data: bytes) -> tuple[float, ...]:
    """The data (the layout is read past)."""
    return decode_labelled_array(data)[1]


# --- std_msgs/String (the phase, the contact state, the kinematics status in a bag)


@_decoding("std_msgs/String")
def decode_string(data: bytes) -> str:
    return _Reader(data, "std_msgs/String").string()
