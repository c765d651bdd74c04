"""The robust law's gain design: the margins of its linearised lateral loop (integrator,
filter H_f, robot lag, delays) and of its depth loop (integrator, its own low-pass, the dither
notches, delays), and the bandwidths that keep the stated phase margin with the stated
``loop_delay`` (:mod:`fbcc_ros.core.control.robust`, module doc)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.control.robust_params import DITHER_FRACTIONS, NOTCH_QUALITY, RobustParams
from fbcc_ros.core.filters import notch_coefficients, second_order_coefficients


@dataclasses.dataclass(frozen=True)
class Margins:
    """Stability margins of one linearised lateral loop (see :func:`loop_margins`).

    Attributes:
        phase_margin: [rad] at the crossover with k̂ = k.
        crossover: The crossover frequency [rad/s].
        gain_margin: The largest factor k / k̂ with which the loop stays stable.
    """

    phase_margin: float
    crossover: float
    gain_margin: float


def loop_transfer(
    params: RobustParams,
    dt: float,
    lag: float,
    z: ArrayLike,
    *,
    delay: float = 0.0,
    bandwidth: float | None = None,
) -> np.ndarray:
    """The sampled loop of one lateral row at z (scalar or array), with k̂ = k (module doc):
    integrator ω_c dt / (z - 1), the filter H_f (ZOH), the robot's first-order lag of time
    constant ``lag`` (ZOH; 0: none), one period from the sample to the command, and ``delay``
    [s] more, in whole periods. ``bandwidth`` overrides ω_c."""
    z = np.asarray(z, dtype=complex)
    h_f = _filter_transfer(params.filter_coefficients(dt)[:, 0], z)
    a = math.exp(-dt / lag) if lag > 0 else 0.0
    robot = (1 - a) / (z - a)
    w_c = params.bandwidth if bandwidth is None else bandwidth
    periods = 1 + round(delay / dt)
    return w_c * dt / (z - 1) * h_f * robot / z**periods  # type: ignore[no-any-return]


def _filter_transfer(c: np.ndarray, z: np.ndarray) -> np.ndarray:
    """A second-order low-pass (ZOH; ``c`` from :func:`~fbcc_ros.core.filters.
    second_order_coefficients`) at z: the first component of (z I - Phi)^-1 Gamma, the 2x2
    inverse written out."""
    det = (z - c[0]) * (z - c[3]) - c[1] * c[2]
    return ((z - c[3]) * c[4] + c[1] * c[5]) / det  # type: ignore[no-any-return]


def depth_transfer(params: RobustParams, dt: float, z: ArrayLike, bandwidth: float) -> np.ndarray:
    """The sampled depth loop at z, with the depth sensitivity ∂e/∂l known: integrator
    ω_l dt / (z - 1), the depth loop's low-pass (``depth_filter_frequency``), the notches of
    the plane with the slowest dither (rows dx and theta_y), one period and ``loop_delay`` more.
    ``bandwidth`` is ω_l. The other plane's notches (47 and 53 Hz) lag a little more: with them
    the design would give 39.514 instead of 39.519 rad/s at the defaults."""
    z = np.asarray(z, dtype=complex)
    notch = np.ones_like(z)
    for fraction in (DITHER_FRACTIONS[0], DITHER_FRACTIONS[3]):
        b0, b1, a2 = notch_coefficients(2 * math.pi * fraction / dt, NOTCH_QUALITY, dt)
        notch = notch * (b0 * z * z + b1 * z + b0) / (z * z + b1 * z + a2)
    periods = 1 + round(params.loop_delay / dt)
    low_pass = _filter_transfer(
        second_order_coefficients(params.depth_filter_frequency, params.filter_damping, dt), z)
    return bandwidth * dt / (z - 1) * low_pass * notch / z**periods  # type: ignore[no-any-return]


def depth_phase_margin(params: RobustParams, dt: float, bandwidth: float) -> float:
    """Phase margin [rad] of :func:`depth_transfer`, at its crossover."""
    omegas = np.geomspace(1e-2, math.pi / dt, 4000)
    l_values = depth_transfer(params, dt, np.exp(1j * omegas * dt), bandwidth)
    i_c = int(np.argmax(np.abs(l_values) < 1.0))
    return float(math.pi + np.unwrap(np.angle(l_values))[i_c])


def _largest(margin: Callable[[float], float], high: float, want: float) -> float:
    """The largest bandwidth up to ``high`` whose ``margin`` is at least ``want`` (bisection;
    the margin falls with the bandwidth)."""
    if margin(high) >= want:
        return high
    low = 0.0
    for _ in range(40):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if margin(mid) >= want else (low, mid)
    return low


def loop_margins(
    params: RobustParams,
    dt: float,
    lag: float = 0.005,
    *,
    delay: float = 0.0,
    bandwidth: float | None = None,
) -> Margins:
    """Phase margin, crossover and gain margin of the linearised lateral loop (frequency sweep
    of :func:`loop_transfer` on the unit circle)."""
    omegas = np.geomspace(1e-2, math.pi / dt, 4000)
    l_values = loop_transfer(params, dt, lag, np.exp(1j * omegas * dt), delay=delay,
                             bandwidth=bandwidth)  # fmt: skip
    mag, ph = np.abs(l_values), np.unwrap(np.angle(l_values))
    i_c = int(np.argmax(mag < 1.0))
    crossover = float(omegas[i_c])
    phase_margin = float(math.pi + ph[i_c])
    below = np.flatnonzero(ph < -math.pi)
    gain_margin = float(1.0 / mag[below[0]]) if below.size else math.inf
    return Margins(phase_margin, crossover, gain_margin)


@dataclasses.dataclass(frozen=True)
class Design:
    """The bandwidths the law runs with at one period (see :func:`design`).

    Attributes:
        bandwidth: ω_c of the lateral loops [rad/s].
        depth_bandwidth: ω_l of the depth loop [rad/s].
        margins: Of the lateral loop with ``loop_delay`` (and no robot lag beyond it).
    """

    bandwidth: float
    depth_bandwidth: float
    margins: Margins


def design(params: RobustParams, dt: float) -> Design:
    """The largest lateral crossover up to ``bandwidth`` whose sampled loop, delayed by
    ``loop_delay``, keeps ``phase_margin`` (:func:`loop_margins`), and the largest depth
    bandwidth up to ``depth_bandwidth`` that keeps it too (:func:`depth_phase_margin`)."""
    delay, want = params.loop_delay, params.phase_margin
    w_c = _largest(lambda w: loop_margins(params, dt, 0.0, delay=delay, bandwidth=w)
                   .phase_margin, params.bandwidth, want)  # fmt: skip
    w_l = _largest(lambda w: depth_phase_margin(params, dt, w), params.depth_bandwidth, want)
    return Design(w_c, w_l, loop_margins(params, dt, 0.0, delay=delay, bandwidth=w_c))
