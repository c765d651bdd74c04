"""A 6-axis force/torque sensor at the arm's flange, as a real cell mounts one under its gripper.

Its frame {S} is the flange's (origin and axes). It carries the tool (gripper and peg: a
:class:`~fbcc_ros.core.compensation.payload.Payload` in {S}) and reads, in {S}:

.. math::
    w_S = w_{payload}(g_S, a_S, \\omega_S, \\dot\\omega_S) + w_{hole \\to peg} + b + n

the payload's wrench on the sensor as it moves (``payload_wrench``: its weight and inertia, the
motion of {S} from the joints), the wrench the hole exerts on the peg moved to the flange, the
bias and white noise. This is the reading ``fbcc-calibrate`` fits (payload and bias) and that the
compensation with ``placement: wrist`` undoes. The joint accelerations are the joint velocities
differenced over one step.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.compensator import sensor_motion
from fbcc_ros.core.compensation.payload import Payload, payload_wrench
from fbcc_ros.core.kinematics.robot import RobotModel

#: The frame_id of its readings.
WRIST_FRAME = "wrist_sensor"


class WristSensor:
    """The sensor of the module doc.

    Args:
        robot: The arm; {S} is its flange frame.
        payload: What the sensor carries, in {S}.
        bias: Its bias (fx, fy, fz, tx, ty, tz) [N, N m].
        noise: 1 σ of the white noise per component [N, N m].
        rng: The noise's generator.
    """

    def __init__(self, robot: RobotModel, payload: Payload, bias: ArrayLike, noise: ArrayLike,
                 rng: np.random.Generator) -> None:  # fmt: skip
        self.robot = robot
        self.payload = payload
        self.bias = np.asarray(bias, dtype=float)
        self.noise = np.asarray(noise, dtype=float)
        self._rng = rng
        self._dq: FloatArray | None = None

    def reading(self, q: FloatArray, dq: FloatArray, dt: float, on_peg: FloatArray
                ) -> FloatArray:  # fmt: skip
        """The reading at joints ``q`` moving at ``dq`` (``dt`` [s] after the last reading),
        with ``on_peg`` the hole's wrench on the peg at the flange, in the flange's axes."""
        ddq = np.zeros_like(dq) if self._dq is None else (dq - self._dq) / dt
        self._dq = dq.copy()
        motion = sensor_motion(self.robot, q, dq, ddq, self.robot.flange_frame)[1]
        noise = self.noise * self._rng.standard_normal(6)
        return payload_wrench(self.payload, motion) + on_peg + self.bias + noise  # type: ignore[no-any-return]
