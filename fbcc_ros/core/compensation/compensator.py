"""Dynamic compensation (the paper's Fig. 7): from the raw sensor reading to the response.

Per sample, :class:`Compensator` does, in this order:

1. **Checks.** The reading's frame must be the configured sensor frame (an error naming both),
   its stamp must be later than the last one, every value finite; a rejected sample is counted,
   never propagated (never a zero). A sustained share of rejected samples (:data:`REJECTED_SHARE`
   of the last :data:`REJECTED_WINDOW`) trips the wrench guard: the input itself is wrong.
2. **Payload and bias** are removed in the sensor frame {S} (:func:`payload.compensate`), with the
   sensor's orientation and motion from the kinematics (constant for a sensor under the hole:
   its payload wrench is computed once).
3. **The sign.** A sensor under the hole (the paper's Section II) carries the hole fixture, so the
   compensated reading *is* the wrench the peg exerts on the hole. A wrist sensor (the paper's
   experiment) carries the peg and reads the wrench the hole exerts on the peg: the reaction, so
   it is negated.
4. **The acting point.** The wrench is expressed in {H} with the moment moved to the equivalent
   acting point (:func:`wrench.transfer_matrix`, ``tau_A = tau_S + (p_S - p_A) x f``; computed
   once for a sensor that does not move). The boundary
   mapping is derived for the point L + H below the top face (eq. 12-13), so every sensor
   placement is moved *there*; this replaces the paper's re-derivation of L and H for the wrist
   sensor (Remark 2 of II.B, Section V.C) by the exact rigid-body lever.
5. **Conditioning**, both off by default: low-pass, then dead band (:mod:`filters`).

The output is the wire wrench (right-handed, {H}, about the acting point) and the response vector
``(Fx, Fy, Fz, Mx, My)`` with ``Fz = -fz`` (:mod:`wrench`).

A virtual sensor (the iiwa's external joint torques, as in the paper's experiment) enters at step
2 as a wrist reading in the frame it is computed for.
"""

from __future__ import annotations

import collections
import dataclasses
import math
from typing import Literal

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.payload import (
    GRAVITY_BASE,
    Motion,
    Payload,
    payload_wrench,
    subtract,
)
from fbcc_ros.core.compensation.wrench import response_from_wrench, transfer_matrix, virtual_wrench
from fbcc_ros.core.compensation.wrench_guard import GuardLimits, WrenchGuard
from fbcc_ros.core.errors import ConfigError, InputError, require_vector
from fbcc_ros.core.filters import LowPass, dead_band
from fbcc_ros.core.kinematics.robot import RobotModel

Placement = Literal["under_hole", "wrist"]
PLACEMENTS = ("under_hole", "wrist")

#: Name of the Pinocchio frame added at a wrist sensor's measuring frame.
SENSOR_FRAME = "fbcc_sensor"



@dataclasses.dataclass(frozen=True)
class SensorSetup:
    """Where the sensor is, what it carries, and how its output is conditioned.

    Attributes:
        placement: ``"under_hole"`` (the sensor carries the hole fixture, Section II) or
            ``"wrist"`` (it carries the peg; the paper's experiment, and the virtual sensor).
        frame: The ``frame_id`` the raw readings must carry.
        pose: The sensor frame {S}: in {H} for ``under_hole``, in the flange frame for ``wrist``.
        hole_in_base: ``T_base_H``; gives the direction of gravity in {S}.
        acting_point: Where the output's moments are taken, in {H} [m]
            (:meth:`PegHole.acting_point_in_hole` gives the one the boundary mapping assumes).
        payload: What the sensor carries between itself and the contact.
        bias: Sensor offset ``(fx, fy, fz, tx, ty, tz)`` in {S} [N, N m].
        lowpass_hz: Cut-off of the output low-pass [Hz]; 0 is off.
        deadband: Dead band on the output's force and moment components [N, N m]; 0 is off.
        acceleration_lowpass_hz: Cut-off of the low-pass on the joint accelerations that are
            differentiated from the joint velocities, for the payload's inertial terms [Hz].
        virtual_damping: lambda of the virtual sensor's damped pseudo-inverse.
        tare_samples: When > 0, the first this many accepted readings are not output but
            averaged into the bias, ``b = mean(reading - payload wrench)``: the usual way to
            zero a sensor under the hole (whose weight and bias a static fit cannot tell apart)
            before an insertion. The peg must not touch the hole meanwhile. Their spread, as
            output, is the sensor's noise floor (``Compensator.noise``).
    """

    placement: Placement = "under_hole"
    frame: str = "ft_sensor"
    pose: pin.SE3 = dataclasses.field(default_factory=pin.SE3.Identity)
    hole_in_base: pin.SE3 = dataclasses.field(default_factory=pin.SE3.Identity)
    acting_point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    payload: Payload = dataclasses.field(default_factory=lambda: Payload(0.0))
    bias: tuple[float, ...] = (0.0,) * 6
    lowpass_hz: float = 0.0
    deadband: tuple[float, float] = (0.0, 0.0)
    acceleration_lowpass_hz: float = 10.0
    virtual_damping: float = 0.01
    tare_samples: int = 0
    guard: GuardLimits = dataclasses.field(default_factory=GuardLimits)

    def __post_init__(self) -> None:
        if self.placement not in PLACEMENTS:
            raise ConfigError("placement", self.placement, f"one of {PLACEMENTS}")
        if not (isinstance(self.frame, str) and self.frame):
            raise ConfigError("sensor_frame", self.frame, "a non-empty frame name")
        require_vector("acting_point", self.acting_point, 3)
        require_vector("bias", self.bias, 6)
        band = require_vector("deadband", self.deadband, 2)
        if (band < 0).any():
            raise ConfigError("deadband", self.deadband, "[force N, moment N m], both >= 0")
        for field in ("pose", "hole_in_base"):
            placement = getattr(self, field)
            if not (isinstance(placement, pin.SE3) and np.isfinite(placement.homogeneous).all()):
                raise ConfigError(field, placement, "a finite rigid transform")
        if not (math.isfinite(self.virtual_damping) and self.virtual_damping >= 0.0):
            raise ConfigError("virtual_sensor.damping", self.virtual_damping, "a damping >= 0")
        if isinstance(self.tare_samples, bool) or not (
            isinstance(self.tare_samples, int) and self.tare_samples >= 0
        ):
            raise ConfigError("tare_samples", self.tare_samples, "an integer >= 0 (0: off)")


@dataclasses.dataclass(frozen=True)
class Compensated:
    """One compensated sample.

    Attributes:
        stamp: The reading's time [s].
        wrench: ``(fx, fy, fz, mx, my, mz)`` the peg exerts on the hole, in {H}, moments about
            the acting point: what goes on the wire.
        response: ``(Fx, Fy, Fz, Mx, My)`` for the controller (``Fz = -fz``).
    """

    stamp: float
    wrench: FloatArray
    response: FloatArray


#: The rejections that say the input itself is wrong (not the guard's, not the tare's).
REJECTIONS = ("non_finite", "out_of_order", "future_stamp")
#: Of the last :data:`REJECTED_WINDOW` samples, this share rejected trips the guard: a sensor
#: rejects none (a reordered best-effort sample is rare), a second source on the topic or a
#: clock ahead of ours rejects most; the law must not run on the remainder.
REJECTED_SHARE = 0.2
REJECTED_WINDOW = 100
#: How far [s] a sample's stamp may lie ahead of its arrival (clocks of two machines disagree by
#: milliseconds); a stamp further ahead is refused, not allowed to make later samples look old.
MAX_STAMP_AHEAD = 0.05


class Compensator:
    """The dynamic compensation of one sensor; see the module doc for the pipeline.

    Args:
        setup: The sensor's placement, payload, bias and filters.
        robot: The arm, needed for a wrist sensor (its pose and motion come from the joints).
    """

    def __init__(self, setup: SensorSetup, robot: RobotModel | None = None) -> None:
        self.setup = setup
        self.robot = robot
        self.counts = {
            "accepted": 0,
            "non_finite": 0,
            "out_of_order": 0,
            "future_stamp": 0,
            "guard": 0,
            "no_joint_state": 0,
            "joint_state_rejected": 0,
            "taring": 0,
        }
        self._tare: list[FloatArray] = []
        self._acting_point = np.asarray(setup.acting_point, dtype=float)
        self._bias = np.asarray(setup.bias, dtype=float)
        self._band = np.repeat(np.asarray(setup.deadband, dtype=float), 3)
        self._lowpass = LowPass(setup.lowpass_hz)
        self._accel_lowpass = LowPass(setup.acceleration_lowpass_hz, "acceleration_lowpass_hz")
        self._last_stamp = -math.inf
        self._recent: collections.deque[bool] = collections.deque()
        self._recent_rejected = 0
        #: limits below the filters (module doc of wrench_guard); tripped, it passes nothing
        self.guard = WrenchGuard(setup.guard)
        #: the guard refused the tare (the configured bias stays)
        self.tare_refused = False
        #: how deep the peg's tip was last heard in the hole [m] (None: not heard), which the
        #: tare's check takes (:meth:`WrenchGuard.tare`)
        self.peg_depth: float | None = None
        #: the output's noise floor measured by the tare: the standard deviation of each
        #: component (fx, fy, fz, mx, my, mz in {H}, as output, before the output's filters) of
        #: the readings averaged into the bias; None before a tare (or without one)
        self.noise: FloatArray | None = None
        self._joints: tuple[float, FloatArray, FloatArray, FloatArray] | None = None
        if setup.placement == "wrist":
            if robot is None:
                raise ConfigError("robot", None, "a robot model for a wrist sensor")
            robot.add_frame(SENSOR_FRAME, setup.pose)
            self._hole_from_base = setup.hole_in_base.inverse()
        else:
            # A sensor under the hole does not move: {S} in {H}, gravity in {S} and so the
            # payload's wrench are constant.
            at_rest = Motion.at_rest(setup.hole_in_base.rotation @ setup.pose.rotation)
            self._static = (
                transfer_matrix(setup.pose, self._acting_point),
                payload_wrench(setup.payload, at_rest),
            )

    @property
    def taring(self) -> bool:
        """Whether the next accepted reading still goes into the tare (no output)."""
        return len(self._tare) < self.setup.tare_samples

    def joints(self, stamp: float, q: ArrayLike, dq: ArrayLike | None = None) -> bool:
        """Takes a joint state; velocities are differentiated from positions when absent, and
        accelerations from velocities (low-passed). Returns False, counted, if rejected."""
        if self.robot is None:
            return True  # a sensor under the hole needs no joint state
        try:
            q_ = self.robot.check_joints(q)
            dq_ = None if dq is None else self.robot.check_joints(dq, "dq")
        except InputError:
            self.counts["joint_state_rejected"] += 1
            return False
        if self._joints is None:
            zero = np.zeros_like(q_)
            self._joints = (stamp, q_, zero if dq_ is None else dq_, zero)
            return True
        t0, q0, dq0, _ = self._joints
        dt = stamp - t0
        if not dt > 0.0:
            self.counts["joint_state_rejected"] += 1
            return False
        dq_ = (q_ - q0) / dt if dq_ is None else dq_
        ddq = self._accel_lowpass((dq_ - dq0) / dt, dt)  # ddq ~ d(dq)/dt, low-passed
        self._joints = (stamp, q_, dq_, ddq)
        return True

    def reading(
        self, stamp: float, frame_id: str, wrench: ArrayLike, received: float | None = None
    ) -> Compensated | None:
        """Compensates one raw reading of the physical sensor, or returns None (counted).
        ``received``: when it arrived, on the clock of the stamps (a sample stamped more than
        :data:`MAX_STAMP_AHEAD` later is refused).

        Raises:
            InputError: The reading's frame is not the configured sensor frame.
        """
        if frame_id != self.setup.frame:
            raise InputError(
                "header.frame_id", frame_id, f"the configured sensor frame '{self.setup.frame}'"
            )
        return self._process(stamp, wrench, received)

    def joint_torques(
        self, stamp: float, external_torques: ArrayLike, received: float | None = None
    ) -> Compensated | None:
        """Compensates the virtual sensor's wrench from the arm's external joint torques.

        ``tau_ext = J^T w`` with ``w`` the wrench on the arm at the sensor frame (KUKA's and
        lbr_fri_ros2's convention); :func:`wrench.virtual_wrench` inverts it.
        """
        if self.setup.placement != "wrist" or self.robot is None:
            raise ConfigError("placement", self.setup.placement, "'wrist' for a virtual sensor")
        if self._joints is None:
            self.counts["no_joint_state"] += 1
            return None
        try:
            # the Jacobian in {S}'s own axes: the wrench comes in {S}, about its origin
            w_sensor = virtual_wrench(
                self.robot.jacobian(self._joints[1], SENSOR_FRAME, pin.LOCAL),
                external_torques,
                self.setup.virtual_damping,
            )
        except InputError:
            self.counts["non_finite"] += 1
            return None
        return self._process(stamp, w_sensor, received)

    def _process(self, stamp: float, wrench: ArrayLike, received: float | None
                 ) -> Compensated | None:  # fmt: skip
        before = self._rejected()
        out = self._compensate(stamp, wrench, received)
        self._watch(self._rejected() > before)
        return out

    def _rejected(self) -> int:
        return sum(self.counts[k] for k in REJECTIONS)

    def _watch(self, rejected: bool) -> None:
        """A sustained share of rejected samples trips the guard (:data:`REJECTED_SHARE`)."""
        self._recent.append(rejected)
        self._recent_rejected += rejected
        if len(self._recent) > REJECTED_WINDOW:
            self._recent_rejected -= self._recent.popleft()
        if (len(self._recent) == REJECTED_WINDOW and not self.guard.tripped
                and self._recent_rejected >= REJECTED_SHARE * REJECTED_WINDOW):  # fmt: skip
            counts = {k: self.counts[k] for k in REJECTIONS if self.counts[k]}
            self.guard.trip(f"{self._recent_rejected} of the last {REJECTED_WINDOW} samples "
                            f"rejected (so far {counts}): a second source on the input, a "
                            "clock that jumped or a failing sensor")  # fmt: skip

    def _compensate(self, stamp: float, wrench: ArrayLike, received: float | None
                    ) -> Compensated | None:  # fmt: skip
        if received is not None and stamp > received + MAX_STAMP_AHEAD:
            # a clock ahead of ours: taken, its stamp would refuse every later sample as old
            self.counts["future_stamp"] += 1
            return None
        if not math.isfinite(stamp) or stamp <= self._last_stamp:
            self.counts["out_of_order"] += 1
            return None
        reading = np.asarray(wrench, dtype=float)
        checkable = reading.shape == (6,) and np.isfinite(reading).all()  # else counted below
        if self.guard.tripped or (checkable and not self.guard.raw(stamp, reading)):
            self.counts["guard"] += 1
            return None
        state = self._sensor_state()
        if state is None:
            self.counts["no_joint_state"] += 1
            return None
        to_hole, payload = state
        if self.taring:
            self._add_tare(stamp, wrench, payload, to_hole)
            return None
        try:
            contact = subtract(wrench, payload, self._bias)
        except InputError:
            self.counts["non_finite"] += 1
            return None
        if self.setup.placement == "wrist":
            contact = -contact  # the sensor reads the hole's wrench on the peg: the reaction
        out = to_hole @ contact  # in {H}, about the acting point (transfer_matrix)
        if not self.guard.contact(out):  # before any filter: nothing below weakens it
            self.counts["guard"] += 1
            return None
        dt = stamp - self._last_stamp
        out = dead_band(self._lowpass(out, dt), self._band)
        self._last_stamp = stamp
        self.counts["accepted"] += 1
        return Compensated(stamp, out, response_from_wrench(out))

    def set_filters(self, lowpass_hz: float, deadband: ArrayLike) -> None:
        """Changes the output filters at runtime (the low-pass restarts from the next sample)."""
        band = require_vector("deadband", deadband, 2)
        if (band < 0).any():
            raise ConfigError("deadband", deadband, "[force N, moment N m], both >= 0")
        self._lowpass = LowPass(lowpass_hz)
        self._band = np.repeat(band, 3)

    def _add_tare(self, stamp: float, wrench: ArrayLike, payload: FloatArray,
                  to_hole: FloatArray) -> None:  # fmt: skip
        try:  # the payload alone: the reading with a zero bias
            self._tare.append(subtract(wrench, payload, np.zeros(6)))
        except InputError:
            self.counts["non_finite"] += 1
            return
        self._last_stamp = stamp
        self.counts["taring"] += 1
        if len(self._tare) == self.setup.tare_samples:
            measured = np.mean(self._tare, axis=0)  # b = mean(reading - payload wrench)
            if self.guard.tare(measured, self._bias, self.peg_depth):  # else tripped
                self._bias = measured
                if len(self._tare) > 1:  # their spread, as output: C_H = T C_S Tᵀ
                    spread = to_hole @ np.cov(np.array(self._tare).T) @ to_hole.T
                    self.noise = np.sqrt(np.clip(np.diag(spread), 0.0, None))
            else:
                self.tare_refused = True

    @property
    def bias(self) -> FloatArray:
        """The bias in use (configured, or measured by the tare)."""
        return self._bias.copy()

    def _sensor_state(self) -> tuple[FloatArray, FloatArray] | None:
        """The wrench transfer from {S} to {H} at the acting point (``transfer_matrix`` of
        ``T_H_S``) and the payload's wrench on the sensor in {S}: from the latest joint state
        if the sensor moves, computed once if not."""
        if self.setup.placement == "under_hole":
            return self._static
        if self._joints is None or self.robot is None:
            return None
        placement, motion = sensor_motion(self.robot, *self._joints[1:])
        to_hole = transfer_matrix(self._hole_from_base * placement, self._acting_point)
        return to_hole, payload_wrench(self.setup.payload, motion)


def sensor_motion(
    robot: RobotModel, q: ArrayLike, dq: ArrayLike, ddq: ArrayLike, frame: str = SENSOR_FRAME
) -> tuple[pin.SE3, Motion]:
    """A robot-mounted sensor's pose ``T_base_S`` and its :class:`Motion` in {S}."""
    placement, velocity, accel = robot.frame_motion(q, dq, ddq, frame)
    return placement, Motion(
        placement.rotation.T @ GRAVITY_BASE,
        np.array(accel.linear),
        np.array(velocity.angular),
        np.array(accel.angular),
    )
