"""Oscillation guard: detects a growing or sustained oscillation of a signal within a few periods.

Independent of the contact identification (it looks only at the signal), so it still acts when
the identification is wrong. A loop that goes unstable near its crossover oscillates about its
set point (zero for FBCC's integrators, which drive the directed response to zero) with an
amplitude that grows by a roughly constant factor per half period. The guard watches the zero
crossings of the signal and the largest |value| between two of them (a half-wave's peak):

* a half-wave counts as *not decaying* when its peak exceeds ``growth`` times the previous one
  and ``min_amplitude`` (noise crosses zero often, with small peaks);
* ``cycles`` such half-waves in a row trip the guard; one that decays faster resets the count.

With ``growth`` > 1 only a growing oscillation trips it; with ``growth`` < 1 (the robust law's
0.9) a sustained one does too — a limit cycle, which a loop delay larger than the margins allow
settles into instead of growing without bound — while an oscillation that decays by more than
``1 - growth`` a half-wave never does. What to do on a trip is the law's business
(:mod:`fbcc_ros.core.control.robust` backs the gains off and holds the depth).
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import ConfigError

#: Peaks of this many standard deviations of a signal's noise, eight half-waves in a row, are
#: not noise: the least ``min_amplitude`` the robust law gives a row (``robust_kernel``).
NOISE_PEAKS = 8.0

#: Columns of one signal's guard state: last sign, current half-wave peak, previous peak,
#: growing half-waves in a row.
N_STATE = 4


@dataclasses.dataclass(frozen=True)
class GuardParams:
    """Attributes:
    growth: A half-wave counts when its peak exceeds this factor times the previous one (> 0;
        below 1, a sustained oscillation counts too).
    cycles: Counted half-waves in a row that trip the guard (>= 2).
    min_amplitude: Peaks below this never count (the signal's units; > 0).
    """

    growth: float = 0.9
    cycles: int = 6
    min_amplitude: float = 1.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.growth) and self.growth > 0.0):
            raise ConfigError("guard.growth", self.growth, "a factor > 0")
        if isinstance(self.cycles, bool) or not isinstance(self.cycles, int) or self.cycles < 2:
            raise ConfigError("guard.cycles", self.cycles, "an integer >= 2")
        if not (math.isfinite(self.min_amplitude) and self.min_amplitude > 0):
            raise ConfigError("guard.min_amplitude", self.min_amplitude, "a number > 0")


@numba.njit(cache=True)  # type: ignore[misc]
def guard_step(
    s: FloatArray, value: float, growth: float, cycles: int, min_amplitude: float
) -> bool:
    """Advance one signal's guard state ``s`` (N_STATE,) by one sample; True when it trips
    (the state is then reset, so a persisting oscillation trips again ``cycles`` half-waves
    later)."""
    sign = 1.0 if value > 0.0 else (-1.0 if value < 0.0 else 0.0)
    if sign != 0.0 and s[0] != 0.0 and sign != s[0]:  # a zero crossing ends a half-wave
        peak, previous = s[1], s[2]
        if peak > min_amplitude and peak > growth * previous:
            s[3] += 1.0
        else:
            s[3] = 0.0
        s[2], s[1] = peak, 0.0
        if s[3] >= cycles:
            s[:] = 0.0
            s[0] = sign
            return True
    if sign != 0.0:
        s[0] = sign
    s[1] = max(s[1], abs(value))
    return False


class OscillationGuard:
    """One guard over one scalar signal (for tests and single-signal use)."""

    def __init__(self, params: GuardParams | None = None) -> None:
        self.params = params or GuardParams()
        self._state = np.zeros(N_STATE)
        self.trips = 0

    def update(self, value: float) -> bool:
        """Feed one sample; True when this sample trips the guard."""
        p = self.params
        tripped = bool(guard_step(self._state, float(value), p.growth, p.cycles, p.min_amplitude))
        self.trips += tripped
        return tripped
