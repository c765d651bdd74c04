"""Serialised messages <-> numpy and pinocchio, one function pair per message type.

The bytes are the messages' CDR (:mod:`fbcc_ros.ros.cdr`): the loop's nodes subscribe raw and
publish bytes, which spares rclpy's message objects at 1 kHz. The checks on what arrives (a
finite pose, a non-zero quaternion, every joint named) are made here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
import pinocchio as pin

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import InputError
from fbcc_ros.ros import cdr


def stamp_to_seconds(stamp: cdr.Stamp) -> float:
    return stamp[0] + stamp[1] * 1e-9


def seconds_to_stamp(seconds: float) -> cdr.Stamp:
    sec = int(seconds // 1)
    return sec, min(round((seconds - sec) * 1e9), 999_999_999)


def wrench_from_cdr(data: bytes) -> tuple[float, str, FloatArray]:
    """WrenchStamped → (stamp [s], frame_id, (fx, fy, fz, tx, ty, tz))."""
    stamp, frame, wrench = cdr.decode_wrench(data)
    return stamp_to_seconds(stamp), frame, np.array(wrench)


def wrench_to_cdr(wrench: FloatArray, frame_id: str, seconds: float) -> bytes:
    return cdr.encode_wrench(seconds_to_stamp(seconds), frame_id, wrench.tolist())


def pose_from_cdr(data: bytes) -> tuple[float, pin.SE3]:
    """PoseStamped → (stamp [s], pose); the quaternion is normalised."""
    stamp, _, (x, y, z, qx, qy, qz, qw) = cdr.decode_pose(data)
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    finite = math.isfinite(x) and math.isfinite(y) and math.isfinite(z) and math.isfinite(norm)
    if not finite or norm < 1e-6:
        raise InputError("pose", (x, y, z, qx, qy, qz, qw),
                         "a finite position and a non-zero quaternion")  # fmt: skip
    quat = pin.Quaternion(qw / norm, qx / norm, qy / norm, qz / norm)
    return stamp_to_seconds(stamp), pin.SE3(quat, np.array([x, y, z]))


def pose_to_cdr(pose: pin.SE3, frame_id: str, seconds: float) -> bytes:
    quat = pin.Quaternion(pose.rotation).coeffs()  # x, y, z, w
    values = [*pose.translation.tolist(), *quat.tolist()]
    return cdr.encode_pose(seconds_to_stamp(seconds), frame_id, values)


def joints_from_cdr(
    data: bytes, names: tuple[str, ...]
) -> tuple[float, FloatArray, FloatArray | None]:
    """JointState → (stamp [s], positions, velocities or None if absent), in ``names`` order."""
    stamp, _, got, position, velocity, _ = cdr.decode_joints(data)
    order = _order(tuple(got), names, len(position), "position")
    q = _ordered(position, order)
    if len(velocity) != len(got):
        return stamp_to_seconds(stamp), q, None
    return stamp_to_seconds(stamp), q, _ordered(velocity, order)


def efforts_from_cdr(data: bytes, names: tuple[str, ...]) -> tuple[float, FloatArray]:
    """JointState's ``effort`` (e.g. external joint torques) → (stamp [s], in ``names`` order)."""
    stamp, _, got, _, _, effort = cdr.decode_joints(data)
    order = _order(tuple(got), names, len(effort), "effort")
    return stamp_to_seconds(stamp), _ordered(effort, order)


@lru_cache(maxsize=8)
def _order(
    got: tuple[str, ...], names: tuple[str, ...], size: int, field: str
) -> list[int] | None:
    """Where each of ``names`` is in ``got``; None if in the same order (nothing to pick)."""
    index = {name: i for i, name in enumerate(got)}
    if any(n not in index for n in names):
        raise InputError("joint_states.name", list(got), f"all of {list(names)}")
    if size != len(got):
        raise InputError(field, size, f"{len(got)} values, one per name")
    order = [index[n] for n in names]
    return None if order == list(range(len(got))) else order


def _ordered(values: Sequence[float], order: list[int] | None) -> FloatArray:
    return np.array(values) if order is None else np.array(values)[order]


def joints_to_cdr(names: Sequence[str], q: FloatArray, dq: FloatArray, seconds: float,
                  effort: FloatArray | None = None) -> bytes:  # fmt: skip
    efforts = () if effort is None else effort.tolist()
    return cdr.encode_joints(seconds_to_stamp(seconds), "", names, q.tolist(), dq.tolist(),
                             efforts)  # fmt: skip


def positions_from_cdr(data: bytes) -> FloatArray:
    """Float64MultiArray → its data."""
    return np.array(cdr.decode_array(data))


def positions_to_cdr(q: FloatArray) -> bytes:
    return cdr.encode_array(q.tolist())
