"""The kinematics stage: joint states → the peg's pose in {H} (the feature solution); a
commanded peg pose in {H} → joint positions (the TCP solution, Fig. 7).

The pose, not the features, crosses the stage's boundary: the features need the peg's radius,
which is the controller's nominal one (:mod:`fbcc_ros.pipeline.controller`), so this stage has
no radius of its own. The commanded pose is reached with the peg's current spin about its axis.

The IK starts from the measured joints, never from its own last command: each command is then
within reach (the joint velocity limits) of where the arm was measured, whatever happened before
(a restarted node, a command the arm did not follow). The reach is the time since that
measurement plus one period, at most :data:`MAX_REACH_PERIODS` periods: a starved loop's joint
states are several periods old when a command is solved, and the arm has moved on since.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.compensator import MAX_STAMP_AHEAD
from fbcc_ros.core.control.supervisor import MAX_PERIODS
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.kinematics.cell import CellKinematics, TcpCommand, aligned_hole_at
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel, Tool
from fbcc_ros.core.kinematics.robot import pose as pose_of
from fbcc_ros.pipeline.parameters import HOLE_FRAME, JOINT_STATES, Param

#: The most control periods a command may take to reach, from the measured joints: as many as
#: the controller steps one late sample by.
MAX_REACH_PERIODS = MAX_PERIODS
#: A stage that solved a command within this many seconds is moving the arm: stopped, it holds
#: it (:meth:`KinematicsStage.hold`).
MOVING_WITHIN = 0.1

#: Where a model that is not built in comes from: the URDF the ``robot_description`` topic
#: latches (robot_state_publisher, ros2_control), or the file ``urdf_file``.
DESCRIPTION, URDF_FILE = "robot_description", "urdf_file"

#: The arm, its tool and where the hole is: shared by the stages that need kinematics.
CELL = (
    Param("robot", "iiwa14", f"robot model: a built-in one, '{DESCRIPTION}' (the URDF on that "
          f"topic) or '{URDF_FILE}'", choices=(*ROBOTS, DESCRIPTION, URDF_FILE)),
    Param("urdf_file", "", f"the URDF's path, with robot '{URDF_FILE}'"),
    Param("description_timeout", 30.0, f"how long a node waits for {DESCRIPTION}, with robot "
          f"'{DESCRIPTION}' (0: for ever)", "s", 0.0, 3600.0),
    Param("flange_frame", "", "the link the tool is mounted on; empty: the built-in model's "
          "flange, or the tip of the URDF's chain"),
    Param("locked_joints", [], "joints of the URDF held at zero and left out (a gripper's "
          "fingers): the others are the arm's, measured and commanded"),
    Param("tool_frame", "", "the frame tool_xyz and tool_rpy are given in: a frame of the "
          "model fixed to the flange's link (a TCP the URDF defines); empty: the flange"),
    Param("tool_xyz", [0.0, 0.0, 0.10], "peg tip centre in the tool frame", "m"),
    Param("tool_rpy", [0.0, 0.0, 0.0], "peg frame orientation in the tool frame", "rad"),
    Param("hole_from_home", True,
          "place {H} aligned under the peg at the robot's home (hole_xyz/rpy ignored)"),
    Param("hole_xyz", [0.0, 0.0, 0.0], "origin of {H} in the base frame", "m"),
    Param("hole_rpy", [0.0, 0.0, 0.0], "orientation of {H} in the base frame", "rad"),
)  # fmt: skip

#: What the node commands: joint positions (ros2_controllers' forward position controller,
#: std_msgs/Float64MultiArray), a one-point trajectory reached in one period
#: (trajectory_msgs/JointTrajectory, for a JointTrajectoryController) or the flange's pose in
#: the base frame (geometry_msgs/PoseStamped, for a Cartesian controller).
COMMAND_TYPES = ("positions", "trajectory", "pose")

TABLE = (
    *CELL,
    Param("rate_hz", 1000.0, "control rate: the IK keeps each step within one period's joint "
          "velocity limits", "Hz", 1.0, 10000.0),
    # transport settings (the node's, not the stage's)
    Param("command_type", "positions", "what is commanded: joint positions "
          "(Float64MultiArray), a one-period JointTrajectory, or the flange pose (PoseStamped "
          "in base_frame)", choices=COMMAND_TYPES),
    Param("command_topic", "joint_command", "where the command goes, e.g. "
          "forward_position_controller/commands"),
    Param("base_frame", "", "frame_id of poses in the base frame; empty: the model's root link"),
    HOLE_FRAME,
    *JOINT_STATES,
)  # fmt: skip


def robot_from(values: dict[str, Any], description: str | None = None, lbr_name: str = ""
               ) -> RobotModel:  # fmt: skip
    """The robot model of the CELL parameters; ``description``: the URDF text the
    ``robot_description`` topic gave, for ``robot: robot_description``; ``lbr_name``: a
    built-in LBR under lbr_fri_ros2_stack's names (``RobotModel.from_name``)."""
    tool = Tool(tuple(values["tool_xyz"]), tuple(values["tool_rpy"]),  # type: ignore[arg-type]
                values["tool_frame"])
    source, flange, locked = values["robot"], values["flange_frame"], values["locked_joints"]
    if source in ROBOTS:
        if locked:
            raise ConfigError("locked_joints", locked, f"[] with the built-in model {source} "
                              "(it locks its own)")  # fmt: skip
        return RobotModel.from_name(source, tool, flange, lbr_name)
    if source == URDF_FILE:
        if not values["urdf_file"]:
            raise ConfigError("urdf_file", "", f"the URDF's path, with robot '{URDF_FILE}'")
        return RobotModel(values["urdf_file"], flange, tool, locked)
    if description is None:
        raise ConfigError("robot", source, f"a model from the {DESCRIPTION} topic, and none "
                          "came (offline: the bag recorded none)")  # fmt: skip
    return RobotModel(description, flange, tool, locked, name=DESCRIPTION)


def needs_description(values: dict[str, Any]) -> bool:
    """Whether the CELL parameters take the model from the ``robot_description`` topic."""
    return bool(values["robot"] == DESCRIPTION)


def hole_from(values: dict[str, Any], robot: RobotModel | None) -> pin.SE3:
    """``T_base_H`` of the CELL parameters: under the peg at the built-in model's home (which
    needs ``robot``), or ``hole_xyz``/``hole_rpy``."""
    if not values["hole_from_home"]:
        return pose_of(values["hole_xyz"], values["hole_rpy"])
    if values["robot"] not in ROBOTS or robot is None:  # a user's model has no home of ours
        raise ConfigError("hole_from_home", True, f"false with robot '{values['robot']}': "
                          "the hole's pose in hole_xyz/hole_rpy (the built-in models only "
                          "have a home to place it under)")  # fmt: skip
    return aligned_hole_at(robot.peg_in_base(robot.home))


def cell_from(values: dict[str, Any], description: str | None = None, lbr_name: str = ""
              ) -> tuple[RobotModel, pin.SE3]:  # fmt: skip
    """The robot model and ``T_base_H`` from the CELL parameters (:func:`robot_from`)."""
    robot = robot_from(values, description, lbr_name)
    return robot, hole_from(values, robot)


class KinematicsStage:
    """The feature and TCP solutions of one cell, configured by :data:`TABLE`'s values.

    Attributes:
        cell: The robot, the hole and the IK.
        dt: The control period [s].
        q: The last measured joints (None before the first), ``t_q`` their stamp [s].
    """

    def __init__(self, values: dict[str, Any], description: str | None = None) -> None:
        robot, hole = cell_from(values, description)
        self.cell = CellKinematics(robot, hole, None)
        self.dt = 1.0 / values["rate_hz"]
        self.q: FloatArray | None = None
        self.t_command: float | None = None  # when the last command was solved [s]
        self.t_q: float | None = None

    def preload(self) -> None:
        """Load the compiled IK step now, not in the first period."""
        self.cell.preload()

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.cell.robot.joint_names

    def joints(self, q: ArrayLike, stamp: float | None = None, received: float | None = None
               ) -> pin.SE3:  # fmt: skip
        """The peg's pose in {H}, ``T_H_P``, at the joints ``q`` measured at ``stamp`` [s].
        ``received``: its arrival, on the clock of the stamps; a stamp more than
        ``MAX_STAMP_AHEAD`` later raises InputError (the features carry it, and the law judges
        their freshness by it: a stamp ahead would let it step on features that stopped)."""
        if stamp is not None and received is not None and stamp > received + MAX_STAMP_AHEAD:
            raise InputError("header.stamp", stamp, f"at most {MAX_STAMP_AHEAD} s after its "
                             f"arrival {received:.3f} (a clock ahead of ours)")  # fmt: skip
        peg = self.cell.peg_in_hole(q)
        self.q, self.t_q = np.asarray(q, dtype=float), stamp
        return peg

    def command(self, peg_in_hole: pin.SE3, now: float | None = None) -> TcpCommand | None:
        """The joints that place the peg at ``peg_in_hole`` within reach of the measured joints
        at ``now`` [s] (module doc; one period without times); None before any joints were
        measured. Raises :class:`~fbcc_ros.core.kinematics.ik.IkError` for a pose out of reach."""
        if self.q is None:
            return None
        solution = self.cell.pose_solution(peg_in_hole, self.q, self.reach(now))
        self.t_command = now
        return solution

    def hold(self, now: float) -> TcpCommand | None:
        """The last measured joints as a command, if a command was solved within
        :data:`MOVING_WITHIN` before ``now`` [s]: a node that stops while the arm moves leaves
        it where it was measured, not on its way to a command nobody follows up. None when
        the arm was not being commanded, or no joints were measured."""
        if self.q is None or self.t_command is None or now - self.t_command > MOVING_WITHIN:
            return None
        robot = self.cell.robot
        return TcpCommand(self.q.copy(), robot.flange_in_base(self.q), robot.peg_in_base(self.q),
                          iterations=0)

    def reach(self, now: float | None) -> float:
        """The time [s] the arm has to reach a command solved at ``now``: since its joints were
        measured, plus one period; one period without times, at most MAX_REACH_PERIODS."""
        if now is None or self.t_q is None:
            return self.dt
        periods = 1 + max(0.0, now - self.t_q) / self.dt
        return self.dt * min(periods, MAX_REACH_PERIODS)
