"""Wrench transfer, the response vector on the wire, the virtual sensor
(fbcc_ros.core.compensation.wrench) and the output filters (fbcc_ros.core.filters)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fbcc_ros.core.compensation.wrench import (
    response_from_wrench,
    transfer,
    virtual_wrench,
    wrench_from_response,
)
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.filters import LowPass, dead_band
from fbcc_ros.core.kinematics.robot import RobotModel

finite = st.floats(-5.0, 5.0)
vec3 = st.tuples(finite, finite, finite).map(np.array)


@settings(max_examples=100, deadline=None)
@given(vec3, vec3, vec3, vec3, st.integers(0, 2**31))
def test_transfer_matches_pinocchio_force_action(f, tau, origin, point, seed) -> None:
    """Independent check: Pinocchio's SE3 action on a Force, then the moment shifted by the
    point, equals transfer()."""
    placement = pin.SE3(Rotation.random(random_state=seed).as_matrix(), origin)
    at_origin = placement.act(pin.Force(f, tau))
    shifted = pin.SE3(np.eye(3), point).actInv(at_origin)
    np.testing.assert_allclose(
        transfer(np.concatenate([f, tau]), placement, point), shifted.vector, atol=1e-12
    )


def test_transfer_hand_worked_lever() -> None:
    # 10 N along +x at 0.1 m above the new point: a moment of +1 N m about y (r x F).
    out = transfer([10, 0, 0, 0, 0, 0], pin.SE3(np.eye(3), np.array([0, 0, 0.1])))
    np.testing.assert_allclose(out, [10, 0, 0, 0, 1.0, 0])


def test_response_sign_on_the_wire() -> None:
    """A centred peg pushed into an interference fit drags the hole down: on the wire fz < 0,
    in the response vector Fz = -fz > 0 (eq. 11)."""
    peghole = PegHole(5e-3, 5.02e-3, 0.01, 0.005, 0.2, 1.8e8)
    response = peghole.response([0, 0, 0.005, 0, 0])
    wire = wrench_from_response(response)
    assert response[2] > 0 and wire[2] == -response[2]
    np.testing.assert_array_equal(response_from_wrench(wire), response)


@pytest.fixture(scope="module")
def iiwa() -> RobotModel:
    return RobotModel.from_name("iiwa14")


def test_virtual_sensor_recovers_the_wrench_from_joint_torques(iiwa: RobotModel) -> None:
    rng = np.random.default_rng(3)
    jac = iiwa.jacobian(iiwa.home, "peg")
    for _ in range(20):
        wrench = rng.normal(0, [20, 20, 20, 2, 2, 2])
        tau = jac.T @ wrench  # tau_ext = J^T w
        np.testing.assert_allclose(virtual_wrench(jac, tau, 0.0), wrench, atol=1e-9)
        # the default damping biases a well-conditioned pose by well under 1 %
        damped = virtual_wrench(jac, tau, 0.01)
        assert np.linalg.norm(damped - wrench) < 0.01 * np.linalg.norm(wrench)


def test_virtual_sensor_stays_bounded_at_a_singularity(iiwa: RobotModel) -> None:
    # q = 0: the arm is stretched upright, axes 1, 3, 5 and 7 align; J^T loses rank.
    jac = iiwa.jacobian(np.zeros(7), "peg")
    assert np.linalg.matrix_rank(jac, tol=1e-9) < 6
    tau = np.array([0.5, 1.0, -0.5, 2.0, 0.1, -0.3, 0.2])
    assert np.linalg.cond(jac @ jac.T) > 1e12  # undamped, the inverse would amplify noise
    wrench = virtual_wrench(jac, tau, 0.01)
    assert np.isfinite(wrench).all()
    # bounded by |J tau| / lambda^2 (the damped inverse's largest gain is 1 / lambda^2)
    assert np.linalg.norm(wrench) <= np.linalg.norm(jac @ tau) / 0.01**2


def test_virtual_sensor_bad_input(iiwa: RobotModel) -> None:
    jac = iiwa.jacobian(iiwa.home, "peg")
    with pytest.raises(InputError, match=r"external_torques.*7 values"):
        virtual_wrench(jac, np.zeros(6), 0.01)
    with pytest.raises(InputError, match="finite joint torques"):
        virtual_wrench(jac, [0, 0, math.nan, 0, 0, 0, 0], 0.01)
    with pytest.raises(ConfigError, match=r"virtual_sensor\.damping"):
        virtual_wrench(jac, np.zeros(7), -1.0)


# --- filters -----------------------------------------------------------------------------------


def test_low_pass_follows_the_continuous_step_response_at_any_sample_spacing() -> None:
    """After a unit step at t = 0 the first-order filter is 1 - exp(-2 pi f_c t), whatever the
    sample times (regular 1 kHz or irregular, as over DDS)."""
    cutoff = 5.0
    rng = np.random.default_rng(0)
    for times in (np.arange(0, 0.2, 1e-3), np.cumsum(rng.uniform(2e-4, 3e-3, 150))):
        lowpass = LowPass(cutoff)
        lowpass(np.zeros(2), 0.0)  # at rest before the step
        t_prev = 0.0
        for t in times:
            y = lowpass(np.ones(2), t - t_prev)
            t_prev = t
        np.testing.assert_allclose(y, 1 - math.exp(-2 * math.pi * cutoff * times[-1]), atol=1e-12)
    # one time constant gives 63.2 %
    lowpass = LowPass(cutoff)
    lowpass(0.0, 0.0)
    assert float(lowpass(1.0, 1 / (2 * math.pi * cutoff))) == pytest.approx(1 - math.exp(-1))


def test_low_pass_off_passes_through_and_bad_cutoffs() -> None:
    lowpass = LowPass(0.0)
    for x in (1.0, -3.0, 7.5):
        assert float(lowpass(x, 1e-3)) == x
    for bad in (-1.0, math.inf, math.nan):
        with pytest.raises(ConfigError, match=r"lowpass_hz.*cut-off"):
            LowPass(bad)


def test_dead_band_is_continuous_and_zero_inside() -> None:
    band = np.array([0.5, 0.05])
    np.testing.assert_allclose(dead_band([0.3, 0.04], band), [0, 0])
    np.testing.assert_allclose(dead_band([2.0, -0.15], band), [1.5, -0.10])
    # no step at the edge
    edge = dead_band([0.5 + 1e-9, -(0.05 + 1e-9)], band)
    assert np.abs(edge).max() < 2e-9


def test_a_wrench_about_the_hole_origin_reads_as_the_response_at_the_acting_point() -> None:
    """The compensation publishes about the {H} origin; the controller moves the moments to
    the acting point: the docs' hand-worked contact (10 N along +x and 4 N of friction down at
    (R, 0, -5 mm), R = 5 mm) about A = (0, 0, -15 mm) has the moment (0, 0.12, 0) N m."""
    at = np.array([0.005, 0.0, -0.005])
    f = np.array([10.0, 0.0, -4.0])
    about_origin = np.r_[f, np.cross(at, f)]
    acting = np.array([0.0, 0.0, -0.015])
    response = response_from_wrench(about_origin, acting)
    np.testing.assert_allclose(response, [10.0, 0.0, 4.0, 0.0, 0.12], atol=1e-12)
    np.testing.assert_allclose(response[3:], np.cross(at - acting, f)[:2], atol=1e-15)
    # about the origin (no point given): the moment of the same contact there
    np.testing.assert_allclose(response_from_wrench(about_origin)[3:], np.cross(at, f)[:2])
    # and back: the wire wrench about the origin of the response at the acting point
    back = wrench_from_response(response, about_origin[5], acting)
    np.testing.assert_allclose(back, about_origin, atol=1e-15)
