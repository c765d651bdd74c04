"""Message <-> numpy conversions, one function pair per message type (the only place that knows
both)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped, WrenchStamped
from numpy.typing import NDArray
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from fbcc_ros.core.errors import InputError

FloatArray = NDArray[np.float64]


def stamp_to_seconds(stamp: Time) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def seconds_to_stamp(seconds: float) -> Time:
    sec = int(seconds // 1)
    return Time(sec=sec, nanosec=min(round((seconds - sec) * 1e9), 999_999_999))


def wrench_from_msg(msg: WrenchStamped) -> FloatArray:
    f, t = msg.wrench.force, msg.wrench.torque
    return np.array([f.x, f.y, f.z, t.x, t.y, t.z])


def wrench_to_msg(wrench: FloatArray, frame_id: str, seconds: float) -> WrenchStamped:
    msg = WrenchStamped()
    msg.header.stamp = seconds_to_stamp(seconds)
    msg.header.frame_id = frame_id
    f, t = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z, t.x, t.y, t.z = (float(v) for v in wrench)
    return msg


def pose_from_msg(msg: PoseStamped) -> pin.SE3:
    p, q = msg.pose.position, msg.pose.orientation
    norm = np.sqrt(q.x**2 + q.y**2 + q.z**2 + q.w**2)
    if not np.isfinite([p.x, p.y, p.z, norm]).all() or norm < 1e-6:
        raise InputError("pose", msg.pose, "a finite position and a non-zero quaternion")
    quat = pin.Quaternion(q.w / norm, q.x / norm, q.y / norm, q.z / norm)
    return pin.SE3(quat.matrix(), np.array([p.x, p.y, p.z]))


def pose_to_msg(pose: pin.SE3, frame_id: str, seconds: float) -> PoseStamped:
    msg = PoseStamped()
    msg.header.stamp = seconds_to_stamp(seconds)
    msg.header.frame_id = frame_id
    p, q = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(v) for v in pose.translation)
    q.x, q.y, q.z, q.w = (float(v) for v in pin.Quaternion(pose.rotation).coeffs())
    return msg


def joints_from_msg(
    msg: JointState, names: tuple[str, ...]
) -> tuple[FloatArray, FloatArray | None]:
    """Positions (and velocities, if the message has them) in the order of ``names``."""
    order = _order(msg, names)
    q = np.asarray(msg.position, dtype=float)[order]
    if len(msg.velocity) != len(msg.name):
        return q, None
    return q, np.asarray(msg.velocity, dtype=float)[order]


def efforts_from_msg(msg: JointState, names: tuple[str, ...]) -> FloatArray:
    """The ``effort`` field (e.g. external joint torques) in the order of ``names``."""
    order = _order(msg, names)
    if len(msg.effort) != len(msg.name):
        raise InputError("effort", len(msg.effort), f"{len(msg.name)} values, one per name")
    return np.asarray(msg.effort, dtype=float)[order]


def _order(msg: JointState, names: tuple[str, ...]) -> list[int]:
    index = {name: i for i, name in enumerate(msg.name)}
    if any(n not in index for n in names):
        raise InputError("joint_states.name", list(msg.name), f"all of {list(names)}")
    return [index[n] for n in names]


def joints_to_msg(
    names: tuple[str, ...], q: FloatArray, dq: FloatArray, seconds: float
) -> JointState:
    msg = JointState()
    msg.header.stamp = seconds_to_stamp(seconds)
    msg.name = list(names)
    msg.position = q.tolist()
    msg.velocity = dq.tolist()
    return msg


def positions_from_msg(msg: Float64MultiArray) -> FloatArray:
    return np.asarray(msg.data, dtype=float)


def positions_to_msg(q: FloatArray) -> Float64MultiArray:
    return Float64MultiArray(data=q.tolist())
