"""The user's files, read with one error that names the file and what was wrong with it."""

from __future__ import annotations

from pathlib import Path

from fbcc_ros.core.errors import ConfigError


def read_text(path: str | Path, field: str) -> str:
    """The UTF-8 text of ``path``; :class:`ConfigError` under ``field`` if it cannot be read
    (missing, unreadable, a folder) or is not UTF-8 text."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(field, str(path), f"a readable file ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(
            field, str(path), f"UTF-8 text (byte {exc.start} is {exc.object[exc.start]:#04x})"
        ) from None
