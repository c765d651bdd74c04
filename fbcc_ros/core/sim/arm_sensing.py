"""What an arm's own sensing reports of a contact on its tool: the external joint torques, the
measured joint torques, and lbr_fri_ros2_stack's estimated wrench.

Conventions (KUKA's, and lbr_fri_ros2_stack's; ``docs/compensation.md``):

* **external joint torques** ``tau_ext = J^T w``, with ``w`` the wrench the environment exerts on
  the arm at a frame of its last link (force, moment about the frame's origin, base axes) and
  ``J`` that frame's Jacobian in the same axes (Pinocchio's LOCAL_WORLD_ALIGNED);
* **measured joint torques** (``JointState.effort`` of the stack's joint states):
  ``tau = g(q) + tau_ext``, ``g`` the torques that hold the arm against gravity (KUKA: the
  external torque is the measured one less the model's); the arm at rest, so no inertial terms.
  The stack low-passes both at 10 Hz (first order) before it publishes them;
* **the estimated wrench** (the stack's ``FTEstimatorImpl::compute``, lbr_fri_ros2/src/
  ft_estimator.cpp, commit 218d723): ``w = (J J^T + lambda^2 E)^-1 J tau_ext`` (its damped
  pseudo-inverse, ``lambda`` = ``damping``, 0.2 by default) at the chain's tip in base axes, each
  component through a continuous dead band ``sign(x) max(|x| - th, 0)`` (``force_*_th``,
  ``torque_*_th``: 2 N and 0.5 N m by default), then rotated into the tip's axes. The stack
  multiplies by ``R_base_tip`` where ``R_base_tip^T`` maps into the tip's axes; the two agree
  for a tool pointing straight down (a half turn about a horizontal axis is symmetric), the
  insertion's pose, and we rotate by the transpose, as the header's frame says.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.wrench import virtual_wrench
from fbcc_ros.core.filters import dead_band
from fbcc_ros.core.kinematics.robot import RobotModel

#: lbr_fri_ros2_stack's defaults (lbr_description/ros2_control/lbr_system_config.yaml):
#: the estimate's damping and its dead band per component [N, N, N, N m, N m, N m], and the
#: first-order low-pass its hardware interface puts on the measured and external joint torques
#: (``measured_torque_cutoff_frequency``, ``external_torque_cutoff_frequency``) [Hz].
LBR_DAMPING = 0.2
LBR_DEADBAND = (2.0, 2.0, 2.0, 0.5, 0.5, 0.5)
LBR_TORQUE_CUTOFF_HZ = 10.0


def wrench_at_frame(wrench: FloatArray, at: pin.SE3, frame: pin.SE3) -> FloatArray:
    """A wrench (force, moment about ``at``'s origin, in ``at``'s axes) as a wrench at
    ``frame``'s origin in base axes: ``f_b = R f``, ``m_F = R m + (p_at - p_F) x f_b``; both
    poses in the base frame."""
    f = at.rotation @ wrench[:3]
    m = at.rotation @ wrench[3:] + np.cross(at.translation - frame.translation, f)
    return np.concatenate([f, m])


def external_torques(robot: RobotModel, q: FloatArray, frame: str, wrench: FloatArray
                     ) -> FloatArray:  # fmt: skip
    """``tau_ext = J^T w``: ``wrench`` on the arm at ``frame``'s origin, in base axes."""
    return robot.jacobian(q, frame, pin.LOCAL_WORLD_ALIGNED).T @ wrench


def measured_torques(robot: RobotModel, q: FloatArray, tau_ext: FloatArray) -> FloatArray:
    """``tau = g(q) + tau_ext``: what the joint torque sensors of an arm at rest read."""
    return robot.gravity(q) + tau_ext


def estimated_wrench(
    robot: RobotModel,
    q: FloatArray,
    tau_ext: FloatArray,
    frame: str,
    damping: float = LBR_DAMPING,
    deadband: tuple[float, ...] = LBR_DEADBAND,
) -> FloatArray:
    """The stack's estimated wrench at ``frame`` (its ``chain_tip``), in that frame's axes."""
    w = virtual_wrench(robot.jacobian(q, frame, pin.LOCAL_WORLD_ALIGNED), tau_ext, damping)
    w = dead_band(w, deadband)  # sign(x) max(|x| - th, 0)
    rotation = robot.frame_in_base(q, frame).rotation
    return np.concatenate([rotation.T @ w[:3], rotation.T @ w[3:]])
