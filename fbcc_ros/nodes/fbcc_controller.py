"""fbcc_controller node: compensated wrench + features → command features (Algorithm 1).

Subscribes ``ft_sensor/compensated`` (WrenchStamped in {H}; each one is a control period) and
``fbcc/features`` (PoseStamped: the peg in {H}); publishes ``fbcc/command`` (PoseStamped: the
command features as the peg's pose in {H}), ``fbcc/phase`` and ``fbcc/contact_state``
(String, on change; the phase latched) and, with the robust law, ``fbcc/contact_estimate``
(Float64MultiArray at ``estimate_rate_hz`` while inserting: the stamp of the sample it follows,
then ``identification.ESTIMATE_FIELDS``). Services ``fbcc/start`` and ``fbcc/abort``
(std_srvs/Trigger).

The law (``fbcc``, or the ``admittance`` baseline, or ``none``), its gains and the insertion come
from a scenario file (DESIGN §4: ``geometry`` is the nominal pair, ``controller.params`` the
gains, ``insertion`` the depth and speed). Safety (:mod:`fbcc_ros.core.supervisor`): a fault —
force limit, stale input, non-finite input, IK failure — holds the last command and says why.
"""

from __future__ import annotations

from typing import Any

import pinocchio as pin
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray, String
from std_srvs.srv import Trigger

from fbcc_ros.core import scenario as scenario_io
from fbcc_ros.core.control import make_law
from fbcc_ros.core.errors import FbccError
from fbcc_ros.core.features import features_from_pose, pose_from_features
from fbcc_ros.core.identification import ESTIMATE_FIELDS
from fbcc_ros.core.robust import RobustFbcc
from fbcc_ros.core.segmentation import response_state
from fbcc_ros.core.supervisor import SafetyLimits, Supervisor
from fbcc_ros.core.wrench import response_from_wrench
from fbcc_ros.nodes import topics
from fbcc_ros.nodes.cdr import encode_array
from fbcc_ros.nodes.convert import pose_from_cdr, pose_to_cdr, wrench_from_cdr
from fbcc_ros.nodes.diagnostics import ERROR, OK, WARN, publish_diagnostics
from fbcc_ros.nodes.params import Param, declare, find_scenario, run

TABLE = (
    Param("scenario", "config/scenarios/bringup_interference.yaml", "scenario YAML with the "
          "nominal geometry, the gains (controller.params) and the insertion; relative paths "
          "are tried from the working directory, then from the package's share directory"),
    Param("law", "fbcc", "control law", choices=("fbcc", "admittance", "none")),
    Param("rate_hz", 1000.0, "control rate (one period per compensated wrench)", "Hz", 1.0,
          10000.0),
    Param("timeout", 0.05, "stale input fault after this gap", "s", 1e-3, 10.0,
          read_only=False),
    Param("max_step", 5e-5, "largest change of dx, dy, l per command", "m", 1e-9, 0.01,
          read_only=False),
    Param("max_step_angle", 1e-3, "largest change of a tilt per command", "rad", 1e-9, 0.1,
          read_only=False),
    Param("auto_start", False, "start an insertion once features and wrenches arrive"),
    Param("estimate_rate_hz", 100.0, "rate of fbcc/contact_estimate (robust law; at most the "
          "control rate)", "Hz", 1.0, 10000.0),
)  # fmt: skip

#: The layout of fbcc/contact_estimate: one dimension labelled with the fields.
ESTIMATE_LAYOUT = [(" ".join(("stamp", *ESTIMATE_FIELDS)), len(ESTIMATE_FIELDS) + 1,
                    len(ESTIMATE_FIELDS) + 1)]  # fmt: skip


def safety_limits(values: dict[str, Any]) -> SafetyLimits:
    """The supervisor's limits from the parameters (also for the offline replay)."""
    return SafetyLimits(values["timeout"], values["max_step"], values["max_step_angle"])


class FbccControllerNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("fbcc_controller", **kwargs)
        values = declare(self, TABLE, self._apply)
        sc = scenario_io.load(find_scenario(values["scenario"]))
        self.nominal = sc.geometry
        law = make_law(values["law"], sc.geometry, sc.params, sc.insertion)
        self.sup = Supervisor(law, 1.0 / values["rate_hz"], safety_limits(values))
        self.auto_start = values["auto_start"]
        self.pub_command = self.create_publisher(PoseStamped, topics.COMMAND, 10)
        self.pub_phase = self.create_publisher(String, topics.PHASE, topics.PHASE_QOS)
        self.pub_state = self.create_publisher(String, topics.CONTACT_STATE, 10)
        self.robust = isinstance(law, RobustFbcc)
        self.pub_estimate = self.create_publisher(Float64MultiArray, topics.CONTACT_ESTIMATE, 100)
        # one estimate every this many periods
        self.estimate_every = max(1, round(values["rate_hz"] / values["estimate_rate_hz"]))
        self._periods = 0
        # raw: CDR bytes, decoded by fbcc_ros.nodes.convert (no rclpy message objects at 1 kHz)
        sub = self.create_subscription
        sub(WrenchStamped, topics.COMPENSATED_WRENCH, self.on_wrench, 10, raw=True)
        sub(PoseStamped, topics.FEATURES, self.on_features, 10, raw=True)
        self.create_subscription(String, topics.KINEMATICS_STATUS, self.on_kinematics, 10)
        self.create_service(Trigger, topics.START, self.on_start)
        self.create_service(Trigger, topics.ABORT, self.on_abort)
        self.create_timer(0.01, self.on_watchdog)
        self._phase_said = ""
        self._state_said = ""
        self._publish_phase()
        publish_diagnostics(self, self._report)

    def _report(self) -> tuple[bytes, str, dict[str, Any]]:
        level = {"fault": ERROR, "force_limit": WARN, "aborted": WARN}.get(self.sup.phase, OK)
        said = f"{self.sup.phase}: {self.sup.reason}" if self.sup.reason else self.sup.phase
        values = {"phase": self.sup.phase, "reason": self.sup.reason,
                  "contact_state": self._state_said}  # fmt: skip
        return level, said, values

    def _apply(self, values: dict[str, Any]) -> None:
        limits = safety_limits(values)  # raises ConfigError, and the change is refused
        self.sup.limits = limits

    def now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_features(self, data: bytes) -> None:
        try:
            _, peg = pose_from_cdr(data)
            x = features_from_pose(peg.rotation, peg.translation, self.nominal.peg_radius)
        except FbccError as exc:
            x = [float("nan")] * 5
            self.get_logger().error(f"features rejected: {exc}", throttle_duration_sec=1.0)
        self.sup.on_features(self.now(), x)

    def on_wrench(self, data: bytes) -> None:
        now = self.now()
        if self.auto_start and self.sup.phase == "idle" and self.sup.features is not None:
            self.start_insertion(now)
        try:
            stamp, _, wrench = wrench_from_cdr(data)
        except FbccError as exc:
            self.get_logger().error(f"wrench rejected: {exc}", throttle_duration_sec=1.0)
            return
        response = response_from_wrench(wrench)
        command = self.sup.on_response(now, response, stamp)
        self._periods += 1
        law = self.sup.law
        if (self.robust and self.sup.active and self._periods % self.estimate_every == 0
                and isinstance(law, RobustFbcc)):  # fmt: skip
            row = [stamp, *law.estimate(0).as_row(law.guard_trips(0))]
            self.pub_estimate.publish(encode_array(row, ESTIMATE_LAYOUT))
        if command is not None:
            rotation, position = pose_from_features(command, self.nominal.peg_radius)
            pose = pin.SE3(rotation, position)
            # stamped with the sample it answers, so latency is traceable down the chain
            self.pub_command.publish(pose_to_cdr(pose, topics.HOLE_FRAME, stamp))
        # the segmentation costs ~50 µs a period: only for someone listening
        heard = self.pub_state.get_subscription_count()
        if heard and self.sup.features is not None and self.sup.active:
            xoz, yoz = response_state(response, self.sup.features[2], self.nominal)
            state = f"{xoz}/{yoz}"
            if state != self._state_said:
                self._state_said = state
                self.pub_state.publish(String(data=state))
        self._publish_phase()

    def on_kinematics(self, msg: String) -> None:
        self.sup.fault(msg.data)
        self._publish_phase()

    def on_watchdog(self) -> None:
        self.sup.watchdog(self.now())
        self._publish_phase()

    def start_insertion(self, now: float) -> tuple[bool, str]:
        ok, message = self.sup.start(now)
        self.get_logger().info(f"start: {message}")
        self._publish_phase()
        return ok, message

    def on_start(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success, response.message = self.start_insertion(self.now())
        return response

    def on_abort(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success, response.message = self.sup.abort()
        self._publish_phase()
        return response

    def _publish_phase(self) -> None:
        said = f"{self.sup.phase}: {self.sup.reason}" if self.sup.reason else self.sup.phase
        if said != self._phase_said:
            self._phase_said = said
            self.pub_phase.publish(String(data=said))
            # one call site per severity: rclpy refuses a site that changes severity
            if self.sup.phase == "fault":
                self.get_logger().error(f"phase {said}")
            else:
                self.get_logger().info(f"phase {said}")


def main() -> None:
    run(FbccControllerNode)


if __name__ == "__main__":
    main()
