"""mock_cell node: a position-controlled arm and a force/torque sensor replaying the contact model.

The arm follows ``joint_command`` (Float64MultiArray, positions in joint order) with the
scenario's lag, within its limits, and publishes ``joint_states`` at ``rate_hz``; the sensor
under the true hole publishes ``ft_sensor/raw`` (WrenchStamped) for the same instant: the
contact of the true geometry (optionally drawn from Table II's tolerances, unknown to the
controller) at the scenario's unknown hole deviation, plus the fixture's weight, the bias and
the noise. With ``wrist_sensor``, a 6-axis sensor at the flange carrying the tool publishes
``wrist_sensor/raw`` too (``core.sim.wrist_sensor``). The ``sensor_fault`` parameter, set while
it runs, passes the readings through a sensor fault to rehearse (``core.sim.sensor_faults``).
For scoring, it also publishes the true features and response of each tick on
``mock_cell/truth`` (Float64MultiArray, fields in ``topics.TRUTH_FIELDS``) while anyone
listens. The plant is
:class:`fbcc_ros.core.sim.mock_cell.MockCell`. One node holds both roles because the sensor
reads the arm's state of the same step.

With ``publish_clock`` the mock is the cell's clock, as a simulator is a ROS graph's: it steps
the plant one period a tick, as fast as it can up to real time, and publishes the plant's time
on ``/clock`` (from one period on); every other node of the cell runs with ``use_sim_time``.
While the cell commands the arm, a tick waits for the answer to the last one (a joint
command), as a simulator's controllers run in its step, at most :data:`ANSWER_WAIT` of the
wall's clock (then it steps, and counts it). A plant slower than real time (MuJoCo in contact)
then closes the loop at every period, where on the wall's clock it would skip periods.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.publisher import Publisher
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String

from fbcc_ros.core.errors import ConfigError, FbccError
from fbcc_ros.core.sim.wrist_sensor import WRIST_FRAME
from fbcc_ros.pipeline.kinematics import needs_description
from fbcc_ros.pipeline.mock_cell import TABLE, MockStage
from fbcc_ros.ros import topics
from fbcc_ros.ros.cdr import encode_array
from fbcc_ros.ros.convert import (
    joints_to_cdr,
    positions_from_cdr,
    seconds_to_stamp,
    wrench_to_cdr,
)
from fbcc_ros.ros.diagnostics import counter_report, publish_diagnostics
from fbcc_ros.ros.params import declare, run
from fbcc_ros.ros.robot_description import DESCRIPTION_QOS, description_for


class MockCellNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("mock_cell", **kwargs)
        values = declare(self, TABLE, lambda v: self.stage.apply(v))
        self.stage = MockStage(values, description_for(self, values))
        self.cell, self.dt, self.frame = self.stage.cell, self.stage.dt, self.stage.frame
        self.names = self.cell.robot.joint_names
        self.counts = {"ticks": 0, "ticks_caught_up": 0, "ticks_skipped": 0,
                       "ticks_unanswered": 0, "commands_refused": 0}  # fmt: skip
        self._start: float | None = None
        # the plant's clock: the cell answered the last tick; it is awaited until (monotonic)
        self._answered, self._await_until = False, 0.0
        self.pub_joints = self.create_publisher(JointState, topics.JOINT_STATES, 10)
        self.pub_raw = self.create_publisher(WrenchStamped, topics.RAW_WRENCH,
                                             topics.input_qos(values["sensor_qos"]))
        self.lbr = values["conventions"] == "lbr"
        self.arm_sensing = values["arm_sensing"]
        self.pub_external = (self.create_publisher(JointState, topics.EXTERNAL_TORQUES, 10)
                             if self.arm_sensing else None)  # fmt: skip
        # the stack's estimated wrench, at its flange (lbr_link_ee)
        self.pub_estimated = (self.create_publisher(WrenchStamped, topics.LBR_WRENCH, 10)
                              if self.lbr and self.arm_sensing else None)  # fmt: skip
        self.pub_wrist = (self.create_publisher(WrenchStamped, topics.WRIST_WRENCH,
                                                topics.input_qos(values["sensor_qos"]))
                          if self.stage.wrist is not None else None)  # fmt: skip
        self.pub_truth = self.create_publisher(Float64MultiArray, topics.TRUTH, 100)
        # raw: CDR bytes, decoded by fbcc_ros.ros.convert (no rclpy message objects at 1 kHz)
        sub = self.create_subscription
        sub(Float64MultiArray, topics.joint_command(values["conventions"]), self.on_command, 10,
            raw=True)  # fmt: skip
        # the stack's robot_state_publisher, played (not with a model from the topic)
        if values["publish_description"] and not needs_description(values):
            self.pub_description = self.create_publisher(
                String, topics.ROBOT_DESCRIPTION, DESCRIPTION_QOS)
            self.pub_description.publish(String(data=self.cell.robot.urdf_text))
        self.pub_clock = None
        if values["publish_clock"]:
            if self.get_parameter("use_sim_time").value:
                raise ConfigError("use_sim_time", True, "false on the mock when it publishes "
                                  "the clock (publish_clock): it is the clock")  # fmt: skip
            self.pub_clock = self.create_publisher(Clock, topics.CLOCK, 10)
        self.create_timer(self.dt, self.on_tick)
        bad = ("ticks_skipped", "ticks_unanswered", "commands_refused")
        publish_diagnostics(self, counter_report(self._counts, bad, "mock cell"))

    def _counts(self) -> dict[str, float]:
        """The counters, and the plant's truth a drill judges safety by: the largest true |f|
        [N] and |m| about the {H} origin [N·m], and the largest joint-command step as a
        fraction of one period's travel at the velocity limits."""
        force, moment = self.cell.peak
        return {**self.counts, "true_peak_force": round(float(force), 3),
                "true_peak_moment": round(float(moment), 4),
                "largest_command_step": round(self.cell.largest_step / self.dt, 4)}

    def preload(self) -> None:
        """Load the compiled code of the cell now (called before the loop, by ``run``)."""
        self.cell.preload()

    def on_command(self, data: bytes) -> None:
        self._answered = True
        try:
            self.cell.command(positions_from_cdr(data))
        except FbccError as exc:
            self.counts["commands_refused"] += 1
            self.get_logger().error(f"joint command refused: {exc}", throttle_duration_sec=1.0)
        if self.pub_clock is not None and self._start is not None and (
                self.counts["ticks"] + 1) * self.dt <= time.monotonic() - self._start:
            self._clock_tick(self.pub_clock)  # answered, the plant behind real time: step now

    def on_tick(self) -> None:
        """Steps the plant once per period elapsed since the first tick, as hardware would
        tick: a timer callback that comes late (a busy executor) is caught up, not lost. More
        than ``MAX_CATCH_UP`` periods behind, the older ones are skipped (the plant pauses for
        them) and counted."""
        if self.pub_clock is not None:
            self._clock_tick(self.pub_clock)
            return
        clock = time.monotonic()
        if self._start is None:
            self._start = clock - self.dt
        due = int((clock - self._start) / self.dt) - self.counts["ticks"]
        if due > MAX_CATCH_UP:
            self.counts["ticks_skipped"] += due - MAX_CATCH_UP
            self.counts["ticks"] += due - MAX_CATCH_UP
            due = MAX_CATCH_UP
        self.counts["ticks_caught_up"] += max(due - 1, 0)
        now = self.get_clock().now().nanoseconds * 1e-9
        for late in range(due - 1, -1, -1):  # each sample stamped with its own period
            self._tick(now - late * self.dt)
            self.counts["ticks"] += 1

    def _clock_tick(self, clock: Publisher) -> None:
        """One period of the plant's time, none skipped (module doc): while the cell commands
        the arm (it answered the tick before), once it answered the last one or waited
        ``ANSWER_WAIT``."""
        wall = time.monotonic()
        if self._start is None:
            self._start = wall - self.dt
        if self._await_until and not self._answered:
            if wall < self._await_until:
                return
            self.counts["ticks_unanswered"] += 1
        self._await_until = wall + ANSWER_WAIT if self._answered else 0.0
        self._answered = False
        now = (self.counts["ticks"] + 1) * self.dt
        sec, nanosec = seconds_to_stamp(now)
        clock.publish(Clock(clock=Time(sec=sec, nanosec=nanosec)))
        self._tick(now)
        self.counts["ticks"] += 1

    def _tick(self, now: float) -> None:
        sample = self.cell.step(self.dt)
        if not self.arm_sensing:
            self.pub_joints.publish(joints_to_cdr(self.names, sample.q, sample.dq, now))
        else:
            arm = self.stage.arm_sensing(sample, estimate=self.pub_estimated is not None)
            self.pub_joints.publish(joints_to_cdr(self.names, sample.q, sample.dq, now,
                                                  arm.measured))  # fmt: skip
            if self.pub_external is not None and self.pub_external.get_subscription_count():
                zero = np.zeros(0)
                self.pub_external.publish(joints_to_cdr(self.names, zero, zero, now,
                                                        arm.external))  # fmt: skip
            if self.pub_estimated is not None and arm.estimated is not None:
                self.pub_estimated.publish(wrench_to_cdr(
                    arm.estimated, self.cell.robot.flange_frame, now))  # fmt: skip
        for stamp, raw in self.stage.readings(now, sample.raw):
            self.pub_raw.publish(wrench_to_cdr(raw, self.frame, stamp))
        wrist = self.stage.wrist_reading(sample)
        if self.pub_wrist is not None and wrist is not None:
            self.pub_wrist.publish(wrench_to_cdr(wrist, WRIST_FRAME, now))
        if self.pub_truth.get_subscription_count():
            row = [now, *sample.features.tolist(), *sample.response.tolist()]
            self.pub_truth.publish(encode_array(row, TRUTH_LAYOUT))


#: How long a tick on the plant's clock waits for the cell's answer to the last one (the
#: wall's [s]): the in-process cell's stall bound (bringup's IN_PROCESS_STALL).
ANSWER_WAIT = 0.05
#: Periods a late tick catches up; beyond, the plant skips (20 ms: a VM stall, a GC pause).
MAX_CATCH_UP = 20
#: The truth's layout: one dimension labelled with the fields (topics.TRUTH_FIELDS).
TRUTH_LAYOUT = [
    (" ".join(topics.TRUTH_FIELDS), len(topics.TRUTH_FIELDS), len(topics.TRUTH_FIELDS))
]


def main() -> None:
    run(MockCellNode)


if __name__ == "__main__":
    main()
