"""The hand-packed CDR against rclpy's own serialisation, both ways, for any values."""

from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import PoseStamped, WrenchStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String

from fbcc_ros.core.errors import InputError
from fbcc_ros.ros import cdr

# lengths 0..9 cover every padding a string or a sequence can need before a double
text = st.text(st.characters(codec="utf-8", exclude_characters="\x00"), max_size=9)
real = st.floats(allow_nan=False, width=64)
stamps = st.tuples(st.integers(-(2**31), 2**31 - 1), st.integers(0, 2**32 - 1))
doubles = st.lists(real, max_size=9)
uint32 = st.integers(0, 2**32 - 1)


def same(a: object, b: object) -> bool:
    return list(a) == list(b)  # type: ignore[call-overload]


def _wrench_values(msg: WrenchStamped) -> list[float]:
    f, t = msg.wrench.force, msg.wrench.torque
    return [f.x, f.y, f.z, t.x, t.y, t.z]


def _pose_values(msg: PoseStamped) -> list[float]:
    p, q = msg.pose.position, msg.pose.orientation
    return [p.x, p.y, p.z, q.x, q.y, q.z, q.w]


STAMPED = {
    "wrench": (cdr.encode_wrench, cdr.decode_wrench, WrenchStamped, _wrench_values, 6),
    "pose": (cdr.encode_pose, cdr.decode_pose, PoseStamped, _pose_values, 7),
}


@pytest.mark.parametrize("kind", STAMPED)
@settings(max_examples=150)
@given(stamp=stamps, frame=text, values=st.lists(real, min_size=7, max_size=7))
def test_stamped_wrench_and_pose_both_ways(kind, stamp, frame, values):
    encode, decode, msg_type, values_of, count = STAMPED[kind]
    values = values[:count]
    msg = deserialize_message(encode(stamp, frame, values), msg_type)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (*stamp, frame)
    assert same(values_of(msg), values)
    assert decode(serialize_message(msg)) == (stamp, frame, tuple(values))
    with pytest.raises(InputError, match=f"{count} numbers"):
        encode(stamp, frame, [*values, 0.0])


@settings(max_examples=150)
@given(stamps, text, st.lists(text, max_size=8), doubles, doubles, doubles)
def test_joint_state_both_ways(stamp, frame, names, position, velocity, effort):
    data = cdr.encode_joints(stamp, frame, names, position, velocity, effort)
    msg = deserialize_message(data, JointState)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (*stamp, frame)
    assert list(msg.name) == names
    assert same(msg.position, position) and same(msg.velocity, velocity)
    assert same(msg.effort, effort)
    decoded = cdr.decode_joints(serialize_message(msg))
    assert decoded == (stamp, frame, names, tuple(position), tuple(velocity), tuple(effort))


@settings(max_examples=150)
@given(doubles, st.lists(st.tuples(text, uint32, uint32), max_size=3))
def test_float64_array_both_ways(data, dims):
    msg = deserialize_message(cdr.encode_array(data, dims), Float64MultiArray)
    assert same(msg.data, data)
    assert [(d.label, d.size, d.stride) for d in msg.layout.dim] == dims
    assert msg.layout.data_offset == 0
    msg.layout.data_offset = 3  # read past, whatever it holds
    assert cdr.decode_array(serialize_message(msg)) == tuple(data)
    labels, values = cdr.decode_labelled_array(serialize_message(msg))
    assert labels == tuple(label for label, _, _ in dims) and values == tuple(data)


@given(text)
def test_string_decodes_like_rclpy(data):
    assert cdr.decode_string(serialize_message(String(data=data))) == data


def test_nan_and_infinity_pass_through():
    stamp = (1, 2)
    values = (math.nan, math.inf, -math.inf, 0.0, -0.0, 1e-308)
    _, _, back = cdr.decode_wrench(cdr.encode_wrench(stamp, "s", values))
    assert math.isnan(back[0]) and back[1:] == values[1:]
    assert math.copysign(1.0, back[4]) == -1.0


def test_a_real_joint_state_decodes_like_rclpy():
    msg = JointState(name=[f"lbr_A{i}" for i in range(1, 8)], position=[0.1 * i for i in range(7)])
    msg.header.frame_id = "base"
    _, frame, names, position, velocity, effort = cdr.decode_joints(serialize_message(msg))
    assert (frame, names, list(position)) == ("base", list(msg.name), list(msg.position))
    assert velocity == effort == ()


def test_remembered_names_are_only_reused_for_the_same_bytes():
    """decode_joints reuses the names it read last at the same offset only when the bytes
    match: two robots' states alternating, and a caller changing the list it got."""
    arm = cdr.encode_joints((1, 0), "b", ["a1", "a2"], [1.0, 2.0])
    other = cdr.encode_joints((1, 0), "b", ["a1", "x2"], [1.0, 2.0])
    longer = cdr.encode_joints((1, 0), "b", ["a1", "a2", "a3"], [1.0, 2.0, 3.0])
    for data, names in [(arm, ["a1", "a2"]), (other, ["a1", "x2"]), (arm, ["a1", "a2"]),
                        (longer, ["a1", "a2", "a3"]), (arm, ["a1", "a2"])]:  # fmt: skip
        got = cdr.decode_joints(data)[2]
        assert got == names
        got.append("changed")
    assert cdr.decode_joints(arm)[2] == ["a1", "a2"]


@pytest.mark.parametrize(
    "decode, kind",
    [
        (cdr.decode_wrench, "WrenchStamped"),
        (cdr.decode_pose, "PoseStamped"),
        (cdr.decode_joints, "JointState"),
        (cdr.decode_array, "Float64MultiArray"),
        (cdr.decode_string, "String"),
    ],
)
def test_garbled_bytes_are_an_input_error_naming_the_type(decode, kind):
    whole = {
        "WrenchStamped": cdr.encode_wrench((0, 0), "frame", [1.0] * 6),
        "PoseStamped": cdr.encode_pose((0, 0), "frame", [1.0] * 7),
        "JointState": cdr.encode_joints((0, 0), "f", ["a", "b"], [1.0, 2.0]),
        "Float64MultiArray": cdr.encode_array([1.0, 2.0], [("x", 2, 2)]),
        "String": serialize_message(String(data="inserting")),
    }[kind]
    with pytest.raises(InputError, match=kind):
        decode(whole[: len(whole) - 5])
    with pytest.raises(InputError, match="little-endian CDR"):
        decode(b"\x00\x00" + whole[2:])  # big-endian encapsulation


def test_joint_states_are_put_in_the_robots_order_and_checked():
    """convert.joints_from_cdr: any order of names on the wire, the robot's order out; a
    missing joint or a short position list is an InputError naming the field."""
    from fbcc_ros.ros.convert import efforts_from_cdr, joints_from_cdr

    robot = ("a1", "a2", "a3")
    same = cdr.encode_joints((2, 500_000_000), "", list(robot), [1.0, 2.0, 3.0], [4.0, 5.0, 6.0])
    stamp, q, dq = joints_from_cdr(same, robot)
    assert stamp == 2.5 and q.tolist() == [1.0, 2.0, 3.0] and dq.tolist() == [4.0, 5.0, 6.0]
    shuffled = cdr.encode_joints((2, 0), "", ["a3", "a1", "a2"], [3.0, 1.0, 2.0], [], [6, 4, 5])
    _, q, dq = joints_from_cdr(shuffled, robot)
    assert q.tolist() == [1.0, 2.0, 3.0] and dq is None
    assert efforts_from_cdr(shuffled, robot)[1].tolist() == [4.0, 5.0, 6.0]
    with pytest.raises(InputError, match=r"joint_states\.name"):
        joints_from_cdr(cdr.encode_joints((2, 0), "", ["a1", "a2"], [1.0, 2.0]), robot)
    with pytest.raises(InputError, match="position"):
        joints_from_cdr(cdr.encode_joints((2, 0), "", list(robot), [1.0, 2.0]), robot)


@pytest.mark.parametrize(
    "values",
    [
        (math.nan, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        (0.0, 0.0, math.inf, 0.0, 0.0, 0.0, 1.0),
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        (0.0, 0.0, 0.0, math.nan, 0.0, 0.0, 1.0),
    ],
)
def test_a_pose_that_is_no_pose_is_rejected(values):
    from fbcc_ros.ros.convert import pose_from_cdr

    with pytest.raises(InputError, match="a finite position and a non-zero quaternion"):
        pose_from_cdr(cdr.encode_pose((1, 0), "hole", values))


def test_a_pose_round_trips_with_its_quaternion_normalised():
    import numpy as np
    import pinocchio as pin

    from fbcc_ros.ros.convert import pose_from_cdr, pose_to_cdr

    rotation = pin.rpy.rpyToMatrix(0.1, -0.2, 0.3)
    pose = pin.SE3(rotation, np.array([1e-3, -2e-3, 0.5]))
    stamp, back = pose_from_cdr(pose_to_cdr(pose, "hole", 12.25))
    assert stamp == 12.25 and back.isApprox(pose, 1e-12)
    qx, qy, qz, qw = pin.Quaternion(rotation).coeffs()
    _, scaled = pose_from_cdr(cdr.encode_pose((1, 0), "hole", (0, 0, 0, 3 * qx, 3 * qy, 3 * qz,
                                                                3 * qw)))  # fmt: skip
    assert np.allclose(scaled.rotation, rotation, atol=1e-12)
