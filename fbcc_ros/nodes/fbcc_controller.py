"""fbcc_controller node: compensated wrench + features → command features (Algorithm 1).

Subscribes ``ft_sensor/compensated`` (WrenchStamped in {H}; each one is a control period) and
``fbcc/features`` (PoseStamped: the peg in {H}); publishes ``fbcc/command`` (PoseStamped: the
command features as the peg's pose in {H}), ``fbcc/phase`` and ``fbcc/contact_state``
(String, on change; the phase latched) and, with the robust law, ``fbcc/contact_estimate``
(Float64MultiArray at ``estimate_rate_hz`` while inserting: the stamp of the sample it follows,
then ``identification.ESTIMATE_FIELDS``) and ``fbcc/contact_state_estimate`` (Float64MultiArray
at ``state_rate_hz`` while inserting, once someone listens: the stamp of the sample it follows,
then P(state) of XOZ and of YOZ over ``segmentation.STATES``, by the deviation filter in a
process of its own, :mod:`fbcc_ros.pipeline.state_worker`). Services ``fbcc/start``,
``fbcc/abort`` and ``fbcc/reset`` (std_srvs/Trigger).

The law and its supervisor are :class:`~fbcc_ros.pipeline.controller.ControllerStage`'s (the
scenario file gives the law's nominal pair, gains and insertion). Safety
(:mod:`fbcc_ros.core.control.supervisor`): a fault — force limit, stale input, non-finite input, IK
failure, a tripped wrench guard — holds where the arm is and says why.
"""

from __future__ import annotations

import time
from typing import Any

from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.duration import Duration as Timeout
from rclpy.node import Node
from rclpy.qos import QoSProfile
from std_msgs.msg import Float64MultiArray, String
from std_srvs.srv import Trigger

from fbcc_ros.core.contact.segmentation import STATES
from fbcc_ros.core.control.identification import ESTIMATE_FIELDS
from fbcc_ros.core.control.phase import NEEDS_RESET, Phase
from fbcc_ros.core.errors import FbccError
from fbcc_ros.pipeline.controller import TABLE, ControllerStage
from fbcc_ros.pipeline.parameters import frame_id
from fbcc_ros.ros import topics
from fbcc_ros.ros.cdr import encode_array
from fbcc_ros.ros.convert import pose_from_cdr, pose_to_cdr, wrench_from_cdr
from fbcc_ros.ros.diagnostics import ERROR, OK, WARN, publish_diagnostics
from fbcc_ros.ros.outlet import Outlet
from fbcc_ros.ros.params import declare, run
from fbcc_ros.ros.process import ACKED_WITHIN
from fbcc_ros.ros.sources import SourceWatch

__all__ = ["TABLE", "FbccControllerNode"]

#: The layout of fbcc/contact_estimate: one dimension labelled with the fields.
ESTIMATE_LAYOUT = [(" ".join(("stamp", *ESTIMATE_FIELDS)), len(ESTIMATE_FIELDS) + 1,
                    len(ESTIMATE_FIELDS) + 1)]  # fmt: skip
#: The layout of fbcc/contact_state_estimate: the stamp, then P(state) per plane.
STATE_FIELDS = ("stamp", *(f"{plane}:{s}" for plane in ("xoz", "yoz") for s in STATES))
STATE_LAYOUT = [(" ".join(STATE_FIELDS), len(STATE_FIELDS), len(STATE_FIELDS))]
#: The services' request queue: deep enough for a burst of callers.
SERVICE_QOS = QoSProfile(depth=100)
#: Contact-state answers published per watchdog tick (100 Hz): twice the 200 Hz they come at.
STATES_PER_TICK = 4
#: How long a stopping controller waits for its last contact states to be acknowledged [s]
#: (hundreds at once on a busy machine: ACKED_WITHIN's single hold is not enough).
STATES_ACKED_WITHIN = 2.0


class FbccControllerNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("fbcc_controller", **kwargs)
        values = declare(self, TABLE, lambda v: self.stage.apply(v))
        self.stage = ControllerStage(values)
        self.hole_frame = frame_id(values, "hole_frame")
        self.sup = self.stage.sup
        self.out_command = Outlet(self.create_publisher(PoseStamped, topics.COMMAND, 10))
        self.pub_phase = self.create_publisher(String, topics.PHASE, topics.PHASE_QOS)
        self.pub_state = self.create_publisher(String, topics.CONTACT_STATE, 10)
        self.pub_estimate = self.create_publisher(Float64MultiArray, topics.CONTACT_ESTIMATE, 100)
        # the filter answers in bursts while it catches up: a deep queue
        self.pub_states = self.create_publisher(Float64MultiArray,
                                                topics.CONTACT_STATE_ESTIMATE, 1000)  # fmt: skip
        # raw: CDR bytes, decoded by fbcc_ros.ros.convert (no rclpy message objects at 1 kHz)
        sub = self.create_subscription
        sub(WrenchStamped, topics.COMPENSATED_WRENCH, self.on_wrench, 10, raw=True)
        sub(PoseStamped, topics.FEATURES, self.on_features, 10, raw=True)
        self.create_subscription(String, topics.KINEMATICS_STATUS, self.on_fault, 10)
        self.create_subscription(String, topics.GUARD, self.on_fault, topics.PHASE_QOS)
        sub(WrenchStamped, topics.NOISE, self.on_noise, topics.PHASE_QOS, raw=True)
        # a burst of calls is answered, each (the default depth of 10 left 10 of 20 concurrent
        # starts unanswered): refused with a reason or accepted, never lost
        for name, callback in ((topics.START, self.on_start), (topics.ABORT, self.on_abort),
                               (topics.RESET, self.on_reset)):  # fmt: skip
            self.create_service(Trigger, name, callback, qos_profile=SERVICE_QOS)
        self.pub_rearm = self.create_publisher(String, topics.REARM, 10)
        self.create_timer(0.01, self.on_watchdog)
        self.sources = SourceWatch(self, (topics.COMPENSATED_WRENCH, topics.FEATURES),
                                   (topics.COMMAND,), self.on_source)
        self._phase_said = ""
        self._state_said = ""
        self._state_filter_gone = False
        self._blind_said = self._blind_tick = 0
        self._warned: set[str] = set()
        self._publish_phase()
        publish_diagnostics(self, self._report)

    def preload(self) -> None:
        """Load the compiled code of the stage now (called before the loop, by ``run``)."""
        self.stage.preload()

    def _report(self) -> tuple[bytes, str, dict[str, Any]]:
        levels = {Phase.FAULT: ERROR, Phase.FORCE_LIMIT: WARN, Phase.ABORTED: WARN}
        level = levels.get(self.sup.phase, OK)
        rate = self.stage.input_rate
        not_armed = self.not_armed(self.now())
        values = {"phase": self.sup.phase, "reason": self.sup.reason,
                  "armed": not not_armed, "not_armed": not_armed,
                  "contact_state": self._state_said, "input_rate_hz": rate.measured_hz,
                  "late_samples": self.sup.late, "stalls": self.sup.stalls,
                  "blind_samples": self.sup.blind,
                  "tracking_error": self._tracking_error()}  # fmt: skip
        worker = self.stage.state_worker
        if worker is not None:
            values["state_estimates_behind"] = worker.behind
            values["state_samples_dropped"] = worker.dropped
        said, warnings = self.stage.said, self.stage.warnings()
        values["warnings"] = "; ".join(warnings)
        for warning in set(warnings) - self._warned:  # each said once, when it starts
            self.get_logger().warn(warning)
        self._warned = set(warnings)
        if warnings and level == OK:
            level, said = WARN, "; ".join([said, *warnings])
        return level, said, values

    def _tracking_error(self) -> float | None:
        """How far the measured pose is from the command: the largest of the offsets' and the
        depth's differences [m] (holding: from the hold); None before both are known."""
        if self.sup.features is None or self.sup.command is None:
            return None
        return round(float(abs(self.sup.features - self.sup.command)[:3].max()), 9)

    def now(self) -> float:
        """The supervisor's clock: steady, so that no parameter (``use_sim_time``) and no
        ``/clock`` publisher can stop the watchdogs [s]."""
        return time.monotonic()

    def stamp_now(self) -> float:
        """The node's ROS time, for the stamps of what it publishes [s]."""
        return self.get_clock().now().nanoseconds * 1e-9

    def on_noise(self, data: bytes) -> None:
        said = self.stage.noise(wrench_from_cdr(data)[2])
        if said:
            self.get_logger().info(said)

    def on_features(self, data: bytes) -> None:
        now = self.now()
        try:
            stamp, pose = pose_from_cdr(data)  # stamped with the joint state it is read from
            command = self.stage.features(now, pose, stamp)
        except FbccError as exc:
            command = self.stage.features(now, None)
            self.get_logger().error(f"features rejected: {exc}", throttle_duration_sec=1.0)
        if command is not None:  # retracting after a fault
            self.out_command.publish(pose_to_cdr(command, self.hole_frame, self.stamp_now()))
        self._publish_phase(hold=True)

    def on_wrench(self, data: bytes) -> None:
        now = self.now()
        if self.stage.ready_to_start:
            self.start_insertion(now)
        try:
            stamp, _, wrench = wrench_from_cdr(data)
        except FbccError as exc:
            self.get_logger().error(f"wrench rejected: {exc}", throttle_duration_sec=1.0)
            return
        command = self.stage.wrench(now, stamp, wrench)
        row = self.stage.estimate(stamp)
        if row is not None:
            self.pub_estimate.publish(encode_array(row, ESTIMATE_LAYOUT))
        if command is not None:
            # stamped with the sample it answers, so latency is traceable down the chain (a hold
            # or a retract answers none: stamped when sent, matching no sample in a replay)
            self.out_command.publish(pose_to_cdr(command, self.hole_frame, stamp))
        # the segmentation costs ~50 µs a period: only for someone listening
        if self.pub_state.get_subscription_count():
            state = self.stage.contact_state()
            if state is not None and state != self._state_said:
                self._state_said = state
                self.pub_state.publish(String(data=state))
        self._publish_phase()

    def on_fault(self, msg: String) -> None:
        """A fault another node reports (an unreachable command, a tripped wrench guard; an
        empty report is a guard re-armed)."""
        if msg.data:
            self.sup.fault(msg.data, self.now())
        self._publish_phase(hold=True)

    def on_source(self, problem: str) -> None:
        """A second publisher on an input, or another commander (:mod:`fbcc_ros.ros.sources`):
        a fault while anything runs, and a start is refused while it lasts."""
        self.get_logger().error(problem)
        self.sup.fault(problem, self.now())
        self._publish_phase(hold=True)

    def on_watchdog(self) -> None:
        stalls, blind = self.sup.stalls, self.sup.blind
        last_tick, self._blind_tick = self._blind_tick, blind
        self.sup.watchdog(self.now())
        if self.sup.stalls > stalls:  # one line per stall: each is an episode of its own
            self.get_logger().warn(f"the controller itself did not run for over "
                                   f"{self.sup.limits.timeout} s (stall {self.sup.stalls}; "
                                   "counted on /diagnostics)")  # fmt: skip
        if blind > self._blind_said and blind == last_tick:  # a pause ended a tick ago
            self.get_logger().warn(f"the law paused on {blind - self._blind_said} wrenches "
                                   "without fresh features (blind_samples on /diagnostics)")
            self._blind_said = blind
        self._publish_phase(hold=True)
        self._publish_states()

    def _publish_states(self) -> None:
        """The contact-state filter's answers; its process starts once someone listens."""
        if self.stage.state_worker is None:
            if not self.pub_states.get_subscription_count():
                return
            if self.stage.start_state_worker():
                self.get_logger().info("contact-state filter started (fbcc/contact_state_estimate"
                                       " is heard)")  # fmt: skip
        # a few a tick: a burst of answers (the filter catching up) is not published in one
        # callback of the loop's executor
        for row in self.stage.state_estimates(STATES_PER_TICK):
            self.pub_states.publish(encode_array(row, STATE_LAYOUT))
        worker = self.stage.state_worker
        if worker is not None and not worker.alive and not self._state_filter_gone:
            self._state_filter_gone = True  # said once; the loop goes on without it
            self.get_logger().error(f"contact-state filter ended (exit status "
                                    f"{worker.exit_code}): fbcc/contact_state_estimate stops")

    def on_shutdown(self) -> None:
        """Stopped while inserting (SIGINT, SIGTERM: ``run``), it aborts and sends a hold at
        the last measured pose: the insertion does not go on without it."""
        if not self.sup.active or self.sup.features is None:
            return
        self.sup.abort("the controller node stopped")
        self.out_command.publish(pose_to_cdr(self.stage.pose(self.sup.features),
                                             self.hole_frame, self.stamp_now()))  # fmt: skip
        self._publish_phase()
        self.get_logger().info("stopping while inserting: aborted, held at the measured pose")
        for pub in (self.out_command.publisher, self.pub_phase):
            pub.wait_for_all_acked(Timeout(seconds=ACKED_WITHIN))

    def destroy_node(self) -> None:
        """Stopping: the contact-state filter's answers still owed are sent first (on a busy
        machine it lags the loop; the recording then holds the whole insertion's)."""
        rows, owed = self.stage.drain_state_estimates()
        if owed:
            for row in rows:
                self.pub_states.publish(encode_array(row, STATE_LAYOUT))
            self.pub_states.wait_for_all_acked(Timeout(seconds=STATES_ACKED_WITHIN))
            self.get_logger().info(f"stopping: the contact-state filter's last {len(rows)} of "
                                   f"{owed} estimates owed sent")  # fmt: skip
        self.stage.close()
        super().destroy_node()

    def not_armed(self, now: float) -> str:
        """Why a start would be refused (``""``: armed): a second source on an input while it
        lasts, else the supervisor's reason."""
        return self.sources.said or self.sup.not_armed(now)

    def start_insertion(self, now: float) -> tuple[bool, str]:
        said = self.sources.said
        ok, message = (False, said) if said else self.sup.start(now)
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

    def on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success, response.message = self.sup.reset()
        self.get_logger().info(f"reset: {response.message}")
        if response.success:  # the compensation's guard re-arms on it
            self.pub_rearm.publish(String(data=response.message))
            self.sources.forget()  # a second source still there faults anew
        self._publish_phase()
        return response

    def _publish_phase(self, hold: bool = False) -> None:
        """The phase, on change; with ``hold``, a fault's hold command too (off the wrench's
        path a fault comes with no wrench to answer, and the arm would go on to the last
        command, a step and its lag beyond where it was measured)."""
        said = self.stage.said
        if said != self._phase_said:
            self._phase_said = said
            if hold and self.sup.phase in NEEDS_RESET and self.sup.command is not None:
                pose = self.stage.pose(self.sup.command)
                self.out_command.publish(pose_to_cdr(pose, self.hole_frame, self.stamp_now()))
            self.pub_phase.publish(String(data=said))
            # one call site per severity: rclpy refuses a site that changes severity
            if self.sup.phase == Phase.FAULT:
                self.get_logger().error(f"phase {said}")
            else:
                self.get_logger().info(f"phase {said}")


def main() -> None:
    run(FbccControllerNode)


if __name__ == "__main__":
    main()
