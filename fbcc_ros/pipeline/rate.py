"""The rate a stage's input actually arrives at, against the one it is configured for.

The law steps by the samples' stamps (:meth:`fbcc_ros.core.control.supervisor.Supervisor.period`),
so a sensor slower than configured still gives the right time, but the gains and filters were
designed for the configured period, and a 100 Hz sensor behind a 1 kHz configuration is a set-up
error a user must hear about. The measured rate is the inverse of the median interval between
stamps over a window: a loaded cell's dropped or bunched samples move it little, a sensor at
another rate moves it all the way.
"""

from __future__ import annotations

import collections
import statistics

#: Intervals in the window the median is taken over.
WINDOW = 200
#: Relative difference of the measured rate from the configured one that is reported.
TOLERANCE = 0.2


class InputRate:
    """Args:
    configured_hz: The rate the stage is configured for [Hz].
    what: The input's name, for the report.
    """

    def __init__(self, configured_hz: float, what: str) -> None:
        self.configured_hz = configured_hz
        self.what = what
        self._intervals: collections.deque[float] = collections.deque(maxlen=WINDOW)
        self._last: float | None = None

    def sample(self, stamp: float) -> None:
        """A sample stamped ``stamp`` [s] arrived (out-of-order stamps are not intervals)."""
        if self._last is not None and stamp > self._last:
            self._intervals.append(stamp - self._last)
        self._last = stamp if self._last is None else max(self._last, stamp)

    @property
    def measured_hz(self) -> float | None:
        """1 / the median interval over the window; None until the window is full."""
        if len(self._intervals) < WINDOW:
            return None
        return 1.0 / statistics.median(self._intervals)

    def mismatch(self) -> str:
        """What is wrong with the rate, or ``""``."""
        hz = self.measured_hz
        if hz is None or abs(hz / self.configured_hz - 1.0) <= TOLERANCE:
            return ""
        return (
            f"{self.what} arrives at {hz:.1f} Hz, configured for {self.configured_hz:g} Hz "
            "(rate_hz): the gains and filters are designed for the configured period"
        )
