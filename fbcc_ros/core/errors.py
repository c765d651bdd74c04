"""Exception types of fbcc_ros.

Every error raised for bad input names the offending field, the value given and what is allowed,
so that a user reading a log line can fix the YAML or the call without opening the code.
Physical outcomes (no contact, jamming, a force limit) are states, never exceptions.
"""

from __future__ import annotations

import difflib
import functools
import math
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray


class FbccError(Exception):
    """Base class of every error fbcc_ros raises on purpose."""


class ConfigError(FbccError, ValueError):
    """A configuration value (geometry, gains, a parameter) is invalid.

    Attributes:
        field: Name of the parameter, as the user spells it.
        value: The value that was given.
        allowed: What would have been accepted, in words.
    """

    def __init__(self, field: str, value: Any, allowed: str) -> None:
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{field}={value!r} is not allowed: expected {allowed}")


class InputError(FbccError, ValueError):
    """A runtime input (features, a response, a wrench sample) is invalid.

    Same attributes as :class:`ConfigError`.
    """

    def __init__(self, field: str, value: Any, allowed: str) -> None:
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{field}={value!r} is not allowed: expected {allowed}")


def require_number(field: str, value: Any, *, positive: bool = False) -> float:
    """``value`` as a finite float (> 0 with ``positive``), else a :class:`ConfigError` naming
    ``field``; booleans are refused (YAML's ``yes`` is no gain)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(field, value, "a number")
    if not math.isfinite(value) or (positive and not value > 0):
        raise ConfigError(field, value, "a finite number > 0" if positive else "a finite number")
    return float(value)


def require_vector(field: str, value: Any, size: int) -> FloatArray:
    """``value`` as ``size`` finite floats, else a :class:`ConfigError` naming ``field``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(field, value, f"{size} finite numbers") from None
    if arr.shape != (size,) or not np.isfinite(arr).all():
        raise ConfigError(field, value, f"{size} finite numbers")
    return arr


def closest(name: str, names: Sequence[str]) -> str:
    """``"did you mean 'x'? "`` for the name among ``names`` closest to a misspelt ``name``,
    else ``""``: the start of an error's ``allowed``."""
    match = difflib.get_close_matches(name, list(names), n=1)
    return f"did you mean {match[0]!r}? " if match else ""


def one_line(exc: FbccError | OSError) -> str:
    """What went wrong, in the line a user reads: an FbccError's own text, or for an OSError
    the file and the system's reason (``/proc/x: No such file or directory``)."""
    if isinstance(exc, FbccError):
        return str(exc)
    where = f"{exc.filename}: " if exc.filename else ""
    return f"{where}{exc.strerror or exc}"


def command(prog: str) -> Callable[[Callable[..., int]], Callable[..., int]]:
    """Decorates a command-line tool's ``main``: bad input (an :class:`FbccError` from anywhere
    in it) or a file the system refuses (an ``OSError``: unwritable, a folder where a file was
    meant, disk full) ends in one line on stderr, ``prog: what``, and exit status 2, never a
    traceback."""

    def wrap(main: Callable[..., int]) -> Callable[..., int]:
        @functools.wraps(main)
        def guarded(*args: Any, **kwargs: Any) -> int:
            try:
                return main(*args, **kwargs)
            except (FbccError, OSError) as exc:
                print(f"{prog}: {one_line(exc)}", file=sys.stderr)
            return 2

        return guarded

    return wrap
