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
import scipy.linalg
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import ConfigError


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
    hold (``compliance.ComplianceFilter.discretise``,
    ``robust_params.RobustParams.filter_coefficients``):
    ``[x, v](k+1) = Phi [x, v](k) + Gamma u(k)``, c rows Phi00, Phi01, Phi10, Phi11, Gamma0,
    Gamma1 per column."""
    for j in range(5):
        xj, vj = x[j], v[j]
        x[j] = c[0, j] * xj + c[1, j] * vj + c[4, j] * u[j]
        v[j] = c[2, j] * xj + c[3, j] * vj + c[5, j] * u[j]


def notch_coefficients(omega: float, quality: float, dt: float) -> FloatArray:
    """(b0, b1, a2) of a discrete notch at ``omega`` [rad/s] (a zero of gain exactly there,
    bilinear transform prewarped to it) with the quality factor ``quality`` (centre over -3 dB
    width): ``H(z) = (b0 + b1 z^-1 + b0 z^-2) / (1 + b1 z^-1 + a2 z^-2)``, ``K = tan(ω dt / 2)``,
    ``b0 = (1 + K²) / n``, ``b1 = 2 (K² - 1) / n``, ``a2 = (1 - K / Q + K²) / n``,
    ``n = 1 + K / Q + K²``."""
    k = math.tan(0.5 * omega * dt)
    norm = 1.0 + k / quality + k * k
    return np.array([(1.0 + k * k) / norm, 2.0 * (k * k - 1.0) / norm,
                     (1.0 - k / quality + k * k) / norm])  # fmt: skip


@numba.njit(cache=True)  # type: ignore[misc]
def notch_step(b: FloatArray, s: FloatArray, x: float) -> float:
    """One sample of the notch ``b`` (:func:`notch_coefficients`) with state ``s`` (2,), in
    place (transposed direct form II); returns the output."""
    y = b[0] * x + s[0]
    s[0] = b[1] * x - b[1] * y + s[1]
    s[1] = b[0] * x - b[2] * y
    return y


def second_order_coefficients(omega: float, damping: float, dt: float) -> FloatArray:
    """The unit-gain second-order low-pass ``ω² / (s² + 2 ζ ω s + ω²)`` discretised exactly for
    a zero-order hold at period dt: (Phi00, Phi01, Phi10, Phi11, Gamma0, Gamma1) of
    ``[x, v](k+1) = Phi [x, v](k) + Gamma u(k)``."""
    w, z = omega, damping
    aug = np.array([[0.0, 1.0, 0.0], [-w * w, -2 * z * w, w * w], [0.0, 0.0, 0.0]])
    e = scipy.linalg.expm(aug * dt)
    return np.array([e[0, 0], e[0, 1], e[1, 0], e[1, 1], e[0, 2], e[1, 2]])


@numba.njit(cache=True)  # type: ignore[misc]
def second_order_step(c: FloatArray, s: FloatArray, u: float) -> float:
    """One sample of one channel of :func:`second_order_coefficients` ``c`` with state
    ``s = (x, v)``, in place; returns the new x."""
    x, v = s[0], s[1]
    s[0] = c[0] * x + c[1] * v + c[4] * u
    s[1] = c[2] * x + c[3] * v + c[5] * u
    return s[0]  # type: ignore[no-any-return]
