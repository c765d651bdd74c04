"""Faults of a force/torque sensor, for rehearsing a cell's reaction to them: the mock cell's
sensor passes each reading through one (its ``sensor_fault`` parameter) before publishing.

Each fault turns the stream of readings ``(stamp, wrench)`` into the stream a faulty sensor or
its driver would deliver — a reading corrupted, withheld, restamped, thinned or held back and
then delivered in a burst — starting with the first reading after it is set. What each does is
in :data:`SENSOR_FAULTS`; the magnitudes are the ones the fault drills use
(:mod:`fbcc_ros.harness.fault_drill`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import ConfigError

Reading = tuple[float, FloatArray]

#: A raw moment far beyond any sensor's range [N·m] (about y, the sensor frame).
MOMENT_SPIKE = 1.0e6
#: A raw force over the guard's force limit but within the sensor's range [N] (z).
FORCE_SPIKE = 500.0
#: How long a spike lasts [s]: fifty readings at 1 kHz. A loop that takes only part of the
#: sensor's samples (about half on a loaded two-core machine, dropped in runs, docs/nodes.md)
#: missed all ten of a 10 ms spike in one drill out of three; the guard's check of a single
#: reading is tested without ROS.
SPIKE_SPAN = 0.05
#: How long the non-finite readings last, the sensor is silent, the stamps run ahead or a burst
#: is held back [s].
NAN_SPAN = 0.1
SILENT_SPAN = 0.3
FUTURE_SPAN = 0.1
BURST_SPAN = 0.03  # 31 readings at once: a depth-10 subscriber keeps the newest 10
#: How far ahead the restamped readings are [s].
FUTURE_BY = 1.0
#: The slow sensor's rate [Hz].
SLOW_HZ = 100.0

#: The faults by name, each with what it does.
SENSOR_FAULTS = {
    "moment-spike": f"{MOMENT_SPIKE:g} N·m added about y for {SPIKE_SPAN * 1e3:g} ms",
    "force-spike": f"{FORCE_SPIKE:g} N added along z for {SPIKE_SPAN * 1e3:g} ms",
    "nan-wrench": f"NaN readings for {NAN_SPAN * 1e3:g} ms",
    "stale-wrench": f"no readings for {SILENT_SPAN * 1e3:g} ms",
    "future-stamp": f"readings stamped {FUTURE_BY:g} s ahead for {FUTURE_SPAN * 1e3:g} ms",
    "slow-sensor": f"one reading in every {SLOW_HZ:g} Hz period from then on",
    "sensor-burst": f"readings held back for {BURST_SPAN * 1e3:g} ms, then delivered at once",
}


class SensorFault:
    """One fault (a name of :data:`SENSOR_FAULTS`) on a sensor sampled every ``dt`` [s].

    ``apply`` takes each reading and returns the readings to publish in its place (none, the
    reading changed, or several at once).
    """

    def __init__(self, name: str, dt: float) -> None:
        if name not in SENSOR_FAULTS:
            raise ConfigError("sensor_fault", name, f"one of {sorted(SENSOR_FAULTS)}")
        self.name = name
        self.dt = dt
        self._held: list[Reading] = []
        self._n = 0
        self._apply: Callable[[float, FloatArray], list[Reading]] = getattr(
            self, "_" + name.replace("-", "_"))

    def apply(self, stamp: float, wrench: FloatArray) -> list[Reading]:
        out = self._apply(stamp, wrench)
        self._n += 1
        return out

    def _within(self, span: float) -> bool:
        """Whether this reading is within ``span`` [s] of the first (counted in readings:
        exact where a difference of stamps is not)."""
        return self._n < round(span / self.dt)

    def _moment_spike(self, stamp: float, w: FloatArray) -> list[Reading]:
        if self._within(SPIKE_SPAN):
            w = w + np.array([0.0, 0.0, 0.0, 0.0, MOMENT_SPIKE, 0.0])
        return [(stamp, w)]

    def _force_spike(self, stamp: float, w: FloatArray) -> list[Reading]:
        if self._within(SPIKE_SPAN):
            w = w + np.array([0.0, 0.0, FORCE_SPIKE, 0.0, 0.0, 0.0])
        return [(stamp, w)]

    def _nan_wrench(self, stamp: float, w: FloatArray) -> list[Reading]:
        return [(stamp, np.full(6, np.nan) if self._within(NAN_SPAN) else w)]

    def _stale_wrench(self, stamp: float, w: FloatArray) -> list[Reading]:
        return [] if self._within(SILENT_SPAN) else [(stamp, w)]

    def _future_stamp(self, stamp: float, w: FloatArray) -> list[Reading]:
        return [(stamp + FUTURE_BY if self._within(FUTURE_SPAN) else stamp, w)]

    def _slow_sensor(self, stamp: float, w: FloatArray) -> list[Reading]:
        every = max(1, round(1.0 / (SLOW_HZ * self.dt)))
        return [(stamp, w)] if self._n % every == 0 else []

    def _sensor_burst(self, stamp: float, w: FloatArray) -> list[Reading]:
        if self._within(BURST_SPAN):
            self._held.append((stamp, w))
            return []
        out, self._held = [*self._held, (stamp, w)], []
        return out
