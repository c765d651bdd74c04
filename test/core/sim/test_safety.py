"""The cell's safety stack in the simulator (fbcc_ros/core/sim/safety.py): the wrench guard ends
a trial with its reason, and an ended trial holds where the arm was measured."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fbcc_ros.core.compensation.wrench import wrench_from_response
from fbcc_ros.core.compensation.wrench_guard import GuardLimits
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.control.supervisor import SafetyLimits
from fbcc_ros.core.sim.safety import TrialSafety
from fbcc_ros.core.sim.scenario import validate
from fbcc_ros.core.sim.simulation import simulate

PAIR = PegHole(5.05e-3, 5.04e-3, 0.01, 0.005, 0.3, 1e11)


def _scenario() -> dict:
    """The robust clearance case on a steel-like part at 100 Hz, its entry unpaced
    (``entry_depth: 0``): the first period's 50 µm step presses the 0.1 mm, 2° off peg into the
    wall with about 950 N."""
    geometry = {k: v for k, v in dataclasses.asdict(PAIR).items() if k not in ("rim", "chamfer")}
    return {"geometry": geometry, "controller": {"type": "fbcc", "params": {"entry_depth": 0.0}},
            "initial": {"dx": 1e-4, "dy": -1e-4, "theta_x": 0.0349066, "theta_y": -0.0349066},
            "rate_hz": 100, "duration": 0.5}  # fmt: skip


def _held_at_measured_pose(traj, k: int) -> None:
    """From step k on, every command is the pose measured at step k."""
    np.testing.assert_array_equal(traj.command[k:, 0], np.broadcast_to(traj.pose[k, 0],
                                                                       traj.command[k:, 0].shape))


def test_the_wrench_guard_ends_a_trial_and_holds_it_where_the_arm_was() -> None:
    outcome, traj = simulate(validate(_scenario()), "fbcc")
    assert traj is not None
    assert outcome.stop_reason[0].startswith("wrench guard: |f| ")
    assert outcome.wrench_guard_tripped[0] and not outcome.success[0]
    force = np.linalg.norm(traj.measured[:, 0, :3], axis=1)
    k = int(np.argmax(force > 0.9 * GuardLimits().force_limit))  # the first sample over it
    _held_at_measured_pose(traj, k)


def test_the_laws_force_limit_holds_where_the_arm_was_not_where_it_was_sent() -> None:
    # without the guard, the law's own limit (Algorithm 1) ends the trial
    outcome, traj = simulate(validate(_scenario()), "fbcc", guard=None)
    assert traj is not None
    assert outcome.stop_reason[0] == "force limit" and outcome.force_limited[0]
    assert not outcome.wrench_guard_tripped[0] and not outcome.success[0]
    force = np.linalg.norm(traj.measured[:, 0, :3], axis=1)
    k = int(np.argmax(force > 300.0))
    _held_at_measured_pose(traj, k)
    # the law's last command lay deeper than the arm: the hold is not it
    assert k > 0 and traj.command[k - 1, 0, 2] > traj.pose[k, 0, 2]


def test_the_paced_entry_meets_the_same_wall_under_the_guard() -> None:
    """Paced (the default ``entry_step``), the same first contact stays under the guard's
    limit: the rigidly held steel peg takes about 19 N a micrometre, so 10 µm a period is about
    190 N where the unpaced 50 µm step is 950 N (twice the step would reach the force limit)."""
    scenario = _scenario()
    scenario["controller"]["params"] = {}
    scenario["duration"] = 1.0  # the first 0.6 mm at 10 µm a period: the contact comes early
    outcome, traj = simulate(validate(scenario), "fbcc")
    assert traj is not None
    assert not (outcome.wrench_guard_tripped[0] or outcome.force_limited[0]), outcome.stop_reason
    force = np.linalg.norm(traj.measured[:, 0, :3], axis=1)
    assert 50.0 < force.max() < 0.9 * GuardLimits().force_limit  # the contact was made
    assert traj.pose[-1, 0, 2] > 5e-4  # and the peg is going in


def test_a_trial_within_the_limits_runs_to_its_end() -> None:
    sc = _scenario()
    sc["geometry"]["stiffness"] = 1.84e8  # the calibrated plastic part
    outcome, _ = simulate(validate(sc | {"rate_hz": 1000, "duration": 3.0}), "fbcc")
    assert outcome.success[0] and outcome.stop_reason[0] == ""


def test_the_guard_judges_the_wrench_the_compensation_gives_it() -> None:
    """About the {H} origin, as the compensation node's ``wrench_from_response`` gives it."""
    rng = np.random.default_rng(0)
    response = rng.normal(scale=[50, 50, 50, 2, 2], size=(6, 5))
    safety = TrialSafety(6, PAIR, SafetyLimits(), GuardLimits())
    got = safety.wrench_about_origin(response, np.zeros((6, 5)))
    for row, w in zip(response, got, strict=True):
        np.testing.assert_allclose(w, wrench_from_response(row, 0.0, PAIR.acting_point_in_hole()),
                                   atol=1e-12)  # fmt: skip


@pytest.mark.parametrize(("moment", "tripped"), [(26.0, False), (28.0, True)])
def test_the_moment_limit_trips_less_its_margin(moment: float, tripped: bool) -> None:
    # a pure moment about the hole bottom is the same about the origin: 30 N·m less 10 %
    safety = TrialSafety(1, PAIR, SafetyLimits(), GuardLimits())
    pose = np.array([[1e-6, 0.0, 2e-3, 0.0, 0.0]])
    command = safety.command(pose, pose + 1e-6, pose, np.array([[0, 0, 0, moment, 0.0]]),
                             pose, np.zeros(1, bool))  # fmt: skip
    assert safety.ended[0] == tripped
    assert (safety.reason[0].startswith("wrench guard: |m| 28 N·m over 27 N·m") if tripped
            else safety.reason[0] == "")  # fmt: skip
    np.testing.assert_array_equal(command, pose if tripped else pose + 1e-6)
