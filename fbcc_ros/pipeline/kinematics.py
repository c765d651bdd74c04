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
from fbcc_ros.core.control.supervisor import MAX_PERIODS
from fbcc_ros.core.kinematics.cell import CellKinematics, TcpCommand, aligned_hole_at
from fbcc_ros.core.kinematics.robot import RobotModel, Tool
from fbcc_ros.core.kinematics.robot import pose as pose_of
from fbcc_ros.pipeline.parameters import Param

#: The most control periods a command may take to reach, from the measured joints: as many as
#: the controller steps one late sample by.
MAX_REACH_PERIODS = MAX_PERIODS

#: The arm, its tool and where the hole is: shared by the stages that need kinematics.
CELL = (
    Param("robot", "iiwa14", "robot model", choices=("iiwa14", "panda", "ur5")),
    Param("tool_xyz", [0.0, 0.0, 0.10], "peg tip centre in the flange frame", "m"),
    Param("tool_rpy", [0.0, 0.0, 0.0], "peg frame orientation in the flange frame", "rad"),
    Param("hole_from_home", True,
          "place {H} aligned under the peg at the robot's home (hole_xyz/rpy ignored)"),
    Param("hole_xyz", [0.0, 0.0, 0.0], "origin of {H} in the base frame", "m"),
    Param("hole_rpy", [0.0, 0.0, 0.0], "orientation of {H} in the base frame", "rad"),
)  # fmt: skip

TABLE = (
    *CELL,
    Param("rate_hz", 1000.0, "control rate: the IK keeps each step within one period's joint "
          "velocity limits", "Hz", 1.0, 10000.0),
)  # fmt: skip


def cell_from(values: dict[str, Any]) -> tuple[RobotModel, pin.SE3]:
    """The robot model and ``T_base_H`` from the CELL parameters."""
    tool = Tool(tuple(values["tool_xyz"]), tuple(values["tool_rpy"]))  # type: ignore[arg-type]
    robot = RobotModel.from_name(values["robot"], tool)
    if values["hole_from_home"]:
        return robot, aligned_hole_at(robot.peg_in_base(robot.home))
    return robot, pose_of(values["hole_xyz"], values["hole_rpy"])


class KinematicsStage:
    """The feature and TCP solutions of one cell, configured by :data:`TABLE`'s values.

    Attributes:
        cell: The robot, the hole and the IK.
        dt: The control period [s].
        q: The last measured joints (None before the first), ``t_q`` their stamp [s].
    """

    def __init__(self, values: dict[str, Any]) -> None:
        robot, hole = cell_from(values)
        self.cell = CellKinematics(robot, hole, None)
        self.dt = 1.0 / values["rate_hz"]
        self.q: FloatArray | None = None
        self.t_q: float | None = None

    def preload(self) -> None:
        """Load the compiled IK step now, not in the first period."""
        self.cell.preload()

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.cell.robot.joint_names

    def joints(self, q: ArrayLike, stamp: float | None = None) -> pin.SE3:
        """The peg's pose in {H}, ``T_H_P``, at the joints ``q`` measured at ``stamp`` [s]."""
        peg = self.cell.peg_in_hole(q)
        self.q, self.t_q = np.asarray(q, dtype=float), stamp
        return peg

    def command(self, peg_in_hole: pin.SE3, now: float | None = None) -> TcpCommand | None:
        """The joints that place the peg at ``peg_in_hole`` within reach of the measured joints
        at ``now`` [s] (module doc; one period without times); None before any joints were
        measured. Raises :class:`~fbcc_ros.core.kinematics.ik.IkError` for a pose out of reach."""
        if self.q is None:
            return None
        return self.cell.pose_solution(peg_in_hole, self.q, self.reach(now))

    def reach(self, now: float | None) -> float:
        """The time [s] the arm has to reach a command solved at ``now``: since its joints were
        measured, plus one period; one period without times, at most MAX_REACH_PERIODS."""
        if now is None or self.t_q is None:
            return self.dt
        periods = 1 + max(0.0, now - self.t_q) / self.dt
        return self.dt * min(periods, MAX_REACH_PERIODS)
