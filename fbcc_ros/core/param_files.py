"""The keys of a ROS 2 parameter file (``node: ros__parameters: {...}``) and the node each names.

rcl matches a key against the node's fully qualified name: a bare ``kinematics`` names the node
only outside a namespace, so a node started under ``/lbr`` would silently ignore it; the shipped
files are keyed ``/**/kinematics`` (any namespace). The tools that read such files (the offline
replay, ``fbcc-calibrate``'s loader) take every form.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fbcc_ros.core.files import read_yaml


def node_of(key: str) -> str:
    """The node a ``ros__parameters`` file's key names: ``kinematics``, ``/kinematics``,
    ``/lbr/kinematics`` and ``/**/kinematics`` (any namespace: how the shipped files are keyed,
    so that a node started under a namespace still reads them) all name ``kinematics``."""
    return str(key).rstrip("/").rsplit("/", 1)[-1]


def node_section(doc: Any, node: str) -> dict[str, Any] | None:
    """The ``ros__parameters`` of ``node`` in a parsed parameter file (its keys by
    :func:`node_of`, later ones winning, as rcl merges them); None if no key names it."""
    found = None
    for key, body in (doc or {}).items() if isinstance(doc, dict) else ():
        if node_of(key) == node and isinstance(body, dict):
            found = {**(found or {}), **(body.get("ros__parameters") or {})}
    return found


def file_parameters(files: Sequence[Path], node: str) -> dict[str, Any]:
    """``node``'s parameters from parameter files applied in order (later files win), as rcl
    applies several ``--params-file``."""
    out: dict[str, Any] = {}
    for file in files:
        out.update(flatten(node_section(read_yaml(file, "--params-file"), node) or {}))
    return out


def flatten(params: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{payload: {mass: 1}}`` → ``{"payload.mass": 1}``, as ROS names nested parameters."""
    out: dict[str, Any] = {}
    for name, value in params.items():
        if isinstance(value, dict):
            out.update(flatten(value, f"{prefix}{name}."))
        else:
            out[f"{prefix}{name}"] = value
    return out
