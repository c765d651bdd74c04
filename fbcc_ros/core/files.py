"""The user's files, read strictly, with one error that names the file and what was wrong.

* Only a regular file is read: a FIFO would hang the reader, ``/dev/zero`` would fill memory,
  a folder says nothing. The kind is judged before the file is opened.
* At most :data:`MAX_BYTES`: every file a user hands us (a scenario, a parameter or calibration
  file) is a few kilobytes; a larger one is a wrong path, refused before it is read.
* UTF-8 text.
* YAML (:func:`read_yaml`): a key given twice in one mapping is refused with both lines (PyYAML
  keeps the last silently: a second ``speed:`` line ran an insertion ten times faster); numbers
  like ``5e-5`` and ``1e8`` are floats (YAML 1.2; PyYAML's YAML 1.1 would give the text).
"""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path
from typing import Any

import yaml

from fbcc_ros.core.errors import ConfigError

#: The largest file read [bytes]: the shipped scenarios and parameter files are under 10 kB.
MAX_BYTES = 1 << 20

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character "
          "device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))  # fmt: skip


def read_text(path: str | Path, field: str) -> str:
    """The UTF-8 text of ``path``; :class:`ConfigError` under ``field`` if it cannot be read
    (missing, unreadable, not a regular file, over :data:`MAX_BYTES`) or is not UTF-8 text."""
    try:
        info = os.stat(path)  # follows links: /dev/stdin is judged as what it points to
    except OSError as exc:
        raise ConfigError(field, str(path), f"a readable file ({exc.strerror})") from None
    for test, kind in _KINDS:
        if test(info.st_mode):
            raise ConfigError(field, str(path), f"a regular file (this is {kind})")
    if info.st_size > MAX_BYTES:
        raise ConfigError(field, str(path), f"a file of at most {MAX_BYTES >> 10} KiB (this "
                          f"one is {info.st_size / 1e6:.1f} MB)")  # fmt: skip
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_BYTES + 1)  # a file that grew since the stat is still bounded
    except OSError as exc:
        raise ConfigError(field, str(path), f"a readable file ({exc.strerror})") from None
    if len(data) > MAX_BYTES:
        raise ConfigError(field, str(path), f"a file of at most {MAX_BYTES >> 10} KiB")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(
            field, str(path), f"UTF-8 text (byte {exc.start} is {exc.object[exc.start]:#04x})"
        ) from None


class StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses a key given twice in one mapping, and reads ``5e-5`` and ``1e8``
    as floats (module doc)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)  # type: ignore[no-untyped-call]
            line = key_node.start_mark.line + 1
            try:
                first = seen.setdefault(key, line)
            except TypeError:  # an unhashable key: SafeLoader says so below
                continue
            if first != line:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} given twice, on line {first} and line {line}: "
                    "say it once", None)  # fmt: skip
        return super().construct_mapping(node, deep)  # type: ignore[no-any-return]


# launch_ros writes the parameter files it hands a node with Python tuples: a list to us
StrictLoader.add_constructor("tag:yaml.org,2002:python/tuple",
                             lambda loader, node: loader.construct_sequence(node))  # fmt: skip
StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def parse_yaml(text: str, field: str, name: str) -> Any:
    """``text`` (of the file ``name``) parsed by :class:`StrictLoader`; :class:`ConfigError`
    under ``field`` if it is not valid YAML or repeats a key."""
    try:
        return yaml.load(text, Loader=StrictLoader)  # a SafeLoader
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        where = "" if mark is None else f", line {mark.line + 1} column {mark.column + 1}"
        raise ConfigError(field, name, f"valid YAML ({exc.problem}{where})") from None
    except yaml.YAMLError as exc:
        raise ConfigError(field, name, f"valid YAML ({' '.join(str(exc).split())})") from None


def read_yaml(path: str | Path, field: str) -> Any:
    """The YAML document of ``path``, read by :func:`read_text` and :func:`parse_yaml`."""
    return parse_yaml(read_text(path, field), field, str(path))
