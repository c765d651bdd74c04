"""The dynamic compensation pipeline (fbcc_ros.core.compensation.compensator): sign and frame for a
sensor under the hole and a wrist sensor against hand-worked cases, the virtual sensor from joint
torques, a moving wrist payload, round trips through the contact model, the filters, and the
rejected samples."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fbcc_ros.core.compensation.compensator import (
    SENSOR_FRAME,
    Compensator,
    SensorSetup,
)
from fbcc_ros.core.compensation.payload import Motion, Payload, payload_wrench
from fbcc_ros.core.compensation.wrench import transfer, wrench_from_response
from fbcc_ros.core.compensation.wrench_guard import GuardLimits
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.kinematics.ik import solve_ik
from fbcc_ros.core.kinematics.robot import RobotModel, pose

G = 9.80665
R = 0.005  # hole radius [m]
PEGHOLE = PegHole(R, 5.02e-3, 0.010, 0.005, 0.2, 1.8e8)  # L = 10 mm, H = 5 mm
ACTING = PEGHOLE.acting_point_in_hole()  # (0, 0, -0.015)
BIAS = np.array([1.0, -2.0, 3.0, 0.01, 0.02, -0.03])

# The hand-worked contact of both placements: the peg presses the hole's wall at (R, 0, -5 mm)
# in {H} with 10 N along +x and drags it down with 4 N of friction. About the acting point,
# r = (R, 0, 10 mm) and r x f = (0, 0.01 * 10 + R * 4, 0) = (0, 0.12, 0):
EXPECTED_WIRE = np.array([10.0, 0.0, -4.0, 0.0, 0.12, 0.0])
EXPECTED_RESPONSE = np.array([10.0, 0.0, 4.0, 0.0, 0.12])  # Fz = -fz (eq. 11)

#: Limits nothing in these tests reaches (the guard has its own tests).
UNGUARDED = GuardLimits(1e12, 1e12, (1e12, 1e12), (1e15, 1e15))


def test_acting_point_is_l_plus_h_below_the_top_face() -> None:
    np.testing.assert_allclose(ACTING, [0, 0, -0.015])


def test_sensor_under_the_hole_hand_worked() -> None:
    """The sensor sits at the acting point, turned 90 deg about z (x_S = y_H, y_S = -x_H), and
    carries a 2 kg fixture whose centre of mass is 3 cm above it."""
    fixture = Payload(2.0, (0.0, 0.0, 0.03))
    setup = SensorSetup(
        "under_hole",
        pose=pose(ACTING, (0, 0, math.pi / 2)),
        acting_point=tuple(ACTING),
        payload=fixture,
        bias=tuple(BIAS),
    )
    # In {S}: f = (f.y_H, -f.x_H, f.z) = (0, -10, -4), tau = (0.12, 0, 0); the fixture's weight
    # adds (0, 0, -2 g) with no moment (its centre of mass is on the sensor's z axis).
    raw = np.array([0.0, -10.0, -4.0 - 2 * G, 0.12, 0.0, 0.0]) + BIAS
    out = Compensator(setup).reading(0.0, "ft_sensor", raw)
    assert out is not None
    np.testing.assert_allclose(out.wrench, EXPECTED_WIRE, atol=1e-12)
    np.testing.assert_allclose(out.response, EXPECTED_RESPONSE, atol=1e-12)


@pytest.fixture(scope="module")
def wrist_cell() -> tuple[RobotModel, np.ndarray, pin.SE3]:
    """The iiwa with its flange pointing straight down at (0.5, 0, 0.3), and {H} placed so that
    the flange (the sensor frame) is at (0, 0, 95 mm) in {H} with axes diag(1, -1, -1)."""
    robot = RobotModel.from_name("iiwa14")
    down = np.diag([1.0, -1.0, -1.0])
    q = solve_ik(robot, pin.SE3(down, np.array([0.5, 0.0, 0.2])), robot.home).q
    flange = robot.flange_in_base(q)
    np.testing.assert_allclose(flange.rotation, down, atol=1e-8)
    sensor_in_hole = pin.SE3(down, np.array([0.0, 0.0, 0.095]))
    return robot, q, flange * sensor_in_hole.inverse()


def test_wrist_sensor_hand_worked(wrist_cell) -> None:
    """The same contact seen from the wrist. The sensor reads the hole's wrench on the peg,
    f = (-10, 0, 4) in {H} at r = (R, 0, -5 mm) - (0, 0, 95 mm) = (R, 0, -0.1) from it:
    tau = r x f = (0, 1 - 0.02, 0). In {S} = diag(1, -1, -1) {H}: f = (-10, 0, -4),
    tau = (0, -0.98, 0). A 0.5 kg peg holder at c = (10, 0, 50) mm in {S}, upside down, weighs
    (0, 0, +0.5 g) in {S} with c x F = (0, -0.01 * 0.5 g, 0)."""
    robot, q, hole_in_base = wrist_cell
    holder = Payload(0.5, (0.01, 0.0, 0.05))
    setup = SensorSetup(
        "wrist",
        hole_in_base=hole_in_base,
        acting_point=tuple(ACTING),
        payload=holder,
        bias=tuple(BIAS),
    )
    raw = np.array([-10.0, 0.0, -4.0 + 0.5 * G, 0.0, -0.98 - 0.01 * 0.5 * G, 0.0]) + BIAS
    comp = Compensator(setup, robot)
    assert comp.joints(0.0, q, np.zeros(7))
    out = comp.reading(0.001, "ft_sensor", raw)
    assert out is not None
    np.testing.assert_allclose(out.wrench, EXPECTED_WIRE, atol=1e-9)
    np.testing.assert_allclose(out.response, EXPECTED_RESPONSE, atol=1e-9)


def test_virtual_sensor_from_joint_torques_hand_worked(wrist_cell) -> None:
    """The same contact through the iiwa's external joint torques, tau_ext = J_S^T w with w the
    hole's wrench on the arm at the sensor frame in base axes ({H} and base share axes here):
    f = (-10, 0, 4), tau = (0, 0.98, 0) as above."""
    robot, q, hole_in_base = wrist_cell
    setup = SensorSetup(
        "wrist", hole_in_base=hole_in_base, acting_point=tuple(ACTING), virtual_damping=1e-6
    )
    comp = Compensator(setup, robot)
    assert comp.joint_torques(0.0, np.zeros(7)) is None  # no joint state yet: counted
    assert comp.counts["no_joint_state"] == 1
    comp.joints(0.0, q)
    tau_ext = robot.jacobian(q, SENSOR_FRAME).T @ np.array([-10.0, 0, 4.0, 0, 0.98, 0])
    out = comp.joint_torques(0.001, tau_ext)
    assert out is not None
    np.testing.assert_allclose(out.response, EXPECTED_RESPONSE, atol=1e-6)


feature_sets = st.tuples(
    st.floats(-2e-4, 2e-4), st.floats(-2e-4, 2e-4), st.floats(1e-3, 9e-3),
    st.floats(-0.02, 0.02), st.floats(-0.02, 0.02),
)  # fmt: skip


@settings(max_examples=40, deadline=None)
@given(feature_sets, st.integers(0, 2**31))
def test_under_hole_round_trip_through_the_contact_model(features, seed) -> None:
    """The contact model's response, seen by a sensor at a random pose under the hole with a
    payload and bias, comes back out of the compensation."""
    rng = np.random.default_rng(seed)
    sensor_in_hole = pin.SE3(
        Rotation.random(random_state=seed).as_matrix(), rng.uniform(-0.05, 0.05, 3)
    )
    hole_in_base = pin.SE3(Rotation.random(random_state=seed + 1).as_matrix(), np.zeros(3))
    fixture = Payload(1.3, tuple(rng.uniform(-0.02, 0.02, 3)))
    response = PEGHOLE.response(features)
    # the wrench about A in {H} axes, seen from {S}: T_S_A = T_S_H T_H_A
    wire = wrench_from_response(response)
    raw_contact = transfer(wire, sensor_in_hole.inverse() * pin.SE3(np.eye(3), ACTING))
    motion = Motion.at_rest(hole_in_base.rotation @ sensor_in_hole.rotation)
    raw = raw_contact + payload_wrench(fixture, motion) + BIAS
    setup = SensorSetup(
        "under_hole",
        pose=sensor_in_hole,
        hole_in_base=hole_in_base,
        acting_point=tuple(ACTING),
        payload=fixture,
        bias=tuple(BIAS),
        guard=UNGUARDED,  # drawn features reach kN: the round trip, not the guard, is tested
    )
    out = Compensator(setup).reading(1.0, "ft_sensor", raw)
    assert out is not None
    np.testing.assert_allclose(out.response, response, atol=1e-9 * (1 + np.abs(response).max()))


def test_moving_wrist_payload_compensates_to_zero(wrist_cell) -> None:
    """A payload with inertia on a wrist sensor moving along q(t) = q0 + v t + a t^2 / 2: the
    joint accelerations are differentiated from the joint velocities, and a pure payload reading
    compensates to zero at every sample."""
    robot, q0, hole_in_base = wrist_cell
    holder = Payload(1.2, (0.01, -0.005, 0.06), ((4e-3, 1e-4, 0), (1e-4, 3e-3, 0), (0, 0, 2e-3)))
    sensor_pose = pose((0, 0, 0.03), (0, 0, 0.4))
    setup = SensorSetup(
        "wrist",
        pose=sensor_pose,
        hole_in_base=hole_in_base,
        acting_point=tuple(ACTING),
        payload=holder,
        bias=tuple(BIAS),
        acceleration_lowpass_hz=0.0,
    )
    comp = Compensator(setup, robot)
    check = RobotModel.from_name("iiwa14")
    check.add_frame("s", sensor_pose)
    v = np.array([0.3, -0.2, 0.4, 0.5, -0.6, 0.7, -0.8])
    a = np.array([1.0, -0.5, 0.8, -1.2, 1.5, -2.0, 2.5])
    for k in range(20):
        t = k * 1e-3
        q, dq = q0 + v * t + a * t * t / 2, v + a * t
        comp.joints(t, q, dq)
        placement, vel, acc = check.frame_motion(q, dq, a, "s")
        motion = Motion(
            placement.rotation.T @ np.array([0, 0, -G]), acc.linear, vel.angular, acc.angular
        )
        out = comp.reading(t, "ft_sensor", payload_wrench(holder, motion) + BIAS)
        assert out is not None
        if k >= 1:  # the first sample has no acceleration estimate yet
            np.testing.assert_allclose(out.wrench, 0.0, atol=1e-9)
    # and the inertial terms matter: ignoring the motion would leave a residual
    static = payload_wrench(holder, Motion(motion.gravity))
    assert np.abs(static - payload_wrench(holder, motion)).max() > 0.1


def test_filters_in_the_pipeline() -> None:
    setup = SensorSetup(acting_point=tuple(ACTING), pose=pose(ACTING), deadband=(0.5, 0.05))
    out = Compensator(setup).reading(0.0, "ft_sensor", EXPECTED_WIRE)
    assert out is not None
    np.testing.assert_allclose(out.response, [9.5, 0.0, 3.5, 0.0, 0.07], atol=1e-12)
    cutoff = 10.0
    comp = Compensator(SensorSetup(lowpass_hz=cutoff))
    comp.reading(0.0, "ft_sensor", np.zeros(6))
    out = comp.reading(1 / (2 * math.pi * cutoff), "ft_sensor", np.ones(6))
    assert out is not None
    np.testing.assert_allclose(out.wrench, 1 - math.exp(-1))


def test_rejected_samples_are_counted_not_propagated() -> None:
    comp = Compensator(SensorSetup())
    assert comp.reading(0.0, "ft_sensor", [0, 0, math.nan, 0, 0, 0]) is None
    assert comp.reading(0.001, "ft_sensor", [0, 0, math.inf, 0, 0, 0]) is None
    assert comp.reading(0.002, "ft_sensor", np.ones(6)) is not None
    assert comp.reading(0.002, "ft_sensor", np.ones(6)) is None  # same stamp
    assert comp.reading(0.001, "ft_sensor", np.ones(6)) is None  # older
    assert comp.counts == {
        "accepted": 1,
        "non_finite": 2,
        "out_of_order": 2,
        "future_stamp": 0,
        "guard": 0,
        "no_joint_state": 0,
        "joint_state_rejected": 0,
        "taring": 0,
    }


def test_a_sample_stamped_in_the_future_is_refused_and_blocks_nothing() -> None:
    """A reading stamped an hour ahead of its arrival (a sensor clock gone wrong): refused and
    counted; the readings after it, stamped right, go through. Taken, its stamp would have made
    every later reading look old."""
    comp = Compensator(SensorSetup())
    assert comp.reading(1.000, "ft_sensor", np.ones(6), received=1.0005) is not None
    assert comp.reading(3601.0, "ft_sensor", np.ones(6), received=1.0015) is None
    late = [comp.reading(1.001 + 1e-3 * k, "ft_sensor", np.ones(6), received=1.0025 + 1e-3 * k)
            for k in range(5)]  # fmt: skip
    assert all(out is not None for out in late)
    assert comp.counts["future_stamp"] == 1 and comp.counts["accepted"] == 6
    # ahead by less than MAX_STAMP_AHEAD (two machines' clocks): taken
    assert comp.reading(1.03, "ft_sensor", np.ones(6), received=1.0) is not None


def test_tare_measures_the_bias_before_contact() -> None:
    """A sensor under the hole, tared on 20 readings without contact: the fixture's weight and
    the bias are measured together, and the contact afterwards comes out exactly."""
    rng = np.random.default_rng(1)
    setup = SensorSetup(pose=pose(ACTING), acting_point=tuple(ACTING), tare_samples=20)
    comp = Compensator(setup)
    at_rest = np.array([0, 0, -2 * G, 0, 0, 0]) + BIAS
    for k in range(20):
        assert comp.reading(k * 1e-3, "ft_sensor", at_rest + rng.normal(0, 1e-3, 6)) is None
    assert comp.counts["taring"] == 20
    np.testing.assert_allclose(comp.bias, at_rest, atol=1e-3)
    out = comp.reading(0.1, "ft_sensor", at_rest + EXPECTED_WIRE)
    assert out is not None
    np.testing.assert_allclose(out.wrench, EXPECTED_WIRE, atol=1e-3)


def test_the_tare_measures_the_noise_floor_as_output() -> None:
    """The spread of the tare's readings, carried into {H} as the output is: a sensor under the
    hole turned a quarter turn about z swaps x and y; the moments about the acting point take
    the forces' noise over its lever. Within the sampling error of 2000 readings (3 %)."""
    rng = np.random.default_rng(4)
    sigma = np.array([0.3, 0.05, 0.1, 0.002, 0.004, 0.001])
    turned = pin.SE3(pin.utils.rotate("z", math.pi / 2), np.zeros(3))
    setup = SensorSetup(pose=turned, acting_point=(0.0, 0.0, -0.02), tare_samples=2000)
    comp = Compensator(setup)
    assert comp.noise is None
    for k in range(2000):
        comp.reading(k * 1e-3, "ft_sensor", BIAS + sigma * rng.standard_normal(6))
    assert comp.noise is not None
    # {H} x = -{S} y, {H} y = {S} x; the moment about the point 2 cm below: m + 0.02 (f x z)
    expected = np.array([0.05, 0.3, 0.1, math.hypot(0.004, 0.02 * 0.3),
                         math.hypot(0.002, 0.02 * 0.05), 0.001])  # fmt: skip
    np.testing.assert_allclose(comp.noise, expected, rtol=0.05)
    untared = Compensator(SensorSetup())
    untared.reading(0.0, "ft_sensor", BIAS)
    assert untared.noise is None  # no tare, nothing measured


def test_frame_mismatch_names_both_frames() -> None:
    comp = Compensator(SensorSetup(frame="ft_sensor"))
    with pytest.raises(InputError, match=r"frame_id='tool0'.*'ft_sensor'"):
        comp.reading(0.0, "tool0", np.zeros(6))


def test_wrist_needs_joints_and_rejects_bad_ones(wrist_cell) -> None:
    robot, q, hole_in_base = wrist_cell
    with pytest.raises(ConfigError, match="robot"):
        Compensator(SensorSetup("wrist"))
    comp = Compensator(SensorSetup("wrist", hole_in_base=hole_in_base), robot)
    assert comp.reading(0.0, "ft_sensor", np.zeros(6)) is None
    assert not comp.joints(0.0, np.full(7, math.nan))
    assert not comp.joints(0.0, q[:6])
    assert comp.joints(0.0, q)
    assert not comp.joints(0.0, q)  # a stamp that does not advance
    assert comp.counts["no_joint_state"] == 1 and comp.counts["joint_state_rejected"] == 3
    with pytest.raises(ConfigError, match="'wrist' for a virtual sensor"):
        Compensator(SensorSetup()).joint_torques(0.0, np.zeros(7))


def test_bad_setup() -> None:
    with pytest.raises(ConfigError, match=r"placement='table'.*under_hole"):
        SensorSetup("table")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="deadband"):
        SensorSetup(deadband=(-1.0, 0.0))
    with pytest.raises(ConfigError, match="bias"):
        SensorSetup(bias=(0.0,) * 5)
    with pytest.raises(ConfigError, match="lowpass_hz"):
        Compensator(SensorSetup(lowpass_hz=-5.0))
