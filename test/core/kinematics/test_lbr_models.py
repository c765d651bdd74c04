"""The KUKA LBR models (iiwa7, iiwa14, med7, med14; fbcc_ros/urdf/): the flange against a product
of exponentials from the data-sheet offsets and against lbr_fri_ros2_stack's joint chain, the
limits and speeds against the stack's joint_limits.yaml, the total mass against KUKA's, the shared
home, and the generated URDFs against their generator (scripts/make_lbr_urdf.py)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation

from fbcc_ros.core.kinematics.ik import solve_ik
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel
from test.core.kinematics.test_kinematics import _published_flange_pose, _random_configurations

LBR_MODELS = ["iiwa7", "iiwa14", "med7", "med14"]
REPO = Path(__file__).resolve().parents[3]

# KUKA data sheets: base to A2, A2 to A4, A4 to A6, A6 to the flange [m]. The Med shares the
# kinematics of the iiwa of its size (the URDF headers' [1]).
DATA_SHEET_OFFSETS = {
    "iiwa7": (0.340, 0.400, 0.400, 0.126),
    "iiwa14": (0.360, 0.420, 0.400, 0.126),
    "med7": (0.340, 0.400, 0.400, 0.126),
    "med14": (0.360, 0.420, 0.400, 0.126),
}

# lbr_fri_ros2_stack (github.com/lbr-stack/lbr_fri_ros2_stack) at commit 218d723,
# lbr_description/urdf/<model>/<model>_description.xacro: the origin xyz of the joints A1..A7 and
# joint_ee (link_7 to link_ee), verbatim. Every origin rpy there is 0 0 0; the axes are A1 z,
# A2 y, A3 z, A4 -y, A5 z, A6 y, A7 z.
STACK_AXES = ((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, -1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1))
STACK_JOINT_ORIGINS = {
    "iiwa7": (
        (0.0, 0.0, 0.1475),
        (0.0, -0.0105, 0.1925),
        (0.0, 0.0105, 0.2075),
        (0.0, 0.0105, 0.1925),
        (0.0, -0.0105, 0.2075),
        (0.0, -0.0707, 0.1925),
        (0.0, 0.0707, 0.091),
        (0.0, 0.0, 0.035),
    ),
    "iiwa14": (
        (0.0, 0.0, 0.1475),
        (0.0, -0.01, 0.2125),
        (0.0, 0.01, 0.228),
        (0.0, 0.0105, 0.192),
        (0.0, -0.0105, 0.2075),
        (0.0, -0.0707, 0.1925),
        (0.0, 0.0707, 0.091),
        (0.0, 0.0, 0.035),
    ),
    "med7": (
        (0.0, 0.0, 0.1475),
        (0.0, -0.0105, 0.1925),
        (0.0, 0.0105, 0.2075),
        (0.0, 0.0105, 0.1925),
        (0.0, -0.0105, 0.2075),
        (0.0, -0.0707, 0.1925),
        (0.0, 0.0707, 0.091),
        (0.0, 0.0, 0.035),
    ),
    "med14": (
        (0.0, 0.0, 0.147),  # 0.1475 in the other three: the stack's med14 is 0.5 mm lower
        (0.0, -0.01, 0.2125),
        (0.0, 0.01, 0.228),
        (0.0, 0.0105, 0.192),
        (0.0, -0.0105, 0.2075),
        (0.0, -0.0707, 0.1925),
        (0.0, 0.0707, 0.091),
        (0.0, 0.0, 0.035),
    ),
}
# Our flange less the stack's link_ee, along the base z, at every pose: they coincide on the iiwas
# and the Med 7; on the Med 14 ours is 0.5 mm higher (KUKA's 360 mm to A2, the stack's 359.5 mm).
STACK_EE_TO_OUR_FLANGE_IN_BASE = {
    "iiwa7": 0.0,
    "iiwa14": 0.0,
    "med7": 0.0,
    "med14": 0.0005,
}

# lbr_fri_ros2_stack at commit 218d723, lbr_description/urdf/<model>/joint_limits.yaml, A1..A7:
# (lower, upper) [deg] and velocity [deg/s]; its lbr_description/test/lbr_model_specifications.py
# gives the same, "as extracted from https://xpert.kuka.com/". (The yaml's effort, 200 on every
# axis, is a placeholder: our torques are KUKA's, the URDF headers' [3].)
_RANGES = (
    (-170, 170),
    (-120, 120),
    (-170, 170),
    (-120, 120),
    (-170, 170),
    (-120, 120),
    (-175, 175),
)
STACK_LIMITS = {
    "iiwa7": (_RANGES, (98, 98, 100, 130, 140, 180, 180)),
    "iiwa14": (_RANGES, (85, 85, 100, 75, 130, 135, 135)),
    "med7": (_RANGES, (98, 98, 100, 130, 140, 180, 180)),
    "med14": (_RANGES, (85, 85, 100, 75, 130, 135, 135)),
}
KUKA_TORQUES = {  # [N m]; the Meds' are the iiwas' (no published figure found: an assumption)
    "iiwa7": (176, 176, 110, 110, 110, 40, 40),
    "iiwa14": (320, 320, 176, 176, 110, 40, 40),
    "med7": (176, 176, 110, 110, 110, 40, 40),
    "med14": (320, 320, 176, 176, 110, 40, 40),
}

# KUKA's published masses [kg] (xpert.kuka.com, as lbr_model_specifications.py at 218d723 gives
# them: AR7606, AR7607, AR16388, AR16387), and how far our models' link masses sum from them.
# The three generated models carry the stack's masses, which it scaled to these figures (up to
# its 6-decimal rounding); iiwa14.urdf carries Drake's estimates, 0.71 kg more.
PUBLISHED_MASS = {"iiwa7": 23.9, "iiwa14": 29.9, "med7": 25.5, "med14": 32.3}
MODEL_MINUS_PUBLISHED = {"iiwa7": -1e-6, "iiwa14": 0.71, "med7": 1e-6, "med14": 0.0}


@pytest.fixture(scope="module", params=LBR_MODELS)
def lbr(request: pytest.FixtureRequest) -> RobotModel:
    return RobotModel.from_name(request.param)


def _screws(offsets: tuple[float, float, float, float]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Joint axes at the zero pose (unit direction, a point on the axis) in the base frame: A1,
    A3, A5, A7 along +z through the centre line; A2, A4, A6 along +y, -y, +y at the shoulder,
    elbow and wrist heights."""
    shoulder, elbow, wrist = np.cumsum(offsets[:3])
    directions = ((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, -1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1))
    heights = (0.0, shoulder, 0.0, elbow, 0.0, wrist, 0.0)
    return [
        (np.array(d, float), np.array([0.0, 0.0, h]))
        for d, h in zip(directions, heights, strict=True)
    ]


def _data_sheet_flange(name: str, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """T_base_flange(q) = exp([S1] q1) ... exp([S7] q7) M, M the flange at sum(offsets) on z."""
    rot, pos = np.eye(3), np.zeros(3)
    for (axis, point), angle in zip(_screws(DATA_SHEET_OFFSETS[name]), q, strict=True):
        r = Rotation.from_rotvec(axis * angle).as_matrix()
        rot, pos = rot @ r, rot @ ((np.eye(3) - r) @ point) + pos
    return rot, rot @ [0.0, 0.0, sum(DATA_SHEET_OFFSETS[name])] + pos


def _stack_flange(name: str, q: np.ndarray) -> pin.SE3:
    """T_base_link_ee(q) through the stack's chain: origin_i * rot(axis_i, q_i), then joint_ee."""
    origins = STACK_JOINT_ORIGINS[name]
    pose = pin.SE3.Identity()
    for xyz, axis, angle in zip(origins[:7], STACK_AXES, q, strict=True):
        pose = (
            pose
            * pin.SE3(np.eye(3), np.array(xyz))
            * pin.SE3(pin.exp3(np.array(axis, float) * angle), np.zeros(3))
        )
    return pose * pin.SE3(np.eye(3), np.array(origins[7]))


# --- (a) Against the data sheet ----------------------------------------------------------------


def test_the_general_product_of_exponentials_is_test_kinematics_one_for_the_iiwa14() -> None:
    for q in np.random.default_rng(2).uniform(-2.0, 2.0, size=(20, 7)):
        for got, want in zip(
            _data_sheet_flange("iiwa14", q), _published_flange_pose(q), strict=True
        ):
            np.testing.assert_allclose(got, want, atol=1e-14)


def test_flange_at_zero_is_the_sum_of_the_offsets_above_the_base(lbr: RobotModel) -> None:
    flange = lbr.flange_in_base(np.zeros(7))
    height = sum(DATA_SHEET_OFFSETS[lbr.name])  # 1.266 m for the 7s, 1.306 m for the 14s
    np.testing.assert_allclose(flange.translation, [0.0, 0.0, height], atol=1e-9)
    np.testing.assert_allclose(flange.rotation, np.eye(3), atol=1e-9)


def test_flange_matches_the_data_sheet_at_random_configurations(lbr: RobotModel) -> None:
    for q in _random_configurations(lbr, 50, seed=4):
        rot, pos = _data_sheet_flange(lbr.name, q)
        flange = lbr.flange_in_base(q)
        np.testing.assert_allclose(flange.translation, pos, atol=1e-9)
        np.testing.assert_allclose(flange.rotation, rot, atol=1e-9)


# --- (b) Against lbr_fri_ros2_stack's description ----------------------------------------------


def test_flange_matches_the_stacks_link_ee_at_random_configurations(lbr: RobotModel) -> None:
    shift = np.array([0.0, 0.0, STACK_EE_TO_OUR_FLANGE_IN_BASE[lbr.name]])
    for q in np.vstack([np.zeros((1, 7)), _random_configurations(lbr, 50, seed=9)]):
        stack = _stack_flange(lbr.name, q)
        ours = lbr.flange_in_base(q)
        np.testing.assert_allclose(ours.translation, stack.translation + shift, atol=1e-9)
        np.testing.assert_allclose(ours.rotation, stack.rotation, atol=1e-9)


def test_the_stacks_med14_alone_puts_a2_half_a_millimetre_low() -> None:
    shoulders = {n: o[0][2] + o[1][2] for n, o in STACK_JOINT_ORIGINS.items()}
    expected = {"iiwa7": 0.34, "iiwa14": 0.36, "med7": 0.34, "med14": 0.3595}
    assert shoulders == pytest.approx(expected, abs=1e-12)


# --- (c) Limits, speeds, torques ---------------------------------------------------------------


def test_limits_and_speeds_are_the_stacks_joint_limits(lbr: RobotModel) -> None:
    ranges, speeds = STACK_LIMITS[lbr.name]
    np.testing.assert_allclose(lbr.lower, np.radians([lo for lo, _ in ranges]), rtol=1e-9)
    np.testing.assert_allclose(lbr.upper, np.radians([hi for _, hi in ranges]), rtol=1e-9)
    np.testing.assert_allclose(lbr.velocity_limit, np.radians(speeds), rtol=1e-9)
    np.testing.assert_array_equal(lbr.model.effortLimit, KUKA_TORQUES[lbr.name])


def test_the_joint_and_flange_names_are_shared(lbr: RobotModel) -> None:
    assert lbr.joint_names == tuple(f"iiwa_joint_{i}" for i in range(1, 8))
    assert lbr.flange_frame == "iiwa_flange"
    np.testing.assert_allclose(lbr.peg_in_flange().translation, [0.0, 0.0, 0.10], atol=1e-15)


# --- (d) Mass ----------------------------------------------------------------------------------


def test_total_mass_against_kukas_published_mass(lbr: RobotModel) -> None:
    total = sum(inertia.mass for inertia in lbr.model.inertias)
    difference = total - PUBLISHED_MASS[lbr.name]
    assert difference == pytest.approx(MODEL_MINUS_PUBLISHED[lbr.name], abs=1e-9)


# --- The shared home, and the IK on the new models ---------------------------------------------


def test_home_is_inside_the_limits_with_the_flange_pointing_down(lbr: RobotModel) -> None:
    assert lbr.within_limits(lbr.home)
    flange = lbr.flange_in_base(lbr.home)
    np.testing.assert_allclose(flange.rotation[:, 2], [0.0, 0.0, -1.0], atol=1e-9)
    # over the table in front of the base: 0.56 m out, the peg tip 0.30 m (7s) or 0.34 m (14s) up
    tip = lbr.peg_in_base(lbr.home).translation
    assert 0.5 < tip[0] < 0.6 and abs(tip[1]) < 1e-9 and 0.25 < tip[2] < 0.4


@pytest.mark.parametrize("name", ["iiwa7", "med7", "med14"])
def test_ik_round_trip_on_the_new_models(name: str) -> None:
    robot = RobotModel.from_name(name)
    rng = np.random.default_rng(11)
    for q_true in _random_configurations(robot, 20, seed=12):
        target = robot.peg_in_base(q_true)
        start = np.clip(q_true + rng.uniform(-0.1, 0.1, 7), robot.lower, robot.upper)
        solution = solve_ik(robot, target, start)
        error = pin.log6(robot.peg_in_base(solution.q).actInv(target)).vector
        assert np.linalg.norm(error[:3]) <= 1e-6 and np.linalg.norm(error[3:]) <= 1e-6


def test_every_lbr_is_known_by_name() -> None:
    assert set(LBR_MODELS) <= set(ROBOTS)
    assert all(ROBOTS[n]().urdf.is_file() for n in LBR_MODELS)


# --- The generated URDFs -----------------------------------------------------------------------


def _generator(monkeypatch: pytest.MonkeyPatch) -> Any:
    path = REPO / "scripts" / "make_lbr_urdf.py"
    spec = importlib.util.spec_from_file_location("make_lbr_urdf", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)  # for its dataclass, while loading
    spec.loader.exec_module(module)
    return module


def test_the_generated_urdfs_are_their_generators_output(monkeypatch: pytest.MonkeyPatch) -> None:
    generator = _generator(monkeypatch)
    assert [model.name for model in generator.MODELS] == ["iiwa7", "med7", "med14"]
    for model in generator.MODELS:
        urdf = ROBOTS[model.name]().urdf
        assert urdf.read_text() == generator.render(model), f"re-run the script for {urdf.name}"


def _stack_model(name: str, inertials: Any) -> pin.Model:
    """The stack's arm as it describes it: its joint origins and axes, and each link's inertial
    (the generator's verbatim copy) in its own link frame."""
    model = pin.Model()
    parent = 0
    for i, (xyz, axis) in enumerate(zip(STACK_JOINT_ORIGINS[name][:7], STACK_AXES, strict=True)):
        joint = pin.JointModelRevoluteUnaligned(np.array(axis, float))
        parent = model.addJoint(parent, joint, pin.SE3(np.eye(3), np.array(xyz)), f"A{i + 1}")
        mass, com, (ixx, ixy, ixz, iyy, iyz, izz) = inertials[i + 1]
        tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        model.appendBodyToJoint(
            parent, pin.Inertia(mass, np.array(com), tensor), pin.SE3.Identity()
        )
    return model


def test_the_carried_over_inertials_give_the_stacks_dynamics(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Inverse dynamics and the mass matrix of our URDFs equal those of the stack's own frames,
    so the rotation and shift of each centre of mass and inertia into our link frames is exact
    (the residue is the URDF's 10-decimal rpy)."""
    for model in _generator(monkeypatch).MODELS:
        ours = RobotModel.from_name(model.name)
        stack = _stack_model(model.name, model.inertials)
        data = stack.createData()
        rng = np.random.default_rng(0)
        for q in _random_configurations(ours, 20, seed=5):
            v, a = rng.uniform(-1, 1, 7), rng.uniform(-1, 1, 7)
            np.testing.assert_allclose(
                pin.rnea(ours.model, ours.data, q, v, a), pin.rnea(stack, data, q, v, a), atol=1e-8
            )
            np.testing.assert_allclose(
                np.triu(pin.crba(ours.model, ours.data, q)),
                np.triu(pin.crba(stack, data, q)),
                atol=1e-9,
            )
