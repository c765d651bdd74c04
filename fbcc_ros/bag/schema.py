"""What a rosbag2 mcap says about each topic: the schema text, the type hash and the QoS.

rosbag2 (``LocalMessageDefinitionSource``) builds the ``ros2msg`` schema from
``share/<pkg>/msg/<Type>.msg`` verbatim, then appends each dependency once, depth-first, in
sorted order, each after a line of 80 ``=`` and ``MSG: <name as written in the field>``. The
type hash (``RIHS01_…``) is the first entry of ``share/<pkg>/msg/<Type>.json``. Both files
ship with the message wheels (PLATFORM.md). The offered QoS are the YAML of rosbag2_storage's
``qos.cpp``, version 9: policies by name, durations as ``{sec, nsec}`` (infinite:
``RMW_DURATION_INFINITE``, 9223372036 s 854775807 ns).
"""

from __future__ import annotations

import importlib
import json
import os
import re
import sys
from functools import lru_cache
from pathlib import Path
from typing import Any

import yaml

from fbcc_ros.core.errors import InputError

#: The first token of a field line ("foo_msgs/Bar" in "foo_msgs/Bar[] bar"), as rosbag2 reads it.
_FIELD_TYPE = re.compile(r"(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
_PRIMITIVES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16",
               "uint16", "int32", "uint32", "int64", "uint64", "string"}  # fmt: skip
DELIMITER = "=" * 80 + "\n"


def _split(type_name: str) -> tuple[str, str]:
    """``pkg/msg/Type`` or ``pkg/Type`` → (pkg, Type)."""
    parts = type_name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise InputError("type", type_name, "a message type as pkg/msg/Type")


def share_dir(package: str) -> Path:
    """The package's share directory: the ament index, else this interpreter's prefix."""
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    for prefix in [*prefixes, sys.prefix]:
        path = Path(prefix) / "share" / package
        if path.is_dir():
            return path
    raise InputError("package", package, "a message package installed in an ament prefix")


@lru_cache(maxsize=64)
def _msg_text(type_name: str) -> str:
    package, name = _split(type_name)
    path = share_dir(package) / "msg" / f"{name}.msg"
    if not path.is_file():
        raise InputError("type", type_name, f"a message with a definition at {path}")
    return path.read_text()


def message_definition(type_name: str) -> str:
    """The complete ``ros2msg`` definition of ``pkg/msg/Type``, as rosbag2 writes it."""
    seen: set[str] = set()

    def append(name: str) -> str:
        text = _msg_text(name)
        package = _split(name)[0]
        deps = set()
        for match in _FIELD_TYPE.finditer(text):
            field = match.group(1)
            if field not in _PRIMITIVES:
                deps.add(field if "/" in field else f"{package}/{field}")
        for dep in sorted(deps):
            if dep not in seen:
                seen.add(dep)
                text += "\n" + DELIMITER + f"MSG: {dep}\n" + append(dep)
        return text

    return append(type_name)


@lru_cache(maxsize=64)
def type_hash(type_name: str) -> str:
    """The RIHS01 type hash of ``pkg/msg/Type`` (what rosbag2 stores as topic_type_hash)."""
    package, name = _split(type_name)
    path = share_dir(package) / "msg" / f"{name}.json"
    return str(json.loads(path.read_text())["type_hashes"][0]["hash_string"])


def message_class(type_name: str) -> Any:
    """The rclpy message class of ``pkg/msg/Type``."""
    package, name = _split(type_name)
    try:
        return getattr(importlib.import_module(f"{package}.msg"), name)
    except (ImportError, AttributeError):
        raise InputError("type", type_name, "a message type installed for Python") from None


#: rmw's RMW_DURATION_INFINITE: what rosbag2 Jazzy writes for an infinite deadline, lifespan or
#: lease duration, since it writes the rmw_time_t as it is (rosbag2_storage qos.cpp,
#: ``convert<rmw_time_t>::encode``).
INFINITE = {"sec": 9223372036, "nsec": 854775807}
#: The Foxy-era "infinite" durations (Fast DDS, Connext; Cyclone's 2**63 - 1 ns is INFINITE
#: itself), which earlier fbcc_ros bags hold too: rosbag2 reads them as INFINITE
#: (``convert<rmw_time_t>::decode``), and so does :func:`offered_qos`.
FOXY_INFINITE = ({"sec": 2147483647, "nsec": 4294967295}, {"sec": 2147483647, "nsec": 2147483647})
DURATIONS = ("deadline", "lifespan", "liveliness_lease_duration")


def qos_profiles(profiles: list[Any]) -> list[dict[str, Any]]:
    """rclpy QoSProfiles → the ``offered_qos_profiles`` entries of a version 9 bag, as rosbag2
    Jazzy writes them: policies by name, durations as rmw gives them (infinite: INFINITE,
    unspecified: 0 s 0 ns)."""

    def duration(d: Any) -> dict[str, int]:
        ns = max(d.nanoseconds, 0)  # rmw_time_t is unsigned
        return dict(INFINITE) if ns >= 2**63 - 1 else {"sec": ns // 10**9, "nsec": ns % 10**9}

    return [
        {
            "history": p.history.name.lower(),
            "depth": p.depth,
            "reliability": p.reliability.name.lower(),
            "durability": p.durability.name.lower(),
            "deadline": duration(p.deadline),
            "lifespan": duration(p.lifespan),
            "liveliness": p.liveliness.name.lower(),
            "liveliness_lease_duration": duration(p.liveliness_lease_duration),
            "avoid_ros_namespace_conventions": p.avoid_ros_namespace_conventions,
        }
        for p in profiles
    ]


def offered_qos(text: str, jazzy: bool = True) -> list[dict[str, Any]]:
    """A channel's ``offered_qos_profiles`` (rosbag2's YAML list) → its profiles, a Foxy-era
    infinite duration read as INFINITE; with ``jazzy=False`` the durations as written (what
    metadata.yaml repeats: rosbags finds a topic's channel by its QoS as parsed, unchanged).
    none if absent or garbled."""
    try:
        profiles = yaml.safe_load(text or "[]")
    except yaml.YAMLError:
        return []
    if not isinstance(profiles, list):
        return []
    read = [dict(p) for p in profiles if isinstance(p, dict)]
    for profile in read if jazzy else ():
        for key in DURATIONS:
            if profile.get(key) in FOXY_INFINITE:
                profile[key] = dict(INFINITE)
    return read
