"""Dynamic compensation, part 1 (fbcc_ros.core.compensation.payload): the payload's wrench on the
sensor against hand-worked cases and Pinocchio's rigid-body dynamics, compensation cancelling a
pure payload at any orientation and motion, and the static calibration."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fbcc_ros.core.compensation.payload import (
    GRAVITY_BASE,
    Motion,
    Payload,
    calibrate_dynamic,
    calibrate_static,
    compensate,
    payload_wrench,
    regressor,
)
from fbcc_ros.core.errors import ConfigError, InputError

PEG_HOLDER = Payload(
    0.8, (0.002, -0.001, 0.06), ((2e-3, 1e-5, 0.0), (1e-5, 2e-3, 0.0), (0.0, 0.0, 4e-4))
)

vectors = st.lists(st.floats(-20.0, 20.0), min_size=3, max_size=3).map(np.array)
quaternions = st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(
    lambda q: np.linalg.norm(q) > 0.1
)


def test_weight_at_rest_hand_worked() -> None:
    # 1 kg, 10 cm along +x of a z-up sensor: the weight (0, 0, -g) and, by r x F, +0.98 N m
    # about y.
    wrench = payload_wrench(Payload(1.0, (0.1, 0.0, 0.0)), Motion.at_rest(np.eye(3)))
    np.testing.assert_allclose(wrench, [0, 0, -9.80665, 0, 0.980665, 0], atol=1e-12)
    # Turned upside down (half a turn about x), the same weight reads +g along the sensor's z.
    flipped = payload_wrench(Payload(1.0), Motion.at_rest(np.diag([1.0, -1.0, -1.0])))
    np.testing.assert_allclose(flipped[:3], [0, 0, 9.80665], atol=1e-12)


def _newton_euler(payload: Payload, motion: Motion) -> np.ndarray:
    """The module doc's equations, written out on 3-vectors (the oracle)."""
    c, i_c = np.array(payload.com), np.array(payload.inertia)
    w, dw = motion.angular_velocity, motion.angular_acceleration
    a_c = motion.linear_acceleration + np.cross(dw, c) + np.cross(w, np.cross(w, c))
    force = payload.mass * (motion.gravity - a_c)
    torque = np.cross(c, force) - (i_c @ dw + np.cross(w, i_c @ w))
    return np.concatenate([force, torque])


@settings(max_examples=200, deadline=None)
@given(quaternions, vectors, vectors, vectors)
def test_matches_the_newton_euler_equations(quat, accel, omega, omega_dot) -> None:
    rotation = Rotation.from_quat(quat).as_matrix()
    motion = Motion(rotation.T @ GRAVITY_BASE, accel, omega, omega_dot)
    np.testing.assert_allclose(
        payload_wrench(PEG_HOLDER, motion), _newton_euler(PEG_HOLDER, motion), rtol=1e-10,
        atol=1e-9,
    )


@settings(max_examples=200, deadline=None)
@given(quaternions, vectors, vectors, vectors, vectors)
def test_does_not_depend_on_the_origin_velocity(quat, velocity, accel, omega, omega_dot) -> None:
    """The reaction of the force Pinocchio needs to move the body, f = I a + v x* I v, with a
    moving origin: the spatial acceleration is then a_o - g - omega x v_o, and f the same."""
    rotation = Rotation.from_quat(quat).as_matrix()
    motion = Motion(rotation.T @ GRAVITY_BASE, accel, omega, omega_dot)
    inertia = PEG_HOLDER.spatial
    v = pin.Motion(velocity, omega)
    a = pin.Motion(accel - motion.gravity - np.cross(omega, velocity), omega_dot)
    needed = inertia * a + v.cross(inertia * v)
    np.testing.assert_allclose(
        payload_wrench(PEG_HOLDER, motion), -needed.vector, rtol=1e-10, atol=1e-9
    )


@settings(max_examples=200, deadline=None)
@given(quaternions, vectors, vectors, vectors, vectors)
def test_compensation_cancels_a_pure_payload(quat, accel, omega, omega_dot, bias3) -> None:
    rotation = Rotation.from_quat(quat).as_matrix()
    motion = Motion(rotation.T @ GRAVITY_BASE, accel, omega, omega_dot)
    bias = np.concatenate([bias3, bias3[::-1] * 0.1])
    reading = payload_wrench(PEG_HOLDER, motion) + bias
    np.testing.assert_allclose(compensate(reading, PEG_HOLDER, motion, bias), 0.0, atol=1e-12)


def test_static_calibration_recovers_mass_com_and_bias_from_noisy_poses() -> None:
    rng = np.random.default_rng(2)
    truth = Payload(0.8, (0.002, -0.001, 0.06))
    bias = np.array([1.5, -0.7, 3.0, 0.05, -0.02, 0.01])
    rotations = Rotation.random(24, random_state=3).as_matrix()
    readings = np.array([payload_wrench(truth, Motion.at_rest(r)) for r in rotations]) + bias
    readings += rng.normal(0.0, [0.05] * 3 + [0.002] * 3, size=readings.shape)  # sensor noise
    fit = calibrate_static(rotations, readings)
    assert fit.payload.mass == pytest.approx(0.8, abs=0.01)
    np.testing.assert_allclose(fit.payload.com, truth.com, atol=1e-3)
    np.testing.assert_allclose(fit.bias[:3], bias[:3], atol=0.05)
    np.testing.assert_allclose(fit.bias[3:], bias[3:], atol=0.003)
    assert fit.residual_rms[0] == pytest.approx(0.05, rel=0.3)
    assert fit.condition < 10


def test_calibration_refuses_poses_that_do_not_excite_every_parameter() -> None:
    # Rotations about the vertical only: gravity is always along -z of the sensor, so the mass
    # and the z bias cannot be told apart.
    rotations = Rotation.from_euler("z", np.linspace(0, 3, 10)[:, None]).as_matrix()
    readings = np.array([payload_wrench(PEG_HOLDER, Motion.at_rest(r)) for r in rotations])
    with pytest.raises(InputError, match=r"condition number .* tilt the sensor"):
        calibrate_static(rotations, readings)


@settings(max_examples=200, deadline=None)
@given(quaternions, vectors, vectors, vectors)
def test_regressor_is_linear_in_the_inertial_parameters(quat, accel, omega, omega_dot) -> None:
    """Y(motion) phi reproduces payload_wrench, with I_o = I_c + m (|c|^2 E - c c^T) in
    Pinocchio's order (Ixx, Ixy, Iyy, Ixz, Iyz, Izz)."""
    rotation = Rotation.from_quat(quat).as_matrix()
    motion = Motion(rotation.T @ GRAVITY_BASE, accel, omega, omega_dot)
    m, c, i_c = PEG_HOLDER.mass, np.array(PEG_HOLDER.com), np.array(PEG_HOLDER.inertia)
    i_o = i_c + m * (c @ c * np.eye(3) - np.outer(c, c))
    phi = np.concatenate([[m], m * c, i_o[[0, 0, 1, 0, 1, 2], [0, 1, 1, 2, 2, 2]]])
    np.testing.assert_allclose(
        regressor(motion) @ phi, _newton_euler(PEG_HOLDER, motion), rtol=1e-10, atol=1e-10
    )


def _excitation(n: int, seed: int) -> list[Motion]:
    """A wrist trajectory's motions: every orientation, rates up to 2 rad/s, angular
    accelerations up to 10 rad/s², linear accelerations up to 3 m/s²."""
    rng = np.random.default_rng(seed)
    rotations = Rotation.random(n, random_state=seed).as_matrix()
    return [
        Motion(
            r.T @ GRAVITY_BASE,
            rng.uniform(-3, 3, 3),
            rng.uniform(-2, 2, 3),
            rng.uniform(-10, 10, 3),
        )
        for r in rotations
    ]


def test_dynamic_calibration_recovers_the_inertia_from_a_noisy_trajectory() -> None:
    truth = Payload(
        1.5,
        (0.01, -0.02, 0.08),
        ((0.012, 0.001, -0.002), (0.001, 0.015, 0.0005), (-0.002, 0.0005, 0.006)),
    )
    bias = np.array([1.5, -0.7, 3.0, 0.05, -0.02, 0.01])
    motions = _excitation(400, seed=5)
    readings = np.array([payload_wrench(truth, m) for m in motions]) + bias
    rng = np.random.default_rng(6)
    readings += rng.normal(0.0, [0.05] * 3 + [0.002] * 3, size=readings.shape)
    fit = calibrate_dynamic(motions, readings)
    assert fit.payload.mass == pytest.approx(1.5, abs=0.01)
    np.testing.assert_allclose(fit.payload.com, truth.com, atol=1e-3)
    # the inertia to 0.1 g m² (measured: 0.025 g m², about 0.2-0.4 % of the principal moments)
    np.testing.assert_allclose(fit.payload.inertia, truth.inertia, atol=1e-4)
    np.testing.assert_allclose(fit.bias[:3], bias[:3], atol=0.05)
    np.testing.assert_allclose(fit.bias[3:], bias[3:], atol=0.003)
    assert fit.samples == 400 and fit.condition < 1e3


def test_dynamic_calibration_refuses_a_trajectory_without_rotation() -> None:
    # Static poses: the inertia columns are all zero, nothing identifies it.
    motions = [Motion.at_rest(r) for r in Rotation.random(30, random_state=1).as_matrix()]
    readings = np.array([payload_wrench(PEG_HOLDER, m) for m in motions])
    with pytest.raises(
        InputError, match=r"condition number .*e\+1\d.*rotate the sensor about every axis"
    ):
        calibrate_dynamic(motions, readings)
    with pytest.raises(InputError, match=r"wrenches.*N = 30"):
        calibrate_dynamic(motions, readings[:10])


def test_bad_input() -> None:
    motion = Motion.at_rest(np.eye(3))
    with pytest.raises(InputError, match="wrench"):
        compensate([0, 0, np.nan, 0, 0, 0], PEG_HOLDER, motion, np.zeros(6))
    with pytest.raises(InputError, match="wrench"):
        compensate([0, 0, 0], PEG_HOLDER, motion, np.zeros(6))
    with pytest.raises(ConfigError, match="bias"):
        compensate(np.zeros(6), PEG_HOLDER, motion, np.zeros(3))
    with pytest.raises(ConfigError, match=r"payload\.mass"):
        Payload(-1.0)
    with pytest.raises(ConfigError, match=r"payload\.inertia"):
        Payload(1.0, inertia=((1.0, 0, 0), (0, -1.0, 0), (0, 0, 1.0)))
    with pytest.raises(InputError, match=r"rotations=\(1, 3, 3\).*N >= 3"):
        calibrate_static(np.eye(3)[None], np.zeros((1, 6)))
