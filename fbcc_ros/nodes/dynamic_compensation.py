"""dynamic_compensation node (Fig. 7): raw WrenchStamped → the compensated wrench in {H}.

Subscribes ``ft_sensor/raw`` (WrenchStamped in the sensor frame) and, for a wrist sensor,
``joint_states``; with ``virtual_sensor`` it takes the arm's external joint torques from the
``effort`` of ``external_joint_torques`` (JointState) instead of a sensor. Publishes
``ft_sensor/compensated``: the wrench the peg exerts on the hole, frame ``hole``, moments about
the acting point (right-handed; the controller's Fz is its negated z force). The pipeline, the
sign conventions and the calibration file are in ``docs/compensation.md``; rejected samples
are counted and logged, never published; the counters go to ``/diagnostics`` each second.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from fbcc_ros.core.compensation import Compensator, SensorSetup
from fbcc_ros.core.errors import ConfigError, FbccError
from fbcc_ros.core.kinematics import pose
from fbcc_ros.core.payload import Payload
from fbcc_ros.nodes import topics
from fbcc_ros.nodes.convert import (
    efforts_from_cdr,
    joints_from_cdr,
    wrench_from_cdr,
    wrench_to_cdr,
)
from fbcc_ros.nodes.diagnostics import counter_report, publish_diagnostics
from fbcc_ros.nodes.params import CELL, Param, cell_from, declare, run

TABLE = (
    Param("placement", "under_hole", "where the sensor is", choices=("under_hole", "wrist")),
    Param("sensor_frame", "ft_sensor", "frame_id the raw readings must carry"),
    Param("sensor_xyz", [0.0, 0.0, -0.015], "sensor frame origin: in {H} (under_hole) or in the "
          "flange frame (wrist)", "m"),
    Param("sensor_rpy", [0.0, 0.0, 0.0], "sensor frame orientation, same parent", "rad"),
    Param("acting_point", [0.0, 0.0, -0.015], "where the output's moments are taken, in {H}: "
          "L + H below the top face for the boundary mapping", "m"),
    Param("payload.mass", 0.0, "mass carried by the sensor", "kg", 0.0, 1000.0),
    Param("payload.com", [0.0, 0.0, 0.0], "its centre of mass in the sensor frame", "m"),
    Param("payload.inertia", [0.0] * 9, "its inertia about the centre of mass, row-major",
          "kg m^2"),
    Param("bias", [0.0] * 6, "sensor bias (fx, fy, fz, tx, ty, tz)", "N, N m"),
    Param("tare_samples", 0, "average this many readings into the bias at start-up (0: off); "
          "no contact meanwhile", "", 0, 1_000_000),
    Param("lowpass_hz", 0.0, "output low-pass cut-off (0: off)", "Hz", 0.0, 10000.0,
          read_only=False),
    Param("deadband", [0.0, 0.0], "output dead band [force, moment]", "N, N m",
          read_only=False),
    Param("virtual_sensor", False, "wrench from external joint torques instead of a sensor"),
    Param("virtual_damping", 0.01, "damping of the virtual sensor's pseudo-inverse", "", 0.0,
          10.0),
    Param("acceleration_lowpass_hz", 10.0, "low-pass of the differentiated joint "
          "accelerations (wrist payload inertia)", "Hz", 0.0, 10000.0),
    *CELL,
)  # fmt: skip


def setup_from(values: dict[str, Any], hole: Any) -> SensorSetup:
    inertia = np.asarray(values["payload.inertia"], dtype=float)
    return SensorSetup(
        placement=values["placement"],
        frame=values["sensor_frame"],
        pose=pose(values["sensor_xyz"], values["sensor_rpy"]),
        hole_in_base=hole,
        acting_point=tuple(values["acting_point"]),  # type: ignore[arg-type]
        payload=Payload(
            values["payload.mass"],
            tuple(values["payload.com"]),  # type: ignore[arg-type]
            tuple(map(tuple, inertia.reshape(3, 3).tolist())) if inertia.size == 9 else inertia,
        ),
        bias=tuple(values["bias"]),
        lowpass_hz=values["lowpass_hz"],
        deadband=tuple(values["deadband"]),  # type: ignore[arg-type]
        acceleration_lowpass_hz=values["acceleration_lowpass_hz"],
        virtual_damping=values["virtual_damping"],
        tare_samples=values["tare_samples"],
    )


class DynamicCompensationNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("dynamic_compensation", **kwargs)
        values = declare(
            self, TABLE, lambda v: self.comp.set_filters(v["lowpass_hz"], v["deadband"])
        )
        robot, hole = cell_from(values)
        setup = setup_from(values, hole)
        if values["virtual_sensor"] and setup.placement != "wrist":
            raise ConfigError("virtual_sensor", True, "placement 'wrist' with it (the joint "
                              "torques give the wrench at the wrist)")  # fmt: skip
        self.robot = robot if setup.placement == "wrist" else None
        self.comp = Compensator(setup, self.robot)
        self.pub = self.create_publisher(WrenchStamped, topics.COMPENSATED_WRENCH, 10)
        self.pub_bias = self.create_publisher(WrenchStamped, topics.BIAS, topics.PHASE_QOS)
        self._publish_bias(self.get_clock().now().nanoseconds * 1e-9)
        self._untared = self.comp.setup.tare_samples > 0
        sub = self.create_subscription  # raw: CDR bytes, decoded by fbcc_ros.nodes.convert
        if self.robot is not None:
            sub(JointState, topics.JOINT_STATES, self.on_joints, 10, raw=True)
        if values["virtual_sensor"]:
            sub(JointState, "external_joint_torques", self.on_torques, 10, raw=True)
        else:
            sub(WrenchStamped, topics.RAW_WRENCH, self.on_raw, 10, raw=True)
        rejected = tuple(k for k in self.comp.counts if k not in ("accepted", "taring"))
        publish_diagnostics(self, counter_report(lambda: self.comp.counts, rejected, "samples"))

    def on_joints(self, data: bytes) -> None:
        assert self.robot is not None
        try:
            stamp, q, dq = joints_from_cdr(data, self.robot.joint_names)
        except FbccError as exc:
            self.get_logger().warn(f"joint state rejected: {exc}", throttle_duration_sec=1.0)
            return
        self.comp.joints(stamp, q, dq)

    def on_raw(self, data: bytes) -> None:
        try:
            out = self.comp.reading(*wrench_from_cdr(data))
        except FbccError as exc:
            self.get_logger().error(str(exc), throttle_duration_sec=1.0)
            return
        self._publish(out)

    def _publish_bias(self, stamp: float) -> None:
        """The bias in use, latched: the configured one at start-up, the measured one with the
        first output after the tare."""
        self.pub_bias.publish(wrench_to_cdr(self.comp.bias, self.comp.setup.frame, stamp))

    def on_torques(self, data: bytes) -> None:
        assert self.robot is not None
        try:
            stamp, tau = efforts_from_cdr(data, self.robot.joint_names)
        except FbccError as exc:
            self.get_logger().warn(f"external torques rejected: {exc}", throttle_duration_sec=1.0)
            return
        self._publish(self.comp.joint_torques(stamp, tau))

    def _publish(self, out: Any) -> None:
        if out is None:
            counts = self.comp.counts
            rejected = {k: v for k, v in counts.items() if k not in ("accepted", "taring") and v}
            if rejected:
                self.get_logger().warn(f"samples rejected: {rejected}", throttle_duration_sec=2.0)
            return
        if self._untared:
            self._untared = False
            self._publish_bias(out.stamp)
            self.get_logger().info(f"tared: bias {np.round(self.comp.bias, 4).tolist()}")
        self.pub.publish(wrench_to_cdr(out.wrench, topics.HOLE_FRAME, out.stamp))


def main() -> None:
    run(DynamicCompensationNode)


if __name__ == "__main__":
    main()
