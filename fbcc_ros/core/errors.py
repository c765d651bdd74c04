"""Exception types of fbcc_ros.

Every error raised for bad input names the offending field, the value given and what is allowed,
so that a user reading a log line can fix the YAML or the call without opening the code.
Physical outcomes (no contact, jamming, a force limit) are states, never exceptions.
"""

from __future__ import annotations

from typing import Any


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
