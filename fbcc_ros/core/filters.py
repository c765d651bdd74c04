"""Filters: the optional conditioning of the compensated wrench (a first-order low-pass and a
dead band), and the per-sample step of the control laws' second-order filters
(:func:`second_order_row`).

Both are off by default. The controller's second-order compliance (M, D, K of Table I) already
filters the response, and a low-pass inside the force loop adds phase lag the user should choose
knowingly; a dead band hides small contact forces the boundary mapping uses near P0.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from fbcc_ros.core.errors import ConfigError

FloatArray = NDArray[np.float64]


class LowPass:
    """First-order low-pass with the cut-off in Hz, exact for any sample spacing.

    The continuous filter ``tau y' = x - y``, ``tau = 1 / (2 pi f_c)``, held over a step ``dt``:

    .. math::
        y_k = y_{k-1} + (1 - e^{-2 \\pi f_c \\, dt}) (x_k - y_{k-1})

    so irregular sample times (a sensor over DDS) do not change the cut-off. ``cutoff_hz = 0``
    passes the signal through.
    """

    def __init__(self, cutoff_hz: float, field: str = "lowpass_hz") -> None:
        if not (math.isfinite(cutoff_hz) and cutoff_hz >= 0.0):
            raise ConfigError(field, cutoff_hz, "a cut-off frequency >= 0 [Hz] (0: off)")
        self.cutoff_hz = float(cutoff_hz)
        self._state: FloatArray | None = None

    def __call__(self, x: ArrayLike, dt: float) -> FloatArray:
        sample = np.asarray(x, dtype=float)
        if self.cutoff_hz == 0.0 or self._state is None:
            self._state = sample.copy()
            return sample
        # y_k = y_{k-1} + (1 - exp(-2 pi f_c dt)) (x_k - y_{k-1})
        gain = -math.expm1(-2.0 * math.pi * self.cutoff_hz * dt)
        self._state = self._state + gain * (sample - self._state)
        return self._state.copy()

    def reset(self) -> None:
        self._state = None


def dead_band(x: ArrayLike, band: ArrayLike) -> FloatArray:
    """Continuous dead band: zero inside ``|x| <= band``, shifted toward zero by ``band`` outside.

    ``y = sign(x) max(|x| - band, 0)`` has no step at the band's edge, so a force crossing it
    does not kick the controller.
    """
    arr = np.asarray(x, dtype=float)
    return np.sign(arr) * np.maximum(np.abs(arr) - np.asarray(band, dtype=float), 0.0)


@numba.njit(cache=True)  # type: ignore[misc]
def second_order_row(c: FloatArray, x: FloatArray, v: FloatArray, u: FloatArray) -> None:
    """One trial's five second-order filters, in place, discretised exactly for a zero-order
    hold (``control.ComplianceFilter.discretise``,
    ``robust_params.RobustParams.filter_coefficients``):
    ``[x, v](k+1) = Phi [x, v](k) + Gamma u(k)``, c rows Phi00, Phi01, Phi10, Phi11, Gamma0,
    Gamma1 per column."""
    for j in range(5):
        xj, vj = x[j], v[j]
        x[j] = c[0, j] * xj + c[1, j] * vj + c[4, j] * u[j]
        v[j] = c[2, j] * xj + c[3, j] * vj + c[5, j] * u[j]
