"""The LBR carrying the peg over the hole, one MuJoCo model, against our kinematics and physics:
the peg is where Pinocchio puts it and stays there under gravity; what the arm's joints feel of
the contact is J^T of the wrench on the hole; a position-mode insertion through the mock cell
goes in without force; a sideways push meets the compliance of the joints and of the grip in
series."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from fbcc_ros.core.compensation.wrench import transfer_matrix, wrench_from_response
from fbcc_ros.core.kinematics.cell import CellKinematics
from fbcc_ros.core.kinematics.ik import solve_ik
from fbcc_ros.core.kinematics.robot import RobotModel
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.arm_sensing import external_torques, wrench_at_frame
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.mock_cell import MockCell
from fbcc_ros.core.sim.plants.mujoco_cell import MujocoCell
from fbcc_ros.core.sim.plants.mujoco_scene import Contact, MujocoPegHole, Part
from fbcc_ros.core.sim.plants.spec import PlantSpec

#: A hole tilted 0.1 rad about the base's x, in front of the arm: gravity is not along {H}'s z.
HOLE = pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.0, 0.0), np.array([0.55, 0.1, 0.15]))
GRIP = Holder(5.0e4, 30.0)


def _clearance_pair() -> scenario_io.Scenario:
    return scenario_io.load(scenario_io.find("config/scenarios/fig9_clearance.yaml"))


def _cell(robot: RobotModel, features: np.ndarray) -> tuple[MujocoCell, CellKinematics]:
    pair = _clearance_pair().geometry
    kin = CellKinematics(robot, HOLE, pair.peg_radius)
    q = solve_ik(robot, kin.peg_target(features, 0.0), robot.home).q
    return MujocoCell(robot, HOLE, q, pair, GRIP, Part(), Contact(), 1e-3), kin


@pytest.mark.parametrize("name", ["iiwa14", "med7"])
def test_the_peg_is_where_pinocchio_puts_it_and_stays_there(name: str) -> None:
    robot = RobotModel.from_name(name)
    above = np.array([2e-5, -1e-5, -2e-3, 0.01, -0.02])  # 2 mm over the hole, tilted
    cell, kin = _cell(robot, above)
    q0 = cell.scene.data.qpos[cell._qpos].copy()
    np.testing.assert_allclose(cell.scene.features(), kin.features(q0), atol=1e-12)
    for _ in range(200):  # 0.2 s held: gravity (along the base's -z) is compensated
        q, x, response = cell.step()
    np.testing.assert_allclose(q, q0, atol=1e-9)
    np.testing.assert_allclose(x, above, atol=1e-9)
    assert not response.any() and not cell.external_torques().any()


def test_what_the_joints_feel_is_the_contact_through_the_jacobian() -> None:
    """The peg 3 mm in the bore, the joints commanded 0.1 mm sideways into the wall: at rest,
    MuJoCo's constraint torques at the arm's joints are J^T of the hole's wrench on the peg
    moved to the flange (arm_sensing, as the mock computes them for the model)."""
    robot = RobotModel.from_name("iiwa14")
    cell, kin = _cell(robot, np.array([0.0, 0.0, 3e-3, 0.0, 0.0]))
    q0 = cell.scene.data.qpos[cell._qpos].copy()
    cell.command(kin.tcp_solution(np.array([1e-4, 0.0, 3e-3, 0.0, 0.0]), q0).q)
    for _ in range(400):
        q, _x, response = cell.step()
    pair = _clearance_pair().geometry
    on_hole = wrench_from_response(response)  # at the acting point, {H} axes
    acting = pin.SE3(np.eye(3), pair.acting_point_in_hole())
    at_origin = transfer_matrix(acting) @ on_hole
    assert abs(at_origin[0]) > 0.5  # pressed on the wall
    on_peg = wrench_at_frame(-at_origin, HOLE, robot.flange_in_base(q))
    expected = external_torques(robot, q, robot.flange_frame, on_peg)
    np.testing.assert_allclose(cell.external_torques(), expected, rtol=0.02,
                               atol=0.02 * np.abs(expected).max())  # fmt: skip


def test_a_sideways_push_meets_the_joints_and_the_grip_in_series() -> None:
    """Commanded 0.1 mm into the wall, the hand held by the arm's joints does not get there
    (they give way under the load) and presses the wall less than a hand that is rigidly where
    it is told (the scene alone, the same grip): the joints' compliance is in series with the
    grip's."""
    robot = RobotModel.from_name("iiwa14")
    push = np.array([1e-4, 0.0, 3e-3, 0.0, 0.0])
    cell, kin = _cell(robot, np.array([0.0, 0.0, 3e-3, 0.0, 0.0]))
    q0 = cell.scene.data.qpos[cell._qpos].copy()
    cell.command(kin.tcp_solution(push, q0).q)
    for _ in range(400):
        q, _x, response = cell.step()
    rigid = MujocoPegHole(_clearance_pair().geometry, GRIP)
    rigid.place(np.array([0.0, 0.0, 3e-3, 0.0, 0.0]))
    rigid.set_hand(push)
    rigid.step(400 * round(1e-3 / rigid.dt))
    alone = rigid.mean_wrench_on_hole()[0]
    assert abs(alone) > 0.5
    assert 0.3 * abs(alone) < abs(response[0]) < 0.95 * abs(alone)
    reached = kin.features(q)[0]
    assert 0.3 * push[0] < reached < 0.95 * push[0]


def test_the_mock_cell_on_mujoco_inserts_an_aligned_peg_without_force() -> None:
    """The mock cell with ``plant: mujoco``: the LBR in MuJoCo, commanded down the hole's axis
    at 10 mm/s, takes the peg 3 mm in with an axial force under 0.5 N (the issue's free
    insertion), its joints following their commands within the servo's lag."""
    sc = _clearance_pair()
    sc = dataclasses.replace(sc, initial=np.zeros(5), plant=PlantSpec(type="mujoco"),
                             holder=GRIP)  # fmt: skip
    robot = RobotModel.from_name("iiwa14")
    cell = MockCell(sc, robot, HOLE, dt=1e-3)
    assert cell.mujoco is not None and cell.contact is None
    q = cell.q
    peak = 0.0
    for k in range(1, 501):
        depth = min(0.01 * k * 1e-3, 3e-3)
        q = cell.believed.tcp_solution(np.array([0.0, 0.0, depth, 0.0, 0.0]), q).q
        cell.command(q)
        sample = cell.step(1e-3)
        peak = max(peak, abs(sample.response[2]))
    assert sample.features[2] == pytest.approx(3e-3, abs=2e-5)
    assert peak < 0.5
    assert np.abs(sample.q - q).max() < 1e-4
