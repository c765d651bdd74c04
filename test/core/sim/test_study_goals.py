"""The robustness study's goals judged on an outcome (fbcc_ros/core/sim/study_goals.py)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim import study_goals
from fbcc_ros.core.sim.montecarlo import draw_trials
from fbcc_ros.core.sim.simulation import Outcome

SCENARIOS = Path(__file__).resolve().parents[3] / "config" / "scenarios"
MODEL = study_goals.Targets(study_goals.GOAL_SUCCESS, 3.0)  # robust_clearance's at 1 kHz


def _outcome(success: np.ndarray, **given: np.ndarray) -> Outcome:
    """An outcome of ``len(success)`` trials: the fields given, the rest quiet (peak Fz 10 N,
    nothing else)."""
    n = len(success)
    quiet = {f.name: np.zeros(n) for f in dataclasses.fields(Outcome)}
    quiet.update(peak_fz=np.full(n, 10.0), peak_force=np.full(n, 10.0),
                 final_features=np.zeros((n, 5)), force_limited=np.zeros(n, bool),
                 wrench_guard_tripped=np.zeros(n, bool),
                 stop_reason=np.full(n, "", dtype=object))  # fmt: skip
    return Outcome(**{**quiet, "success": success, **given})


def test_a_study_success_meets_every_per_trial_goal() -> None:
    """A trial assembled too slowly, with too much lateral force left, or past its zero tilt is a
    failed trial of the study, with each goal it missed named."""
    n = 6
    outcome = _outcome(
        success=np.array([1, 1, 1, 0, 0, 1], bool),
        insertion_time=np.array([2.1, 3.07, 2.5, np.nan, np.nan, 2.9]),
        residual_force=np.array([0.3, 0.2, 0.6, 1.0, 5.0, 0.1]),
        tilt_overshoot=np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.004]),
        force_limited=np.array([0, 0, 0, 0, 1, 0], bool),
        stop_reason=np.array(["", "", "", "", "force limit", ""], dtype=object),
    )
    missed = study_goals.missed_goals(outcome, 3.0)
    assert missed[0] == []
    assert missed[1] == ["assembled in 3.07 s > 3 s"]
    assert missed[2] == ["residual 0.60 N > 0.5 N"]
    assert missed[3] == ["not assembled at the end"] and missed[4] == ["force limit"]
    assert missed[5] == ["tilt overshoot 0.23 deg"]
    trials = draw_trials(scenario_io.load(SCENARIOS / "robust_clearance.yaml").geometry, n, 0)
    rows = study_goals.goals(outcome, trials, missed, MODEL)
    assert rows["success"]["measured"] == pytest.approx(1 / 6) and rows["success"]["failed"] == 5
    # each per-trial goal's row: the share assembled within it, and the assembled trials over it
    assert rows["insertion_time_s"]["share"] == pytest.approx(3 / 6)
    assert rows["insertion_time_s"]["over_target"] == 1 and not rows["insertion_time_s"]["met"]
    assert rows["residual_force_N"]["share"] == pytest.approx(3 / 6)
    assert rows["residual_force_N"]["over_target"] == 1 and not rows["residual_force_N"]["met"]
    assert not rows["tilt_overshoot_deg"]["met"]


def test_a_trial_the_wrench_guard_ended_is_failed_with_its_reason() -> None:
    why = "wrench guard: |f| 281 N over 270 N, the limit 300 N less its stop margin"
    outcome = _outcome(success=np.array([1, 0], bool), insertion_time=np.array([2.0, np.nan]),
                       wrench_guard_tripped=np.array([0, 1], bool),
                       stop_reason=np.array(["", why], dtype=object))  # fmt: skip
    assert study_goals.missed_goals(outcome, 3.0) == [[], [why]]


@pytest.mark.parametrize(("slow", "met"), [(1, True), (2, True), (3, False)])
def test_a_slow_part_is_a_failed_trial_and_an_overshoot_fails_the_study(slow: int,
                                                                        met: bool) -> None:
    """Of 2000 parts, 1 or 2 assembled over the time goal keep >= 99.9 % of the study within
    it, 3 do not; the time row says how slow and how many either way. One tilt overshoot fails
    its goal whatever the share: the issue says "never" of it."""
    n = 2000
    t = np.full(n, 2.1)
    t[:slow] = 3.5
    outcome = _outcome(success=np.ones(n, bool), insertion_time=t)
    trials = draw_trials(scenario_io.load(SCENARIOS / "robust_clearance.yaml").geometry, n, 0)
    rows = study_goals.goals(outcome, trials, study_goals.missed_goals(outcome, 3.0), MODEL)
    time = rows["insertion_time_s"]
    assert time["over_target"] == slow and time["measured"] == pytest.approx(3.5)
    assert time["met"] is met and rows["success"]["met"] is met
    assert rows["success"]["failed"] == slow and rows["tilt_overshoot_deg"]["met"]
    outcome.tilt_overshoot[-1] = 0.0036  # 0.206 deg past zero, one trial of 2000
    rows = study_goals.goals(outcome, trials, study_goals.missed_goals(outcome, 3.0), MODEL)
    assert not rows["tilt_overshoot_deg"]["met"] and rows["success"]["failed"] == slow + 1


def test_the_time_goal_is_the_travel_and_one_second() -> None:
    """The issue's 3 s is for 10 mm at 5 mm/s; another insertion keeps the one second beyond
    its own travel, and a trial is judged against that."""
    sc = scenario_io.load(SCENARIOS / "robust_clearance.yaml")
    assert study_goals.time_goal(sc.insertion) == pytest.approx(3.0)
    deep = dataclasses.replace(sc.insertion, depth=0.015)
    fast = dataclasses.replace(sc.insertion, speed=0.01)
    assert study_goals.time_goal(deep) == pytest.approx(4.0)
    assert study_goals.time_goal(fast) == pytest.approx(2.0)
    outcome = _outcome(success=np.ones(2, bool), insertion_time=np.array([3.5, 4.2]))
    assert study_goals.missed_goals(outcome, study_goals.time_goal(deep)) == [
        [], ["assembled in 4.20 s > 4 s"]]  # fmt: skip


@pytest.mark.parametrize(("rate_hz", "goal"), [(2000.0, 3.0), (1000.0, 3.0), (250.0, 3.0 + 1 / 3),
                                               (100.0, 4.0), (50.0, 3.0 + 19 / 9)])
def test_a_slower_loop_is_given_the_issues_second_at_100_hz_in_proportion_to_its_period(
        rate_hz: float, goal: float) -> None:  # fmt: skip
    """The issue's 3 s at 1 kHz and 4 s at 100 Hz: the entry is paced by the period."""
    sc = scenario_io.load(SCENARIOS / "rim_clearance.yaml")
    assert study_goals.time_goal(sc.insertion, rate_hz) == pytest.approx(goal)


@pytest.mark.parametrize(("over", "met"), [(10, True), (30, False)])
def test_the_peak_force_goal_judges_the_tail_not_the_median(over: int, met: bool) -> None:
    """Of 2000 parts peaking at 10 N, 10 clearance parts at 80 N leave the 99th percentile of
    the clearance parts under 30 N (Fz) and 50 N (|F|); 30 put it over both, while the median
    still reads 10 N."""
    n = 2000
    geometry = scenario_io.load(SCENARIOS / "robust_clearance.yaml").geometry
    trials = draw_trials(geometry, n, 0)
    clearance = np.flatnonzero([g.push_in_force() == 0 for g in trials.geometries])
    assert len(clearance) > 1800  # the tolerances make a few pairs interference fits
    peak = np.full(n, 10.0)
    peak[clearance[:over]] = 80.0
    outcome = _outcome(success=np.ones(n, bool), insertion_time=np.full(n, 2.0), peak_fz=peak,
                       peak_force=peak)  # fmt: skip
    rows = study_goals.goals(outcome, trials, study_goals.missed_goals(outcome, 3.0), MODEL)
    row = rows["peak_fz_clearance_p99_N"]
    assert row["median"] == pytest.approx(10.0) and row["met"] is met
    assert row["trials"] == len(clearance)
    # the whole force, the same peaks: 80 N on the tail is over its 50 N too
    assert rows["peak_force_clearance_p99_N"]["met"] is met


@pytest.mark.parametrize(("rate_hz", "deadline"), [(1000.0, 3.8), (100.0, 4.8)])
def test_mujoco_is_judged_on_its_own_targets(rate_hz: float, deadline: float) -> None:
    """The issue asks of MuJoCo 99 % in 5 s for 10 mm at 5 mm/s, and |F| p99 <= 50 N: the MuJoCo
    case's 4 mm are given their travel and 3 s (and the slow loop's second), its 5 s run covers
    that, and 10 failed trials of 1000 meet its share while they fail our model's."""
    sc = scenario_io.load(SCENARIOS / "mujoco_clearance.yaml")
    sc = dataclasses.replace(sc, rate_hz=rate_hz)
    target = study_goals.targets(sc)
    assert target == (pytest.approx(0.99), pytest.approx(deadline), None)
    assert sc.duration >= target.deadline
    model = study_goals.targets(scenario_io.load(SCENARIOS / "rim_clearance.yaml"))
    assert model.success == study_goals.GOAL_SUCCESS
    n = 1000
    t = np.full(n, 3.5)
    t[:10] = np.nan
    outcome = _outcome(success=~np.isnan(t), insertion_time=t)
    trials = draw_trials(sc.geometry, n, 0)
    missed = study_goals.missed_goals(outcome, target.deadline)
    rows = study_goals.goals(outcome, trials, missed, target)
    assert rows["success"]["met"] and rows["peak_force_clearance_p99_N"]["met"]
    assert "peak_fz_clearance_p99_N" not in rows  # the issue asks MuJoCo for |F| alone
    rows = study_goals.goals(outcome, trials, missed, model)
    assert not rows["success"]["met"] and rows["peak_fz_clearance_p99_N"]["met"]
    # 3.5 s is within MuJoCo's 3.8 s and over our model's 3 s
    assert sum(map(bool, missed)) == 10
    assert sum(map(bool, study_goals.missed_goals(outcome, model.deadline))) == n
