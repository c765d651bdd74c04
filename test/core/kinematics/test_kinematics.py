"""Robot kinematics (fbcc_ros.core.kinematics: robot, ik, cell): the iiwa model against its
published kinematics, Jacobians against finite differences, the feature and TCP solutions, IK
round trips and refusals on the iiwa, Panda and UR5, and the errors on bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation

from fbcc_ros.core.contact.features import pose_from_features
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.kinematics.cell import CellKinematics, aligned_hole_at, follow
from fbcc_ros.core.kinematics.ik import IkError, solve_ik
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel, Tool, pose

ROBOT_NAMES = ["iiwa14", "panda", "ur5"]
PEG_RADIUS = 5.04e-3

# The LBR iiwa 14 R820 from KUKA's data sheet (the URDF header's [1] and [3]), as a product of
# exponentials: joint axes at the zero pose (unit direction, a point on the axis) in the base
# frame, and the flange 0.360 + 0.420 + 0.400 + 0.126 = 1.306 m above the base, parallel to it.
IIWA_SCREWS = [
    ((0, 0, 1), (0, 0, 0)),
    ((0, 1, 0), (0, 0, 0.36)),
    ((0, 0, 1), (0, 0, 0)),
    ((0, -1, 0), (0, 0, 0.78)),
    ((0, 0, 1), (0, 0, 0)),
    ((0, 1, 0), (0, 0, 1.18)),
    ((0, 0, 1), (0, 0, 0)),
]
IIWA_FLANGE_AT_ZERO = 1.306


def _published_flange_pose(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """T_base_flange(q) = exp([S1] q1) ... exp([S7] q7) M."""
    rot, pos = np.eye(3), np.zeros(3)
    for (axis, point), angle in zip(IIWA_SCREWS, q, strict=True):
        r = Rotation.from_rotvec(np.asarray(axis, float) * angle).as_matrix()
        t = (np.eye(3) - r) @ np.asarray(point, float)  # rotation about an axis through `point`
        rot, pos = rot @ r, rot @ t + pos
    return rot, rot @ [0.0, 0.0, IIWA_FLANGE_AT_ZERO] + pos


@pytest.fixture(scope="module", params=ROBOT_NAMES)
def robot(request: pytest.FixtureRequest) -> RobotModel:
    return RobotModel.from_name(request.param)


@pytest.fixture(scope="module")
def iiwa() -> RobotModel:
    return RobotModel.from_name("iiwa14")


def _random_configurations(robot: RobotModel, n: int, seed: int) -> np.ndarray:
    """Seeded configurations inside the limits, within +-pi so a 2 pi range stays unambiguous."""
    rng = np.random.default_rng(seed)
    lo, hi = np.maximum(robot.lower, -math.pi), np.minimum(robot.upper, math.pi)
    return rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), size=(n, robot.nq))


def _pose_error(a: pin.SE3, b: pin.SE3) -> tuple[float, float]:
    err = pin.log6(a.actInv(b)).vector
    return float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:]))


# --- The iiwa model against its published kinematics ----------------------------------------


def test_iiwa_flange_is_1306_mm_above_the_base_at_zero(iiwa: RobotModel) -> None:
    flange = iiwa.flange_in_base(np.zeros(7))
    np.testing.assert_allclose(flange.translation, [0.0, 0.0, 1.306], atol=1e-9)
    np.testing.assert_allclose(flange.rotation, np.eye(3), atol=1e-9)


@pytest.mark.parametrize(
    ("q", "flange_position"),
    [
        # A2 = +90°: everything above the shoulder (0.36 m) lies along +x, 0.42 + 0.40 + 0.126.
        ([0, math.pi / 2, 0, 0, 0, 0, 0], [0.946, 0.0, 0.36]),
        # A4 = +90° about -y: the forearm from the elbow (0.78 m) points along -x.
        ([0, 0, 0, math.pi / 2, 0, 0, 0], [-0.526, 0.0, 0.78]),
        # Add A6 = -90° about +y: the 0.126 m hand turns from -x to -z, so the flange is at
        # (-0.40, 0, 0.78 - 0.126); A1 = +90° about z then carries -x to -y.
        ([math.pi / 2, 0, 0, math.pi / 2, 0, -math.pi / 2, 0], [0.0, -0.40, 0.654]),
    ],
)
def test_iiwa_flange_at_bent_configurations(iiwa: RobotModel, q, flange_position) -> None:
    # Positions worked by hand from the data sheet's offsets; the orientation from the
    # product of exponentials of the same data.
    rot, pos = _published_flange_pose(np.asarray(q, float))
    np.testing.assert_allclose(pos, flange_position, atol=1e-12)
    flange = iiwa.flange_in_base(q)
    np.testing.assert_allclose(flange.translation, flange_position, atol=1e-9)
    np.testing.assert_allclose(flange.rotation, rot, atol=1e-9)


def test_iiwa_matches_its_published_kinematics_at_random_configurations(iiwa: RobotModel) -> None:
    for q in _random_configurations(iiwa, 50, seed=4):
        rot, pos = _published_flange_pose(q)
        flange = iiwa.flange_in_base(q)
        np.testing.assert_allclose(flange.translation, pos, atol=1e-9)
        np.testing.assert_allclose(flange.rotation, rot, atol=1e-9)


def test_iiwa_limits_and_masses_are_the_published_ones(iiwa: RobotModel) -> None:
    deg = np.radians
    np.testing.assert_allclose(iiwa.upper, deg([170, 120, 170, 120, 170, 120, 175]), rtol=1e-9)
    np.testing.assert_allclose(iiwa.lower, -iiwa.upper)
    np.testing.assert_allclose(
        iiwa.velocity_limit, deg([85, 85, 100, 75, 130, 135, 135]), rtol=1e-9
    )
    np.testing.assert_allclose(iiwa.model.effortLimit, [320, 320, 176, 176, 110, 40, 40])
    total = sum(inertia.mass for inertia in iiwa.model.inertias)
    assert total == pytest.approx(29.9, abs=1.0)  # KUKA: 29.9 kg; the URDF header explains 30.6


# --- Jacobians -------------------------------------------------------------------------------


@pytest.mark.parametrize("frame", ["peg", "flange"])
def test_jacobian_matches_finite_differences(robot: RobotModel, frame: str) -> None:
    name = "peg" if frame == "peg" else robot.flange_frame
    fid = robot.model.getFrameId(name)
    h = 1e-6
    for q in _random_configurations(robot, 10, seed=7):
        jac = robot.jacobian(q, name)
        numeric = np.zeros_like(jac)
        for i in range(robot.nq):
            plus, minus = q.copy(), q.copy()
            plus[i] += h
            minus[i] -= h
            a = _frame_pose(robot, plus, fid)
            b = _frame_pose(robot, minus, fid)
            numeric[:3, i] = (a.translation - b.translation) / (2 * h)
            # angular velocity in base axes: log3(R+ R-^T) / 2h
            numeric[3:, i] = pin.log3(a.rotation @ b.rotation.T) / (2 * h)
        np.testing.assert_allclose(jac, numeric, atol=1e-8)


def _frame_pose(robot: RobotModel, q: np.ndarray, fid: int) -> pin.SE3:
    pin.forwardKinematics(robot.model, robot.data, q)
    return pin.updateFramePlacement(robot.model, robot.data, fid).copy()


def test_frame_motion_matches_finite_differences_along_a_trajectory() -> None:
    """Velocity and classical acceleration of an added wrist-sensor frame, in its own axes,
    against central differences of FK along q(t) = q0 + v t + a t^2 / 2."""
    robot = RobotModel.from_name("iiwa14")
    robot.add_frame("sensor", pose((0.01, -0.02, 0.03), (0.3, -0.2, 1.0)))
    rng = np.random.default_rng(11)
    for q0 in _random_configurations(robot, 5, seed=12):
        v, a = rng.uniform(-1, 1, robot.nq), rng.uniform(-2, 2, robot.nq)
        placement, velocity, accel = robot.frame_motion(q0, v, a, "sensor")
        h = 1e-4
        poses = [robot.frame_in_base(q0 + v * t + a * t * t / 2, "sensor") for t in (-h, 0, h)]
        rot = placement.rotation
        assert np.allclose(poses[1].homogeneous, placement.homogeneous)
        lin_v = (poses[2].translation - poses[0].translation) / (2 * h)
        lin_a = (poses[2].translation - 2 * poses[1].translation + poses[0].translation) / h**2
        np.testing.assert_allclose(velocity.linear, rot.T @ lin_v, atol=1e-6)
        np.testing.assert_allclose(accel.linear, rot.T @ lin_a, atol=1e-5)
        omega = pin.log3(poses[2].rotation @ poses[0].rotation.T) / (2 * h)
        np.testing.assert_allclose(velocity.angular, rot.T @ omega, atol=1e-6)
        # omega_dot in own axes is R^T d(omega_base)/dt, omega_base = J(q(t)) q'(t) (J checked)
        omegas = [
            robot.jacobian(q0 + v * t + a * t * t / 2, "sensor")[3:] @ (v + a * t) for t in (-h, h)
        ]
        np.testing.assert_allclose(
            accel.angular, rot.T @ (omegas[1] - omegas[0]) / (2 * h), atol=1e-6
        )


def test_added_frames_and_unknown_frames(iiwa: RobotModel) -> None:
    robot = RobotModel.from_name("iiwa14")
    offset = pose((0.0, 0.0, 0.035))
    robot.add_frame("sensor", offset)
    q = robot.home
    expected = robot.flange_in_base(q) * offset
    assert np.allclose(robot.frame_in_base(q, "sensor").homogeneous, expected.homogeneous)
    robot.add_frame("sensor", pose((0.0, 0.0, 0.05)))  # moved, not duplicated
    assert robot.frame_in_base(q, "sensor").translation[2] != expected.translation[2]
    with pytest.raises(ConfigError, match=r"frame='nowhere'.*iiwa_flange"):
        robot.frame_in_base(q, "nowhere")
    with pytest.raises(ConfigError, match="frame='peg'"):
        robot.add_frame("peg", offset)


# --- IK round trips and refusals -------------------------------------------------------------


def test_ik_round_trip_on_random_reachable_targets(robot: RobotModel) -> None:
    rng = np.random.default_rng(11)
    for q_true in _random_configurations(robot, 40, seed=12):
        target = robot.peg_in_base(q_true)
        start = np.clip(q_true + rng.uniform(-0.1, 0.1, robot.nq), robot.lower, robot.upper)
        solution = solve_ik(robot, target, start)
        position_error, rotation_error = _pose_error(robot.peg_in_base(solution.q), target)
        assert position_error <= 1e-6 and rotation_error <= 1e-6
        assert robot.within_limits(solution.q)


def test_ik_for_one_control_period_stays_within_the_velocity_limits(robot: RobotModel) -> None:
    dt = 1e-3
    q = robot.home.copy()
    rng = np.random.default_rng(3)
    for _ in range(50):
        # A step as large as the controller commands at its fastest: 5 µm and 50 µrad.
        nudge = pin.SE3(pin.exp3(rng.normal(size=3) * 3e-5), rng.normal(size=3) * 3e-6)
        target = robot.peg_in_base(q) * nudge
        solution = solve_ik(robot, target, q, dt=dt)
        assert solution.iterations <= 3
        assert np.all(np.abs(solution.q - q) <= robot.velocity_limit * dt + 1e-15)
        position_error, rotation_error = _pose_error(robot.peg_in_base(solution.q), target)
        assert position_error <= 1e-6 and rotation_error <= 1e-6
        q = solution.q


def test_ik_refuses_a_target_out_of_reach(robot: RobotModel) -> None:
    target = robot.peg_in_base(robot.home)
    target.translation = target.translation + np.array([3.0, 0.0, 0.0])
    with pytest.raises(IkError, match=r"out of reach|held by") as info:
        solve_ik(robot, target, robot.home)
    assert info.value.position_error > 1.0


def test_ik_refuses_a_step_beyond_the_velocity_limits(robot: RobotModel) -> None:
    target = robot.peg_in_base(robot.home)
    target.translation = target.translation + np.array([0.0, 0.0, 0.05])  # 5 cm in one millisecond
    with pytest.raises(IkError, match=r"velocity limit") as info:
        solve_ik(robot, target, robot.home, dt=1e-3)
    assert info.value.position_error > 0.04
    # Without the one-period bound the same target is reachable.
    assert solve_ik(robot, target, robot.home).position_error <= 1e-8


def test_iiwa_ik_refuses_a_pose_that_needs_the_elbow_beyond_its_limit(iiwa: RobotModel) -> None:
    # The shoulder-wrist distance of the iiwa depends on |q4| alone, so a pose made with q4 = 2.6
    # rad (limit 2.094) has no solution inside the limits, whatever the redundancy does.
    q_beyond = np.array([0.3, 0.4, 0.2, 2.6, 0.1, -0.5, 0.0])
    target = _frame_pose(iiwa, q_beyond, iiwa.peg_id)
    start = np.array([0.3, 0.4, 0.2, 1.9, 0.1, -0.5, 0.0])
    with pytest.raises(IkError, match=r"iiwa_joint_4 at its upper position limit") as info:
        solve_ik(iiwa, target, start)
    assert info.value.position_error > 1e-3


def test_ik_refuses_a_start_outside_the_limits(iiwa: RobotModel) -> None:
    q = iiwa.home.copy()
    q[3] = -2.5
    with pytest.raises(InputError, match=r"iiwa_joint_4"):
        solve_ik(iiwa, iiwa.peg_in_base(iiwa.home), q)


# --- The cell: feature solution and TCP solution ----------------------------------------------


def _cell_over_the_hole(robot: RobotModel, depth: float = 0.002) -> CellKinematics:
    """A hole under the peg at home: the peg aligned and `depth` inserted."""
    peg_at_home = robot.peg_in_base(robot.home)
    hole = peg_at_home * pin.SE3(np.diag([1.0, -1.0, -1.0]), np.array([0.0, 0.0, -depth]))
    return CellKinematics(robot, hole, PEG_RADIUS)


def test_feature_solution_at_home_over_the_hole(robot: RobotModel) -> None:
    cell = _cell_over_the_hole(robot, depth=0.002)
    np.testing.assert_allclose(cell.features(robot.home), [0, 0, 0.002, 0, 0], atol=1e-12)


def test_features_to_joints_to_features_round_trip(robot: RobotModel) -> None:
    cell = _cell_over_the_hole(robot)
    rng = np.random.default_rng(5)
    for _ in range(20):
        x_c = np.array(
            [*rng.uniform(-2e-4, 2e-4, 2), rng.uniform(-0.01, 0.01), *rng.uniform(-0.05, 0.05, 2)]
        )
        command = cell.tcp_solution(x_c, robot.home)
        np.testing.assert_allclose(cell.features(command.q), x_c, atol=1e-6)
        position_error, rotation_error = _pose_error(
            robot.peg_in_base(command.q), command.peg_in_base
        )
        assert position_error <= 1e-6 and rotation_error <= 1e-6
        # The flange command carries the same pose through the tool placement.
        flange = command.flange_in_base * robot.peg_in_flange()
        assert max(_pose_error(flange, command.peg_in_base)) <= 1e-12


def test_aligned_hole_and_following_a_command_trajectory(iiwa: RobotModel) -> None:
    cell = CellKinematics(iiwa, aligned_hole_at(iiwa.peg_in_base(iiwa.home)), PEG_RADIUS)
    np.testing.assert_allclose(cell.features(iiwa.home), np.zeros(5), atol=1e-12)
    # Insert 2 mm at 5 mm/s while taking out a 1 mrad tilt: 400 steps of 1 ms.
    steps = 400
    commands = np.zeros((steps, 5))
    commands[:, 2] = np.linspace(0.0, 0.002, steps)
    commands[:, 4] = np.linspace(1e-3, 0.0, steps)
    start = cell.tcp_solution(commands[0], iiwa.home).q
    result = follow(cell, commands, start, dt=1e-3)
    np.testing.assert_allclose(result.features, commands, atol=1e-6)
    assert result.q.shape == (steps, 7) and result.iterations.max() <= 2
    assert np.all(np.abs(np.diff(result.q, axis=0)) <= iiwa.velocity_limit * 1e-3 + 1e-15)
    # A jump of 5 cm halfway through is refused at that step, not clipped.
    commands[200:, 0] += 0.05
    with pytest.raises(IkError, match=r"step 200 \(t = 0\.200 s\).*velocity limit"):
        follow(cell, commands, start, dt=1e-3)


def test_tcp_solution_keeps_the_pegs_spin(iiwa: RobotModel) -> None:
    cell = _cell_over_the_hole(iiwa)
    q = iiwa.home.copy()
    q[6] += 0.4  # spin the peg about its own axis
    command = cell.tcp_solution([1e-4, 0, 0.003, 0.01, 0.0], q)
    spun = iiwa.peg_in_base(q).rotation[:, 0]
    assert command.peg_in_base.rotation[:, 0] @ spun > math.cos(0.02)


def test_a_commanded_pose_is_solved_as_its_features_whatever_its_spin(iiwa: RobotModel) -> None:
    """``pose_solution`` (the kinematics stage's: a pose in {H}) and ``tcp_solution`` (features)
    command the same joints, the peg keeping its current spin either way; no radius needed."""
    cell = _cell_over_the_hole(iiwa)
    posed = CellKinematics(iiwa, cell.hole_in_base, None)
    q = iiwa.home.copy()
    q[6] += 0.4
    rng = np.random.default_rng(11)
    for spin in rng.uniform(-3.0, 3.0, 5):
        x_c = np.array([*rng.uniform(-2e-4, 2e-4, 2), 0.003, *rng.uniform(-0.03, 0.03, 2)])
        pose_in_hole = pin.SE3(*pose_from_features(x_c, PEG_RADIUS, spin))
        by_pose = posed.pose_solution(pose_in_hole, q)
        np.testing.assert_allclose(by_pose.q, cell.tcp_solution(x_c, q).q, atol=1e-12)
    with pytest.raises(ConfigError, match="peg_radius"):
        posed.features(q)


def test_tool_placement_moves_the_peg_frame() -> None:
    long_tool = RobotModel.from_name("iiwa14", Tool(xyz=(0.0, 0.0, 0.25)))
    tip = long_tool.peg_in_base(np.zeros(7)).translation
    np.testing.assert_allclose(tip, [0.0, 0.0, 1.306 + 0.25], atol=1e-9)
    tilted = RobotModel.from_name("panda", Tool(xyz=(0.01, 0.0, 0.1), rpy=(0.0, 0.2, 0.0)))
    np.testing.assert_allclose(
        tilted.peg_in_flange().rotation, Rotation.from_euler("y", 0.2).as_matrix(), atol=1e-12
    )


# --- Bad input ---------------------------------------------------------------------------------


def test_unknown_robot_names_the_known_ones() -> None:
    with pytest.raises(ConfigError, match=r"robot='kr6'.*iiwa14.*panda.*ur5"):
        RobotModel.from_name("kr6")
    assert set(ROBOT_NAMES) <= set(ROBOTS)


def test_urdf_without_the_named_frames(tmp_path: Path) -> None:
    urdf = ROBOTS["iiwa14"]().urdf
    with pytest.raises(ConfigError, match=r"flange_frame='tool0'.*iiwa_flange"):
        RobotModel(urdf, "tool0")
    with pytest.raises(ConfigError, match=r"locked_joints.*finger"):
        RobotModel(urdf, "iiwa_flange", locked_joints=["finger"])
    with pytest.raises(ConfigError, match=r"urdf=.*missing.urdf"):
        RobotModel(tmp_path / "missing.urdf", "iiwa_flange")
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'/><joint name='j'/></robot>")
    with pytest.raises(ConfigError, match=r"urdf=.*broken.urdf.*Pinocchio can parse"):
        RobotModel(broken, "a")
    # A 'peg' frame hung on another link than the flange cannot take the tool placement.
    elsewhere = tmp_path / "peg_elsewhere.urdf"
    joint = '<parent link="{}"/>\n    <child link="peg"/>'
    text = urdf.read_text()
    assert joint.format("iiwa_flange") in text
    elsewhere.write_text(text.replace(joint.format("iiwa_flange"), joint.format("iiwa_link_5")))
    with pytest.raises(ConfigError, match=r"'peg' frame on the same link as the flange"):
        RobotModel(elsewhere, "iiwa_flange")


@pytest.mark.parametrize(
    "q",
    [np.zeros(6), np.zeros(8), [0, 0, 0, math.nan, 0, 0, 0], [0, 0, 0, 0, math.inf, 0, 0]],
)
def test_joint_vectors_of_the_wrong_length_or_non_finite(iiwa: RobotModel, q) -> None:
    with pytest.raises(InputError, match=r"q=.*7 finite joint values of iiwa14"):
        iiwa.peg_in_base(q)
    cell = _cell_over_the_hole(iiwa)
    with pytest.raises(InputError, match=r"q_current"):
        cell.tcp_solution(np.zeros(5), q)


def test_bad_command_features_and_tool(iiwa: RobotModel) -> None:
    cell = _cell_over_the_hole(iiwa)
    with pytest.raises(InputError, match=r"command_features"):
        cell.tcp_solution([0, 0, math.nan, 0, 0], iiwa.home)
    with pytest.raises(InputError, match=r"command_features"):
        cell.tcp_solution([0, 0, 0.001], iiwa.home)
    with pytest.raises(ConfigError, match=r"tool.xyz"):
        RobotModel.from_name("iiwa14", Tool(xyz=(0.0, math.nan, 0.1)))
    with pytest.raises(ConfigError, match=r"peg_radius"):
        CellKinematics(iiwa, pose([0.5, 0, 0.2]), 0.0)
