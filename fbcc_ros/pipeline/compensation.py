"""The compensation stage (Fig. 7): a raw sensor reading, or the arm's external joint torques,
→ the wrench the peg exerts on the hole, in {H}, moments about the {H} origin (the ROS
convention for a wrench in frame ``hole``; the controller moves them to the acting point its
boundary mapping assumes).

The pipeline, the sign conventions and the calibration file are in ``docs/compensation.md``;
the core is :class:`~fbcc_ros.core.compensation.compensator.Compensator`. This stage builds it from
its parameters and says when the tare is done (the first output after it), so the node can publish
the bias it measured and the offline replay can redo or skip the tare.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from fbcc_ros.core.compensation.compensator import Compensated, Compensator, SensorSetup
from fbcc_ros.core.compensation.payload import Payload
from fbcc_ros.core.compensation.wrench_guard import GuardLimits, WrenchGuard
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.robot import pose
from fbcc_ros.pipeline.kinematics import CELL, hole_from, robot_from
from fbcc_ros.pipeline.lateral_watch import RESOLVE_FORCE, deadband_warning
from fbcc_ros.pipeline.parameters import HOLE_FRAME, INPUT_QOS, JOINT_STATES, Param


def payload_params(prefix: str, mass: float, com: list[float], inertia: list[float]
                   ) -> tuple[Param, ...]:  # fmt: skip
    """The three parameters of what a sensor carries (``<prefix>.mass`` etc.), defaults given."""
    return (
        Param(f"{prefix}.mass", mass, "mass carried by the sensor", "kg", 0.0, 1000.0),
        Param(f"{prefix}.com", com, "its centre of mass in the sensor frame", "m"),
        Param(f"{prefix}.inertia", inertia, "its inertia about the centre of mass, row-major",
              "kg m^2"),
    )


def payload_of(values: dict[str, Any], prefix: str) -> Payload:
    """The :class:`Payload` of the ``<prefix>.*`` parameters (an error names them)."""
    inertia = np.asarray(values[f"{prefix}.inertia"], dtype=float)
    try:
        return Payload(
            values[f"{prefix}.mass"],
            tuple(values[f"{prefix}.com"]),  # type: ignore[arg-type]
            tuple(map(tuple, inertia.reshape(3, 3).tolist())) if inertia.size == 9 else inertia,  # type: ignore[arg-type]
        )
    except ConfigError as exc:  # the core names them payload.*
        raise ConfigError(exc.field.replace("payload", prefix, 1), exc.value,
                          exc.allowed) from None  # fmt: skip


TABLE = (
    Param("placement", "under_hole", "where the sensor is", choices=("under_hole", "wrist")),
    Param("sensor_frame", "ft_sensor", "frame_id the raw readings must carry"),
    Param("sensor_xyz", [0.0, 0.0, -0.015], "sensor frame origin: in {H} (under_hole) or in the "
          "flange frame (wrist)", "m"),
    Param("sensor_rpy", [0.0, 0.0, 0.0], "sensor frame orientation, same parent", "rad"),
    *payload_params("payload", 0.0, [0.0, 0.0, 0.0], [0.0] * 9),
    Param("bias", [0.0] * 6, "sensor bias (fx, fy, fz, tx, ty, tz)", "N, N m"),
    Param("tare_samples", 200, "average this many readings into the bias at start-up (0: off); "
          "the arm still and out of contact meanwhile", "", 0, 1_000_000),
    Param("lowpass_hz", 0.0, "output low-pass cut-off (0: off); while running only 0 or at least "
          "its start-up value (a lower one lags the law's input)", "Hz", 0.0, 10000.0,
          read_only=False),
    Param("deadband", [0.0, 0.0], "output dead band [force, moment]; while running a force band "
          f"over {RESOLVE_FORCE:g} N only if no wider than at start-up (it hides the lateral "
          "forces the law aligns with)", "N, N m", read_only=False),
    Param("wrench_topic", "ft_sensor/raw", "where the raw wrench comes from (e.g. "
          "force_torque_broadcaster/wrench, the LBR stack's estimate)"),
    Param("wrench_qos", "reliable", "reliability of the raw wrench (or external joint torques) "
          "subscription: best_effort for a driver publishing sensor-data QoS, which a reliable "
          "subscription never hears (a best-effort one hears both); match: its publishers', "
          "subscribed once one is seen", choices=INPUT_QOS),
    HOLE_FRAME,
    *JOINT_STATES,
    Param("virtual_sensor", False, "wrench from the arm's joint torques instead of a sensor"),
    Param("joint_torques", "external", "the virtual sensor's torques: external (the arm's "
          "estimate, effort of external_joint_torques) or measured (effort of joint_states, less "
          "our gravity model)", choices=("external", "measured")),
    Param("virtual_damping", 0.01, "damping of the virtual sensor's pseudo-inverse", "", 0.0,
          10.0),
    Param("acceleration_lowpass_hz", 10.0, "low-pass of the differentiated joint "
          "accelerations (wrist payload inertia)", "Hz", 0.0, 10000.0),
    Param("guard.force_limit", 300.0, "largest |f| of the contact wrench before any filter; "
          "over it the guard trips", "N", 1.0, 5000.0),
    Param("guard.moment_limit", 30.0, "largest |m| of the contact wrench about the {H} origin "
          "before any filter", "N m", 0.01, 500.0),
    Param("guard.sensor_range", [660.0, 60.0], "the sensor's rated range per component "
          "[force, moment]: a raw reading beyond it is implausible", "N, N m"),
    Param("guard.max_rate", [1.0e6, 1.0e5], "fastest plausible change of a raw component "
          "[force, moment]", "N/s, N m/s"),
    Param("guard.max_tare", [20.0, 2.0], "largest |difference| between a tare's bias and the "
          "configured one [force, moment]; more trips the guard (a load while taring)",
          "N, N m"),
    Param("guard.stop_margin", 0.1, "the guard trips this fraction below each limit, for the "
          "arm to stop in before the contact reaches it", "", 0.0, 0.9),
    *CELL,
)  # fmt: skip


def needs_robot(values: dict[str, Any]) -> bool:
    """Whether the stage needs the arm's model: a wrist sensor (where the sensor is), or the
    hole placed under the peg at the arm's home."""
    return values["placement"] == "wrist" or bool(values["hole_from_home"])


def setup_from(values: dict[str, Any], hole: pin.SE3) -> SensorSetup:
    """The sensor set-up of :data:`TABLE`'s values, the hole at ``hole`` (``T_base_H``)."""
    return SensorSetup(
        placement=values["placement"],
        frame=values["sensor_frame"],
        pose=pose(values["sensor_xyz"], values["sensor_rpy"]),
        hole_in_base=hole,
        acting_point=(0.0, 0.0, 0.0),  # the {H} origin: the output is a wrench in frame hole
        payload=payload_of(values, "payload"),
        bias=tuple(values["bias"]),
        lowpass_hz=values["lowpass_hz"],
        deadband=tuple(values["deadband"]),  # type: ignore[arg-type]
        acceleration_lowpass_hz=values["acceleration_lowpass_hz"],
        virtual_damping=values["virtual_damping"],
        tare_samples=values["tare_samples"],
        guard=GuardLimits(values["guard.force_limit"], values["guard.moment_limit"],
                          _pair(values["guard.sensor_range"]), _pair(values["guard.max_rate"]),
                          _pair(values["guard.max_tare"]), values["guard.stop_margin"]),
    )


def _pair(value: Sequence[float]) -> tuple[float, float]:
    """A [force, moment] parameter (its length is checked by the core's dataclass)."""
    return tuple(float(v) for v in value)  # type: ignore[return-value]


class CompensationStage:
    """The compensator of :data:`TABLE`'s values.

    Attributes:
        comp: The core compensator (its ``counts`` say what it accepted and rejected).
        robot: The arm (wrist placement) or None (under the hole).
        just_tared: True after the call that gave the first output of a tare: the bias is
            measured from then on.
        just_tripped: True after the call in which the wrench guard tripped (its reason:
            ``comp.guard.reason``); the stage passes nothing from then on.
    """

    def __init__(self, values: dict[str, Any], description: str | None = None) -> None:
        robot = robot_from(values, description) if needs_robot(values) else None
        hole = hole_from(values, robot)
        self.setup = setup_from(values, hole)
        self.virtual = bool(values["virtual_sensor"])
        self.measured = self.virtual and values["joint_torques"] == "measured"
        if self.virtual and self.setup.placement != "wrist":
            raise ConfigError("virtual_sensor", True, "placement 'wrist' with it (the joint "
                              "torques give the wrench at the wrist)")  # fmt: skip
        self.robot = robot if self.setup.placement == "wrist" else None
        self.comp = Compensator(self.setup, self.robot)
        self._filters = (values["lowpass_hz"], values["deadband"])
        self._startup_band = tuple(values["deadband"])
        self._startup_cut = float(values["lowpass_hz"])
        self._untared = self.setup.tare_samples > 0
        self.just_tared = False
        self.just_tripped = False
        self._tripped_said = False

    def apply(self, values: dict[str, Any]) -> None:
        """The runtime parameters (``lowpass_hz``, ``deadband``). A low-pass cut-off lower than
        at start-up is refused (ConfigError): it lags the law's input. A dead band that would hide
        the lateral forces the law aligns with (:func:`~fbcc_ros.pipeline.lateral_watch.
        deadband_warning`) is refused (ConfigError) unless it is no wider than at start-up:
        the law would go on pushing the peg in, blind to them."""
        band = values["deadband"]
        if (deadband_warning(tuple(band), None, "deadband")
                and any(b > s for b, s in zip(band, self._startup_band, strict=True))):
            raise ConfigError("deadband", list(band), f"a force band of at most "
                              f"{RESOLVE_FORCE:g} N, or no wider than at start-up "
                              f"{list(self._startup_band)}, while running (a wider band hides "
                              "the lateral forces the law aligns with)")
        cut, start = values["lowpass_hz"], self._startup_cut
        if cut > 0.0 and (start == 0.0 or cut < start):
            raise ConfigError("lowpass_hz", cut, f"0 (off) or at least its start-up value "
                              f"{start:g} Hz while running (a lower cut-off lags the law's "
                              "input beyond the delay its margins budget for)")
        self._filters = (cut, band)
        self.comp.set_filters(*self._filters)

    def retare(self, samples: int, bias: Sequence[float] | None = None) -> None:
        """A fresh compensator that tares on ``samples`` readings (at most the configured
        ``tare_samples``), or that uses ``bias`` as it is, with no tare."""
        tare = 0 if bias is not None else min(samples, self.setup.tare_samples)
        setup = dataclasses.replace(self.setup, tare_samples=tare)
        if bias is not None:
            setup = dataclasses.replace(setup, bias=tuple(bias))
        depth = self.comp.peg_depth
        self.comp = Compensator(setup, self.robot)
        self.comp.set_filters(*self._filters)  # as set while running
        self.comp.peg_depth = depth
        self._untared = tare > 0
        self._tripped_said = False

    def peg(self, peg_in_hole_z: float) -> None:
        """The peg's tip height over the hole's top face [m] (``fbcc/features``' z): a tare
        is refused while it is in the hole."""
        self.comp.peg_depth = -float(peg_in_hole_z)

    def rearm(self) -> str | None:
        """A fresh wrench guard (the controller's reset acknowledged the trip); returns the
        reason of the trip it clears, None if it had not tripped. A tare it refused is taken
        again from the next readings (the load may be gone; if not, it is refused again)."""
        cleared = self.comp.guard.reason
        if self.comp.tare_refused:
            self.retare(self.setup.tare_samples)
        else:
            self.comp.guard = WrenchGuard(self.setup.guard)
        self._tripped_said = False
        return cleared

    def trip(self, reason: str) -> bool:
        """Trips the wrench guard for a fault the node sees (a second source on an input):
        nothing passes until :meth:`rearm`. Returns whether it was not tripped before (the
        reason to publish)."""
        if self.comp.guard.tripped:
            return False
        self.comp.guard.trip(reason)
        self._tripped_said = True
        return True

    def joints(self, stamp: float, q: ArrayLike, dq: ArrayLike | None = None) -> None:
        """The arm's joint state (wrist placement: where the sensor and payload are)."""
        self.comp.joints(stamp, q, dq)

    def reading(self, stamp: float, frame: str, wrench: ArrayLike, received: float | None = None
                ) -> Compensated | None:  # fmt: skip
        """One raw reading (sensor frame) → the compensated wrench; None while taring and for a
        rejected sample (counted in ``comp.counts``). ``received``: its arrival time, when
        known (a stamp far ahead of it is refused)."""
        return self._output(self.comp.reading(stamp, frame, wrench, received))

    def torques(self, stamp: float, external_torques: ArrayLike, received: float | None = None
                ) -> Compensated | None:  # fmt: skip
        """The virtual sensor: external joint torques → the compensated wrench."""
        return self._output(self.comp.joint_torques(stamp, external_torques, received))

    def measured_torques(self, stamp: float, q: ArrayLike, dq: ArrayLike | None,
                         effort: ArrayLike, received: float | None = None
                         ) -> Compensated | None:  # fmt: skip
        """The virtual sensor from one joint state's measured torques:
        ``tau_ext = tau - g(q)`` (KUKA's: the external torque is the measured one less the
        model's), ``g`` our gravity model of the arm (an error in it reads as a wrench: the
        tare takes its value at the start pose)."""
        assert self.robot is not None  # a virtual sensor is a wrist one
        if not self.comp.joints(stamp, q, dq):
            return None
        tau_ext = np.asarray(effort, dtype=float) - self.robot.gravity(q)
        return self.torques(stamp, tau_ext, received)

    def _output(self, out: Compensated | None) -> Compensated | None:
        self.just_tripped = self.comp.guard.tripped and not self._tripped_said
        self._tripped_said = self.comp.guard.tripped
        self.just_tared = out is not None and self._untared
        if self.just_tared:
            self._untared = False
        return out
