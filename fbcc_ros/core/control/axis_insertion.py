"""The insertion along the peg's axis, to the depth in the hole's estimated frame: the
coordinates in which every law runs.

The laws' features are those of the hole the robot *believes* in. When the true hole is tilted
by θ0, two things go wrong in those coordinates once the lateral loops have aligned the peg with
it (tilted by -θ0 in the believed frame):

* **the depth**: the believed ``l`` of the aligned peg differs from its true depth by
  ``2 r sin θ0`` (0.35 mm at 2°, r = 5 mm): a ramp to ``l = L`` ends that far short;
* **the direction**: advancing ``l`` at fixed believed ``(dx, dy)`` moves the peg's mid-point
  along the believed axis, across the true one by ``sin θ0 / 2`` per unit depth (87 µm over
  10 mm at 2°): the lateral loops chase a ramp, pressing the peg on the wall with a force that
  grows with the contact's stiffness (at 5 GPa the depth loop stalled at mid-depth).

A law therefore sees, and commands, these coordinates instead:

* **depth along the peg's axis**: the lateral features are the believed ones less a drift
  ``D``; each advance ``Δλ`` of the commanded depth moves the peg rigidly along its own
  (commanded) axis ``a``, which in the believed features is

  .. math::
      \\Delta l = \\Delta\\lambda, \\qquad
      \\Delta(dx, dy) = -\\tfrac12 (a_x, a_y)\\,\\Delta\\lambda

  (``(dx, dy)`` is the axis point at mid-depth, which moves half as far as the tip). The drift
  is a path integral, not a function of the pose: a tilt adjustment still turns the peg about
  its mid-depth point ``O_p`` (the point the direction matrix of eq. 28 is written for), and only
  depth moves along the axis. Once the peg is aligned, this is the hole's axis.
* **the depth λ in the hole's estimated frame** {Ĥ}: the hole's axis is estimated from the peg
  in it, ``θ̂`` (the believed tilts of a peg aligned with it) following the measured tilts
  through a first-order low-pass of ``AXIS_TIME_CONSTANT`` while the peg is below the top face
  (``l > 0``), from 0 (the believed hole). {Ĥ} is placed as the deviation convention places a
  tilted hole (:func:`fbcc_ros.core.contact.features.true_features` with ``x_dev = (0, 0, 0, -θ̂x,
  -θ̂y)``), and λ is the peg's depth ``l`` there: the true depth once the peg is aligned and
  ``θ̂`` has converged, whatever the hole's tilt. A residual misalignment δ between the peg and
  the true hole leaves an error of at most about ``2 r |δ|`` (10 µm for 1 mrad, r = 5 mm).
  The low-pass keeps the controller's own tilt dither out: λ has a kink of ``2 r |θ - θ̂|`` in
  the peg's tilt (the end face's lowest point changes sides), and a λ that followed the
  dithered tilt itself pumped a stiff contact at every dither period.

With an untilted hole and an aligned peg, λ = l and D = 0.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import in_deviated_hole

#: Time constant of the hole-axis estimate [s]: slow against the dither (300-400 rad/s at
#: 1 kHz), fast against an insertion (2 s).
AXIS_TIME_CONSTANT = 0.05
#: Depth step of the numerical slope ∂λ/∂l (λ is affine in l at fixed lateral features) [m].
_SLOPE_STEP = 0.01


class AxisInsertion:
    """The coordinates of one batch of insertions (N rows), see the module doc.

    ``reset(features)`` at the start, then per period ``measured(features, dt)`` for what the
    law sees and ``command(internal)`` for what it commands (which advances the drift).

    Args:
        peg_radius: Nominal r [m].
    """

    def __init__(self, peg_radius: float) -> None:
        self.peg_radius = float(peg_radius)
        self.reset(np.zeros((1, 5)))

    def reset(self, features: FloatArray) -> FloatArray:
        """Start from the measured features (N, 5): no drift, the believed axis; their law
        coordinates."""
        n = len(features)
        self._drift = np.zeros((n, 2))
        self._axis = np.zeros((n, 2))
        rows = self.measured(features, 0.0)
        self._last = rows[:, 2].copy()
        return rows

    @property
    def drift(self) -> FloatArray:
        """D per row (N, 2) [m]."""
        return self._drift

    @property
    def hole_tilts(self) -> FloatArray:
        """θ̂ per row (N, 2): the believed tilts ``(θx, θy)`` of a peg aligned with the estimated
        hole axis [rad]."""
        return self._axis

    def measured(self, features: FloatArray, dt: float) -> FloatArray:
        """Believed features (N, 5), ``dt`` [s] after the last ones → the law's coordinates
        ``(dx - Dx, dy - Dy, λ, θx, θy)``; updates the axis estimate."""
        x = np.ascontiguousarray(features, dtype=float)
        out = np.empty_like(x)
        gain = 1.0 - math.exp(-dt / AXIS_TIME_CONSTANT)
        _measured_rows(x, gain, self._axis, self._drift, self.peg_radius, out)
        return out

    def command(self, internal: FloatArray) -> FloatArray:
        """The law's command (N, 5) → believed features, after moving the drift along the
        estimated axis by the advance of the commanded λ since the last call."""
        c = np.ascontiguousarray(internal, dtype=float)
        out = np.empty_like(c)
        _command_rows(c, self._axis, self._drift, self._last, self.peg_radius, out)
        return out


@numba.njit(cache=True)  # type: ignore[misc]
def _upward(theta_x: float, theta_y: float) -> tuple[float, float, float]:
    """The upward axis of these tilts (eq. 3): ``a ∝ (tan θy, -tan θx, 1)``."""
    tx, ty = math.tan(theta_y), -math.tan(theta_x)
    norm = math.sqrt(1.0 + tx * tx + ty * ty)
    return tx / norm, ty / norm, 1.0 / norm


@numba.njit(cache=True)  # type: ignore[misc]
def _measured_rows(
    x: FloatArray, gain: float, axis: FloatArray, drift: FloatArray, r: float, out: FloatArray
) -> None:
    dev = np.zeros(5)
    hat = np.zeros(5)
    for i in range(x.shape[0]):
        if x[i, 2] > 0.0:  # in the hole: its axis is the peg's, low-passed
            axis[i, 0] += gain * (x[i, 3] - axis[i, 0])
            axis[i, 1] += gain * (x[i, 4] - axis[i, 1])
        dev[3], dev[4] = -axis[i, 0], -axis[i, 1]  # {Ĥ}: x_dev = (0, 0, 0, -θ̂x, -θ̂y)
        in_deviated_hole(x[i], dev, r, r, hat)
        out[i, 0] = x[i, 0] - drift[i, 0]
        out[i, 1] = x[i, 1] - drift[i, 1]
        out[i, 2] = hat[2]  # λ
        out[i, 3] = x[i, 3]
        out[i, 4] = x[i, 4]


@numba.njit(cache=True)  # type: ignore[misc]
def _command_rows(
    c: FloatArray, axis: FloatArray, drift: FloatArray, last: FloatArray, r: float,
    out: FloatArray,
) -> None:  # fmt: skip
    dev = np.zeros(5)
    pose = np.zeros(5)
    hat = np.zeros(5)
    for i in range(c.shape[0]):
        a_x, a_y, _ = _upward(c[i, 3], c[i, 4])  # the commanded peg's axis
        advance = c[i, 2] - last[i]
        last[i] = c[i, 2]
        # Δ(dx, dy) = -(a_x, a_y) Δλ / 2: a rigid move by Δλ along the peg's axis
        drift[i, 0] -= 0.5 * a_x * advance
        drift[i, 1] -= 0.5 * a_y * advance
        pose[0], pose[1] = c[i, 0] + drift[i, 0], c[i, 1] + drift[i, 1]
        pose[3], pose[4] = c[i, 3], c[i, 4]
        dev[3], dev[4] = -axis[i, 0], -axis[i, 1]
        # λ is affine in l at fixed lateral features: l = (λ - λ(0)) / slope
        pose[2] = 0.0
        in_deviated_hole(pose, dev, r, r, hat)
        at_zero = hat[2]
        pose[2] = _SLOPE_STEP
        in_deviated_hole(pose, dev, r, r, hat)
        slope = (hat[2] - at_zero) / _SLOPE_STEP
        out[i, 0] = pose[0]
        out[i, 1] = pose[1]
        out[i, 2] = (c[i, 2] - at_zero) / slope
        out[i, 3] = c[i, 3]
        out[i, 4] = c[i, 4]
