"""The arm's own sensing of a contact (fbcc_ros.core.sim.arm_sensing), in the mock cell: the
external and measured joint torques give back, through the compensation's virtual sensor, the
wrench the peg exerts on the hole; the stack's estimated wrench is that wrench at the flange,
shrunk by its damping and dead band as the stack's code does it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

from fbcc_ros.core.compensation.wrench import wrench_from_response
from fbcc_ros.core.kinematics.cell import CellKinematics
from fbcc_ros.core.kinematics.ik import solve_ik
from fbcc_ros.core.sim import arm_sensing
from fbcc_ros.pipeline.compensation import TABLE as COMPENSATION
from fbcc_ros.pipeline.compensation import CompensationStage
from fbcc_ros.pipeline.mock_cell import TABLE as MOCK
from fbcc_ros.pipeline.mock_cell import MockStage
from fbcc_ros.pipeline.parameters import resolve

ROOT = Path(__file__).resolve().parents[3]
#: Where the peg is pushed: 2 mm into the interference fit, off-centre and tilted, so every
#: component of the wrench is there.
FEATURES = np.array([2e-5, -1e-5, 2e-3, 1e-3, -5e-4])


@pytest.fixture(scope="module")
def pressed(tmp_path_factory: pytest.TempPathFactory) -> tuple[MockStage, object, np.ndarray]:
    """The mock (hole where it is believed, no torque noise) holding the peg at FEATURES, its
    last sample and the wrench the peg exerts on the hole about the {H} origin, {H} axes."""
    data = yaml.safe_load((ROOT / "config/scenarios/bringup_interference.yaml").read_text())
    data["initial"] = {"dx": 0.0, "dy": 0.0, "theta_x": 0.0, "theta_y": 0.0}
    path = tmp_path_factory.mktemp("sc") / "aligned.yaml"
    path.write_text(yaml.safe_dump(data))
    stage = MockStage(resolve("mock_cell", MOCK, {"scenario": str(path), "torque_noise": 0.0,
                                                  "conventions": "lbr"}))  # fmt: skip
    cell = stage.cell
    kin = CellKinematics(cell.robot, cell.truth.hole_in_base, cell.sc.geometry.peg_radius)
    cell.command(solve_ik(cell.robot, kin.peg_target(FEATURES, 0.0), cell.q).q)
    for _ in range(3000):
        sample = cell.step(1e-3)
    on_hole = cell._to_origin @ wrench_from_response(sample.response)
    assert np.linalg.norm(on_hole[:3]) > 10.0  # pressed into the interference fit
    return stage, sample, on_hole


def test_the_external_torques_are_the_contact_through_the_jacobian(pressed) -> None:
    stage, sample, on_hole = pressed
    robot = stage.cell.robot
    flange = robot.flange_in_base(sample.q)
    on_peg = arm_sensing.wrench_at_frame(-on_hole, stage.cell.truth.hole_in_base, flange)
    jac = robot.jacobian(sample.q, robot.flange_frame, pin.LOCAL_WORLD_ALIGNED)
    np.testing.assert_allclose(stage.cell.external_torques(), jac.T @ on_peg, atol=1e-12)
    # the moment moved by hand: about the flange, tau_F = tau_O + (p_O - p_F) x f
    f = stage.cell.truth.hole_in_base.rotation @ -on_hole[:3]
    lever = stage.cell.truth.hole_in_base.translation - flange.translation
    expected = stage.cell.truth.hole_in_base.rotation @ -on_hole[3:] + np.cross(lever, f)
    np.testing.assert_allclose(on_peg[3:], expected, atol=1e-12)


@pytest.mark.parametrize("torques", ["external", "measured"])
def test_the_virtual_sensor_gives_back_the_wrench_on_the_hole(pressed, torques: str) -> None:
    """With no damping the damped least squares is the exact inverse: the compensation of a
    virtual sensor at the flange (no payload) returns the peg's wrench on the hole."""
    stage, sample, on_hole = pressed
    robot = stage.cell.robot
    hole = stage.cell.truth.hole_in_base
    # the arm under the LBR stack's names, from the description the mock latches
    values = resolve("dynamic_compensation", COMPENSATION, {
        "robot": "robot_description", "placement": "wrist", "virtual_sensor": True,
        "tare_samples": 0,
        "joint_torques": torques, "virtual_damping": 0.0, "sensor_xyz": [0.0, 0.0, 0.0],
        "hole_from_home": False, "hole_xyz": hole.translation.tolist(),
        "hole_rpy": pin.rpy.matrixToRpy(hole.rotation).tolist()})  # fmt: skip
    comp = CompensationStage(values, robot.urdf_text)
    reading = stage.arm_sensing(sample, estimate=False)
    out = None
    for k in range(3):  # joint states first: the wrist sensor's pose
        t = 1.0 + k * 1e-3
        if torques == "measured":
            out = comp.measured_torques(t, sample.q, np.zeros(7), reading.measured)
        else:
            comp.joints(t, sample.q, np.zeros(7))
            out = comp.torques(t, reading.external)
    assert out is not None
    np.testing.assert_allclose(out.wrench, on_hole, rtol=0.0, atol=1e-6 * np.abs(on_hole).max())


def test_the_stacks_estimate_shrinks_by_its_damping_and_dead_band(pressed) -> None:
    stage, sample, on_hole = pressed
    robot = stage.cell.robot
    q, frame, tau_ext = sample.q, robot.flange_frame, stage.cell.external_torques()
    flange = robot.flange_in_base(q)
    exact_base = arm_sensing.wrench_at_frame(-on_hole, stage.cell.truth.hole_in_base, flange)
    exact = np.concatenate([flange.rotation.T @ exact_base[:3],
                            flange.rotation.T @ exact_base[3:]])  # fmt: skip
    undamped = arm_sensing.estimated_wrench(robot, q, tau_ext, frame, 0.0, (0.0,) * 6)
    np.testing.assert_allclose(undamped, exact, atol=1e-9 * np.abs(exact).max())
    stack = arm_sensing.estimated_wrench(robot, q, tau_ext, frame)
    damped = arm_sensing.estimated_wrench(robot, q, tau_ext, frame, 0.2, (0.0,) * 6)
    # the stack's pinv (lbr_fri_ros2/pinv.hpp): V diag(s / (s^2 + lambda^2)) U^T, then
    # w = pinv(J)^T tau_ext, at the flange in base axes
    u, sv, vt = np.linalg.svd(robot.jacobian(q, frame, pin.LOCAL_WORLD_ALIGNED))
    pinv = vt.T[:, :6] @ np.diag(sv / (sv**2 + 0.2**2)) @ u.T
    by_svd = pinv.T @ tau_ext
    np.testing.assert_allclose(damped[:3], flange.rotation.T @ by_svd[:3], atol=1e-9)
    np.testing.assert_allclose(damped[3:], flange.rotation.T @ by_svd[3:], atol=1e-9)
    # its damping is no small correction here: docs/integration.md gives the figure
    assert np.linalg.norm(damped - exact) > 0.1 * np.linalg.norm(exact)
    # the dead band, in base axes, component by component: sign(x) max(|x| - th, 0)
    base = np.concatenate([flange.rotation @ damped[:3], flange.rotation @ damped[3:]])
    band = np.array(arm_sensing.LBR_DEADBAND)
    banded = np.sign(base) * np.maximum(np.abs(base) - band, 0.0)
    np.testing.assert_allclose(stack[:3], flange.rotation.T @ banded[:3], atol=1e-12)
    np.testing.assert_allclose(stack[3:], flange.rotation.T @ banded[3:], atol=1e-12)
    assert (np.abs(base) < band).any() and (banded[np.abs(base) < band] == 0.0).all()
