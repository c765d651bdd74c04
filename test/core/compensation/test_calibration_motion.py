"""The calibration motion (fbcc_ros.core.compensation.calibration_motion): within the speed it
is given, continuous, the peg never lower than where it started, holding each pose, and back at
the start; for every built-in model."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.compensation import calibration_motion as cm
from fbcc_ros.core.compensation.calibration_poses import calibration_poses
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel

STEP = 1e-3  # sampled [s]


@pytest.fixture(scope="module", params=sorted(ROBOTS))
def motion(request: pytest.FixtureRequest) -> tuple[RobotModel, cm.CalibrationMotion, np.ndarray]:
    robot = RobotModel.from_name(request.param)
    m = cm.calibration_motion(robot, robot.home, n=6)
    q = np.array([m.at(t) for t in np.arange(0.0, m.duration + STEP, STEP)])
    return robot, m, q


def test_no_joint_exceeds_the_speed_given(motion: tuple) -> None:  # type: ignore[type-arg]
    robot, _, q = motion
    speed = np.abs(np.diff(q, axis=0)).max(axis=0) / STEP / robot.velocity_limit
    assert speed.max() <= cm.SPEED * 1.001, speed
    assert speed.max() > 0.95 * cm.SPEED  # and the time is not wasted


def test_the_motion_starts_and_ends_where_the_arm_is_and_stays_in_its_limits(motion: tuple
                                                                          ) -> None:  # type: ignore[type-arg]  # fmt: skip
    robot, _, q = motion
    assert np.abs(q[0] - robot.home).max() < 1e-9 and np.abs(q[-1] - robot.home).max() < 1e-9
    assert all(robot.within_limits(x) for x in q[::20])


def test_the_peg_rises_straight_and_never_comes_below_its_start(motion: tuple) -> None:  # type: ignore[type-arg]
    robot, m, q = motion
    start = robot.peg_in_base(robot.home).translation
    heights = np.array([robot.peg_in_base(x).translation[2] for x in q[::10]]) - start[2]
    assert heights.min() >= -1e-9
    lift = m.segments[0]
    for t in np.linspace(0.0, lift.duration, 25):  # the lift: straight up, within 0.1 mm
        p = robot.peg_in_base(lift.at(t)).translation
        assert np.hypot(*(p[:2] - start[:2])) < 1e-4, t
    assert robot.peg_in_base(lift.at(lift.duration)).translation[2] - start[2] == pytest.approx(
        cm.LIFT, abs=1e-6)


def test_each_pose_is_held_still_for_the_hold(motion: tuple) -> None:  # type: ignore[type-arg]
    robot, m, _ = motion
    holds = m.holds()
    assert len(holds) == len(m.poses) == 6
    for (t0, t1), pose in zip(holds, m.poses, strict=True):
        assert t1 - t0 == pytest.approx(cm.HOLD)
        for t in np.linspace(t0, t1, 5):
            assert np.abs(m.at(t) - pose).max() < 1e-12
    # the poses are the calibration poses around the lifted arm
    lifted = m.segments[0].waypoints[-1]
    assert np.allclose(m.poses, calibration_poses(robot, 6, home=lifted).q)


def test_a_motion_with_impossible_settings_is_refused() -> None:
    robot = RobotModel.from_name("iiwa14")
    for name, value in (("hold", 0.1), ("speed", 1.5), ("lift", -0.1)):
        with pytest.raises(ConfigError, match=name):
            cm.calibration_motion(robot, robot.home, n=4, **{name: value})


def test_the_minimum_jerk_profile_starts_and_ends_at_rest() -> None:
    p, v, a = cm.minimum_jerk([0.0, 0.5, 1.0])
    assert p.tolist() == [0.0, 0.5, 1.0]
    assert v[0] == v[2] == 0.0 and v[1] == pytest.approx(1.875)
    assert a[0] == a[2] == 0.0
