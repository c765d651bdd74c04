"""mock_cell node: a position-controlled arm and a force/torque sensor replaying the contact model.

The arm follows ``joint_command`` (Float64MultiArray, positions in joint order) with the
scenario's lag, within its limits, and publishes ``joint_states`` at ``rate_hz``; the sensor
under the true hole publishes ``ft_sensor/raw`` (WrenchStamped) for the same instant: the
contact of the true geometry (optionally drawn from Table II's tolerances, unknown to the
controller) at the scenario's unknown hole deviation, plus the fixture's weight, the bias and
the noise. For scoring, it also publishes the true features and response of each tick on
``mock_cell/truth`` (Float64MultiArray, fields in ``topics.TRUTH_FIELDS``) while anyone
listens. The plant is :class:`fbcc_ros.core.cell.MockCell`. One node holds both roles because
the sensor reads the arm's state of the same step.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, MultiArrayLayout

from fbcc_ros.core import scenario as scenario_io
from fbcc_ros.core.cell import MockCell
from fbcc_ros.core.errors import FbccError
from fbcc_ros.core.mapping_study import perturbed
from fbcc_ros.core.payload import Payload
from fbcc_ros.nodes import topics
from fbcc_ros.nodes.convert import joints_to_msg, positions_from_msg, wrench_to_msg
from fbcc_ros.nodes.diagnostics import counter_report, publish_diagnostics
from fbcc_ros.nodes.params import CELL, Param, cell_from, declare, find_scenario, run

TABLE = (
    Param("scenario", "config/scenarios/bringup_interference.yaml", "scenario YAML: the true "
          "deviation of the hole (initial), the sensor noise and bias, the robot lag"),
    Param("rate_hz", 1000.0, "joint state and sensor rate", "Hz", 1.0, 10000.0),
    Param("draw_geometry", False, "draw the true radii from Table II's tolerances"),
    Param("seed", 0, "seed of the noise and of the drawn geometry", "", 0, 2**31 - 1),
    Param("sensor_frame", "ft_sensor", "frame_id of the raw readings"),
    Param("fixture_mass", 1.5, "mass of the hole fixture on the sensor", "kg", 0.0, 100.0),
    *CELL,
)  # fmt: skip


class MockCellNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("mock_cell", **kwargs)
        values = declare(self, TABLE)
        sc = scenario_io.load(find_scenario(values["scenario"]))
        robot, hole = cell_from(values)
        geometry = None
        if values["draw_geometry"]:
            geometry = perturbed(sc.geometry, np.random.default_rng(values["seed"]),
                                 friction_spread=0.0, stiffness_octaves=0.0)  # fmt: skip
        fixture = Payload(values["fixture_mass"], (0.0, 0.0, 0.02))
        self.cell = MockCell(sc, robot, hole, geometry, fixture, values["seed"])
        self.dt = 1.0 / values["rate_hz"]
        self.frame = values["sensor_frame"]
        self.names = robot.joint_names
        self.rejected = 0
        self.pub_joints = self.create_publisher(JointState, topics.JOINT_STATES, 10)
        self.pub_raw = self.create_publisher(WrenchStamped, topics.RAW_WRENCH, 10)
        self.pub_truth = self.create_publisher(Float64MultiArray, topics.TRUTH, 100)
        self._truth = truth_message()
        self.create_subscription(Float64MultiArray, topics.JOINT_COMMAND, self.on_command, 10)
        self.create_timer(self.dt, self.on_tick)
        refused = ("commands_refused",)
        publish_diagnostics(
            self, counter_report(lambda: {"commands_refused": self.rejected}, refused, "commands")
        )

    def on_command(self, msg: Float64MultiArray) -> None:
        try:
            self.cell.command(positions_from_msg(msg))
        except FbccError as exc:
            self.rejected += 1
            self.get_logger().error(f"joint command refused: {exc}", throttle_duration_sec=1.0)

    def on_tick(self) -> None:
        sample = self.cell.step(self.dt)
        now = self.get_clock().now().nanoseconds * 1e-9
        self.pub_joints.publish(joints_to_msg(self.names, sample.q, sample.dq, now))
        self.pub_raw.publish(wrench_to_msg(sample.raw, self.frame, now))
        if self.pub_truth.get_subscription_count():
            self._truth.data = [now, *sample.features.tolist(), *sample.response.tolist()]
            self.pub_truth.publish(self._truth)


def truth_message() -> Float64MultiArray:
    """An empty truth sample, its layout labelled with the fields (topics.TRUTH_FIELDS)."""
    n = len(topics.TRUTH_FIELDS)
    label = " ".join(topics.TRUTH_FIELDS)
    return Float64MultiArray(layout=MultiArrayLayout(dim=[MultiArrayDimension(label=label,
                             size=n, stride=n)]))  # fmt: skip


def main() -> None:
    run(MockCellNode)


if __name__ == "__main__":
    main()
