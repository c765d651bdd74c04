"""The cell's kinematics (Fig. 7): a robot bound to the hole's pose.

:class:`CellKinematics` gives the feature solution ``features(q)`` and the TCP solutions
``tcp_solution(x_c, q)`` (command features) and ``pose_solution(T_H_P, q)`` (a commanded peg
pose in {H}); :func:`follow` runs the TCP solution along a command trajectory. {H} is the hole
frame; the robot's frames are :mod:`fbcc_ros.core.kinematics.robot`'s.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import (
    R_ALIGNED,
    features_from_pose,
    pose_from_features,
    spin_of,
)
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.kinematics.ik import IkError, IkSettings, checked_start, clik, preload_ik
from fbcc_ros.core.kinematics.robot import RobotModel


class CellKinematics:
    """The feature solution and TCP solution of one cell: a robot, the hole, the peg.

    Args:
        robot: The arm, with its peg frame.
        hole_in_base: Pose of {H} in the base frame, ``T_base_H``.
        peg_radius: r [m], used by the feature conversion (:mod:`fbcc_ros.core.contact.features`);
            None for a cell that only solves poses (:meth:`pose_solution`).
        settings: IK settings.
    """

    def __init__(
        self,
        robot: RobotModel,
        hole_in_base: pin.SE3,
        peg_radius: float | None,
        settings: IkSettings | None = None,
    ) -> None:
        if peg_radius is not None and not (peg_radius > 0.0 and math.isfinite(peg_radius)):
            raise ConfigError("peg_radius", peg_radius, "a radius > 0 [m]")
        self.robot = robot
        self.hole_in_base = hole_in_base.copy()
        self.peg_radius = peg_radius
        self.settings = settings or IkSettings()

    def preload(self) -> None:
        """Load the compiled IK step now, not in the first control period."""
        preload_ik(self.robot.nq)

    def peg_in_hole(self, q: ArrayLike) -> pin.SE3:
        """``T_H_P`` at joints ``q``."""
        return self.hole_in_base.actInv(self.robot.peg_in_base(q))

    def features(self, q: ArrayLike) -> FloatArray:
        """Feature solution: joints → ``(dx, dy, l, theta_x, theta_y)`` [m, rad]."""
        peg = self.peg_in_hole(q)
        return features_from_pose(peg.rotation, peg.translation, self._radius())

    def _radius(self) -> float:
        if self.peg_radius is None:
            raise ConfigError("peg_radius", None, "a radius > 0 [m] for the feature conversion")
        return self.peg_radius

    def peg_target(self, command_features: ArrayLike, spin: float) -> pin.SE3:
        """``T_base_P`` of the command features, with the peg's spin about its axis."""
        x_c = np.asarray(command_features, dtype=float)
        if x_c.shape != (5,) or not np.isfinite(x_c).all():
            raise InputError(
                "command_features",
                command_features,
                "5 finite values (dx, dy, l, theta_x, theta_y)",
            )
        rotation, position = pose_from_features(x_c, self._radius(), spin)
        return self.hole_in_base * pin.SE3(rotation, position)

    def tcp_solution(
        self, command_features: ArrayLike, q_current: ArrayLike, dt: float | None = None
    ) -> TcpCommand:
        """TCP solution: command features → peg pose in {H} → flange pose in base → joints.

        The peg keeps its current spin about its own axis (the features do not fix it). With
        ``dt``, the joints must be reachable within one period at the velocity limits.
        Raises :class:`IkError` rather than return a command that misses the target.
        """
        q_now = checked_start(self.robot, q_current, dt, "q_current")
        return self._solve(self.peg_target(command_features, self._spin(q_now)), q_now, dt)

    def pose_solution(
        self, peg_in_hole: pin.SE3, q_current: ArrayLike, dt: float | None = None
    ) -> TcpCommand:
        """TCP solution of a commanded peg pose in {H} (``T_H_P``), as :meth:`tcp_solution`:
        the peg keeps its current spin about its own axis, whatever the command's."""
        q_now = checked_start(self.robot, q_current, dt, "q_current")
        rotation = peg_in_hole.rotation
        turn = self._spin(q_now) - spin_of(rotation)  # R_HP = S(a) R_aligned R_z(spin)
        spun = rotation @ pin.rpy.rpyToMatrix(0.0, 0.0, turn)
        return self._solve(self.hole_in_base * pin.SE3(spun, peg_in_hole.translation), q_now, dt)

    def _spin(self, q: FloatArray) -> float:
        return spin_of(self.hole_in_base.actInv(self.robot._frame_in_base(q, self.robot.peg_id))
                       .rotation)  # fmt: skip

    def _solve(self, target: pin.SE3, q_now: FloatArray, dt: float | None) -> TcpCommand:
        solution = clik(self.robot, target, q_now, dt, self.settings)
        return TcpCommand(solution.q, target * self.robot._flange_in_peg, target,
                          solution.iterations)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class TcpCommand:
    """What the TCP solution commands.

    Attributes:
        q: Joint positions [rad].
        flange_in_base: The flange pose for a Cartesian position interface, ``T_base_F``.
        peg_in_base: The peg pose it realises, ``T_base_P``.
        iterations: IK iterations used.
    """

    q: FloatArray
    flange_in_base: pin.SE3
    peg_in_base: pin.SE3
    iterations: int


@dataclasses.dataclass(frozen=True)
class FollowResult:
    """The TCP solution applied along a command trajectory, one row per control step.

    Attributes:
        q: Joint positions commanded, (T, nq) [rad].
        features: Features of those joints (the feature solution), (T, 5) [m, rad].
        iterations: IK iterations per step, (T,).
        seconds: Wall time of each step's TCP solution, (T,) [s].
    """

    q: FloatArray
    features: FloatArray
    iterations: NDArray[np.int64]
    seconds: FloatArray


def follow(
    cell: CellKinematics, commands: ArrayLike, q_start: ArrayLike, dt: float
) -> FollowResult:
    """Run the TCP solution on each command features row in turn, warm-started from the
    previous step and bounded by the velocity limits over ``dt`` [s], as the kinematics node
    does in the closed loop. Raises :class:`IkError` (with the step in its message) on the
    first step the robot cannot follow."""
    x_c = np.asarray(commands, dtype=float)
    q = cell.robot.check_joints(q_start, "q_start")
    steps = x_c.shape[0]
    joints = np.empty((steps, q.size))
    features = np.empty((steps, 5))
    iterations = np.empty(steps, dtype=np.int64)
    seconds = np.empty(steps)
    for k in range(steps):
        t0 = time.perf_counter()
        try:
            command = cell.tcp_solution(x_c[k], q, dt)
        except IkError as exc:
            exc.args = (f"step {k} (t = {k * dt:.3f} s): {exc}",)
            raise
        seconds[k] = time.perf_counter() - t0
        q = command.q
        joints[k], iterations[k] = q, command.iterations
        features[k] = cell.features(q)
    return FollowResult(joints, features, iterations, seconds)


def aligned_hole_at(peg_in_base: pin.SE3) -> pin.SE3:
    """``T_base_H`` of a hole whose top face centre is at the peg's tip and whose axis is the
    peg's: the peg at this pose has features (0, 0, 0, 0, 0) and zero spin."""
    return peg_in_base * pin.SE3(R_ALIGNED.T, np.zeros(3))
