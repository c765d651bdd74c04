"""The wrench guard: limits below the law that no filter or gain can weaken.

The controller's force limit (Algorithm 1's F_ext_limit) acts on the wrench it is given, after
the compensation's low-pass and dead band: a large dead band or a low cut-off lets the true force
far past it, and it has no moment limit. The guard acts in the compensation, on each sample:

* **plausibility of the raw reading**: every component within the sensor's rated range, and no
  faster change between two samples than ``max_rate`` (a single corrupt sample, My = 1e6 N·m,
  is no contact);
* **limits on the contact**: the compensated wrench in {H}, before any filter, within
  ``force_limit`` (|f|) and ``moment_limit`` (|m| about the {H} origin) less ``stop_margin`` of
  them: the guard trips that far below a limit because the arm goes on pressing until the hold
  reaches it (the loop's latency times the approach: 8 N past the trip point in the dead-band
  drill on a loaded two-core machine, docs/safety.md), and the limit is what the contact must
  never see. The margin must also cover a bias a tare took under a load within ``max_tare``
  (the guard reads low by as much): 30 N at the defaults, against 8 N of stopping and up to
  20 N of tare;
* **a tare only when it is safe**: the bias a tare measures within ``max_tare`` of the
  configured one (a tare under load, the peg in the hole, would take the contact for a bias),
  and, where the compensation hears the peg's pose, the peg out of the hole.

The first violation trips it, with the reason; it stays tripped (the compensation publishes no
more wrenches, so the controller, told of the trip, also sees its input go stale). Its limits are
read-only parameters: they cannot be loosened while the cell runs.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import ConfigError

#: The deepest the peg's tip may be in the hole while the sensor tares [m]: deeper, it may
#: touch the wall (a start over the hole, the tip at its top face, is 0).
TARE_DEPTH = 5e-4


@dataclasses.dataclass(frozen=True)
class GuardLimits:
    """What the guard allows.

    Attributes:
        force_limit: Largest |f| of the contact wrench [N].
        moment_limit: Largest |m| of the contact wrench about the {H} origin [N·m].
        sensor_range: The sensor's rated range, (force [N], moment [N·m]) per component.
        max_rate: Fastest plausible change of a raw component, (force [N/s], moment [N·m/s]).
        max_tare: Largest difference between the bias a tare measures and the configured one,
            (|force| [N], |moment| [N·m]): more is a load on the sensor while taring (the peg in
            contact) or a payload that is not configured.
        stop_margin: The fraction of each limit the guard trips below it, for the arm to stop in.
    """

    force_limit: float = 300.0
    moment_limit: float = 30.0
    sensor_range: tuple[float, float] = (660.0, 60.0)
    max_rate: tuple[float, float] = (1e6, 1e5)
    max_tare: tuple[float, float] = (20.0, 2.0)
    stop_margin: float = 0.1

    def __post_init__(self) -> None:
        for name in ("force_limit", "moment_limit"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ConfigError(f"guard.{name}", value, "a finite limit > 0")
        if not 0.0 <= self.stop_margin <= 0.9:
            raise ConfigError("guard.stop_margin", self.stop_margin, "a fraction in [0, 0.9]")
        for name in ("sensor_range", "max_rate", "max_tare"):
            pair = np.asarray(getattr(self, name), dtype=float)
            if pair.shape != (2,) or not (np.isfinite(pair).all() and (pair > 0).all()):
                raise ConfigError(f"guard.{name}", getattr(self, name),
                                  "[force, moment], both finite and > 0")  # fmt: skip


class WrenchGuard:
    """Checks each raw reading and each compensated wrench; ``reason`` once it has tripped."""

    def __init__(self, limits: GuardLimits) -> None:
        self.limits = limits
        self._range = np.repeat(limits.sensor_range, 3)
        self._rate = np.repeat(limits.max_rate, 3)
        self._last: tuple[float, FloatArray] | None = None
        self.reason: str | None = None

    @property
    def tripped(self) -> bool:
        return self.reason is not None

    def raw(self, stamp: float, reading: FloatArray) -> bool:
        """A raw reading (sensor frame, N and N·m): False, and tripped, if implausible."""
        over = np.abs(reading) > self._range
        if over.any():
            i = int(np.argmax(over))
            return self.trip(f"raw {_AXES[i]} {reading[i]:.4g} beyond the sensor's range "
                             f"±{self._range[i]:.4g}")  # fmt: skip
        if self._last is not None and stamp > self._last[0]:
            rate = np.abs(reading - self._last[1]) / (stamp - self._last[0])
            fast = rate > self._rate
            if fast.any():
                i = int(np.argmax(fast))
                return self.trip(f"raw {_AXES[i]} changed at {rate[i]:.4g}/s, faster than "
                                 f"{self._rate[i]:.4g}/s")  # fmt: skip
        self._last = (stamp, reading.copy())
        return True

    def contact(self, wrench: FloatArray) -> bool:
        """The compensated, unfiltered wrench in {H} about its origin: False, and tripped, if
        over a limit."""
        reason = contact_excess(np.asarray(wrench, dtype=float)[None], self.limits)[0]
        return self.trip(reason) if reason else True

    def tare(self, measured: FloatArray, configured: FloatArray,
             peg_depth: float | None = None) -> bool:  # fmt: skip
        """A tare's bias against the configured one: False, and tripped, if they differ by more
        than ``max_tare``, or if the peg's tip was heard deeper than :data:`TARE_DEPTH` in the
        hole (``peg_depth`` [m], None: not heard). A load under ``max_tare`` (a part pushed in
        gently) passes the first check; the peg's place does not."""
        if peg_depth is not None and peg_depth > TARE_DEPTH:
            return self.trip(
                f"tare refused: the peg's tip is {peg_depth * 1e3:.3g} mm in the hole (a tare "
                f"is taken with it out, at most {TARE_DEPTH * 1e3:g} mm in): its contact would "
                "be taken for a bias")
        d = measured - configured
        df, dm = float(np.linalg.norm(d[:3])), float(np.linalg.norm(d[3:]))
        if df > self.limits.max_tare[0] or dm > self.limits.max_tare[1]:
            return self.trip(
                f"tare refused: it measured {df:.4g} N and {dm:.4g} N·m from the configured bias "
                f"(at most {self.limits.max_tare[0]:g} N, {self.limits.max_tare[1]:g} N·m): a "
                "load on the sensor while taring, or a payload not configured")
        return True

    def trip(self, reason: str) -> bool:
        """Trips with ``reason`` (the first reason stays); returns False, as a failed check."""
        if self.reason is None:
            self.reason = reason
        return False


_AXES = ("fx", "fy", "fz", "tx", "ty", "tz")


def contact_excess(wrenches: FloatArray, limits: GuardLimits) -> list[str]:
    """Per compensated, unfiltered wrench in {H} about its origin (N, 6): why it is over the
    guard's contact limits less their stop margin, or "" where it is within them (the rule of
    :meth:`WrenchGuard.contact`, for a batch: the simulator's trials)."""
    f = np.linalg.norm(wrenches[:, :3], axis=1)
    m = np.linalg.norm(wrenches[:, 3:], axis=1)
    keep = 1.0 - limits.stop_margin
    out = [""] * len(wrenches)
    for size, limit, what, unit in ((m, limits.moment_limit, "|m|", "N·m"),
                                    (f, limits.force_limit, "|f|", "N")):  # fmt: skip
        for i in np.flatnonzero(size > keep * limit):  # the force's reason first, if both
            out[i] = (f"{what} {size[i]:.4g} {unit} over {keep * limit:.4g} {unit}, the limit "
                      f"{limit:g} {unit} less its stop margin")  # fmt: skip
    return out
