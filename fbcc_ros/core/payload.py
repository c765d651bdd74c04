"""Dynamic compensation, part 1: the payload's wrench on the sensor, and its static calibration.

The sensor frame {S} is the force/torque sensor's measuring frame. A sensor reading is the wrench
that the tool side (the payload: the peg holder and the peg, or the hole fixture) exerts on the
sensor, expressed in {S} with torques about the origin of {S}, plus the sensor's bias.

A rigid payload of mass m, centre of mass c (in {S}) and inertia I_c (about c, in {S}) on a
sensor whose origin accelerates with a_o, rotating at omega with omega_dot (all in {S}), in
gravity g (in {S}: ``R_base_S^T g_base``) exerts (Newton-Euler on the payload, then the reaction)

.. math::
    a_c = a_o + \\dot\\omega \\times c + \\omega \\times (\\omega \\times c)

    F = m (g - a_c)

    \\tau = c \\times F - (I_c \\dot\\omega + \\omega \\times I_c \\omega)

At rest this is ``F = m g``, ``tau = c x m g``: the weight, as a static sensor reads it.
Compensation subtracts this wrench and the bias; what is left is the contact wrench.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fbcc_ros.core.errors import ConfigError, InputError

FloatArray = NDArray[np.float64]

#: Standard gravity in a z-up base frame [m/s²].
GRAVITY_BASE = np.array([0.0, 0.0, -9.80665])


def _vector(value: ArrayLike, field: str, size: int = 3) -> FloatArray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (size,) or not np.isfinite(arr).all():
        raise ConfigError(field, value, f"{size} finite numbers")
    return arr


@dataclasses.dataclass(frozen=True)
class Payload:
    """The rigid body between the sensor and the contact.

    Attributes:
        mass: m [kg], >= 0.
        com: Centre of mass c in {S} [m].
        inertia: I_c about the centre of mass, in {S} [kg m²], symmetric positive
            semi-definite; zeros (the default) leave the rotational inertia out.
    """

    mass: float
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple[tuple[float, ...], ...] = ((0.0,) * 3,) * 3

    def __post_init__(self) -> None:
        if not (np.isfinite(self.mass) and self.mass >= 0.0):
            raise ConfigError("payload.mass", self.mass, "a mass >= 0 [kg]")
        _vector(self.com, "payload.com")
        inertia = np.asarray(self.inertia, dtype=float)
        if inertia.shape != (3, 3) or not np.isfinite(inertia).all():
            raise ConfigError("payload.inertia", self.inertia, "a 3x3 finite matrix [kg m²]")
        if not np.allclose(inertia, inertia.T) or np.linalg.eigvalsh(inertia).min() < -1e-12:
            raise ConfigError(
                "payload.inertia", self.inertia, "a symmetric positive semi-definite matrix"
            )


@dataclasses.dataclass(frozen=True)
class Motion:
    """The sensor frame's motion, all in {S}.

    Attributes:
        gravity: g in {S} [m/s²] (``R_base_S^T g_base``).
        linear_acceleration: a_o, of the origin of {S} [m/s²], without gravity.
        angular_velocity: omega [rad/s].
        angular_acceleration: omega_dot [rad/s²].
    """

    gravity: FloatArray
    linear_acceleration: FloatArray = dataclasses.field(default_factory=lambda: np.zeros(3))
    angular_velocity: FloatArray = dataclasses.field(default_factory=lambda: np.zeros(3))
    angular_acceleration: FloatArray = dataclasses.field(default_factory=lambda: np.zeros(3))

    @classmethod
    def at_rest(cls, rotation_base_sensor: ArrayLike) -> Motion:
        """A sensor at rest with orientation ``R_base_S`` in a z-up base."""
        return cls(np.asarray(rotation_base_sensor, dtype=float).T @ GRAVITY_BASE)


def payload_wrench(payload: Payload, motion: Motion) -> FloatArray:
    """The wrench ``(Fx, Fy, Fz, Tx, Ty, Tz)`` the payload exerts on the sensor, in {S} [N, N m].

    Implements the Newton-Euler equations of the module doc.
    """
    c = np.asarray(payload.com, dtype=float)
    inertia = np.asarray(payload.inertia, dtype=float)
    w, dw = motion.angular_velocity, motion.angular_acceleration
    # a_c = a_o + dw x c + w x (w x c)
    a_c = motion.linear_acceleration + np.cross(dw, c) + np.cross(w, np.cross(w, c))
    # F = m (g - a_c)
    force = payload.mass * (motion.gravity - a_c)
    # tau = c x F - (I_c dw + w x I_c w)
    torque = np.cross(c, force) - (inertia @ dw + np.cross(w, inertia @ w))
    return np.concatenate([force, torque])


def compensate(
    wrench_measured: ArrayLike, payload: Payload, motion: Motion, bias: ArrayLike
) -> FloatArray:
    """The contact wrench at the sensor, in {S}: the reading minus the payload and the bias.

    Raises :class:`InputError` on a non-finite reading rather than propagate it.
    """
    measured = np.asarray(wrench_measured, dtype=float)
    if measured.shape != (6,) or not np.isfinite(measured).all():
        raise InputError("wrench", wrench_measured, "6 finite numbers (Fx, Fy, Fz, Tx, Ty, Tz)")
    return measured - payload_wrench(payload, motion) - _vector(bias, "bias", 6)


@dataclasses.dataclass(frozen=True)
class StaticCalibration:
    """Result of :func:`calibrate_static`.

    Attributes:
        payload: Mass and centre of mass (inertia left at zero).
        bias: Sensor bias (Fx, Fy, Fz, Tx, Ty, Tz) [N, N m].
        residual_rms: RMS of the fit's residual, force [N] and torque [N m].
        condition: Condition number of the (column-scaled) regression matrix.
    """

    payload: Payload
    bias: FloatArray
    residual_rms: tuple[float, float]
    condition: float


#: Largest accepted condition number of the calibration regression: beyond it the poses do not
#: excite every parameter (e.g. all poses share one gravity direction).
MAX_CONDITION = 1e3


def calibrate_static(
    rotations_base_sensor: ArrayLike, wrenches: ArrayLike, max_condition: float = MAX_CONDITION
) -> StaticCalibration:
    """Least-squares mass, centre of mass and bias from N static poses.

    At rest the reading is linear in the ten parameters ``(m, m c, b_F, b_tau)``:

    .. math::
        F = m g + b_F, \\qquad \\tau = -[g]_\\times (m c) + b_\\tau

    Args:
        rotations_base_sensor: (N, 3, 3) sensor orientations ``R_base_S``.
        wrenches: (N, 6) readings in {S}.
        max_condition: Refuse the fit when the regression's condition number exceeds this.
    """
    rotations = np.asarray(rotations_base_sensor, dtype=float)
    readings = np.asarray(wrenches, dtype=float)
    n = rotations.shape[0] if rotations.ndim == 3 else 0
    if rotations.shape != (n, 3, 3) or readings.shape != (n, 6) or n < 3:
        raise InputError(
            "poses",
            (rotations.shape, readings.shape),
            "(N, 3, 3) rotations and (N, 6) wrenches, N >= 3",
        )
    if not (np.isfinite(rotations).all() and np.isfinite(readings).all()):
        raise InputError("poses", "non-finite values", "finite rotations and wrenches")
    g = rotations.transpose(0, 2, 1) @ GRAVITY_BASE  # (N, 3) gravity in {S}
    rows = np.zeros((n, 6, 10))
    eye = np.eye(3)
    rows[:, :3, 0] = g  # F = m g + b_F
    rows[:, :3, 4:7] = eye
    rows[:, 3:, 1:4] = -_skew(g)  # tau = -[g]x (m c) + b_tau
    rows[:, 3:, 7:10] = eye
    a = rows.reshape(6 * n, 10)
    b = readings.reshape(6 * n)
    # Condition number with the columns scaled to unit norm (units differ: kg, kg m, N, N m);
    # a column that never varies (a parameter no pose excites) makes it infinite.
    scale = np.linalg.norm(a, axis=0)
    singular = np.linalg.svd(a / np.where(scale > 0.0, scale, 1.0), compute_uv=False)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0.0 else np.inf
    if not condition <= max_condition:
        raise InputError(
            "poses",
            f"condition number {condition:.3g}",
            f"poses whose gravity directions excite every parameter (condition <= "
            f"{max_condition:.3g}; tilt the sensor about at least two axes)",
        )
    x, *_ = np.linalg.lstsq(a, b, rcond=None)
    residual = (a @ x - b).reshape(n, 6)
    mass = float(x[0])
    com = x[1:4] / mass if mass > 0 else np.zeros(3)
    return StaticCalibration(
        Payload(max(mass, 0.0), tuple(com.tolist())),
        x[4:10],
        (
            float(np.sqrt(np.mean(residual[:, :3] ** 2))),
            float(np.sqrt(np.mean(residual[:, 3:] ** 2))),
        ),
        condition,
    )


def _skew(v: FloatArray) -> FloatArray:
    """Cross-product matrices of the rows of v, (N, 3, 3): ``_skew(v) @ u = v x u``."""
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out
