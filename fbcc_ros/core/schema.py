"""Checks of a configuration file's values: each refusal names the key, the value given and
what is allowed (:class:`~fbcc_ros.core.errors.ConfigError`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from fbcc_ros.core.errors import ConfigError, closest


def number(
    key: str, value: Any, low: float, high: float, unit: str, *, low_open: bool = False
) -> float:
    """``value`` as a float in [low, high] (``(low, high]`` if ``low_open``), else a
    :class:`ConfigError` naming ``key``, the value and what is allowed."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        hint = ""
        if isinstance(value, str):
            try:
                float(value)
                hint = " (given as text: quoted, or a YAML 1.1 parser, which reads 5e-5 as text)"
            except ValueError:
                pass
        raise ConfigError(key, value, f"a number in {unit}{hint}")
    v = float(value)
    ok = math.isfinite(v) and (v > low if low_open else v >= low) and v <= high
    if not ok:
        bracket = "(" if low_open else "["
        raise ConfigError(key, value, f"a value in {bracket}{low:g}, {high:g}] {unit}")
    return v


def mapping(
    key: str, value: Any, allowed: tuple[str, ...], required: tuple[str, ...] = ()
) -> Mapping[str, Any]:
    """``value`` as a mapping of only ``allowed`` keys, each of ``required`` present, else a
    :class:`ConfigError` naming the key (and the closest allowed one to a misspelt key)."""
    if not isinstance(value, Mapping):
        raise ConfigError(key, value, f"a mapping with keys {', '.join(allowed)}")
    unknown = [k for k in value if k not in allowed]
    if unknown:
        raise ConfigError(f"{key}.{unknown[0]}", value[unknown[0]],
                          f"{closest(str(unknown[0]), allowed)}a key of {key}: one of "
                          f"{', '.join(allowed)}")  # fmt: skip
    missing = [k for k in required if k not in value]
    if missing:
        raise ConfigError(f"{key}.{missing[0]}", "<missing>", "a value: this key is required")
    return value
