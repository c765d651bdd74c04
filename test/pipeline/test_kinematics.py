"""The kinematics stage solves every command from the measured joints."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from fbcc_ros.core.kinematics.ik import IkError
from fbcc_ros.pipeline.kinematics import (
    MAX_REACH_PERIODS,
    MOVING_WITHIN,
    TABLE,
    KinematicsStage,
)
from fbcc_ros.pipeline.parameters import resolve


def test_each_command_is_within_one_period_of_the_measured_joints() -> None:
    """The arm does not follow (its measured joints stay put) while the commands walk away
    0.1 mm a period: each command the stage gives is within one period's reach of the measured
    joints, and a pose beyond that reach is refused. Seeded from its own last command instead,
    the commands would walk on with the target (each a period's reach from the one before)."""
    stage = KinematicsStage(resolve("kinematics", TABLE, {}))
    robot = stage.cell.robot
    q_measured = robot.home.copy()
    start = stage.joints(q_measured)
    reach = robot.velocity_limit * stage.dt
    given = 0
    for k in range(1, 40):
        target = start * pin.SE3(np.eye(3), np.array([1e-4 * k, 0.0, 0.0]))
        try:
            command = stage.command(target)
        except IkError:
            break
        assert command is not None
        assert np.all(np.abs(command.q - q_measured) <= reach * (1 + 1e-9))
        given += 1
    else:
        pytest.fail("a target 4 mm from the arm was reached within one period")
    assert given >= 2  # the near ones were solved


def test_the_reach_grows_with_the_age_of_the_measured_joints_up_to_a_bound() -> None:
    """A starved loop solves a command several periods after its joint state: the arm has had
    that long to move, so the reach is the time since the measurement plus one period, at most
    MAX_REACH_PERIODS periods (then a stalled arm's old joints still bound the command)."""
    stage = KinematicsStage(resolve("kinematics", TABLE, {}))
    start = stage.joints(stage.cell.robot.home, stamp=1.0)
    far = start * pin.SE3(np.eye(3), np.array([4e-4, 0.0, 0.0]))  # beyond one period's reach
    with pytest.raises(IkError):
        stage.command(far, now=1.0)
    assert stage.command(far, now=1.003) is not None  # four periods' reach
    assert stage.reach(1.5) == pytest.approx(MAX_REACH_PERIODS * stage.dt)
    assert stage.reach(None) == stage.dt


def test_a_stage_that_moves_the_arm_holds_it_at_the_measured_joints() -> None:
    """Stopped within MOVING_WITHIN of its last command, the stage gives the measured joints
    (not the command it was heading for); stopped later, or never commanding, nothing."""
    stage = KinematicsStage(resolve("kinematics", TABLE, {}))
    q = stage.cell.robot.home.copy()
    start = stage.joints(q, stamp=1.0)
    assert stage.hold(1.0) is None  # never commanded
    command = stage.command(start * pin.SE3(np.eye(3), np.array([5e-5, 0.0, 0.0])), now=1.0)
    assert command is not None and not np.allclose(command.q, q)
    hold = stage.hold(1.0 + 0.5 * MOVING_WITHIN)
    assert hold is not None and np.array_equal(hold.q, q)
    assert np.allclose(hold.peg_in_base.homogeneous,
                       stage.cell.robot.peg_in_base(q).homogeneous)  # fmt: skip
    assert stage.hold(1.0 + 2 * MOVING_WITHIN) is None


def test_joints_stamped_ahead_of_their_arrival_are_refused() -> None:
    """A joint state stamped 1 s ahead would make the features look fresh to the law for a
    second after they stopped: refused, as the compensation refuses such a wrench."""
    from fbcc_ros.core.errors import InputError

    stage = KinematicsStage(resolve("kinematics", TABLE, {}))
    q = stage.cell.robot.home
    stage.joints(q, 10.04, received=10.0)  # within the allowance for two machines' clocks
    said = r"header\.stamp=11\.0 .*arrival 10\.000 \(a clock ahead of ours\)"
    with pytest.raises(InputError, match=said):
        stage.joints(q, 11.0, received=10.0)
