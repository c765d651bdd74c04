"""Topic and service names, relative so that a namespace or a remap moves a whole cell."""

from collections.abc import Sequence

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

JOINT_STATES = "joint_states"
JOINT_COMMAND = "joint_command"
#: lbr_fri_ros2_stack's joint position command (its forward_position_controller).
LBR_COMMAND = "forward_position_controller/commands"


def joint_command(conventions: str) -> str:
    """Where the joint command goes beside the stack the mock plays (``conventions``: fbcc or
    lbr)."""
    return LBR_COMMAND if conventions == "lbr" else JOINT_COMMAND


#: lbr_fri_ros2_stack's estimated wrench at its lbr_link_ee (its force_torque_broadcaster).
LBR_WRENCH = "force_torque_broadcaster/wrench"
#: The arm's external joint torques (JointState, in ``effort``): a virtual sensor's input.
EXTERNAL_TORQUES = "external_joint_torques"
#: The robot's URDF, latched (robot_state_publisher's, ros2_control's convention).
ROBOT_DESCRIPTION = "robot_description"
RAW_WRENCH = "ft_sensor/raw"
#: The mock's wrist sensor (``wrist_sensor``): a 6-axis F/T sensor at the flange, carrying the
#: tool (WrenchStamped in its frame ``wrist_sensor``).
WRIST_WRENCH = "wrist_sensor/raw"
COMPENSATED_WRENCH = "ft_sensor/compensated"
#: The bias the compensation subtracts (sensor frame), latched: the configured one at start-up,
#: the measured one once the tare is done; it makes a bag's compensation reproducible offline.
BIAS = "ft_sensor/bias"
#: The compensated wrench's noise floor, measured by the tare (WrenchStamped: the standard
#: deviation of each component, in {H}), latched: the robust law takes it where the source is
#: noisier than it was told (a virtual sensor's).
NOISE = "ft_sensor/noise"
FEATURES = "fbcc/features"
COMMAND = "fbcc/command"
TCP_COMMAND = "fbcc/tcp_command"
PHASE = "fbcc/phase"
CONTACT_STATE = "fbcc/contact_state"
KINEMATICS_STATUS = "fbcc/kinematics_status"
#: Why the compensation's wrench guard tripped (String, latched; empty once re-armed): the
#: controller faults on it.
GUARD = "fbcc/guard"
#: The controller's reset, passed on (String: what it acknowledged): the guard re-arms.
REARM = "fbcc/rearm"
#: The robust law's contact identification, Float64MultiArray at ``estimate_rate_hz`` while an
#: insertion runs: the stamp of the sample it follows, then identification.ESTIMATE_FIELDS.
CONTACT_ESTIMATE = "fbcc/contact_estimate"
#: The contact state by the deviation filter, Float64MultiArray at ``state_rate_hz`` while an
#: insertion runs and someone listens: the stamp of the sample it follows, then P(state) of XOZ
#: and of YOZ over segmentation.STATES.
CONTACT_STATE_ESTIMATE = "fbcc/contact_state_estimate"
START = "fbcc/start"
ABORT = "fbcc/abort"
#: Acknowledges a fault, a force limit or an abort (std_srvs/Trigger): back to idle.
RESET = "fbcc/reset"
#: The simulated time of a mock that is the cell's clock (mock_cell's publish_clock), absolute
#: as ROS's own time source reads it.
CLOCK = "/clock"
#: The mock cell's ground truth, one Float64MultiArray per tick (published only when heard):
#: what the real cell cannot measure, for scoring a hardware-free run.
TRUTH = "mock_cell/truth"
TRUTH_FIELDS = ("stamp", "dx", "dy", "l", "theta_x", "theta_y", "Fx", "Fy", "Fz", "Mx", "My")
#: The phase and the bias are latched (transient local): a late subscriber still gets the
#: current one.
PHASE_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


#: A sensor input's reliability: ``reliable`` (ours and most ROS publishers), ``best_effort``
#: for a driver publishing sensor-data QoS, which a reliable subscription never matches (a
#: best-effort one hears both), or ``match``: its publishers', once one is seen
#: (:func:`matching_reliability`).
RELIABILITIES = ("reliable", "best_effort", "match")


def input_qos(reliability: str, depth: int = 10) -> QoSProfile:
    """A sensor input's subscription QoS, ``reliable`` or ``best_effort``."""
    policy = {"reliable": ReliabilityPolicy.RELIABLE, "best_effort": ReliabilityPolicy.BEST_EFFORT}
    return QoSProfile(depth=depth, reliability=policy[reliability])


def matching_reliability(offered: Sequence[QoSProfile]) -> str:
    """The reliability a subscription to these publishers takes: ``reliable`` only when every
    one of them is (a reliable subscription never hears a best-effort publisher; a best-effort
    one hears both)."""
    reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
    return "reliable" if reliable else "best_effort"
