"""dynamic_compensation node (Fig. 7): raw WrenchStamped → the compensated wrench in {H}.

Subscribes ``wrench_topic`` (``ft_sensor/raw`` by default; WrenchStamped in the sensor frame;
reliable, or best-effort with ``wrench_qos: best_effort`` for a driver publishing sensor-data
QoS) and, for a wrist sensor, ``joint_states``. With ``virtual_sensor`` it takes the arm's joint
torques instead of a sensor: the external ones from the ``effort`` of ``external_joint_torques``
(JointState), or with ``joint_torques: measured`` the measured ones from the ``effort`` of
``joint_states``, less our gravity model. Publishes
``ft_sensor/compensated``: the wrench the peg exerts on the hole, frame ``hole``, moments about
its origin (right-handed; the controller's Fz is its negated z force). The pipeline, the
sign conventions and the calibration file are in ``docs/compensation.md``; rejected samples
are counted and logged, never published; the counters go to ``/diagnostics`` each second.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from fbcc_ros.core.compensation.compensator import Compensated
from fbcc_ros.core.errors import FbccError
from fbcc_ros.pipeline.compensation import TABLE, CompensationStage, needs_robot
from fbcc_ros.pipeline.lateral_watch import deadband_warning
from fbcc_ros.pipeline.parameters import frame_id
from fbcc_ros.ros import topics
from fbcc_ros.ros.cdr import decode_pose
from fbcc_ros.ros.convert import efforts_from_cdr, joints_from_cdr, wrench_from_cdr, wrench_to_cdr
from fbcc_ros.ros.diagnostics import counter_report, publish_diagnostics
from fbcc_ros.ros.inputs import subscribe_input
from fbcc_ros.ros.outlet import Outlet
from fbcc_ros.ros.params import declare, run
from fbcc_ros.ros.robot_description import description_for
from fbcc_ros.ros.sources import SourceWatch

__all__ = ["TABLE", "DynamicCompensationNode"]

class DynamicCompensationNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("dynamic_compensation", **kwargs)
        values = declare(self, TABLE, lambda v: self.stage.apply(v))
        self.stage = CompensationStage(
            values, description_for(self, values) if needs_robot(values) else None)
        self.hole_frame = frame_id(values, "hole_frame")
        hidden = deadband_warning(tuple(values["deadband"]), None, "deadband")  # the peg's
        if hidden:  # radius is the controller's: launch and fbcc_bringup judge the moment too
            self.get_logger().warning(hidden)
        self._said: set[str] = set()  # the kinds of rejection logged
        self.out_compensated = Outlet(
            self.create_publisher(WrenchStamped, topics.COMPENSATED_WRENCH, 10))
        self.pub_bias = self.create_publisher(WrenchStamped, topics.BIAS, topics.PHASE_QOS)
        self.pub_noise = self.create_publisher(WrenchStamped, topics.NOISE, topics.PHASE_QOS)
        self.out_guard = Outlet(self.create_publisher(String, topics.GUARD, topics.PHASE_QOS),
                                latched=True)
        self.create_subscription(String, topics.REARM, self.on_rearm, 10)
        # where the peg is (the kinematics' features): a tare is refused while it is in the hole
        self.create_subscription(PoseStamped, topics.FEATURES, self.on_features, 10, raw=True)
        self._publish_bias(self.get_clock().now().nanoseconds * 1e-9)
        # the inputs (their topics and QoS transport settings: the stage has none)
        joints, joints_qos = values["joint_states_topic"], values["joint_states_qos"]
        inputs = [joints] if self.stage.robot is not None else []
        if self.stage.measured:  # the joint states carry the torques: one input
            subscribe_input(self, JointState, joints, self.on_measured, joints_qos)
        else:
            if self.stage.robot is not None:
                subscribe_input(self, JointState, joints, self.on_joints, joints_qos)
            if self.stage.virtual:
                inputs.append(topics.EXTERNAL_TORQUES)
                subscribe_input(self, JointState, topics.EXTERNAL_TORQUES, self.on_torques,
                                values["wrench_qos"])  # fmt: skip
            else:
                inputs.append(values["wrench_topic"])
                subscribe_input(self, WrenchStamped, values["wrench_topic"], self.on_raw,
                                values["wrench_qos"])  # fmt: skip
        self.sources = SourceWatch(self, inputs, (), self.on_source)
        counts = self.stage.comp.counts
        rejected = tuple(k for k in counts if k not in ("accepted", "taring"))
        publish_diagnostics(self, counter_report(self._counts, rejected, "samples"))

    def _counts(self) -> dict[str, float]:
        """The samples' counts, and the limits the running wrench guard holds."""
        guard = self.stage.setup.guard
        return {**self.stage.comp.counts, "force_limit": guard.force_limit,
                "moment_limit": guard.moment_limit}

    @property
    def _names(self) -> tuple[str, ...]:
        assert self.stage.robot is not None
        return self.stage.robot.joint_names

    def on_joints(self, data: bytes) -> None:
        try:
            stamp, q, dq = joints_from_cdr(data, self._names)
        except FbccError as exc:
            self.get_logger().warn(f"joint state rejected: {exc}", throttle_duration_sec=1.0)
            return
        self.stage.joints(stamp, q, dq)

    def now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_raw(self, data: bytes) -> None:
        try:
            out = self.stage.reading(*wrench_from_cdr(data), received=self.now())
        except FbccError as exc:
            self.get_logger().error(str(exc), throttle_duration_sec=1.0)
            return
        self._publish(out)

    def on_torques(self, data: bytes) -> None:
        try:
            stamp, tau = efforts_from_cdr(data, self._names)
        except FbccError as exc:
            self.get_logger().warn(f"external torques rejected: {exc}", throttle_duration_sec=1.0)
            return
        self._publish(self.stage.torques(stamp, tau, received=self.now()))

    def on_measured(self, data: bytes) -> None:
        try:
            stamp, q, dq = joints_from_cdr(data, self._names)
            _, effort = efforts_from_cdr(data, self._names)
        except FbccError as exc:
            self.get_logger().warn(f"joint state rejected: {exc}", throttle_duration_sec=1.0)
            return
        self._publish(self.stage.measured_torques(stamp, q, dq, effort, received=self.now()))

    def on_features(self, data: bytes) -> None:
        try:
            _, _, (_, _, z, *_) = decode_pose(data)
        except FbccError:
            return  # the controller says it; the tare keeps the last place heard
        self.stage.peg(z)

    def on_source(self, problem: str) -> None:
        """A second publisher on an input (:mod:`fbcc_ros.ros.sources`): the guard trips."""
        if self.stage.trip(problem):
            self._say_trip()

    def on_rearm(self, msg: String) -> None:
        self.sources.forget()  # a second source still there trips it anew
        cleared = self.stage.rearm()
        if cleared is not None:
            self.get_logger().info(f"wrench guard re-armed ({msg.data})")
            self.out_guard.publish(String(data=""))  # the latched trip is over

    def _say_trip(self) -> None:
        reason = f"wrench guard: {self.stage.comp.guard.reason}"
        self.get_logger().error(reason)
        self.out_guard.publish(String(data=reason))

    def _publish_bias(self, stamp: float) -> None:
        """The bias in use, latched: the configured one at start-up, the measured one with the
        first output after the tare."""
        comp = self.stage.comp
        self.pub_bias.publish(wrench_to_cdr(comp.bias, comp.setup.frame, stamp))

    def _publish(self, out: Compensated | None) -> None:
        if self.stage.just_tripped:
            self._say_trip()
        if out is None:
            counts = self.stage.comp.counts
            rejected = {k: v for k, v in counts.items() if k not in ("accepted", "taring") and v}
            # each kind of rejection logged once, when it first happens; /diagnostics keeps
            # the counts (a sensor catching up would otherwise log every period)
            if set(rejected) - self._said:
                self.get_logger().warn(f"samples rejected: {rejected} (counts on /diagnostics)")
                self._said |= set(rejected)
            return
        if self.stage.just_tared:
            self._publish_bias(out.stamp)
            noise = self.stage.comp.noise
            if noise is not None:
                self.pub_noise.publish(wrench_to_cdr(noise, self.hole_frame, out.stamp))
            measured = "" if noise is None else f", noise {np.round(noise, 4).tolist()}"
            bias = np.round(self.stage.comp.bias, 4).tolist()
            self.get_logger().info(f"tared: bias {bias}{measured}")
        self.out_compensated.publish(wrench_to_cdr(out.wrench, self.hole_frame, out.stamp))


def main() -> None:
    run(DynamicCompensationNode)


if __name__ == "__main__":
    main()
